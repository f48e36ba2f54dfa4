"""CLI commands of the data stage: ``nnda presets`` and ``nnda generate``."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table
from rich.text import Text

from nnda.data.checks import MAX_DETECTIONS
from nnda.data.dataset import write_collection, write_dataset
from nnda.data.generator import check_scenario, generate_runs
from nnda.data.pedestrian.scenes import PEDESTRIAN_SCENES
from nnda.data.pedestrian.walkers import is_walker_config, load_walker_scene, walker_runs
from nnda.data.presets import GROUP_DESCRIPTIONS, GROUPS, PRESETS, resolve
from nnda.data.scenario import load_scenario
from nnda.errors import ConfigError
from nnda.files import check_output_location, read_config


def presets() -> None:
    """List the preset scenarios and groups of the reference thesis."""
    table = Table(title="nnda presets")
    for col in ("name", "targets", "scans", "description"):
        table.add_column(col)
    for name, s in PRESETS.items():
        table.add_row(name, str(len(s.targets)), str(s.n_scans), s.description)
    for name, members in GROUPS.items():
        table.add_row(f"[bold]{name}[/]", "", str(len(members)) + " sets", GROUP_DESCRIPTIONS[name])
    for name, scene in PEDESTRIAN_SCENES.items():  # seed-000's walkers (nnda.data.pedestrian.scenes)
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
    if preset in PEDESTRIAN_SCENES or (config is not None and is_walker_config(read_config(config, "scenario"))):
        scene = PEDESTRIAN_SCENES[preset] if preset is not None else load_walker_scene(config)  # walkers
        _write_runs(out, preset or str(config), list(walker_runs(scene, range(runs), seed)), overwrite)
        return
    try:
        scenarios = resolve(preset) if preset is not None else [load_scenario(config)]
    except ConfigError as exc:
        if preset is None:
            raise
        raise ConfigError(f"{exc}, or a walker scene ({', '.join(PEDESTRIAN_SCENES)})") from None
    warn = Console(stderr=True)
    for scenario in scenarios:
        try:
            lines = check_scenario(scenario, max_detections)
        except ConfigError as exc:
            raise ConfigError(f"{config or f'preset {scenario.name}'}: {exc}") from None
        for line in lines:
            warn.print(Text.assemble(("warning:", "bold yellow"), " ", line), highlight=False, soft_wrap=True)
    single = len(scenarios) == 1
    if single and runs == 1:
        dataset = next(generate_runs(scenarios[0], [0], seed, max_detections))
        write_dataset(dataset, out, overwrite)
        Console().print(f"wrote {out} ({dataset.detections.scan.size} detections)", markup=False, highlight=False)
        return

    def members():
        for scenario in scenarios:
            for ds in generate_runs(scenario, range(runs), seed, max_detections):
                if runs == 1:
                    yield scenario.name, ds
                elif single:
                    yield f"run-{ds.run:04d}", ds
                else:
                    yield f"{scenario.name}-run-{ds.run:04d}", ds

    what = preset or str(config)
    seeds = seed if seed is not None else "per scenario"
    description = f"{what}: {len(scenarios)} scenario(s) x {runs} run(s), seed {seeds}"
    with Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                  TimeElapsedColumn(), transient=False) as bar:
        task = bar.add_task(f"generating {what}", total=len(scenarios) * runs)
        write_collection(members(), out, description, overwrite,
                         on_member=lambda _name: bar.advance(task))
    Console().print(f"wrote {out} ({len(scenarios) * runs} datasets)", markup=False, highlight=False)


def _write_runs(out: Path, what: str, datasets: list, overwrite: bool) -> None:
    """One dataset, or a collection of runs ``run-0000``, ...; prints what was written."""
    if len(datasets) == 1:
        write_dataset(datasets[0], out, overwrite)
        Console().print(f"wrote {out} ({datasets[0].detections.scan.size} detections)", markup=False, highlight=False)
        return
    write_collection(((f"run-{d.run:04d}", d) for d in datasets), out, f"{what}: {len(datasets)} run(s)", overwrite)
    Console().print(f"wrote {out} ({len(datasets)} datasets)", markup=False, highlight=False)
