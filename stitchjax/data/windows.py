"""Fixed-length motion windows: slicing, foot contacts, centring + facing alignment, time reversal;
the windows of a clip and the statistics of a set of clips, for every dataset.

The facts reproduced here are those of the official LAFAN1 benchmark code (docs/design.md §4):

- window starts ``0, offset, 2*offset, ...`` while ``start + window < T`` (strict: a window never
  ends on the file's last frame);
- contacts are computed on the *raw* window (before alignment) from FK global positions: a foot joint
  is in contact at frame t when ``|p[t+1] - p[t]|² < 0.02`` (file units², cm² for LAFAN1); the last
  frame repeats the previous frame's value;
- centring subtracts, from the root's x and z, their mean over the whole window (y untouched);
- facing: forward = (root global rotation at ``frame``) applied to (0, 1, 0), y zeroed, normalised;
  the whole window is rotated about the vertical axis through the origin so that forward becomes +X;
  local transforms are recovered by inverse kinematics.

One deliberate difference: the official code normalises the facing quaternion as ``q / (|q| + 1e-8)``,
which leaves it short of unit length by ~1e-8/|q| (and so scales the rotated window very slightly).
Here the facing rotation is exactly unit (docs/design.md §4: how far the two differ).

Everything works on numpy float64 arrays with leading window axis N and is vectorised over windows
(no Python loop over windows or frames).
"""
from __future__ import annotations

import dataclasses

import numpy as np

from stitchjax import rotations as R
from stitchjax.skeleton import GlobalTransforms, Skeleton, forward_kinematics

__all__ = [
    "Windows", "window_starts", "window_indices", "foot_contacts", "contacts_from_displacement",
    "center_and_face", "center_and_face_global", "facing_rotation", "Stats", "window_statistics", "moments",
    "combine_moments", "stats_from_moments", "clip_windows", "clip_moments", "concatenate_clips", "clips_statistics",
    "facing_per_frame",
    "CONTACT_THRESHOLD",
    "FOOT_HEIGHT_THRESHOLD_CM",
    "FACING_FRAME",
]

CONTACT_THRESHOLD = 0.02  # squared displacement per frame, file units² (cm² for LAFAN1)
FOOT_HEIGHT_THRESHOLD_CM = 2.5  # H of the foot-slide weight clip(2 - 2^(h/H), 0, 1) (docs/design.md §6), cm
FACING_FRAME = 9  # the last of the 10 context frames of the LAFAN1 benchmark


@dataclasses.dataclass(frozen=True, eq=False)
class Windows(GlobalTransforms):
    """A batch of N fixed-length clips of T frames on one skeleton (J joints).

    Attributes:
      rotations: (N, T, J, 4) local unit quaternions (w, x, y, z).
      positions: (N, T, J, 3) local positions, file units (LAFAN1: cm): the root's position in the
        world and every other joint's offset from its parent.
      contacts: (N, T, C) foot contacts as 0./1. floats, one channel per foot joint in the order of
        the dataset's feet (LAFAN1: LeftFoot, LeftToe, RightFoot, RightToe).
      skeleton: the joint hierarchy (its offsets are those of the first file loaded).
      fps: frames per second.
      sources: N strings ``"<file name>:<start frame>"`` telling where each window comes from.
    """

    rotations: np.ndarray
    positions: np.ndarray
    contacts: np.ndarray
    skeleton: Skeleton
    fps: float
    sources: list

    def __post_init__(self):
        n, t, j = np.shape(self.rotations)[:3]
        if (np.shape(self.rotations) != (n, t, j, 4) or np.shape(self.positions) != (n, t, j, 3)
                or np.shape(self.contacts)[:2] != (n, t) or np.ndim(self.contacts) != 3):
            raise ValueError(
                "Windows needs rotations (N, T, J, 4), positions (N, T, J, 3) and contacts (N, T, C); "
                f"got {np.shape(self.rotations)}, {np.shape(self.positions)}, {np.shape(self.contacts)}")
        if j != self.skeleton.num_joints:
            raise ValueError(f"Windows have {j} joints but the skeleton has {self.skeleton.num_joints}")
        if len(self.sources) != n:
            raise ValueError(f"{len(self.sources)} sources for {n} windows")
        object.__setattr__(self, "sources", list(self.sources))

    @property
    def num_windows(self) -> int:
        return int(np.shape(self.rotations)[0])

    @property
    def window_length(self) -> int:
        return int(np.shape(self.rotations)[1])

    def __len__(self) -> int:
        return self.num_windows

    def __getitem__(self, index) -> "Windows":
        """A subset of windows (a slice, an index array or a boolean mask); an int keeps one window."""
        if isinstance(index, (int, np.integer)):
            index = [int(index)]
        picked = np.arange(self.num_windows)[index]
        return dataclasses.replace(
            self, rotations=self.rotations[picked], positions=self.positions[picked],
            contacts=self.contacts[picked], sources=[self.sources[i] for i in np.atleast_1d(picked)])

    def reversed(self) -> "Windows":
        """The same windows played backwards in time (frames and contacts reversed), for training
        the backward generator; ``sources`` are unchanged. ``w.reversed().reversed()`` equals ``w``."""
        return dataclasses.replace(
            self, rotations=self.rotations[:, ::-1].copy(), positions=self.positions[:, ::-1].copy(),
            contacts=self.contacts[:, ::-1].copy())

    def __repr__(self):
        return (f"Windows({self.num_windows} windows x {self.window_length} frames, "
                f"{self.skeleton.num_joints} joints, fps={self.fps:g})")


@dataclasses.dataclass(frozen=True, eq=False)
class Stats:
    """Normalisation statistics of a training set (official LAFAN1 ``get_train_stats``).

    Attributes:
      mean: (J*3,) mean of each global position coordinate over all training frames, joint-major
        (joint j, axis a at index 3*j + a), file units.
      std: (J*3,) population standard deviation (ddof=0) of the same.
      offsets: (J, 3) local joint offsets from the first frame of the first training window; row 0
        (the root, whose local position is its trajectory) is zero.
    """

    mean: np.ndarray
    std: np.ndarray
    offsets: np.ndarray


def moments(x):
    """(count, mean, m2) of the rows of ``x`` (M, D): m2 is the sum of squared deviations (D,)."""
    x = np.asarray(x, dtype=np.float64)
    mean = x.mean(axis=0)
    return x.shape[0], mean, np.sum((x - mean) ** 2, axis=0)


def combine_moments(a, b):
    """Exact combination of two (count, mean, m2) triples (Chan et al.)."""
    (na, ma, sa), (nb, mb, sb) = a, b
    if na == 0:
        return b
    n = na + nb
    delta = mb - ma
    return n, ma + delta * (nb / n), sa + sb + delta ** 2 * (na * nb / n)


def window_statistics(windows: "Windows", global_positions=None) -> Stats:
    """:class:`Stats` of ``windows`` (their FK global positions, or the given (N, T, J, 3) ones).

    Computed per 1024 windows and combined exactly, so memory stays bounded.
    """
    if global_positions is None:
        global_positions = windows.global_positions()
    n, t, j, _ = np.shape(global_positions)
    if n == 0:
        raise ValueError("statistics of an empty set of windows")
    total = (0, np.zeros(j * 3), np.zeros(j * 3))
    for i in range(0, n, 1024):
        total = combine_moments(total, moments(np.reshape(global_positions[i:i + 1024], (-1, j * 3))))
    return stats_from_moments(total, windows.positions[0, 0])


def stats_from_moments(total, first_local_positions) -> Stats:
    """:class:`Stats` from combined (count, mean, m2) and the first window's first-frame local
    positions (J, 3) (the root row is set to zero)."""
    count, mean, m2 = total
    offsets = np.array(first_local_positions, dtype=np.float64)
    offsets[0] = 0.0
    return Stats(mean=np.asarray(mean, dtype=np.float64), std=np.sqrt(m2 / count), offsets=offsets)


def window_starts(num_frames: int, window: int, offset: int) -> np.ndarray:
    """Start frames ``0, offset, 2*offset, ...`` of the windows with ``start + window < num_frames``.

    The inequality is strict, as in the official LAFAN1 code: a file of exactly ``window`` frames
    gives no window. Returns an int64 array (possibly empty).
    """
    if window < 1 or offset < 1:
        raise ValueError(f"window and offset must be positive, got window={window}, offset={offset}")
    last = int(num_frames) - int(window) - 1  # the largest allowed start
    if last < 0:
        return np.zeros((0,), dtype=np.int64)
    return np.arange(0, last + 1, int(offset), dtype=np.int64)


def window_indices(starts, window: int) -> np.ndarray:
    """(N, window) frame indices ``starts[:, None] + arange(window)`` for gathering windows."""
    return np.asarray(starts, dtype=np.int64)[:, None] + np.arange(int(window), dtype=np.int64)


def contacts_from_displacement(squared_displacement, threshold: float = CONTACT_THRESHOLD):
    """Contacts from per-frame squared displacements ``|p[t+1] - p[t]|²`` of shape (..., T-1, C):
    ``< threshold`` as 0./1. floats, with the last frame repeating the previous one -> (..., T, C)."""
    moving = (squared_displacement < threshold).astype(np.float64)
    return np.concatenate([moving, moving[..., -1:, :]], axis=-2)


def foot_contacts(global_positions, feet, threshold: float = CONTACT_THRESHOLD) -> np.ndarray:
    """Binary foot contacts from global joint positions.

    Args:
      global_positions: (..., T, J, 3) FK positions of the raw (unaligned) window, file units, T >= 2.
      feet: joint indices of the contact channels, e.g. ``LAFAN1_FEET = (3, 4, 7, 8)``.
      threshold: a joint is in contact when its squared displacement to the next frame is below this
        (0.02 cm² for LAFAN1).
    Returns:
      (..., T, len(feet)) float 0./1.; the last frame repeats the previous frame's value.
    """
    p = np.asarray(global_positions)[..., list(feet), :]
    if p.shape[-3] < 2:
        raise ValueError(f"foot contacts need at least 2 frames, got {p.shape[-3]}")
    d = np.sum((p[..., 1:, :, :] - p[..., :-1, :, :]) ** 2, axis=-1)
    return contacts_from_displacement(d, threshold).astype(p.dtype if p.dtype.kind == "f" else np.float64)


def facing_rotation(root_global_rotation, forward_axis=(0.0, 1.0, 0.0)):
    """Rotation about +Y that takes the horizontal forward direction of ``root_global_rotation``
    (..., 4) (its local ``forward_axis``, y zeroed) onto +X. Returns (..., 4) unit quaternions.
    ``forward_axis`` is the root's local axis that points forward: +Y for LAFAN1's Hips.

    Built as in the official code: ``yrot = between(+X, forward)`` and the window is then rotated by
    ``yrot⁻¹``; returned here is ``yrot⁻¹``. A forward direction opposite to +X (where the shortest
    arc is undefined) gives the half turn about +Y.
    """
    q = np.asarray(root_global_rotation)
    axis = np.broadcast_to(np.asarray(forward_axis, dtype=q.dtype), q.shape[:-1] + (3,))
    forward = R.quat_rotate(q, axis) * np.array([1.0, 0.0, 1.0], dtype=q.dtype)
    forward = forward / (np.sqrt(np.sum(forward * forward, axis=-1, keepdims=True)) + 1e-8)
    x_axis = np.zeros_like(forward)
    x_axis[..., 0] = 1.0
    # Shortest arc +X -> forward: (|x||f| + x.f, x cross f), normalised.
    w = np.sqrt(np.sum(forward * forward, axis=-1)) + forward[..., 0]
    yrot = np.concatenate([w[..., None], np.cross(x_axis, forward)], axis=-1)
    norm = np.sqrt(np.sum(yrot * yrot, axis=-1, keepdims=True))
    half_turn = np.array([0.0, 0.0, 1.0, 0.0], dtype=q.dtype)
    yrot = np.where(norm > 1e-12, yrot / np.maximum(norm, 1e-300), half_turn)
    return R.quat_conjugate(yrot)


def center_and_face(rotations, positions, parents, frame: int = FACING_FRAME,
                    forward_axis=(0.0, 1.0, 0.0), centre_frames: int | None = None):
    """Centre each window on the ground plane and turn it to face +X at ``frame``.

    Args:
      rotations: (..., T, J, 4) local quaternions; positions: (..., T, J, 3) local positions (file
        units); the leading axes are windows.
      parents: parent index per joint (root first; only the root is changed).
      frame: the frame whose root orientation defines "forward" (9 for LAFAN1: the last context frame).
      forward_axis: the root's local axis that points forward (LAFAN1 Hips: +Y).
      centre_frames: the mean is taken over the first this many frames (None: all of them), so a window
        carried with extra frames after it is aligned exactly as the window alone.
    Returns:
      (rotations, positions): aligned local transforms, same shapes (new arrays).

    Order (official code): centring first — subtract the window-mean of the root's x and z from the
    root's position — then rotate the whole window about +Y through the origin by
    :func:`facing_rotation` of the root's global rotation at ``frame``. The official code rotates
    every FK global transform and recovers local ones by IK; since the rotation is applied to the
    whole body, that changes only the root's local rotation (``turn * q_root``) and position
    (``turn`` applied to it) — every other joint's local transform is unchanged (IK would give it
    back up to rounding). This function computes that directly: no FK/IK pass over the windows.
    """
    rotations = np.array(rotations, copy=True)
    positions = np.array(positions, copy=True)
    if rotations.ndim < 3 or rotations.shape[-1] != 4 or positions.shape[:-1] != rotations.shape[:-1]:
        raise ValueError(f"center_and_face needs (..., T, J, 4) rotations and (..., T, J, 3) "
                         f"positions, got {rotations.shape} and {positions.shape}")
    if not 0 <= frame < rotations.shape[-3]:
        raise ValueError(f"facing frame {frame} is outside windows of {rotations.shape[-3]} frames")
    if parents[0] != -1:
        raise ValueError("joint 0 must be the root")
    root = positions[..., :, 0, :]  # (..., T, 3), a view
    mean_xz = np.mean(root[..., :centre_frames, [0, 2]], axis=-2, keepdims=True)  # (..., 1, 2)
    root[..., :, 0] -= mean_xz[..., 0]
    root[..., :, 2] -= mean_xz[..., 1]
    turn = facing_rotation(rotations[..., frame, 0, :], forward_axis)[..., None, :]  # (..., 1, 4)
    rotations[..., :, 0, :] = R.quat_mul(turn, rotations[..., :, 0, :])
    positions[..., :, 0, :] = R.quat_rotate(turn, root)
    return rotations, positions


def center_and_face_global(global_positions, root_positions, root_rotations, frame: int = FACING_FRAME,
                           forward_axis=(0.0, 1.0, 0.0)):
    """The aligned global positions of windows, from their raw ones, without FK.

    ``global_positions`` (..., T, J, 3) raw FK positions, ``root_positions`` (..., T, 3) and
    ``root_rotations`` (..., T, 4) the raw root transforms. Returns (..., T, J, 3): the positions the
    windows have after :func:`center_and_face` (translate by minus the root's mean x/z, then turn).
    """
    mean_xz = np.mean(root_positions[..., :, [0, 2]], axis=-2)  # (..., 2)
    turn = R.quat_to_matrix(facing_rotation(root_rotations[..., frame, :], forward_axis))  # about +Y
    m = turn[..., None, None, :, :]
    x = global_positions[..., 0] - mean_xz[..., None, None, 0]
    y = global_positions[..., 1]
    z = global_positions[..., 2] - mean_xz[..., None, None, 1]
    out = np.empty(np.shape(global_positions), dtype=np.result_type(global_positions, turn))
    for i in range(3):  # a rotation about +Y: (m[1, 0], m[1, 2]) = 0, m[1, 1] = 1 up to rounding
        out[..., i] = m[..., i, 0] * x + m[..., i, 1] * y + m[..., i, 2] * z
    return out


# ------------------------------------------------------------------------------------------ clips


def clip_windows(rotations, positions, parents, window: int, offset: int, feet, frame: int = FACING_FRAME,
                 forward_axis=(0.0, 1.0, 0.0), extra_frames: int = 0) -> dict:
    """The windows of one clip, cut and aligned as the LAFAN1 benchmark does (see the module docstring).

    rotations (T, J, 4) / positions (T, J, 3): the clip's local transforms, file units. feet: the C contact
    joints; frame / forward_axis: as :func:`center_and_face`. Returns {"starts": (N,) int64 start frames,
    "rotations": (N, window, J, 4), "positions": (N, window, J, 3) centred and faced, "contacts": (N, window,
    C) 0./1. on the raw windows}; N = 0 (no FK run) when the clip is not longer than ``window`` frames.

    extra_frames > 0 (random window starts): each window carries the clip's next ``extra_frames`` frames too
    (arrays of window + extra_frames frames, aligned as the window alone: the rotations and positions of its
    first ``window`` frames are the window's bit for bit; the contacts of the window's last frame come from the
    clip's next frame instead of repeating the frame before). "start_counts" (N,) int64 says how many starts
    ``start + s`` (s = 0, 1, ...) still give a whole window inside the clip (``start + s + window < T``) and
    "turns" (N, 4) is the turn each window was faced by; frames past the clip's end repeat its last frame and
    are never part of a window. With ``extra_frames = offset - 1`` the windows' starts cover every frame that
    can start a window (:func:`window_starts` with offset 1).
    """
    starts = window_starts(np.shape(rotations)[0], window, offset)
    frames = window + int(extra_frames)
    if len(starts) == 0:
        j = np.shape(rotations)[-2]
        out = {"starts": starts, "rotations": np.zeros((0, frames, j, 4)), "positions": np.zeros((0, frames, j, 3)),
               "contacts": np.zeros((0, frames, len(feet)))}
        return {**out, "start_counts": np.zeros((0,), np.int64), "turns": np.zeros((0, 4))} if extra_frames else out
    num_frames = np.shape(rotations)[0]
    idx = np.minimum(window_indices(starts, frames), num_frames - 1)
    rotations_raw_root = np.asarray(rotations)[:, 0]
    _, global_positions = forward_kinematics(rotations, positions, parents)  # once: a window's FK is a slice
    feet_positions = global_positions[:, list(feet)]
    step = np.sum((feet_positions[1:] - feet_positions[:-1]) ** 2, axis=-1)  # (T-1, C) squared displacements
    rotations, positions = center_and_face(rotations[idx], positions[idx], parents, frame, forward_axis,
                                           centre_frames=window)
    out = {"starts": starts, "rotations": rotations, "positions": positions,
           "contacts": contacts_from_displacement(step[np.minimum(idx[:, :-1], num_frames - 2)])}
    if extra_frames:
        last = num_frames - window - 1  # the largest start of a whole window
        out["start_counts"] = np.minimum(int(extra_frames), last - starts) + 1
        out["turns"] = facing_rotation(rotations_raw_root[starts + frame], forward_axis)
    return out


def clip_moments(rotations, positions, parents, window: int, offset: int, frame: int = FACING_FRAME,
                 forward_axis=(0.0, 1.0, 0.0)) -> dict:
    """What the statistics need of one clip's windows, without materialising them (arguments as
    :func:`clip_windows`). Returns {"starts": (N,), "moments": (count, mean, m2) of the aligned global
    positions as rows of J*3, "first_local_positions": (J, 3) aligned local positions of the first window's
    first frame, or None when N = 0}. Alignment touches only the root, so no FK runs per window."""
    starts = window_starts(np.shape(rotations)[0], window, offset)
    if len(starts) == 0:
        return {"starts": starts, "moments": (0, 0.0, 0.0), "first_local_positions": None}
    idx = window_indices(starts, window)
    _, global_positions = forward_kinematics(rotations, positions, parents)  # once: a window's FK is a slice
    aligned = center_and_face_global(global_positions[idx], positions[idx, 0], rotations[idx, 0], frame,
                                     forward_axis)
    _, first = center_and_face(rotations[idx[:1]], positions[idx[:1]], parents, frame, forward_axis)
    return {"starts": starts, "moments": moments(aligned.reshape(-1, aligned.shape[-2] * 3)),
            "first_local_positions": first[0, 0]}


def concatenate_clips(clips) -> dict:
    """The "rotations", "positions" and "contacts" of :func:`clip_windows` results (a non-empty list),
    concatenated in order along the window axis."""
    return {key: np.concatenate([clip[key] for clip in clips]) for key in ("rotations", "positions", "contacts")}


def clips_statistics(clips) -> Stats:
    """:class:`Stats` of the windows of :func:`clip_moments` results, in order: moments combined exactly,
    offsets from the first clip that has a window. Raises ValueError when none has one."""
    kept = [clip for clip in clips if len(clip["starts"])]
    if not kept:
        raise ValueError("no clip is longer than the window: no training windows")
    total = (0, 0.0, 0.0)
    for clip in kept:
        total = combine_moments(total, clip["moments"])
    return stats_from_moments(total, kept[0]["first_local_positions"])


def facing_per_frame(root_rotations, forward_axis=(0.0, 1.0, 0.0), turns=None) -> np.ndarray:
    """(N, T, 4): for each frame t of aligned windows (root rotations (N, T, 4), faced by ``turns`` (N, 4);
    None: not turned), the rotation F_t that faces the window at frame t when applied to the aligned root:
    F_t = facing_rotation(raw root at t) * turn^-1, so F_t * aligned = facing_rotation(raw) * raw, the
    benchmark's aligned root with its sign (random window starts re-face a cut window with it)."""
    q = np.asarray(root_rotations, np.float64)
    if turns is None:
        return facing_rotation(q, forward_axis)
    undo = R.quat_conjugate(np.asarray(turns, np.float64))[:, None, :]
    raw = R.quat_mul(undo, q)
    return R.quat_mul(facing_rotation(raw, forward_axis), np.broadcast_to(undo, raw.shape))
