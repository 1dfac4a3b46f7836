"""Left/right mirror images of aligned windows (``config.data.mirror``): which joint and contact channel each
becomes, whether a skeleton is its own mirror image, and the mirrored arrays.

Mirroring reflects the world and every joint's frame across the vertical plane z = 0, which keeps +Y (up) and
+X (the faced forward) of windows centred and faced by :mod:`stitchjax.data.windows`; joints are paired by their
side prefixes (Left*/Right*, L_*/R_*, ...).
"""
from __future__ import annotations

import numpy as np

__all__ = ["mirror_joint_map", "mirror_contact_map", "check_mirror_symmetry", "mirror_arrays"]

_SIDES = (("Left", "Right"), ("left", "right"), ("LEFT", "RIGHT"), ("L_", "R_"), ("l_", "r_"))


def _other_side(name: str) -> str | None:
    """``name`` with its side prefix swapped (LeftFoot -> RightFoot, L_Hand -> R_Hand); None: no side."""
    for left, right in _SIDES:
        if name.startswith(left):
            return right + name[len(left):]
        if name.startswith(right):
            return left + name[len(right):]
    return None


def mirror_joint_map(names) -> np.ndarray:
    """(J,) int64: the joint each joint becomes in the mirror image, from the names (Left* <-> Right*;
    a joint without a side prefix maps to itself). ValueError naming a sided joint without its twin."""
    names = [str(n) for n in names]
    out = []
    for j, name in enumerate(names):
        twin = _other_side(name)
        if twin is None:
            out.append(j)
        elif twin in names:
            out.append(names.index(twin))
        else:
            raise ValueError(f"data.mirror: joint {name!r} has no twin {twin!r} on the other side; mirroring "
                             "needs Left*/Right* joints in pairs (or set data.mirror=false)")
    return np.asarray(out, np.int64)


def mirror_contact_map(feet, joint_map) -> np.ndarray:
    """(C,) int64: the contact channel each channel becomes in the mirror image (LAFAN1: [2, 3, 0, 1])."""
    feet = [int(f) for f in feet]
    try:
        return np.asarray([feet.index(int(joint_map[f])) for f in feet], np.int64)
    except ValueError:
        raise ValueError(f"data.mirror: the contact joints {feet} are not closed under left/right mirroring "
                         "(each foot joint's twin must be a contact joint too)") from None


_MIRROR_QUAT = np.array([1.0, -1.0, -1.0, 1.0])  # reflection z -> -z: (w, x, y, z) -> (w, -x, -y, z)
_MIRROR_POS = np.array([1.0, 1.0, -1.0])


def check_mirror_symmetry(offsets, joint_map, names, tolerance: float = 0.01) -> None:
    """ValueError unless the skeleton is its own mirror image: each joint's bone offset (J, 3), reflected
    across z in its parent's frame, is its twin's up to ``tolerance`` x the bone's length (+ 0.01 unit).
    Mirroring reflects every joint's frame across z, which keeps +Y (up) and +X (the faced forward)."""
    offsets = np.asarray(offsets, np.float64)
    mirrored = offsets[joint_map] * _MIRROR_POS
    error = np.linalg.norm(mirrored[1:] - offsets[1:], axis=-1)
    limit = tolerance * np.linalg.norm(offsets[1:], axis=-1) + 0.01
    bad = np.flatnonzero(error > limit) + 1
    if len(bad):
        j = int(bad[0])
        raise ValueError(f"data.mirror: the skeleton is not left/right symmetric across its z axis: joint "
                         f"{names[j]!r} offset {np.round(offsets[j], 3).tolist()} against its twin's mirror image "
                         f"{np.round(mirrored[j], 3).tolist()}; set data.mirror=false for this skeleton")


def mirror_arrays(rotations, positions, contacts, joint_map, contact_map):
    """The left/right mirror image of aligned windows: reflection across the vertical plane z = 0 of the
    world and of every joint's frame (quaternions (w, -x, -y, z), positions (x, y, -z)), then joints and
    contact channels swapped by ``joint_map`` / ``contact_map``. rotations (..., J, 4), positions (..., J, 3),
    contacts (..., C). Only sign flips and a swap: mirroring twice gives the input back bit for bit, and a
    window faced to +X and centred stays so."""
    rotations = np.asarray(rotations)
    positions = np.asarray(positions)
    return ((rotations * _MIRROR_QUAT.astype(rotations.dtype))[..., joint_map, :],
            (positions * _MIRROR_POS.astype(positions.dtype))[..., joint_map, :],
            np.asarray(contacts)[..., contact_map])
