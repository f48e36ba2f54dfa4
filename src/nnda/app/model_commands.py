"""CLI commands that train and score the association network and end in its tables: ``nnda train``,
``nnda evaluate``. They live in reports/ with the tables they print and write
(`nnda.reports.classifier_tables`, `nnda.reports.text_table`), as ``nnda compare`` does, since
models/ sits below reports/ and may not import them.

``nnda train`` has four modes, each writing one output directory atomically:

* one model (default): ``model.json`` (the model file), ``training.json``
  (loss per epoch, timing, metrics per subset), ``metrics.md``, ``roc.png``
  and ``loss.png``;
* ``--sweep 1-10``: ``--restarts`` fits per hidden size; ``sweep.json``,
  ``sweep.md``, ``sweep.png``;
* ``--repeats N``: fits with seeds seed .. seed+N-1 (``--method both`` runs
  GD and LM on the same splits); ``repeats.json`` and ``repeats.md``, the
  table in the layout of Vargas Avila (2015), Table 6.3, with mean and 95% intervals;
* ``--ablation --repeats N``: the feature ablation of `nnda.models.ablation`
  (kinematic vs extended features vs each added feature, under both data models:
  measured or true track history); ``ablation.json``, ``ablation.md``, ``ablation_roc.png``.

``--features`` picks the pair-feature set of the first three modes
(`nnda.models.feature_sets`; default Vargas Avila (2015)'s ``kinematic-3``). One model
can also be trained on seeded multi-target scenes besides the data
(``--encounters N``, `nnda.data.encounters`) and on pairs harvested from the
neural tracker's own runs (``--dagger R``, `nnda.tracking.harvest`; each
round's model is kept as ``dagger/dagger-round-<r>.json``); the model's
metadata records the recipe.
"""

from __future__ import annotations

import json
import re
from enum import Enum
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from nnda.data.dataset import iter_datasets
from nnda.errors import ConfigError
from nnda.files import atomic_directory, check_output_location
from nnda.models.feature_sets import FEATURE_SETS
from nnda.models.features import KINEMATIC
from nnda.models.innovation import IMM_INNOVATION
from nnda.models.pairs import PairSet, load_pairs, model_pair_options
from nnda.models.scorer import MODEL_FILE, load_model, save_model

if TYPE_CHECKING:
    from nnda.models.experiment import RunSummary

# Training (torch), metrics and tables (scikit-learn) and plots (matplotlib) are
# imported inside the functions that use them: every `nnda` command loads this
# module, and none but these should pay for those imports. `nnda evaluate` runs
# without torch.


class MethodChoice(str, Enum):
    gd = "gd"
    lm = "lm"
    both = "both"


class InitChoice(str, Enum):
    nguyen_widrow = "nguyen-widrow"
    uniform = "uniform"


FeatureChoice = Enum("FeatureChoice", {name: name for name in FEATURE_SETS}, type=str)


class HistoryChoice(str, Enum):
    measured = "measured"
    true = "true"


def parse_sizes(text: str) -> list[int]:
    """Hidden sizes from ``"1-10"``, ``"2,4,6"`` or ``"1-3,8"``; ConfigError if malformed."""
    sizes: list[int] = []
    for part in text.split(","):
        m = re.fullmatch(r"\s*(\d+)\s*(?:-\s*(\d+)\s*)?", part)
        if not m or int(m.group(1)) < 1 or (m.group(2) and int(m.group(2)) < int(m.group(1))):
            raise ConfigError(f"--sweep {text!r}: expected sizes >= 1 like 1-10 or 2,4,6")
        sizes += range(int(m.group(1)), int(m.group(2) or m.group(1)) + 1)
    return sorted(set(sizes))


def _write_json(path: Path, data: dict) -> None:
    path.write_text(json.dumps(data, indent=1, sort_keys=True) + "\n")


def _describe(pairs: PairSet, data: Path) -> str:
    return (f"{data}: {len(pairs)} pairs from {len(pairs.names)} dataset(s): {pairs.n_positive} own contact, "
            f"{pairs.n_clutter} clutter, {pairs.n_other_target} other targets' contacts")


def _run_bar(total: int, what: str):
    bar = Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                   TextColumn("{task.fields[info]}"), TimeElapsedColumn())
    return bar, bar.add_task(what, total=total, info="")


def train(
    data: Annotated[Path, typer.Option(
        help="dataset or collection directory, e.g. from `nnda generate --preset train`")],
    out: Annotated[Path, typer.Option(help="output directory")],
    method: Annotated[MethodChoice, typer.Option(help="gd, lm, or both (with --repeats)")] = MethodChoice.lm,
    hidden: Annotated[int, typer.Option(min=1, help="hidden tanh units")] = 5,
    seed: Annotated[int, typer.Option(min=0, help="seed of the split and the initial weights")] = 0,
    sweep_sizes: Annotated[str | None, typer.Option("--sweep", help="sweep hidden sizes, e.g. 1-10")] = None,
    restarts: Annotated[int, typer.Option(min=1, help="fits per hidden size in a sweep")] = 10,
    repeats: Annotated[int, typer.Option(min=1, help="fits with seeds seed..seed+N-1, tabulated")] = 1,
    history: Annotated[HistoryChoice, typer.Option(
        help="track history of the pairs: measured contacts (as in Vargas Avila 2015) or true positions",
    )] = HistoryChoice.measured,
    init: Annotated[InitChoice, typer.Option(
        help="initial weights: Nguyen-Widrow (MATLAB's default) or uniform in [-0.5, 0.5]")] = InitChoice.nguyen_widrow,
    features: Annotated[FeatureChoice, typer.Option(
        help="pair features: Vargas Avila (2015)'s three or the IMM-extended nine")] = FeatureChoice[KINEMATIC.name],
    starts: Annotated[int | None, typer.Option(
        min=1, help="initial-weight draws per fit, the lowest validation MSE kept (default 1; ablation 3)")] = None,
    ablation: Annotated[bool, typer.Option(
        help="feature ablation over --repeats seeds, both data models (ignores --features and --history)")] = False,
    encounters: Annotated[int, typer.Option(
        min=0, help="add this many seeded multi-target scenes (crossing, parallel, near-miss; "
        "nnda.data.encounters, drawn from --seed) to the training data (one model only)")] = 0,
    dagger: Annotated[int, typer.Option(
        min=0, help="rounds of harvesting pairs from the nn tracker's own runs on the training data, "
        "labelled by the truth, each followed by retraining (nnda.tracking.harvest; one model only)")] = 0,
    dagger_ratio: Annotated[float, typer.Option(
        min=0.0, help="pairs kept of the harvest's tracks on clutter, per pair of its tracks with a target")] = 1.0,
    overwrite: Annotated[bool, typer.Option(help="replace an existing output directory")] = False,
) -> None:
    """Train the association network on the pairs of a dataset or collection."""
    if sweep_sizes is not None and (repeats > 1 or ablation):
        raise ConfigError("give --sweep, --repeats or --ablation --repeats, not two of them")
    if method is MethodChoice.both and repeats == 1:
        raise ConfigError("--method both needs --repeats N (N >= 2); a sweep or a model takes gd or lm")
    if (encounters or dagger) and (sweep_sizes is not None or repeats > 1 or ablation):
        raise ConfigError("--encounters and --dagger train one model: give them without --sweep, --repeats "
                          "or --ablation")
    if ablation and repeats < 2:
        raise ConfigError("--ablation needs --repeats N (N >= 2; 10 is the usual protocol) for its intervals")
    check_output_location(out, [data])  # --out replaced with --overwrite must never be the training data
    methods = ("gd", "lm") if method is MethodChoice.both else (method.value,)
    console = Console()
    if ablation:
        with atomic_directory(out, overwrite) as tmp:
            _train_ablation(data, methods, hidden, range(seed, seed + repeats), init.value, starts or 3, tmp, console)
        console.print(f"wrote {out}/", markup=False, highlight=False)
        return
    sizes = parse_sizes(sweep_sizes) if sweep_sizes is not None else None
    options = {"history": history.value, "other_targets": "negative", "max_missed": 3, "features": features.value}
    pairs = load_pairs(data, **options)
    console.print(_describe(pairs, data), markup=False, highlight=False)
    provenance = {"data": str(data), "pair_options": options, "dataset_names": list(pairs.names),
                  "recipe": {"encounters": encounters, "dagger": dagger}}
    with atomic_directory(out, overwrite) as tmp:
        if encounters or dagger:
            pairs, provenance["recipe"] = _recipe_pairs(pairs, data, options, encounters, dagger, dagger_ratio, seed,
                                                        (method.value, hidden, seed, init.value, starts or 1),
                                                        tmp, console)
            console.print(_describe(pairs, data), markup=False, highlight=False)
        if sizes is not None:
            _train_sweep(pairs, method.value, sizes, restarts, seed, init.value, tmp, console)
        elif repeats > 1:
            _train_repeats(pairs, methods, hidden, range(seed, seed + repeats), init.value, tmp, console)
        else:
            _train_one(pairs, method.value, hidden, seed, init.value, starts or 1, provenance, tmp, console)
    console.print(f"wrote {out}/", markup=False, highlight=False)


def _train_one(pairs: PairSet, method: str, hidden: int, seed: int, init: str, starts: int, provenance: dict,
               tmp: Path, console: Console) -> None:
    from nnda.models.experiment import fit
    from nnda.models.plots import plot_losses, plot_roc
    from nnda.models.trainers import GDSettings, LMSettings
    from nnda.reports.classifier_tables import fit_table

    settings = GDSettings() if method == "gd" else LMSettings()
    shape = f"{pairs.feature_set.size}-{hidden}-1"
    bar, task = _run_bar(settings.max_epochs, f"training {method.upper()} {shape} on {pairs.feature_set.name}")
    with bar:
        def on_epoch(epoch: int, losses: dict[str, float]) -> None:
            bar.update(task, completed=epoch, info=f"val MSE {losses['validation']:.4f}")
        result = fit(pairs, method, hidden, seed, settings=settings, on_epoch=on_epoch, provenance=provenance,
                     init=init, starts=starts)
        bar.update(task, total=result.training.epochs, completed=result.training.epochs)
    save_model(result.scorer, tmp / MODEL_FILE)
    t = result.training
    _write_json(tmp / "training.json", {
        "method": method, "n_hidden": hidden, "seed": seed, "epochs": t.epochs, "best_epoch": t.best_epoch,
        "stop_reason": t.stop_reason, "seconds": t.seconds,
        "loss_per_epoch": {k: v.tolist() for k, v in t.loss.items()}, "mu_per_epoch": t.mu.tolist(),
        "metrics": {k: m.as_dict() for k, m in result.metrics.items()},
    })
    table = fit_table(result)
    (tmp / "metrics.md").write_text(table.markdown())
    labels = pairs.labels
    plot_roc({"test": (labels[result.split.test], result.scores[result.split.test]),
              "all pairs": (labels, result.scores)}, tmp / "roc.png", f"ROC, {method.upper()} {shape}")
    plot_losses(t, tmp / "loss.png")
    console.print(table.rich())


def _recipe_pairs(pairs: PairSet, data: Path, options: dict, encounters: int, dagger: int, ratio: float,
                  seed: int, fit_args: tuple, tmp: Path, console: Console) -> tuple[PairSet, dict]:
    """The training pairs of ``--encounters`` and ``--dagger`` (added to the oracle ``pairs`` of ``data``) and
    the recipe the model records: the counts asked for and, per DAgger round, the pairs harvested."""
    from nnda.data.encounters import encounter_scenes
    from nnda.data.generator import generate
    from nnda.models.experiment import fit
    from nnda.models.pairs import concatenate, pairs_from_datasets
    from nnda.tracking.harvest import dagger_pairs
    from nnda.tracking.lifecycle import THESIS_LIFECYCLE

    scenes = [generate(s, seed) for s in encounter_scenes(encounters, seed)]
    if scenes:
        pairs = concatenate([pairs, pairs_from_datasets(scenes, **options)])
    recipe: dict = {"encounters": encounters, "encounter_seed": seed, "dagger": dagger}
    if dagger:
        recipe["dagger_ratio"] = ratio
    if dagger:
        method, hidden, fit_seed, init, starts = fit_args
        datasets = [*iter_datasets(data), *scenes]
        # the harvesting tracker runs the M/N rule, as when the recipe was made: the same recipe, the same model
        params = {"feature_set": options["features"], "lifecycle": THESIS_LIFECYCLE}
        work = tmp / "dagger"
        work.mkdir()
        console.print(f"DAgger: {dagger} round(s) on {len(datasets)} datasets", markup=False, highlight=False)
        pairs, recipe["dagger_rounds"] = dagger_pairs(
            datasets, pairs, params, dagger, work,
            lambda p: fit(p, method, hidden, fit_seed, init=init, starts=starts).scorer, seed, ratio)
    return pairs, recipe


def _train_sweep(pairs: PairSet, method: str, sizes: list[int], restarts: int, seed: int, init: str,
                 tmp: Path, console: Console) -> None:
    from nnda.models.experiment import sweep
    from nnda.models.plots import plot_sweep
    from nnda.reports.classifier_tables import sweep_table

    bar, task = _run_bar(len(sizes) * restarts, f"sweeping {method.upper()} over hidden sizes")
    with bar:
        def on_run(run: RunSummary) -> None:
            bar.advance(task)
            bar.update(task, info=f"H={run.n_hidden} test MSE {run.metrics['test'].mse:.4f}")
        result = sweep(pairs, sizes, restarts, method, seed, on_run=on_run, init=init)
    table = sweep_table(result)
    _write_json(tmp / "sweep.json", {"method": method, "hidden_sizes": list(sizes), "restarts": restarts,
                                     "seed": seed, "init": init, "best_size": result.best_size,
                                     "runs": [r.as_dict() for r in result.runs]})
    (tmp / "sweep.md").write_text(table.markdown())
    plot_sweep(result, tmp / "sweep.png")
    console.print(table.rich())


def _train_repeats(pairs: PairSet, methods: tuple[str, ...], hidden: int, seeds: range, init: str,
                   tmp: Path, console: Console) -> None:
    from nnda.models.experiment import repeat
    from nnda.reports.classifier_tables import repeats_table

    bar, task = _run_bar(len(seeds) * len(methods), f"training {'+'.join(m.upper() for m in methods)}")
    with bar:
        def on_run(run: RunSummary) -> None:
            bar.advance(task)
            bar.update(task, info=f"{run.method.upper()} seed {run.seed} test acc {run.metrics['test'].accuracy:.4f}")
        runs = repeat(pairs, methods, hidden, seeds, on_run=on_run, init=init)
    table = repeats_table(runs)
    _write_json(tmp / "repeats.json", {"methods": list(methods), "n_hidden": hidden, "seeds": list(seeds), "init": init,
                                       "runs": [r.as_dict() for r in runs]})
    (tmp / "repeats.md").write_text(table.markdown())
    console.print(table.rich())


def _train_ablation(data: Path, methods: tuple[str, ...], hidden: int, seeds: range, init: str, starts: int,
                    tmp: Path, console: Console) -> None:
    from nnda.models.ablation import (
        ABLATION_FILE,
        ABLATION_FORMAT,
        ABLATION_FORMAT_VERSION,
        HISTORIES,
        ablation,
        variants,
    )
    from nnda.models.plots import plot_ablation_roc
    from nnda.reports.classifier_tables import ablation_table

    datasets = list(iter_datasets(data))
    total = len(HISTORIES) * len(variants()) * len(seeds) * len(methods)
    bar, task = _run_bar(total, "feature ablation")
    with bar:
        def on_run(history: str, variant: str, run: RunSummary) -> None:
            bar.advance(task)
            bar.update(task, info=f"{history} history, {variant}: test acc {run.metrics['test'].accuracy:.4f}")
        results, described = ablation(datasets, methods, hidden, seeds, init, starts, on_run)
    rows = [r.as_dict() for r in results]
    _write_json(tmp / ABLATION_FILE, {
        "format": ABLATION_FORMAT, "format_version": ABLATION_FORMAT_VERSION, "data": str(data),
        "methods": list(methods), "n_hidden": hidden, "seeds": list(seeds), "init": init,
        "starts": starts, "pairs": described, "results": rows})
    tables = [ablation_table(rows, m) for m in methods]
    (tmp / "ablation.md").write_text("\n".join(t.markdown() for t in tables))
    plot_ablation_roc(rows, tmp / "ablation_roc.png")
    for t in tables:
        console.print(t.rich())


def evaluate(
    model: Annotated[Path, typer.Argument(help="model directory (from `nnda train`) or its model.json")],
    data: Annotated[Path, typer.Option(help="dataset or collection directory to score")],
    out: Annotated[Path | None, typer.Option(help="directory for evaluation.json, metrics.md and roc.png")] = None,
    overwrite: Annotated[bool, typer.Option(help="replace an existing output directory")] = False,
) -> None:
    """Score every gated pair of a dataset or collection with a trained model and tabulate the metrics.

    Pairs are built with the options the model was trained with.
    """
    from nnda.models.metrics import classifier_metrics
    from nnda.models.plots import plot_roc
    from nnda.reports.classifier_tables import metrics_table

    if out is not None:
        check_output_location(out, [model, data])
    scorer = load_model(model)
    options = model_pair_options(scorer.metadata, scorer.features.name)
    pairs = load_pairs(data, **options)
    console = Console()
    console.print(_describe(pairs, data), markup=False, highlight=False)
    scores = scorer(pairs.features)
    metrics = classifier_metrics(pairs.labels, scores)
    table = metrics_table(f"{model} on {data}", {"all pairs": metrics})
    if out is not None:
        with atomic_directory(out, overwrite) as tmp:
            _write_json(tmp / "evaluation.json", {"model": str(model), "data": str(data),
                                                  "pair_options": options, "metrics": metrics.as_dict()})
            (tmp / "metrics.md").write_text(table.markdown())
            plot_roc({"all pairs": (pairs.labels, scores)}, tmp / "roc.png", f"ROC of {model.name} on {data.name}")
        console.print(f"wrote {out}/", markup=False, highlight=False)
    console.print(table.rich())


def train_thesis_models(data: Path, models: Path, seed: int) -> Path:
    """The association networks of the radar thesis's comparison (`nnda.study.config.default_study`), trained on
    the dataset collection ``data`` into ``models``/gd, lm (the thesis's three features, gradient descent and
    Levenberg-Marquardt) and ext (the IMM-extended features, three starts); returns ``models`` (absolute).
    The same seed gives the same model files, so a study that names them resumes."""
    models = models.resolve()
    for method in (MethodChoice.gd, MethodChoice.lm):
        train(data=data, out=models / method.value, method=method, seed=seed, overwrite=True)
    train(data=data, out=models / "ext", method=MethodChoice.lm, features=FeatureChoice[IMM_INNOVATION.name],
          starts=3, seed=seed, overwrite=True)
    return models
