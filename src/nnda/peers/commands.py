"""CLI command of the peers: ``nnda import-stonesoup`` (Stone Soup is imported only when it runs)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console

from nnda.files import check_output_location
from nnda.peers import require_stonesoup


def import_stonesoup(
    out: Annotated[Path, typer.Option(help="output dataset directory")],
    seed: Annotated[int, typer.Option(min=0, help="seed of every Stone Soup random draw")] = 0,
    scans: Annotated[int, typer.Option(min=1, help="scans to simulate")] = 60,
    targets: Annotated[int, typer.Option(min=0, help="targets at the first scan")] = 4,
    birth_rate: Annotated[float, typer.Option(min=0, help="mean targets born per scan (Poisson)")] = 0.02,
    clutter: Annotated[float, typer.Option(min=0, help="mean clutter contacts per scan (Poisson)")] = 100.0,
    pd: Annotated[float, typer.Option(min=0, max=1, help="detection probability")] = 0.9,
    overwrite: Annotated[bool, typer.Option(help="replace an existing output directory")] = False,
) -> None:
    """Simulate a scene with Stone Soup's ground-truth and detection simulators; write an nnda dataset."""
    check_output_location(out)
    require_stonesoup("nnda import-stonesoup")
    from nnda.data.scenario import Sensor
    from nnda.peers.importer import StoneSoupScene
    from nnda.peers.importer import import_stonesoup as run

    scene = StoneSoupScene(n_scans=scans, targets=targets, birth_rate=birth_rate, clutter=clutter,
                           sensor=Sensor(pd=pd))
    path = run(out, scene, seed, overwrite)
    Console().print(f"wrote {path} (Stone Soup scene, seed {seed}, {scans} scans)", markup=False, highlight=False)
