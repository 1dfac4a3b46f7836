"""Bring a take onto a model's (or a dataset's) terms: frame rate, units, up axis, joints, placement.

Pure numpy functions on :class:`stitchjax.data.bvh.Motion` (float64), used by the generic BVH-folder
dataset (``stitchjax.data.bvh_folder``) on load and by ``stitchjax.sample.takes`` on keyframes from any file:

- :func:`resample`: a take at another frame rate, slerp for rotations and linear for positions, on a
  time grid anchored at one frame so that frame is kept exactly;
- :func:`retime`: a transition stretched onto another number of frames, both ends kept (back to a take's rate);
- :func:`scale_ratio`, :func:`check_scale`: the ratio of a skeleton's bone lengths to a reference one
  (units: metres vs centimetres), refused with the measured ratio and the fix;
- :func:`rescale`: positions and offsets times a factor;
- :func:`to_y_up`, :func:`from_y_up`: the whole take turned so that its up axis becomes +Y and back
  (root transform only);
- :func:`map_joints`: a take with extra joints (e.g. a root bone above Hips) onto a skeleton of named
  joints, refused with the names that differ;
- :func:`place`: a take turned about the vertical axis and moved, relative to its own file.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from stitchjax import rotations as R
from stitchjax.skeleton import Skeleton, forward_kinematics, inverse_kinematics

__all__ = ["ConformError", "resample", "retime", "bone_lengths", "scale_ratio", "check_scale", "rescale", "parse_axis",
           "axis_name", "up_turn", "to_y_up", "from_y_up", "map_joints", "place", "SCALE_TOLERANCE"]

SCALE_TOLERANCE = 0.1  # bone lengths may differ from the reference by 10 % (other actors) before refusing


class ConformError(ValueError):
    """A take that cannot be brought onto the wanted terms; the message says what differs and the fix."""


def resample(motion, fps: float, anchor: int = 0):
    """``motion`` at ``fps`` frames per second: (new Motion, index of frame ``anchor`` in it).

    The new frames sit at times ``anchor / motion.fps + k / fps`` (all integers k inside the take), so
    frame ``anchor`` is kept exactly (bit for bit). Rotations: slerp on the short arc; positions:
    linear. Same fps: returned unchanged.
    """
    fps = float(fps)
    if fps <= 0:
        raise ConformError(f"frame rate must be positive, got {fps}")
    if abs(float(motion.fps) - fps) <= 1e-6 * fps:
        return motion, int(anchor)
    n = motion.num_frames
    if not 0 <= anchor < n:
        raise ConformError(f"frame {anchor} is outside the take's {n} frames")
    duration = (n - 1) / motion.fps
    t_anchor = anchor / motion.fps
    first = -int(np.floor(t_anchor * fps + 1e-9))
    last = int(np.floor((duration - t_anchor) * fps + 1e-9))
    times = t_anchor + np.arange(first, last + 1) / fps  # seconds
    source = np.clip(times * motion.fps, 0.0, n - 1)  # fractional source frames
    rotations, positions = _sample_at(motion, source)
    k = -first
    rotations[k], positions[k] = motion.rotations[anchor], motion.positions[anchor]
    rotations = R.quat_continuity(rotations, axis=0)
    out = dataclasses.replace(motion, rotations=rotations, positions=positions, fps=fps)
    return out, k


def _sample_at(motion, source):
    """(rotations, positions) of ``motion`` at fractional frames ``source`` (F,): slerp / lerp."""
    n = motion.num_frames
    lo = np.minimum(np.floor(source).astype(np.int64), max(n - 2, 0))
    hi = np.minimum(lo + 1, n - 1)
    w = (source - lo)[:, None]
    q0, q1 = motion.rotations[lo], motion.rotations[hi]
    q1 = np.where(np.sum(q0 * q1, axis=-1, keepdims=True) < 0, -q1, q1)  # short arc
    rotations = R.quat_normalize(R.quat_slerp(q0, q1, np.broadcast_to(w, q0.shape[:-1])))
    positions = (1.0 - w[..., None]) * motion.positions[lo] + w[..., None] * motion.positions[hi]
    return rotations, positions


def retime(motion, num_frames: int, fps: float):
    """``motion`` stretched onto ``num_frames`` evenly spaced frames from its first frame to its last (both
    kept exactly), labelled ``fps``: slerp for rotations, linear for positions. A transition generated at a
    model's frame rate goes back to a take's rate this way (its duration is then the take's frames)."""
    num_frames = int(num_frames)
    if num_frames < 2:
        raise ConformError(f"retime needs at least 2 frames (the two ends), got {num_frames}")
    source = np.linspace(0.0, motion.num_frames - 1, num_frames)
    rotations, positions = _sample_at(motion, source)
    for k, frame in ((0, 0), (-1, motion.num_frames - 1)):
        rotations[k], positions[k] = motion.rotations[frame], motion.positions[frame]
    rotations = R.quat_continuity(rotations, axis=0)
    return dataclasses.replace(motion, rotations=rotations, positions=positions, fps=float(fps))


def bone_lengths(offsets) -> np.ndarray:
    """(J,) lengths of the bone offsets (J, 3); the root's row is 0."""
    lengths = np.linalg.norm(np.asarray(offsets, np.float64), axis=-1)
    lengths[0] = 0.0
    return lengths


def scale_ratio(offsets, reference_offsets) -> float:
    """Median over bones of length / reference length: 100 for a metres skeleton against centimetres
    is 0.01. Bones shorter than 1 % of the longest one (zero-length joints) are left out."""
    a, b = bone_lengths(offsets), bone_lengths(reference_offsets)
    if a.shape != b.shape:
        raise ConformError(f"skeletons have {a.shape[0]} and {b.shape[0]} joints")
    keep = (a > 0.01 * a.max()) & (b > 0.01 * b.max())
    if not keep.any():
        raise ConformError("no bone of non-zero length to compare the skeletons' scales")
    return float(np.median(a[keep] / b[keep]))


def check_scale(offsets, reference_offsets, what: str, reference: str, fix: str,
                tolerance: float = SCALE_TOLERANCE, applied: float = 1.0) -> float:
    """Refuse a skeleton whose bones differ in length from the reference's by more than ``tolerance``.

    Returns the ratio (length / reference length). The message names ``what``, the measured ratio, the
    factor that fixes it and ``fix`` (how to apply it, e.g. "bin/inbetween --scale {factor}"), where
    {factor} is the whole factor to ask for: ``applied`` (the scale the offsets already had applied) times
    the correction, so a second try with it is right.
    """
    ratio = scale_ratio(offsets, reference_offsets)
    if abs(np.log(ratio)) > np.log1p(tolerance):
        factor = 1.0 / ratio
        whole = float(applied) * factor
        applied_note = f" on top of the scale {float(applied):.6g} already applied" if applied != 1.0 else ""
        raise ConformError(
            f"{what} has bones {ratio:.4g} times as long as {reference} (median over bones): its units differ "
            f"(e.g. metres vs centimetres); rescale it by {factor:.6g}{applied_note}: "
            f"{fix.format(factor=f'{whole:.6g}')}")
    return ratio


def rescale(motion, factor: float):
    """Positions and bone offsets (and End Sites) times ``factor``; rotations unchanged."""
    factor = float(factor)
    sk = motion.skeleton
    skeleton = Skeleton(sk.names, sk.parents, sk.offsets * factor)
    end_sites = None if motion.end_sites is None else tuple(
        (j, tuple(float(x) * factor for x in off)) for j, off in motion.end_sites)
    return dataclasses.replace(motion, positions=motion.positions * factor, skeleton=skeleton,
                               end_sites=end_sites)


_AXES = {"x": 0, "y": 1, "z": 2}


def parse_axis(text: str) -> np.ndarray:
    """"+y", "-z", "x" ... -> the unit vector (3,). Raises ConformError naming the allowed forms."""
    t = str(text).strip().lower()
    sign = -1.0 if t.startswith("-") else 1.0
    t = t.lstrip("+-")
    if t not in _AXES:
        raise ConformError(f"axis {text!r}: use one of +x, -x, +y, -y, +z, -z")
    v = np.zeros(3)
    v[_AXES[t]] = sign
    return v


def axis_name(axis) -> str:
    """(3,) signed coordinate axis -> "+y", "-z", ... (inverse of :func:`parse_axis`)."""
    v = np.asarray(axis, np.float64)
    k = int(np.argmax(np.abs(v)))
    if v.shape != (3,) or not np.allclose(np.abs(v), np.eye(3)[k]):
        raise ConformError(f"axis {tuple(v)} is not a signed coordinate axis (+x, -x, +y, -y, +z, -z)")
    return ("+" if v[k] > 0 else "-") + "xyz"[k]


def up_turn(up) -> np.ndarray:
    """(4,) the world rotation taking the up direction ``up`` (3,) onto +Y (identity for +Y; a half turn
    about +X for -Y). It also takes offsets given in the take's axes into the +Y-up frame."""
    up = np.asarray(up, np.float64)
    if np.allclose(up, (0.0, 1.0, 0.0)):
        return np.array([1.0, 0.0, 0.0, 0.0])
    if np.allclose(up, (0.0, -1.0, 0.0)):  # opposite: a half turn about +X
        return np.array([0.0, 1.0, 0.0, 0.0])
    return R.quat_between(up, np.array([0.0, 1.0, 0.0]))


def from_y_up(motion, up) -> "object":
    """Inverse of :func:`to_y_up`: a +Y-up take turned back so +Y becomes ``up`` (3,). +Y: unchanged."""
    if np.allclose(np.asarray(up, np.float64), (0.0, 1.0, 0.0)):
        return motion
    return _turn_world(motion, R.quat_conjugate(up_turn(up)))


def to_y_up(motion, up) -> "object":
    """The take turned as a whole so that its up direction ``up`` (3,) becomes +Y: only the root's
    rotation and position change (a rotation of the world). +Y already: unchanged."""
    if np.allclose(np.asarray(up, np.float64), (0.0, 1.0, 0.0)):
        return motion
    return _turn_world(motion, up_turn(up))


def _turn_world(motion, turn):
    """The take rotated as a whole by the unit quaternion ``turn`` (4,) about the origin."""
    rotations = motion.rotations.copy()
    positions = motion.positions.copy()
    rotations[:, 0] = R.quat_mul(np.broadcast_to(turn, rotations[:, 0].shape), rotations[:, 0])
    positions[:, 0] = R.quat_rotate(np.broadcast_to(turn, rotations[:, 0].shape), positions[:, 0])
    return dataclasses.replace(motion, rotations=rotations, positions=positions)


def map_joints(motion, names, parents, what: str = "the take"):
    """``motion`` on the skeleton of joints ``names`` (with ``parents``), picked from its joints by name.

    Every wanted joint must exist in the take, and each wanted parent must be an ancestor of its child
    there; joints the take has beyond those (an extra root bone above Hips, finger joints) are dropped,
    their motion folded into the kept joints' local transforms (FK, then IK on the kept joints).
    Same names in the same order: returned unchanged. Returns a Motion (channels: the LAFAN1 layout).
    """
    names, parents = tuple(names), tuple(int(p) for p in parents)
    sk = motion.skeleton
    if sk.names == names and sk.parents == parents:
        return motion
    missing = [n for n in names if n not in sk.names]
    if missing:
        extra = [n for n in sk.names if n not in names]
        raise ConformError(
            f"{what}'s skeleton lacks joint{'s' if len(missing) > 1 else ''} {', '.join(missing)} of the "
            f"model's skeleton (it has {', '.join(extra) or 'no other joints'} instead); rename its joints to the "
            f"model's names ({', '.join(names)})")
    index = [sk.names.index(n) for n in names]
    for j, p in enumerate(parents):
        if p < 0:
            continue
        a = sk.parents[index[j]]
        while a >= 0 and a != index[p]:
            a = sk.parents[a]
        if a != index[p]:
            raise ConformError(f"{what}: joint {names[j]!r} does not hang below {names[p]!r} as in the model's "
                               f"skeleton; the hierarchies differ beyond extra joints")
    grot, gpos = forward_kinematics(motion.rotations, motion.positions, sk.parents)
    rotations, positions = inverse_kinematics(grot[:, index], gpos[:, index], parents)
    rotations = R.quat_continuity(R.quat_normalize(rotations), axis=0)
    offsets = positions[0].copy()
    offsets[0] = sk.offsets[index[0]]
    skeleton = Skeleton(names, parents, offsets)
    return dataclasses.replace(motion, rotations=rotations, positions=positions, skeleton=skeleton,
                               channels=None, end_sites=None)


def place(motion, offset=(0.0, 0.0, 0.0), turn_degrees: float = 0.0, pivot: int = 0):
    """The take turned by ``turn_degrees`` about the vertical (+Y) axis through the root of frame
    ``pivot``, then moved by ``offset`` (3,) (file units): a rigid motion of the whole take."""
    offset = np.asarray(offset, np.float64)
    if offset.shape != (3,):
        raise ConformError(f"offset must be 3 numbers (x, y, z), got {offset.shape}")
    turn = R.quat_from_axis_angle(np.array([0.0, 1.0, 0.0]), np.deg2rad(float(turn_degrees)))
    rotations = motion.rotations.copy()
    positions = motion.positions.copy()
    centre = positions[pivot, 0].copy()
    centre[1] = 0.0
    shape = rotations[:, 0].shape
    rotations[:, 0] = R.quat_mul(np.broadcast_to(turn, shape), rotations[:, 0])
    positions[:, 0] = R.quat_rotate(np.broadcast_to(turn, shape), positions[:, 0] - centre) + centre + offset
    return dataclasses.replace(motion, rotations=rotations, positions=positions)
