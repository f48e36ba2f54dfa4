"""CLI command that fits a tracker's config to one dataset with Optuna: ``nnda tune``.

Writes into ``--out``, atomically as a whole: ``config.toml`` (the base config with the tuned fields set:
``nnda track --config`` and a study's tracker params read it), ``trials.csv`` (every trial: number,
state, objective, the values tried, one column per config path) and ``tune.md`` (the search and the default
and tuned configs' measures on the tuning and held-out scans). No wall-clock time is written: the same
dataset, base config and seed give the same bytes. The search itself is `nnda.study.tuning.tune`.
"""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console

from nnda.errors import OutputError
from nnda.files import atomic_directory, check_output_location
from nnda.study.metrics import DEFAULT_CUTOFF_M

#: how tune.md names each measure of the scores
TITLES = {"gospa": "GOSPA (m)", "hit_rate": "Hit rate (%)", "lost_targets": "Lost targets",
          "false_tracks": "False tracks", "objective": "Objective (innovation consistency)",
          "nis_per_dim": "Mean NIS / 2 (1 when consistent)", "lost_fraction": "Confirmed tracks lost (share)",
          "confirmed_tracks": "Confirmed tracks", "updates": "Updates of confirmed tracks",
          "track_switches": "Track switches (GOSPA assignment)"}


def _title(measure: str, result) -> str:
    """tune.md's name of a measure of ``result``'s scores (the switching penalty's value in the objective's)."""
    if measure == "gospa_switching":
        return f"GOSPA with switching penalty {result.switching_penalty_m:g} m (m)"
    return TITLES[measure]


def _number(value) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "-"
    return f"{value:d}" if isinstance(value, int) else f"{value:.6g}"


def trials_csv(result) -> str:
    """``trials.csv``: one row per trial, in order: number, state, objective (empty when pruned), then the
    value of each dimension by its config path."""
    paths = [d.path for d in result.space]
    text = io.StringIO()
    writer = csv.writer(text, lineterminator="\n")
    writer.writerow(["number", "state", "objective", *paths])
    for t in result.trials:
        writer.writerow([t.number, t.state, "" if t.objective is None else repr(t.objective),
                         *(repr(t.params[p]) if p in t.params else "" for p in paths)])
    return text.getvalue()


def _objective_text(result) -> str:
    """What ``result``'s search minimised, in words."""
    if not result.truth:
        return ("innovation consistency (no truth in the dataset): the mean over confirmed tracks of |mean NIS / 2 "
                "- 1| plus the share of confirmed tracks deleted before the last scan")
    gospa = f"(alpha = 2, p = 2, cut-off {result.cutoff_m:g} m)"
    if not result.switching_penalty_m:
        return f"mean GOSPA over the tuning scans {gospa}"
    return (f"mean over the tuning scans of GOSPA with switching penalty gamma = {result.switching_penalty_m:g} m "
            f"{gospa}: per scan (GOSPA^2 + gamma^2 n)^(1/2), n the scan's track switches of the GOSPA assignment "
            f"(1 for a target passed from one confirmed track to another, 0.5 between a track and none)")


def tune_markdown(result, dataset: Path) -> str:
    """``tune.md``: what was searched on what, the objective, the trials, the best values and the measures of
    the default and tuned configs on the tuning and held-out scans."""
    from nnda.study.tuning_space import field_value
    from nnda.tracking.registry import check_config

    k, n = result.tuning_scans, result.n_scans
    done = sum(t.state == "COMPLETE" for t in result.trials)
    objective = _objective_text(result)
    base = check_config(result.tracker, result.base_params)
    lines = [f"# nnda tune: {result.tracker} on {result.scenario}", "",
             f"- dataset: `{dataset}` ({n} scans)",
             f"- split: scans 1-{k} tuned on, {k + 1}-{n} held out (each run from a fresh start)",
             f"- objective (minimised): {objective}",
             f"- trials: {len(result.trials)} ({done} complete, {len(result.trials) - done} pruned: refused by the "
             f"config), TPE sampler; the best is trial {result.best_trial}",
             *([f"- kept at the base config's values: {', '.join(f'`{name}`' for name in result.kept)}"]
               if result.kept else []), "",
             "## Tuned fields", "", "| field | range | default | tuned |", "|---|---|---|---|"]
    for d in result.space:
        scale = ", log" if d.log else ""
        lines.append(f"| `{d.path}` | {_number(d.low)} - {_number(d.high)}{scale} | "
                     f"{_number(field_value(base, d.path))} | {_number(result.best_values[d.path])} |")
    lines += ["", "## Default against tuned", "",
              "| measure | default, tuning | tuned, tuning | default, held out | tuned, held out |",
              "|---|---|---|---|---|"]
    for m in result.measures:
        row = [_number(result.scores[(c, p)][m]) for p in ("tuning", "held-out") for c in ("default", "tuned")]
        lines.append(f"| {_title(m, result)} | {row[0]} | {row[1]} | {row[2]} | {row[3]} |")
    lines += ["", "`config.toml` holds the base config with the tuned fields: run it with "
              f"`nnda track DATASET --tracker {result.tracker} --config config.toml`.", ""]
    return "\n".join(lines)


def tune(
    dataset: Annotated[Path, typer.Argument(help="dataset directory (one dataset, not a collection)")],
    tracker: Annotated[str, typer.Option(help="registered tracker: gnn, jpda, mht, nn, gmphd, ...")],
    out: Annotated[Path, typer.Option(help="directory for config.toml, trials.csv and tune.md")],
    trials: Annotated[int, typer.Option(help="trials of the search (1 or more)")] = 40,
    seed: Annotated[int, typer.Option(help="seed of the TPE sampler")] = 0,
    fraction: Annotated[float, typer.Option(help="share of the scans tuned on (0 < f < 1); the rest are held "
                                            "out")] = 0.5,
    config: Annotated[Path | None, typer.Option(help="base tracker config (.toml or .json): the search starts "
                                                "from it and the tuned config keeps its other fields")] = None,
    model: Annotated[Path | None, typer.Option(help="model file or directory (the nn tracker)")] = None,
    cutoff: Annotated[float, typer.Option(help="GOSPA cut-off and position-matching threshold, m")
                      ] = DEFAULT_CUTOFF_M,
    keep: Annotated[list[str] | None, typer.Option(
        help="a field the search leaves at the base config's value (repeatable), e.g. lifecycle.max_misses: one "
             "whose cost GOSPA does not see")] = None,
    switching_penalty: Annotated[float, typer.Option(
        help="GOSPA's switching penalty gamma, m (needs truth): the objective charges each scan's track switches "
             "of the GOSPA assignment (1 from one track to another, 0.5 between a track and none) as gamma^2 "
             "each; 0: none")] = 0.0,
    overwrite: Annotated[bool, typer.Option(help="replace an existing directory at --out")] = False,
) -> None:
    """Fit a tracker's parameters (IMM process noise and mode switching, gate, initiation window, life-cycle
    or PHD thresholds) to a dataset with Optuna's TPE sampler: tune on the first --fraction of the scans,
    score the default and the tuned config on the rest; write config.toml, trials.csv and tune.md."""
    import tomli_w

    from nnda.study.track import load, tracker_params
    from nnda.study.tuning import tune as search
    from nnda.tracking.registry import check_config

    check_output_location(out, [p for p in (dataset, model, config) if p is not None])
    if out.exists() and not out.is_dir():
        raise OutputError(f"--out {out}: is a file; give a directory for config.toml, trials.csv and tune.md")
    if out.exists() and not overwrite:
        raise FileExistsError(f"{out}: already exists (pass --overwrite to replace it)")
    where = f"tracker config {config}" if config is not None else "tracker config"
    base = tracker_params(config, None)
    ds = load(dataset)
    # a base config for another tracker, or one that does not go with the class of target the sensors declare
    check_config(tracker, tracker_params(base, model), where, ds.scenario.sensors)
    console = Console()

    def progress(done: int, total: int) -> None:
        if console.is_terminal:
            console.print(f"trial {done}/{total}", end="\r", highlight=False)

    result = search(ds, tracker, tracker_params(base, model), trials=trials, seed=seed, fraction=fraction,
                    cutoff_m=cutoff, where=where, on_trial=progress, keep=keep or (),
                    switching_penalty_m=switching_penalty)
    tuned = {key: value for key, value in result.best_params.items() if key in base or key != "model"}
    with atomic_directory(out, overwrite) as tmp:
        (tmp / "config.toml").write_text(tomli_w.dumps(tuned))
        (tmp / "trials.csv").write_text(trials_csv(result))
        (tmp / "tune.md").write_text(tune_markdown(result, dataset))
    key = result.measures[0]
    what = _title(key, result) if result.truth else "objective"
    held = [_number(result.scores[(c, "held-out")][key]) for c in ("default", "tuned")]
    console.print(f"{tracker}: {len(result.trials)} trials in {result.seconds:.1f} s "
                  f"({result.seconds / len(result.trials):.2f} s a trial); held-out {what}: default {held[0]}, "
                  f"tuned {held[1]}", markup=False, highlight=False)
    console.print(f"wrote {out}", markup=False, highlight=False)
