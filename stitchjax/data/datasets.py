"""The dataset registry: one entry per value of ``config.data.dataset``, and the one place that asks it.

Each entry says where its windows come from and what its skeleton is:

    entry = datasets.get("lafan1")
    windows, stats = entry.training_windows(data_dir, config.data)    # subjects 1-4, 50/20 (config.data)
    windows, stats = entry.test_windows(data_dir, config.data)        # the benchmark windows, training stats
    facts = entry.skeleton_facts(data_dir, config.data)               # joint names, feet, axes, units

Every loader returns centred, facing-aligned windows in centimetres with +Y up (``windows.Windows``), and
:class:`~stitchjax.data.windows.Stats` of the training windows' global positions. LAFAN1 and Human3.6M have fixed
skeletons (the facts below); a BVH folder reads its skeleton from the files (``stitchjax.data.bvh_folder``).
"""
from __future__ import annotations

import dataclasses
import pathlib
import re
from typing import Callable

import numpy as np

from stitchjax.data import bvh, bvh_folder, conform, features, h36m, lafan1, bundled, mirror
from stitchjax.data import windows as windows_lib
from stitchjax import config as config_lib
from stitchjax.skeleton import LAFAN1_FEET, LAFAN1_FPS, LAFAN1_JOINTS, LAFAN1_PARENTS, Skeleton
from stitchjax.data.windows import Stats, Windows

__all__ = ["Dataset", "REGISTRY", "get", "names", "load_training_data", "stats_to_json", "skeleton_facts",
           "uses_training_set_options", "validation_files", "validation_windows", "training_set", "take_of",
           "extra_training_files"]

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
            default_data_dir=bundled.sample_dir, joint_names=LAFAN1_JOINTS, parents=LAFAN1_PARENTS,
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


def load_training_data(data, data_dir):
    """(dataset dict of (N, T, ...) numpy arrays from ``features.prepare_dataset``, Stats) of the training
    windows of ``data.dataset`` (``data``: the config's data section); data_dir None = the dataset's default
    (LAFAN1: the bundled sample).

    With any of data.validation_files, data.extra_train_dirs, data.random_starts, data.mirror set, the
    windows come from :func:`training_set` (random starts: T = window + offset - 1 frames per carried window,
    plus ``features.RANDOM_START_KEYS``). Raises ValueError saying what to fix (a validation take that is a
    test file, an extra file that is a test, validation or main take, an asymmetric skeleton to mirror)."""
    entry = get(data.dataset)
    if uses_training_set_options(data):
        return training_set(entry.data_dir(data_dir), data)
    windows, stats = entry.training_windows(entry.data_dir(data_dir), data)
    dataset = features.prepare_dataset(windows, stats, data)
    return {name: np.asarray(x) for name, x in dataset.items()}, stats


# ------------------------------------------------------------------------ validation split, extra data


def uses_training_set_options(data) -> bool:
    """True when ``data`` sets any of validation_files, extra_train_dirs, random_starts, mirror."""
    return bool(data.validation_files or data.extra_train_dirs or data.random_starts or data.mirror)


def _main_files(folder: pathlib.Path, data) -> tuple[list, list]:
    """(training files before the validation split, test files) of the main dataset folder."""
    if data.dataset == "lafan1":
        found = lafan1.list_files(folder)
        train = sorted((p for s in data.train_subjects for p in found.get(s, [])), key=lambda p: p.name)
        test = sorted((p for s in lafan1.TEST_SUBJECTS for p in found.get(s, [])), key=lambda p: p.name)
        return train, test
    if data.dataset == "bvh_folder":
        no_validation = dataclasses.replace(data, validation_files=())
        train = bvh_folder.split_files(folder, no_validation, "train")
        test = bvh_folder.split_files(folder, data, "test") if data.test_files else []
        return train, test
    raise ValueError(f"data.validation_files / extra_train_dirs / random_starts / mirror work with the lafan1 and "
                     f"bvh_folder datasets, not {data.dataset!r}; unset them")


def _is_test_take(stem: str, test_stems, data) -> bool:
    if stem in test_stems:
        return True
    return data.dataset == "lafan1" and any(stem.endswith(f"_{s}") for s in lafan1.TEST_SUBJECTS)


def validation_files(data_dir, data) -> list:
    """The files of ``data.validation_files`` (take names: file names without .bvh / .bvh.gz) in the main
    folder, in the config's order. ValueError when one is a test file, is missing, or is not a training file."""
    folder = pathlib.Path(data_dir).expanduser()
    train, test = _main_files(folder, data)
    test_stems = {bvh.file_stem(p) for p in test}
    by_stem = {bvh.file_stem(p): p for p in train}
    chosen = []
    for name in data.validation_files:
        stem = bvh.file_stem(name)
        if _is_test_take(stem, test_stems, data):
            raise ValueError(f"data.validation_files: {name!r} is a test file; the validation split must come from "
                             f"the training files (test files: {', '.join(sorted(test_stems)) or 'the test subjects'})")
        if stem not in by_stem:
            raise ValueError(f"data.validation_files: {name!r} is not a training file in {folder}; name takes "
                             f"among {', '.join(sorted(by_stem))}")
        chosen.append(by_stem[stem])
    return chosen


_TAKE = re.compile(r"^(?P<take>[A-Za-z0-9]+_subject\d+)(_.*)?$")


def take_of(stem: str) -> str:
    """The take a file stem belongs to: ``walk2_subject1_walk_filtered`` -> ``walk2_subject1`` (LAFAN1
    names ``<action>_subject<N>``); other names are their own take."""
    match = _TAKE.match(stem)
    return match["take"] if match else stem


def extra_training_files(data_dir, data) -> list:
    """Every .bvh / .bvh.gz file of ``data.extra_train_dirs`` (sorted per folder). ValueError naming the file
    when one's take is a test file (or of a test subject), a validation take, or a take of the main folder."""
    folder = pathlib.Path(data_dir).expanduser()
    train, test = _main_files(folder, data)
    test_stems = {bvh.file_stem(p) for p in test}
    main_takes = {take_of(bvh.file_stem(p)) for p in list(bvh_folder.list_files(folder))}
    validation = {take_of(bvh.file_stem(n)) for n in data.validation_files}
    files = []
    for extra in data.extra_train_dirs:
        extra_dir = pathlib.Path(extra).expanduser()
        if not extra_dir.is_absolute():
            extra_dir = folder / extra_dir
        try:
            found = bvh_folder.list_files(extra_dir)
        except FileNotFoundError as error:
            raise ValueError(f"data.extra_train_dirs: {error}") from None
        for path in found:
            take = take_of(bvh.file_stem(path))
            if _is_test_take(take, {take_of(t) for t in test_stems}, data):
                raise ValueError(f"data.extra_train_dirs: {path} is of the test take {take!r}; remove it from "
                                 f"{extra_dir} (test data never trains)")
            if take in validation:
                raise ValueError(f"data.extra_train_dirs: {path} is of the validation take {take!r}; remove it "
                                 f"from {extra_dir} or from data.validation_files")
            if take in main_takes:
                raise ValueError(f"data.extra_train_dirs: {path} is of the take {take!r}, already a file of "
                                 f"{folder}; remove it from {extra_dir}")
            files.append(path)
    return files


def _conformed(motion, data, names, parents, reference_offsets, what: str):
    """An extra take on the main skeleton: at data.fps (an integer ratio keeps every k-th original frame),
    joints mapped by name (an extra root above Hips folded in), bone lengths checked against the main ones."""
    ratio = float(motion.fps) / float(data.fps)
    if abs(ratio - round(ratio)) < 1e-6 and round(ratio) >= 1:
        step = int(round(ratio))
        motion = dataclasses.replace(motion, rotations=motion.rotations[::step], positions=motion.positions[::step],
                                     fps=float(data.fps))
    else:
        motion, _ = conform.resample(motion, data.fps, 0)
    try:
        motion = conform.map_joints(motion, names, parents, what)
        conform.check_scale(motion.skeleton.offsets, reference_offsets, what, "the main training skeleton",
                            "convert the file to the main files' units",
                            tolerance=bvh_folder.DATASET_SCALE_TOLERANCE)
    except conform.ConformError as error:
        raise ValueError(f"data.extra_train_dirs: {error}") from None
    return motion


def _main_loader(train: list, data) -> tuple:
    """(the first main training file's Motion, load(path) -> a main training file's Motion (the first one not
    read again), the contact joints, the forward axis) of ``data.dataset``."""
    if data.dataset == "lafan1":
        first = bvh.load(train[0])
        feet, forward = tuple(LAFAN1_FEET), (0.0, 1.0, 0.0)

        def load_main(path):
            return first if path == train[0] else bvh.load(path)
    else:
        first, resolved = bvh_folder.load_take(train[0], data)
        feet, forward = tuple(resolved.feet), tuple(resolved.forward)

        def load_main(path):
            return first if path == train[0] else bvh_folder.load_take(path, data, resolved)[0]
    return first, load_main, feet, forward


def _training_clips(train: list, extra: list, load_main, skeleton: Skeleton, data, feet, forward) -> tuple:
    """(clips, sources): the windows of every main (``train``) and extra training file
    (``windows.clip_windows``) and each window's "file:start"."""
    names, parents = skeleton.names, skeleton.parents
    extra_frames = data.offset - 1 if data.random_starts else 0
    clips, sources = [], []
    for path, is_extra in [(p, False) for p in train] + [(p, True) for p in extra]:
        motion = load_main(path) if not is_extra else _conformed(bvh.load(path), data, names, parents,
                                                                   skeleton.offsets, str(path))
        if (motion.skeleton.names, motion.skeleton.parents) != (names, parents):
            raise ValueError(f"{path} has a different joint hierarchy from {train[0]}; all training files must "
                             "share one skeleton")
        clip = windows_lib.clip_windows(motion.rotations, motion.positions, parents, data.window, data.offset, feet,
                                        windows_lib.FACING_FRAME, forward, extra_frames=extra_frames)
        clips.append(clip)
        sources += [f"{pathlib.Path(path).name}:{s}" for s in clip["starts"]]
    if not sources:
        raise ValueError(f"no training file is longer than data.window={data.window} frames: no training windows")
    return clips, sources


def _with_mirror_images(arrays: tuple, sources: list, counts, facing, names, feet, forward) -> tuple:
    """(rotations, positions, contacts) ``arrays``, sources, counts and facing with every window's left/right
    mirror image appended (``mirror.mirror_arrays``), in the same order."""
    rotations, positions, contacts = arrays
    joint_map = mirror.mirror_joint_map(names)
    mirror.check_mirror_symmetry(positions[0, 0], joint_map, names)
    mirrored = mirror.mirror_arrays(rotations, positions, contacts, joint_map,
                                    mirror.mirror_contact_map(feet, joint_map))
    arrays = tuple(np.concatenate([a, b]) for a, b in zip((rotations, positions, contacts), mirrored))
    sources = sources + [f"{s}:mirrored" for s in sources]
    counts = None if counts is None else np.concatenate([counts, counts])
    if facing is not None:  # the mirror images are aligned windows of their own (no turn to undo)
        facing = np.concatenate([facing, windows_lib.facing_per_frame(mirrored[0][:, :, 0], forward)])
    return arrays, sources, counts, facing


def training_set(data_dir, data):
    """(dataset dict, Stats) of the training set with the data.* options (see :func:`load_training_data`).

    The main training files less ``data.validation_files``, then the files of ``data.extra_train_dirs``
    (conformed to the main skeleton by :func:`_conformed`), cut into windows as the benchmark does
    (window / offset of ``data``, centred and faced at frame 9). data.random_starts: each window carries
    offset - 1 more frames and the arrays "facing" and "start_counts", so the train step can start a window at
    any frame (features.random_start_batch). data.mirror: every window is followed by its left/right mirror
    image (mirror.mirror_arrays). Stats: of every window's first ``window`` frames, mirrored ones included.
    """
    folder = pathlib.Path(data_dir).expanduser()
    train, _ = _main_files(folder, data)
    held_out = set(validation_files(folder, data))
    train = [p for p in train if p not in held_out]
    if not train:
        raise ValueError("data.validation_files holds out every training file: keep some for training")
    extra = extra_training_files(folder, data)
    first, load_main, feet, forward = _main_loader(train, data)
    skeleton = first.skeleton
    names, parents = skeleton.names, skeleton.parents
    clips, sources = _training_clips(train, extra, load_main, skeleton, data, feet, forward)
    arrays = windows_lib.concatenate_clips(clips)
    rotations, positions, contacts = arrays["rotations"], arrays["positions"], arrays["contacts"]
    counts = np.concatenate([clip["start_counts"] for clip in clips]) if data.random_starts else None
    facing = (windows_lib.facing_per_frame(rotations[:, :, 0], forward, np.concatenate([c["turns"] for c in clips]))
              if data.random_starts else None)
    if data.mirror:
        (rotations, positions, contacts), sources, counts, facing = _with_mirror_images(
            (rotations, positions, contacts), sources, counts, facing, names, feet, forward)
    windows = Windows(rotations, positions, contacts, Skeleton(names, parents, skeleton.offsets), float(data.fps),
                      sources)
    dataset = features.prepare_dataset(windows, None, data)
    stats = windows_lib.window_statistics(windows, dataset["global_positions"][:, :data.window])
    if data.random_starts:
        dataset["facing"] = facing.astype(np.float32)
        dataset["start_counts"] = counts.astype(np.int32)[:, None]
    return {name: np.asarray(x) for name, x in dataset.items()}, stats


def validation_windows(data_dir, data):
    """(Windows, Stats) of the validation takes (``data.validation_files``), cut as the dataset's test windows
    (LAFAN1: 65 frames every 40), with the statistics the test windows are scored with."""
    folder = pathlib.Path(data_dir).expanduser()
    files = validation_files(folder, data)
    if not files:
        raise ValueError("no validation split: set data.validation_files to training takes to hold out")
    if data.dataset == "lafan1":
        return (lafan1.load_file_windows(files, lafan1.TEST_WINDOW, lafan1.TEST_OFFSET),
                lafan1.train_statistics(folder))
    return bvh_folder.load_windows(folder, data, "validation"), bvh_folder.load_windows_and_stats(folder, data)[1]


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
