"""Human3.6M walking actions (exponential-map text files) as :class:`~stitchjax.data.windows.Windows`.

File format (``../shared/data/h36m/SKELETON.md``): one frame per line, 99 comma-separated floats at
50 Hz; columns 0-2 the root translation and columns 3-5 the root rotation, both *differential*;
columns 3+3k..5+3k the exponential map of joint k (k = 0..31). Files live in ``<data_dir>/<S>/*.txt``
(S1, S5, S6, S7, S8 train; S9, S11 test).

What this module produces, and the choices made (each checked on the shared data):

- **Rotation convention.** The files are row-vector style: ``R_child = R_local · R_parent`` and a
  child's position is ``offset · R_parent + parent``. In our column convention (global = parent *
  local, positions rotated by the parent's global rotation) the local rotation is the transpose,
  i.e. the quaternion of ``-expmap`` (``conj(expmap_to_quat(e))``). Checked: bone lengths are
  constant over time and the reconstructed body stays upright and on its feet.
- **Root.** Reconstructed as SKELETON.md states, starting from the identity at the frame before
  the first: ``R_t = R(d_t) R_{t-1}`` and ``T_t = T_{t-1} + R_{t-1}^T d_t`` (row convention) — in
  quaternions ``q_t = q_{t-1} * conj(quat(d_t))``, ``T_t = T_{t-1} + rotate(q_{t-1}, d_t)``.
- **Up axis: +Y, ground at y = 0.** Since the root starts at the identity, the reconstructed
  motion lives in the frame of the first frame's pelvis, which is up to ~22° off the vertical (the
  files' trajectories tilt by ~70 cm over a walk). Each file is therefore levelled: the ground
  plane is fitted (least squares) through the lowest foot joint of every frame, and the whole
  motion is rotated (a proper rotation, no axis swap) so that the plane's normal is +Y and shifted
  so that the plane is y = 0. The original visualisation's y/z swap is not needed: after the
  differential reconstruction the body's own up axis is the pelvis's +Y.
- **Units: centimetres** (the files' millimetres / 10), like LAFAN1, so the contact threshold and
  cm-based metrics mean the same on both datasets.
- **Frame rate: 25 Hz.** Reconstruction and levelling run at 50 Hz; every second frame is then kept
  (frames 0, 2, 4, ...), the usual practice in motion-prediction work.
- **Joints: the 21 that move.** The 11 joints 5, 10, 15, 20-23, 28-31 have a zero exponential map
  in every frame of every file (std 0 on the training set, so std > 1e-4 keeps the other 21);
  they are end sites or constant leaf chains below the hands. They carry no motion — only where
  the toe tips, head top and hand ends sit — so they are dropped, which keeps the network's
  per-joint state free of constant channels. No kept joint hangs below a dropped one, so the
  remaining tree and offsets are unchanged.
- **Feet** (contact order as LAFAN1: left foot, left toe, right foot, right toe): original joints
  8, 9, 3, 4 — joints 1-5 are the right leg (checked: the joint-1 hip lies on the walker's right
  of the direction of travel in every file) — i.e. indices (7, 8, 3, 4) of the kept skeleton.
- **Facing:** the pelvis's local +Z points forward (checked against the walking direction), so
  windows are turned so that it faces +X at frame 9, like LAFAN1; centring as LAFAN1.
- Windows of 50 frames every 20 (training, S1 S5 S6 S7 S8), contacts with the LAFAN1 rule
  (squared displacement per frame < 0.02 cm², at 25 Hz).
"""
from __future__ import annotations

import dataclasses
import os
import pathlib

import numpy as np

from stitchjax.data import cache
from stitchjax import rotations as R
from stitchjax.skeleton import Skeleton, forward_kinematics
from stitchjax.data.windows import (FACING_FRAME, Stats, Windows, clip_moments, clip_windows, clips_statistics,
                               concatenate_clips)

__all__ = [
    "H36MNotFoundError", "H36M_SKELETON", "H36M_FEET", "FEET", "JOINT_NAMES", "PARENTS",
    "FORWARD_AXIS", "TRAIN_SUBJECTS", "TEST_SUBJECTS", "FPS",
    "list_files", "read_file", "load_windows", "train_statistics", "test_windows",
]

TRAIN_SUBJECTS = ("S1", "S5", "S6", "S7", "S8")
TEST_SUBJECTS = ("S9", "S11")
SOURCE_FPS = 50.0
SUBSAMPLE = 2
FPS = SOURCE_FPS / SUBSAMPLE
FORWARD_AXIS = (0.0, 0.0, 1.0)  # the pelvis's local forward axis

# The 32-joint skeleton of the files (SKELETON.md), offsets in millimetres.
_PARENTS_32 = (-1, 0, 1, 2, 3, 4, 0, 6, 7, 8, 9, 0, 11, 12, 13, 14, 12, 16, 17, 18, 19, 20, 19, 22,
               12, 24, 25, 26, 27, 28, 27, 30)
_OFFSETS_32_MM = np.array([
    (0, 0, 0), (-132.948591, 0, 0), (0, -442.894612, 0), (0, -454.206447, 0),
    (0, 0, 162.767078), (0, 0, 74.999437), (132.948826, 0, 0), (0, -442.894413, 0),
    (0, -454.206590, 0), (0, 0, 162.767426), (0, 0, 74.999948), (0, 0.1, 0),
    (0, 233.383263, 0), (0, 257.077681, 0), (0, 121.134938, 0), (0, 115.002227, 0),
    (0, 257.077681, 0), (0, 151.034226, 0), (0, 278.882773, 0), (0, 251.733451, 0),
    (0, 0, 0), (0, 0, 99.999627), (0, 100.000188, 0), (0, 0, 0),
    (0, 257.077681, 0), (0, 151.031437, 0), (0, 278.892924, 0), (0, 251.728680, 0),
    (0, 0, 0), (0, 0, 99.999888), (0, 137.499922, 0), (0, 0, 0)])
_NAMES_32 = (
    "Hips", "RightUpLeg", "RightLeg", "RightFoot", "RightToeBase", "RightToeEnd", "LeftUpLeg",
    "LeftLeg", "LeftFoot", "LeftToeBase", "LeftToeEnd", "Spine", "Spine1", "Neck", "Head",
    "HeadEnd", "LeftShoulder", "LeftArm", "LeftForeArm", "LeftHand", "LeftHandThumb",
    "LeftThumbEnd", "LeftWristEnd", "LeftWristEndSite", "RightShoulder", "RightArm",
    "RightForeArm", "RightHand", "RightHandThumb", "RightThumbEnd", "RightWristEnd",
    "RightWristEndSite")
CONSTANT_JOINTS = (5, 10, 15, 20, 21, 22, 23, 28, 29, 30, 31)  # zero expmap in every frame
KEPT_JOINTS = tuple(j for j in range(32) if j not in CONSTANT_JOINTS)  # 21 joints
_NEW_INDEX = {j: i for i, j in enumerate(KEPT_JOINTS)}

H36M_SKELETON = Skeleton(
    names=tuple(_NAMES_32[j] for j in KEPT_JOINTS),
    parents=tuple(-1 if _PARENTS_32[j] < 0 else _NEW_INDEX[_PARENTS_32[j]] for j in KEPT_JOINTS),
    offsets=_OFFSETS_32_MM[list(KEPT_JOINTS)] / 10.0)  # centimetres
# LeftFoot, LeftToeBase, RightFoot, RightToeBase (original joints 8, 9, 3, 4).
H36M_FEET = tuple(_NEW_INDEX[j] for j in (8, 9, 3, 4))
# Short aliases (what configs and other modules look up).
FEET = H36M_FEET
JOINT_NAMES = H36M_SKELETON.names
PARENTS = H36M_SKELETON.parents


_CODE = ("stitchjax.rotations", "stitchjax.skeleton", "stitchjax.data.windows", "stitchjax.data.h36m")


class H36MNotFoundError(FileNotFoundError):
    """The Human3.6M folder or the files of the subjects a step needs are missing."""


def list_files(data_dir) -> dict:
    """``{"S1": [Path, ...], ...}``: the ``<data_dir>/<subject>/*.txt`` files, sorted."""
    folder = pathlib.Path(os.fspath(data_dir)).expanduser()
    if not folder.is_dir():
        raise H36MNotFoundError(
            f"Human3.6M folder {folder} does not exist: pass the folder holding S1, S5, ... "
            f"(exponential-map .txt files, e.g. ../shared/data/h36m).")
    found = {}
    for sub in sorted(folder.iterdir(), key=lambda p: (len(p.name), p.name)):
        if sub.is_dir() and sub.name.startswith("S") and sub.name[1:].isdigit():
            files = sorted(p for p in sub.glob("*.txt") if p.is_file())
            if files:
                found[sub.name] = files
    return found


def _files_for(data_dir, subjects) -> list:
    subjects = (subjects,) if isinstance(subjects, str) else tuple(subjects)
    found = list_files(data_dir)
    files = [p for s in subjects for p in found.get(s, [])]
    if not files:
        have = (f"it holds {', '.join(f'{s} ({len(v)} files)' for s, v in found.items())}" if found
                else "it holds no <subject>/*.txt files")
        raise H36MNotFoundError(f"no Human3.6M files of {', '.join(subjects)} in {data_dir}: {have}.")
    return files


def _prefix_products(q):
    """Ordered prefix products ``q[0] * q[1] * ... * q[t]`` along axis 0 (log-depth scan)."""
    out = np.array(q, copy=True)
    shift = 1
    while shift < len(out):
        out[shift:] = R.quat_mul(out[:-shift], out[shift:])
        shift *= 2
    return R.quat_normalize(out)


def read_file(path):
    """One exponential-map file -> (rotations (T, 21, 4), positions (T, 21, 3)) local transforms at
    25 Hz, cm, Y-up, levelled and on the ground (see the module docstring)."""
    try:
        values = np.loadtxt(path, delimiter=",", dtype=np.float64, ndmin=2)
    except ValueError as e:
        raise ValueError(f"{path}: not a Human3.6M exponential-map file ({e})") from None
    if values.shape[1] != 99 or len(values) < 2:
        raise ValueError(f"{path}: expected lines of 99 comma-separated numbers, got {values.shape}")
    expmaps = values[:, 3:].reshape(-1, 32, 3)[:, list(KEPT_JOINTS)]
    local = R.quat_conjugate(R.expmap_to_quat(expmaps))  # row-vector R_local -> its transpose
    root = _prefix_products(local[:, 0])  # absolute root orientation, column convention
    before = np.concatenate([R.quat_identity((1,)), root[:-1]])  # q_{t-1}, identity before frame 0
    trajectory = np.cumsum(R.quat_rotate(before, values[:, :3]), axis=0) / 10.0  # cm
    local[:, 0] = root
    positions = np.broadcast_to(H36M_SKELETON.offsets, local.shape[:-1] + (3,)).copy()
    positions[:, 0] = trajectory
    local, positions = _level(local, positions)
    return local[::SUBSAMPLE], positions[::SUBSAMPLE]


def _level(rotations, positions):
    """Rotate the whole motion so the fitted ground plane is horizontal (+Y up) and at y = 0."""
    _, gpos = forward_kinematics(rotations, positions, H36M_SKELETON.parents)
    feet = gpos[:, list(H36M_FEET)]  # (T, 4, 3)
    up = gpos[:, H36M_SKELETON.index("Head")] - gpos[:, 0]
    normal = up.mean(axis=0)
    normal /= np.linalg.norm(normal)
    for _ in range(3):  # plane through each frame's lowest foot joint, refit with the new "down"
        lowest = feet[np.arange(len(feet)), np.argmin(feet @ normal, axis=1)]
        centre = lowest.mean(axis=0)
        fitted = np.linalg.svd(lowest - centre, full_matrices=False)[2][2]
        normal = fitted if fitted @ normal > 0 else -fitted
    turn = R.quat_between(normal, np.array([0.0, 1.0, 0.0]))
    rotations = rotations.copy()
    positions = positions.copy()
    rotations[:, 0] = R.quat_mul(turn, rotations[:, 0])
    positions[:, 0] = R.quat_rotate(turn, positions[:, 0])
    positions[:, 0, 1] -= R.quat_rotate(turn, centre)[1]
    return rotations, positions


def _source_name(path) -> str:
    """``<subject>/<file>`` of a file, as the windows' sources name it."""
    return f"{pathlib.Path(path).parent.name}/{pathlib.Path(path).name}"


def _build(files, window, offset, frame=FACING_FRAME) -> dict:
    """The cached arrays of ``files``: rotations, positions, contacts (windows of all files, in order), sources."""
    clips = [clip_windows(*read_file(f), H36M_SKELETON.parents, window, offset, H36M_FEET, frame, FORWARD_AXIS)
             for f in files]
    return {**concatenate_clips(clips),
            "sources": np.array([f"{_source_name(f)}:{s}" for f, c in zip(files, clips) for s in c["starts"]],
                                dtype=str)}


def load_windows(data_dir, subjects=TRAIN_SUBJECTS, window: int = 50, offset: int = 20,
                 cache_dir=None) -> Windows:
    """Centred, facing-aligned windows (float64, cm, 25 Hz, 21 joints) of all files of ``subjects``.

    ``sources`` name ``<subject>/<file>:<start frame at 25 Hz>``. Cached like LAFAN1 windows.
    """
    subjects = (subjects,) if isinstance(subjects, str) else tuple(subjects)
    files = _files_for(data_dir, subjects)
    params = {"window": int(window), "offset": int(offset), "frame": FACING_FRAME,
              "subjects": list(subjects), "names": [_source_name(p) for p in files]}
    arrays = cache.cached("h36m-windows", files, params, lambda: _build(files, window, offset),
                          cache_dir, _CODE)
    return Windows(arrays["rotations"], arrays["positions"], arrays["contacts"], H36M_SKELETON, FPS,
                   arrays["sources"].tolist())


def test_windows(data_dir, window: int = 65, offset: int = 40, cache_dir=None) -> Windows:
    """Evaluation windows of the test subjects S9 and S11 (65/40, the LAFAN1 protocol of
    docs/design.md §6 applied to Human3.6M)."""
    return load_windows(data_dir, TEST_SUBJECTS, window, offset, cache_dir)


test_windows.__test__ = False  # a data loader, not a pytest test


def train_statistics(data_dir, subjects=TRAIN_SUBJECTS, window: int = 50, offset: int = 20,
                     cache_dir=None) -> Stats:
    """:class:`Stats` of the training windows (global positions, centred + faced), 63 values, cm."""
    subjects = (subjects,) if isinstance(subjects, str) else tuple(subjects)
    files = _files_for(data_dir, subjects)
    params = {"window": int(window), "offset": int(offset), "frame": FACING_FRAME,
              "names": [_source_name(p) for p in files]}

    def compute():
        clips = [clip_moments(*read_file(f), H36M_SKELETON.parents, window, offset, FACING_FRAME, FORWARD_AXIS)
                 for f in files]
        return dataclasses.asdict(clips_statistics(clips))

    return Stats(**cache.cached("h36m-stats", files, params, compute, cache_dir, _CODE))
