"""Scenarios, the radar model, the generator and datasets on disk."""

from nnda.data.dataset import (
    Dataset, Detections, Scan, Truth, iter_datasets, read_dataset, write_collection, write_dataset,
)
from nnda.data.generator import generate, generate_runs
from nnda.data.presets import GROUPS, PRESETS, preset, resolve
from nnda.data.scenario import (
    Clutter, ProcessNoise, Scenario, Segment, Sensor, Target, load_scenario, scenario_from_dict,
)

__all__ = [
    "Clutter", "Dataset", "Detections", "GROUPS", "PRESETS", "ProcessNoise", "Scan", "Scenario",
    "Segment", "Sensor", "Target", "Truth", "generate", "generate_runs", "iter_datasets",
    "load_scenario", "preset", "read_dataset", "resolve", "scenario_from_dict", "write_collection",
    "write_dataset",
]
