"""The dataset registry: one entry per value of ``config.data.dataset``, and the one place that asks it.

Each entry says where its windows come from and what its skeleton is:

    entry = datasets.get("lafan1")
    windows, stats = entry.training_windows(data_dir, config.data)    # subjects 1-4, 50/20 (config.data)
    windows, stats = entry.test_windows(data_dir, config.data)        # the benchmark windows, training stats
    facts = entry.skeleton_facts(data_dir, config.data)               # joint names, feet, axes, units

Every loader returns centred, facing-aligned windows in centimetres with +Y up (``windows.Windows``), and
:class:`~stitchjax.windows.Stats` of the training windows' global positions. LAFAN1 and Human3.6M have fixed
skeletons (the facts below); a BVH folder reads its skeleton from the files (``stitchjax.bvh_folder``).
"""
from __future__ import annotations

import dataclasses
import pathlib
from typing import Callable

import numpy as np

from stitchjax import bvh_folder, conform, features, h36m, lafan1, sample
from stitchjax import config as config_lib
from stitchjax.skeleton import LAFAN1_FEET, LAFAN1_FPS, LAFAN1_JOINTS, LAFAN1_PARENTS
from stitchjax.windows import Stats, Windows

__all__ = ["Dataset", "REGISTRY", "get", "names", "load_training_data", "stats_to_json", "skeleton_facts"]

@dataclasses.dataclass(frozen=True)
class Dataset:
    """One dataset: its loaders and, for a fixed skeleton, its facts (None: read from the files).

    training_windows / test_windows: (data_dir, config.data) -> (Windows, Stats of the training windows).
    data_dir_help: what --data must hold (said when it is missing); default_data_dir: used when no --data
    is given (None: --data is required).
    """
    name: str
    training_windows: Callable[..., tuple[Windows, Stats]]
    test_windows: Callable[..., tuple[Windows, Stats]]
    data_dir_help: str
    default_data_dir: Callable[[], pathlib.Path] | None = None
    joint_names: tuple | None = None
    parents: tuple | None = None
    feet: tuple | None = None  # contact joints, in the order of the contact channels
    fps: float | None = None
    up_axis: str = "+y"  # of the loaded windows
    forward_axis: str | None = None  # the root's local forward axis

    def data_dir(self, data_dir) -> pathlib.Path:
        """`data_dir` as a folder, the default when None; FileNotFoundError saying what --data must hold."""
        if data_dir is None:
            if self.default_data_dir is None:
                raise FileNotFoundError(f"the {self.name} dataset needs --data DIR ({self.data_dir_help})")
            return self.default_data_dir()
        data_dir = pathlib.Path(data_dir).expanduser()
        if not data_dir.is_dir():
            raise FileNotFoundError(f"--data {data_dir}: no such folder (expected {self.data_dir_help})")
        return data_dir

    def skeleton_facts(self, data_dir, data) -> dict | None:
        """What inference must know of the training skeleton (saved in checkpoints): {"joint_names",
        "feet", "feet_names", "up_axis", "forward_axis", "unit_scale" (cm per file unit)}; None when the
        skeleton is read from files and `data_dir` is None."""
        if self.joint_names is None:
            return bvh_folder.skeleton_facts(data_dir, data)
        names = [str(n) for n in self.joint_names]
        return {"joint_names": names, "feet": [int(j) for j in self.feet],
                "feet_names": [names[int(j)] for j in self.feet], "up_axis": self.up_axis,
                "forward_axis": self.forward_axis, "unit_scale": 1.0}


def _subject_loaders(module):
    """(training_windows, test_windows) of a dataset module with subject splits (lafan1, h36m): its
    ``load_windows`` / ``train_statistics`` on ``data.train_subjects`` and its benchmark ``test_windows``."""
    def training(data_dir, data):
        kwargs = dict(window=data.window, offset=data.offset)
        return (module.load_windows(data_dir, data.train_subjects, **kwargs),
                module.train_statistics(data_dir, data.train_subjects, **kwargs))

    def test(data_dir, data):
        return module.test_windows(data_dir), module.train_statistics(data_dir)

    return training, test


def _bvh_folder_test(data_dir, data):
    return bvh_folder.load_windows(data_dir, data, "test"), bvh_folder.load_windows_and_stats(data_dir, data)[1]


_ENTRIES = (
    Dataset("lafan1", *_subject_loaders(lafan1), "LAFAN1 .bvh files, <action>_subject<N>.bvh",
            default_data_dir=sample.sample_dir, joint_names=LAFAN1_JOINTS, parents=LAFAN1_PARENTS,
            feet=LAFAN1_FEET, fps=LAFAN1_FPS, forward_axis="+y"),
    Dataset("h36m", *_subject_loaders(h36m), "the Human3.6M exponential-map folder, S1/ .. S11/",
            joint_names=h36m.JOINT_NAMES, parents=h36m.PARENTS, feet=h36m.FEET, fps=h36m.FPS,
            forward_axis=conform.axis_name(h36m.FORWARD_AXIS)),
    Dataset("bvh_folder", bvh_folder.load_windows_and_stats, _bvh_folder_test,
            "a folder of .bvh / .bvh.gz files of one skeleton"),
)
REGISTRY = {entry.name: entry for entry in _ENTRIES}
# config.CHOICES is the one list of allowed names (checked when overridden); every name has an entry here
assert tuple(REGISTRY) == config_lib.CHOICES[("data", "dataset")], "datasets.REGISTRY and config.CHOICES differ"


def names() -> tuple:
    """The dataset names, as ``config.data.dataset`` takes them."""
    return tuple(REGISTRY)


def get(name: str) -> Dataset:
    """The registry entry of `name`; ValueError listing the names when there is none."""
    if name not in REGISTRY:
        raise ValueError(f"config.data.dataset={name!r}: expected one of {', '.join(REGISTRY)}")
    return REGISTRY[name]


def skeleton_facts(data_dir, data) -> dict | None:
    """:meth:`Dataset.skeleton_facts` of ``data.dataset`` (None for an unknown name)."""
    entry = REGISTRY.get(data.dataset)
    return None if entry is None else entry.skeleton_facts(data_dir, data)


def load_training_data(config, data_dir):
    """(dataset dict of (N, T, ...) numpy arrays from ``features.prepare_dataset``, Stats) of the training
    windows of ``config.data.dataset``; data_dir None = the dataset's default (LAFAN1: the bundled sample)."""
    entry = get(config.data.dataset)
    windows, stats = entry.training_windows(entry.data_dir(data_dir), config.data)
    dataset = features.prepare_dataset(windows, stats, config)
    return {name: np.asarray(x) for name, x in dataset.items()}, stats


def stats_to_json(stats) -> dict:
    """Normalisation statistics (namedtuple / dataclass / dict of arrays) as a JSON-able dict."""
    if stats is None:
        return {}
    if hasattr(stats, "_asdict"):
        items = stats._asdict()
    elif dataclasses.is_dataclass(stats):
        items = {f.name: getattr(stats, f.name) for f in dataclasses.fields(stats)}
    else:
        items = dict(stats)
    return {name: np.asarray(value).tolist() for name, value in items.items()}
