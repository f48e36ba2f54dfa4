"""The ``nnda`` command line: generate datasets, train models, compare trackers, write reports.

Every command is defined in this package (`nnda.app`), one module per
group: ``data_commands`` (presets, generate), ``import_commands`` (import-
detections, import-stonesoup), ``model_commands`` (train, evaluate),
``track_commands`` (track), ``tune_commands`` (tune), ``study_commands`` (compare, report,
plot-scenario and the reference studies); they are registered on one
typer app here.
Errors from bad input (nnda.errors.NndaError) are printed without a
traceback and exit with status 2.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.text import Text

from nnda.app import (
    data_commands,
    import_commands,
    model_commands,
    reproduce,
    study_commands,
    track_commands,
    tune_commands,
)
from nnda.app.model_commands import train_thesis_models
from nnda.data.dataset import collection_members
from nnda.data.presets import GROUPS
from nnda.errors import NndaError

app = typer.Typer(
    name="nnda",
    help="Data association in radar multi-target tracking: datasets, models, comparisons.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)



def _show_version(value: bool) -> None:
    if value:
        from nnda.version import __version__

        typer.echo(f"nnda {__version__}")
        raise typer.Exit()


@app.callback()
def _options(
    version: Annotated[bool, typer.Option("--version", callback=_show_version, is_eager=True,
                                          help="Print the installed nnda's version and exit.")] = False,
) -> None:
    """Data association in radar multi-target tracking: datasets, models, comparisons."""


app.command("presets")(data_commands.presets)
app.command("generate")(data_commands.generate)
app.command("train")(model_commands.train)
app.command("evaluate")(model_commands.evaluate)
app.command("plot-scenario")(study_commands.plot_scenario)
app.command("run")(study_commands.compare)
app.command("compare")(study_commands.compare)
app.command("report")(study_commands.report)
app.command("import-stonesoup")(import_commands.import_stonesoup)
app.command("import-detections")(import_commands.import_detections_command)
app.command("track")(track_commands.track)
app.command("tune")(tune_commands.tune)
app.command("reentry")(study_commands.reentry)
app.command("pedestrian")(study_commands.pedestrian)
app.command("tbd")(study_commands.tbd)


def demo(
    out: Annotated[Path, typer.Option(help="directory for everything the demo writes")] = Path("demo"),
    seed: Annotated[int, typer.Option(min=0, help="seed of every random draw")] = 0,
    runs: Annotated[int, typer.Option(min=1, help="Monte Carlo runs of each of S1-S6 in the comparison")] = 10,
    jobs: Annotated[int, typer.Option(min=1, help="worker processes of the comparison")] = 2,
) -> None:
    """Run the whole job: generate the presets, train the models (GD and LM on Vargas Avila (2015)'s three
    features, LM on the IMM-extended ones, the feature ablation), compare the trackers on S1-S6, report."""
    from nnda.study.config import default_study, study_to_toml  # the trackers: when the demo runs

    console = Console()
    data = out / "data"
    for group in GROUPS:
        data_commands.generate(preset=group, out=data / group, seed=seed, overwrite=True)
    plots = out / "scenarios"
    plots.mkdir(parents=True, exist_ok=True)
    for group in ("train", "validation"):
        for member in collection_members(data / group):
            study_commands.plot_scenario(member, plots / f"{member.name}.png", overwrite=True)
    models = train_thesis_models(data / "train", out / "models", seed)
    model_commands.train(data=data / "train", out=models / "ablation", method=model_commands.MethodChoice.lm,
                         ablation=True, repeats=10, seed=seed, overwrite=True)
    study = default_study(models / "gd", models / "lm", models / "ext", runs=runs, seed=seed,
                          ablation=models / "ablation")
    study_file = out / "study.toml"
    study_file.write_text(study_to_toml(study, relative_to=out))
    study_commands.compare(study=study_file, out=out / "comparison", jobs=jobs, overwrite=True)
    console.print(f"demo written to {out}/; open {out / 'comparison' / 'report.html'}")


app.command("demo")(demo)
app.command("reproduce")(reproduce.reproduce)


def _print_error(message: str) -> None:
    # plain text: a path or a config section in brackets must not read as markup
    Console(stderr=True).print(Text.assemble(("error:", "bold red"), " ", message), highlight=False, soft_wrap=True)


def main() -> None:
    """Entry point: run the app; bad input is one plain-text line on stderr and exit status 2.

    Bad input is nnda's (`nnda.errors.NndaError`, an output that exists
    without ``--overwrite``) or the command line's own (an unknown option, a
    value outside its range), which typer would print as a framed panel.
    """
    try:
        code = app(standalone_mode=False)
    except (NndaError, FileExistsError) as exc:
        _print_error(str(exc))
        sys.exit(2)
    except typer.TyperException as exc:  # click's usage errors
        ctx = getattr(exc, "ctx", None)
        if ctx is not None and not exc.format_message().strip():  # no arguments: typer printed the help
            sys.exit(exc.exit_code)
        hint = f" (see {ctx.command_path} --help)" if ctx is not None else ""
        _print_error(f"{exc.format_message()}{hint}")
        sys.exit(exc.exit_code)
    except (typer.Abort, KeyboardInterrupt):  # click turns Ctrl-C into Abort
        _print_error("interrupted: nothing half-written was left; a study's finished jobs are kept for --resume")
        sys.exit(130)
    sys.exit(code if isinstance(code, int) else 0)
