"""A folder of BVH files on any one skeleton as training / test windows (next to lafan1 and h36m).

What the config (``config.data``) declares, each with a default inferred from common joint names:

- ``feet``: the four contact joints by name, in the order left foot, left toe, right foot, right toe
  (default: joints named like LeftFoot / LeftToe(Base) / RightFoot / RightToe(Base), also ``L``/``R``
  prefixes and ankle / toes spellings);
- ``up_axis``: the files' world up axis ("+y", "+z", ...; default: the axis nearest the direction from
  the feet to the head in the first frame);
- ``forward_axis``: the root's local forward axis (default: the cross product of the left-minus-right
  upper-leg direction with the up direction, in the root's rest frame);
- the split: ``train_files`` / ``test_files`` (glob patterns of paths relative to the folder), or
  ``train_subjects`` (a subject matches a folder of that name or a file stem ending in ``_<subject>``);
  with neither, every file trains;
- ``fps``: the model's frame rate; every clip is resampled to it on load (slerp for rotations);
- ``unit_scale``: centimetres per file unit (0 = inferred: a skeleton 80-250 units from feet to head is
  in cm, 0.8-2.5 in m; otherwise an error asks for it). All files' bone lengths are checked against the
  first training file's (the training skeleton), so a file in other units is refused by name.

On load, every take is rescaled to centimetres, turned so its up axis is +Y and resampled to ``fps``;
windows, contacts (on the declared feet) and statistics then follow the LAFAN1 recipe (docs/design.md §4)
with the declared forward axis. Cached like the LAFAN1 windows.
"""
from __future__ import annotations

import dataclasses
import fnmatch
import os
import pathlib
import re

import numpy as np

from stitchjax.data import bvh, cache, conform
from stitchjax.data.features import NUM_CONTACTS
from stitchjax import rotations as R
from stitchjax.skeleton import Skeleton, forward_kinematics
from stitchjax.data.windows import FACING_FRAME, Stats, Windows, clip_windows, concatenate_clips, window_statistics

__all__ = ["BVHFolderError", "Resolved", "list_files", "split_files", "resolve", "load_take", "load_windows",
           "load_windows_and_stats", "skeleton_facts", "DATASET_SCALE_TOLERANCE"]

DATASET_SCALE_TOLERANCE = 0.3  # actors differ by ~10-20 %; units by 2.54x, 100x
_CODE = ("stitchjax.rotations", "stitchjax.skeleton", "stitchjax.data.bvh", "stitchjax.data.windows",
         "stitchjax.data.conform", "stitchjax.data.bvh_folder")


class BVHFolderError(ValueError):
    """The folder, its split or the declared skeleton facts do not fit; the message says what to set."""


@dataclasses.dataclass(frozen=True)
class Resolved:
    """The skeleton facts of a folder: feet (joint indices), up (3,), forward (3,) root-local, cm per unit."""

    feet: tuple
    up: tuple
    forward: tuple
    unit_scale: float


# ------------------------------------------------------------------------------------------ files

def list_files(data_dir) -> list:
    """Every ``.bvh`` / ``.bvh.gz`` file below ``data_dir`` (recursive), sorted by relative path."""
    folder = pathlib.Path(os.fspath(data_dir)).expanduser()
    if not folder.is_dir():
        what = "is a file, not a folder" if folder.exists() else "does not exist"
        raise FileNotFoundError(f"--data {folder} {what}: pass a folder of .bvh / .bvh.gz files")
    files = [p for p in folder.rglob("*") if p.is_file() and p.name.lower().endswith((".bvh", ".bvh.gz"))]
    if not files:
        raise FileNotFoundError(f"--data {folder}: no .bvh or .bvh.gz files in it")
    return sorted(files, key=lambda p: p.relative_to(folder).as_posix())


def _matches_subject(rel: pathlib.PurePath, subject: str) -> bool:
    return subject in rel.parts[:-1] or bvh.file_stem(rel.name).endswith(f"_{subject}")


def split_files(data_dir, data, split: str = "train") -> list:
    """The files of ``split`` ("train", "validation" or "test") under ``data_dir`` by ``data``'s patterns or
    subjects; "validation" = the stems of ``data.validation_files``, which "train" leaves out."""
    folder = pathlib.Path(os.fspath(data_dir)).expanduser()
    files = list_files(folder)
    rel = {p: pathlib.PurePosixPath(p.relative_to(folder).as_posix()) for p in files}
    train_patterns, test_patterns = tuple(data.train_files), tuple(data.test_files)

    def matches(p, patterns):
        return any(fnmatch.fnmatch(str(rel[p]), pat) or fnmatch.fnmatch(rel[p].name, pat) for pat in patterns)

    validation = {bvh.file_stem(n) for n in getattr(data, "validation_files", ())}
    if split == "validation":
        chosen = [p for p in files if bvh.file_stem(p) in validation]
        what = f"data.validation_files={tuple(data.validation_files)}"
    elif split == "test":
        chosen = [p for p in files if matches(p, test_patterns)] if test_patterns else []
        what = f"data.test_files={test_patterns}"
    elif train_patterns:
        chosen = [p for p in files if matches(p, train_patterns) and not matches(p, test_patterns)]
        what = f"data.train_files={train_patterns}"
    elif data.train_subjects and any(_matches_subject(rel[p], s) for p in files for s in data.train_subjects):
        chosen = [p for p in files if any(_matches_subject(rel[p], s) for s in data.train_subjects)
                  and not matches(p, test_patterns)]
        what = f"data.train_subjects={tuple(data.train_subjects)}"
    else:
        chosen = [p for p in files if not matches(p, test_patterns)]
        what = "every file not in data.test_files"
    if split == "train":
        chosen = [p for p in chosen if bvh.file_stem(p) not in validation]  # the validation takes never train
    if not chosen:
        names = ", ".join(str(rel[p]) for p in files[:6]) + (" ..." if len(files) > 6 else "")
        raise BVHFolderError(f"no {split} files in {folder} for {what}; it holds {names}. Set data.train_files / "
                             f"data.test_files to glob patterns (e.g. data.train_files='*.bvh')")
    return chosen


# ------------------------------------------------------------------------------- skeleton facts

_LEFT = re.compile(r"^(left|l(?=[A-Z_])|l_)", re.IGNORECASE)
_RIGHT = re.compile(r"^(right|r(?=[A-Z_])|r_)", re.IGNORECASE)


def _side_and_part(name: str):
    """("left" / "right" / None, the rest of the name lower-cased without separators)."""
    for side, pattern in (("left", _LEFT), ("right", _RIGHT)):
        m = pattern.match(name)
        if m and (m.group(0).lower() in ("left", "right") or name[len(m.group(0)):][:1].isupper()
                  or m.group(0).endswith("_")):
            return side, re.sub(r"[^a-z0-9]", "", name[len(m.group(0)):].lower())
    return None, re.sub(r"[^a-z0-9]", "", name.lower())


def _find(names, side, parts):
    """Index of the first joint of ``side`` whose part is one of ``parts`` (in order of preference)."""
    labelled = [_side_and_part(n) for n in names]
    for part in parts:
        for j, (s, p) in enumerate(labelled):
            if s == side and p == part:
                return j
    return None


_FOOT = ("foot", "ankle")
_TOE = ("toebase", "toe", "toes", "toe0", "ball")
_UPLEG = ("upleg", "upperleg", "thigh", "hip", "hipjoint")


def _index(names, name: str, what: str) -> int:
    if name not in names:
        raise BVHFolderError(f"{what}: no joint named {name!r}; the joints are {', '.join(names)}")
    return names.index(name)


def resolve(motion, data) -> Resolved:
    """The feet, up axis, root forward axis and units of a take, from ``data`` or inferred from names."""
    names = motion.skeleton.names
    if data.feet:
        if len(data.feet) != NUM_CONTACTS:
            raise BVHFolderError(f"data.feet={tuple(data.feet)} names {len(data.feet)} joints; name "
                                 f"{NUM_CONTACTS}: the left foot, left toe, right foot and right toe")
        feet = tuple(_index(names, n, "data.feet") for n in data.feet)
    else:
        found = [_find(names, side, parts) for side in ("left", "right") for parts in (_FOOT, _TOE)]
        if None in found:
            raise BVHFolderError(
                f"cannot tell the foot joints from the names ({', '.join(names)}): set data.feet to the left "
                f"foot, left toe, right foot and right toe joint names, e.g. data.feet=LeftFoot,LeftToe,RightFoot,"
                f"RightToe")
        feet = tuple(found)
    grot, gpos = forward_kinematics(motion.rotations[:1], motion.positions[:1], motion.skeleton.parents)
    gpos, root_rotation = gpos[0], grot[0, 0]  # the first frame, in the world
    head = next((j for j, n in enumerate(names) if _side_and_part(n) == (None, "head")), None)
    if head is None:  # the joint farthest from the feet
        head = int(np.argmax(np.linalg.norm(gpos - gpos[list(feet)].mean(0), axis=-1)))
    up_world = gpos[head] - gpos[list(feet)].mean(0)
    up = _declared_axis(data.up_axis, "up_axis") if data.up_axis else _snap(up_world)
    if data.forward_axis:
        forward = _declared_axis(data.forward_axis, "forward_axis")
    else:
        left, right = _find(names, "left", _UPLEG), _find(names, "right", _UPLEG)
        if left is None or right is None:
            raise BVHFolderError(f"cannot tell the root's forward axis: no left / right upper-leg joints among "
                                 f"{', '.join(names)}; set data.forward_axis (e.g. +z)")
        forward_world = np.cross(gpos[left] - gpos[right], up)  # left x up = forward (right-handed)
        forward = _snap(R.quat_rotate(R.quat_conjugate(root_rotation), forward_world))
    up_local = up_world
    scale = float(data.unit_scale)
    if scale <= 0:
        height = float(np.linalg.norm(up_local))
        if 80 <= height <= 250:
            scale = 1.0
        elif 0.8 <= height <= 2.5:
            scale = 100.0
        else:
            raise BVHFolderError(
                f"cannot tell the files' units: the skeleton measures {height:.4g} units from feet to head, "
                f"neither centimetres nor metres; set data.unit_scale to centimetres per file unit (CMU "
                f"files: 5.6444, inches: 2.54)")
    return Resolved(feet, tuple(float(x) for x in up), tuple(float(x) for x in forward), scale)


def skeleton_facts(data_dir, data) -> dict | None:
    """The skeleton facts of a BVH-folder run (``stitchjax.data.datasets.Dataset.skeleton_facts``), resolved as
    :func:`load_windows` resolves them, on the first training file under ``data_dir`` (None when
    ``data_dir`` is None: arrays prepared elsewhere, facts unknown)."""
    if data_dir is None:
        return None
    motion = bvh.load(split_files(data_dir, data, "train")[0])
    resolved = resolve(motion, data)
    names = [str(n) for n in motion.skeleton.names]
    feet = resolved.feet
    return {"joint_names": names, "feet": [int(j) for j in feet], "feet_names": [names[int(j)] for j in feet],
            "up_axis": conform.axis_name(resolved.up), "forward_axis": conform.axis_name(resolved.forward),
            "unit_scale": float(resolved.unit_scale)}


def _declared_axis(text: str, field: str) -> np.ndarray:
    """The unit axis ``data.<field>`` names ("+y", "-z", ...); BVHFolderError naming the field otherwise."""
    try:
        return conform.parse_axis(text)
    except conform.ConformError as error:
        raise BVHFolderError(f"data.{field}: {error}") from None


def _snap(v) -> np.ndarray:
    """The signed coordinate axis nearest the direction ``v``."""
    v = np.asarray(v, np.float64)
    out = np.zeros(3)
    k = int(np.argmax(np.abs(v)))
    out[k] = np.sign(v[k]) or 1.0
    return out


def load_take(path, data, resolved: Resolved | None = None):
    """One file in the model's terms: (Motion in cm, +Y up, at ``data.fps``; its Resolved facts)."""
    motion = bvh.load(path)
    resolved = resolve(motion, data) if resolved is None else resolved
    motion = conform.rescale(motion, resolved.unit_scale) if resolved.unit_scale != 1.0 else motion
    motion = conform.to_y_up(motion, resolved.up)
    motion, _ = conform.resample(motion, data.fps, 0)
    return motion, resolved


# ------------------------------------------------------------------------------------- windows

def _build(files, data, window: int, offset: int) -> dict:
    first_motion, resolved = load_take(files[0], data)
    ref_offsets = first_motion.skeleton.offsets  # the training skeleton: every file is checked against it
    sk0 = first_motion.skeleton
    clips, sources = [], []
    for path in files:
        motion = first_motion if path == files[0] else load_take(path, data, resolved)[0]
        sk = motion.skeleton
        if (sk.names, sk.parents) != (sk0.names, sk0.parents):
            raise BVHFolderError(f"{path} has a different joint hierarchy from {files[0]}; all files of a folder "
                                 f"must share one skeleton (or split them with data.train_files)")
        try:
            conform.check_scale(sk.offsets, ref_offsets, str(path), f"the training skeleton ({files[0].name})",
                                "set data.unit_scale for its folder, or convert the file",
                                tolerance=DATASET_SCALE_TOLERANCE)
        except conform.ConformError as error:
            raise BVHFolderError(str(error)) from None
        clip = clip_windows(motion.rotations, motion.positions, sk.parents, window, offset, resolved.feet,
                            FACING_FRAME, resolved.forward)
        clips.append(clip)
        sources += [f"{pathlib.Path(path).name}:{s}" for s in clip["starts"]]
    if not sources:
        raise BVHFolderError(f"no file is longer than {window} frames at {data.fps:g} fps: no windows")
    return {**concatenate_clips(clips), "sources": np.array(sources, dtype=str),
            "names": np.array(sk0.names, dtype=str), "parents": np.array(sk0.parents, dtype=np.int64),
            "offsets": sk0.offsets, "feet": np.array(resolved.feet, dtype=np.int64),
            "forward": np.array(resolved.forward), "up": np.array(resolved.up),
            "unit_scale": np.float64(resolved.unit_scale), "joints": np.int64(sk0.num_joints)}


def _params(data, window, offset, split) -> dict:
    keys = ("feet", "up_axis", "forward_axis", "train_files", "test_files", "train_subjects", "fps", "unit_scale")
    return {"window": int(window), "offset": int(offset), "split": split, "frame": FACING_FRAME,
            **{k: getattr(data, k) for k in keys}, "num_contacts": NUM_CONTACTS}


def load_windows(data_dir, data, split: str = "train", window: int | None = None, offset: int | None = None,
                 cache_dir=None) -> Windows:
    """Centred, facing-aligned windows (float64, cm, +Y up, ``data.fps``) of the files of ``split``.

    window / offset default to ``data.window`` / ``data.offset``. ``Windows.contacts`` follow the
    declared (or inferred) feet; the resolved facts are in the returned windows' ``resolved`` attribute.
    """
    window = data.window if window is None else window
    offset = data.offset if offset is None else offset
    files = split_files(data_dir, data, split)
    names = [p.name for p in files]
    arrays = cache.cached("bvh-folder-windows", files, {**_params(data, window, offset, split), "names": names},
                          lambda: _build(files, data, window, offset), cache_dir, _CODE)
    skeleton = Skeleton(tuple(arrays["names"].tolist()), tuple(arrays["parents"].tolist()), arrays["offsets"])
    windows = Windows(arrays["rotations"], arrays["positions"], arrays["contacts"], skeleton, float(data.fps),
                      arrays["sources"].tolist())
    object.__setattr__(windows, "resolved", Resolved(tuple(int(f) for f in arrays["feet"]),
                                                    tuple(arrays["up"].tolist()), tuple(arrays["forward"].tolist()),
                                                    float(arrays["unit_scale"])))
    return windows


def load_windows_and_stats(data_dir, data):
    """(training Windows, Stats) for ``bin/train`` (stats: global positions of the windows, cm)."""
    windows = load_windows(data_dir, data, "train")
    stats = window_statistics(windows)
    return windows, Stats(mean=stats.mean, std=stats.std, offsets=stats.offsets)
