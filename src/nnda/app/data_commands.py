"""CLI commands of the data stage: ``nnda presets`` and ``nnda generate``."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table
from rich.text import Text

from nnda.data.changes import changes_from_text
from nnda.data.checks import MAX_DETECTIONS
from nnda.data.dataset import write_collection, write_dataset
from nnda.data.pedestrian.scenes import PEDESTRIAN_SCENES
from nnda.data.presets import GROUP_DESCRIPTIONS, GROUPS, PRESETS
from nnda.data.sources import resolve_scenes
from nnda.errors import ConfigError
from nnda.files import check_output_location


def presets() -> None:
    """List the preset scenarios and groups of Vargas Avila (2015)."""
    table = Table(title="nnda presets")
    for col in ("name", "targets", "scans", "description"):
        table.add_column(col)
    for name, s in PRESETS.items():
        table.add_row(name, str(len(s.targets)), str(s.n_scans), s.description)
    for name, members in GROUPS.items():
        table.add_row(f"[bold]{name}[/]", "", str(len(members)) + " sets", GROUP_DESCRIPTIONS[name])
    for name, scene in PEDESTRIAN_SCENES.items():  # Frencl (2014)'s walkers (nnda.data.pedestrian.scenes)
        table.add_row(name, "walkers", str(scene.n_scans), scene.description)
    Console().print(table)


def generate(
    out: Annotated[Path, typer.Option(help="output directory (a dataset, or a collection of them)")],
    preset: Annotated[str | None, typer.Option(help="preset, group or walker scene (see `nnda presets`)")] = None,
    config: Annotated[Path | None, typer.Option(
        help="scenario config file (.toml or .json), or a walker scene (one with a `map`)")] = None,
    seed: Annotated[int | None, typer.Option(min=0, help="seed; defaults to the scenario's own")] = None,
    runs: Annotated[int, typer.Option(min=1, help="independently seeded Monte Carlo runs")] = 1,
    max_detections: Annotated[int, typer.Option(
        min=1, help="refuse a scenario whose dataset could hold more detections (each about 60 bytes)")
    ] = MAX_DETECTIONS,
    overwrite: Annotated[bool, typer.Option(help="replace an existing output directory")] = False,
    change: Annotated[list[str] | None, typer.Option(
        "--set", help="change a field of the scenario (of each, for a group): PATH=VALUE, e.g. clutter.count=1000 "
        "or sensor.pd=0.8; repeat for more; VALUE is read as JSON, else as text")] = None,
) -> None:
    """Generate datasets from a preset, a preset group or a config file.

    One scenario and one run give a dataset directory; more runs or a group
    give a collection directory with one dataset per member. Every scenario
    is checked before the first draw (size, clutter against the coverage);
    implausible targets are printed as warnings.
    """
    if (preset is None) == (config is None):
        raise ConfigError("give exactly one of --preset or --config")
    check_output_location(out, [config] if config is not None else [])
    sources = resolve_scenes(preset=preset, config=config, changes=changes_from_text(change or [], "--set"))
    warn = Console(stderr=True)
    for source in sources:
        try:
            lines = source.check(max_detections)
        except ConfigError as exc:
            raise ConfigError(f"{config or f'preset {source.name}'}: {exc}") from None
        for line in lines:
            warn.print(Text.assemble(("warning:", "bold yellow"), " ", line), highlight=False, soft_wrap=True)
    single = len(sources) == 1
    if single and runs == 1:
        dataset = sources[0].load(0, 1, seed)[0]
        write_dataset(dataset, out, overwrite)
        Console().print(f"wrote {out} ({dataset.detections.scan.size} detections)", markup=False, highlight=False)
        return

    def members():
        for source in sources:
            for ds in source.iterate(0, runs, seed):  # one run at a time: a collection is never all in memory
                if runs == 1:
                    yield source.name, ds
                elif single:
                    yield f"run-{ds.run:04d}", ds
                else:
                    yield f"{source.name}-run-{ds.run:04d}", ds

    what = preset or str(config)
    seeds = seed if seed is not None else "per scenario"
    description = f"{what}: {len(sources)} scenario(s) x {runs} run(s), seed {seeds}"
    with Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                  TimeElapsedColumn(), transient=False) as bar:
        task = bar.add_task(f"generating {what}", total=len(sources) * runs)
        write_collection(members(), out, description, overwrite,
                         on_member=lambda _name: bar.advance(task))
    Console().print(f"wrote {out} ({len(sources) * runs} datasets)", markup=False, highlight=False)
