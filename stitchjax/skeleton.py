"""Skeletons and forward / inverse kinematics.

A :class:`Skeleton` is static data (names, parents, bone offsets) that can be passed to ``jax.jit``
as a static argument. FK and IK take the parents tuple and work on any leading batch shape, with
numpy (float64 data pipeline) or jax.numpy (model) arrays.
"""
from __future__ import annotations

import dataclasses
from functools import lru_cache

import numpy as np

from stitchjax import rotations as R

# LAFAN1 skeleton (docs/design.md §4): 22 joints, Y-up, centimetres, 30 fps.
LAFAN1_JOINTS = (
    "Hips", "LeftUpLeg", "LeftLeg", "LeftFoot", "LeftToe", "RightUpLeg", "RightLeg", "RightFoot",
    "RightToe", "Spine", "Spine1", "Spine2", "Neck", "Head", "LeftShoulder", "LeftArm", "LeftForeArm",
    "LeftHand", "RightShoulder", "RightArm", "RightForeArm", "RightHand",
)
LAFAN1_PARENTS = (-1, 0, 1, 2, 3, 0, 5, 6, 7, 0, 9, 10, 11, 12, 11, 14, 15, 16, 11, 18, 19, 20)
LAFAN1_FEET = (3, 4, 7, 8)  # LeftFoot, LeftToe, RightFoot, RightToe: the contact channels, in this order.
LAFAN1_FPS = 30.0


@dataclasses.dataclass(frozen=True, eq=False)
class Skeleton:
    """Joint hierarchy. ``parents[j] < j`` for every non-root joint; the root's parent is -1.

    Attributes:
      names: joint names, (J,).
      parents: parent index of each joint, (J,).
      offsets: bone offsets from each joint's parent in the parent's frame, (J, 3), file units.
    """

    names: tuple
    parents: tuple
    offsets: np.ndarray

    def __post_init__(self):
        object.__setattr__(self, "names", tuple(str(n) for n in self.names))
        object.__setattr__(self, "parents", tuple(int(p) for p in self.parents))
        offsets = np.array(self.offsets, dtype=np.float64).reshape(len(self.parents), 3)
        offsets.setflags(write=False)
        object.__setattr__(self, "offsets", offsets)
        if len(self.names) != len(self.parents):
            raise ValueError(f"{len(self.names)} joint names but {len(self.parents)} parents")
        check_parents(self.parents)

    @property
    def num_joints(self) -> int:
        return len(self.parents)

    def index(self, name: str) -> int:
        try:
            return self.names.index(name)
        except ValueError:
            raise KeyError(f"no joint named {name!r}; joints are {', '.join(self.names)}") from None

    def children(self, joint: int) -> tuple:
        return tuple(j for j, p in enumerate(self.parents) if p == joint)

    @property
    def depths(self) -> tuple:
        return _depths(self.parents)

    def _key(self):
        return (self.names, self.parents, self.offsets.tobytes())

    def __eq__(self, other):
        return isinstance(other, Skeleton) and self._key() == other._key()

    def __hash__(self):
        return hash(self._key())

    def __repr__(self):
        return f"Skeleton({self.num_joints} joints, root={self.names[0]!r})"


def lafan1_skeleton(offsets) -> Skeleton:
    """The LAFAN1 skeleton with the given bone offsets (22, 3) in cm."""
    return Skeleton(LAFAN1_JOINTS, LAFAN1_PARENTS, offsets)


def check_parents(parents) -> None:
    """Raise ValueError unless ``parents`` is a valid topologically ordered hierarchy with one root."""
    for j, p in enumerate(parents):
        if j == 0 and p != -1:
            raise ValueError("joint 0 must be the root (parent -1)")
        if j > 0 and not 0 <= p < j:
            raise ValueError(f"joint {j} has parent {p}; parents must come before their children")


@lru_cache(maxsize=None)
def _depths(parents: tuple) -> tuple:
    depth = []
    for p in parents:
        depth.append(0 if p < 0 else depth[p] + 1)
    return tuple(depth)


@lru_cache(maxsize=None)
def _levels(parents: tuple) -> tuple:
    """Joints grouped by depth below the root: ((joints at depth 1), (their parents)), ..."""
    depth = _depths(parents)
    levels = []
    for d in range(1, max(depth) + 1 if depth else 1):
        joints = tuple(j for j in range(len(parents)) if depth[j] == d)
        levels.append((joints, tuple(parents[j] for j in joints)))
    return tuple(levels)


def forward_kinematics(local_rotations, local_positions, parents):
    """Local joint transforms to global ones.

    Args:
      local_rotations: (..., J, 4) unit quaternions relative to each parent.
      local_positions: (..., J, 3): the root's position and each joint's offset from its parent.
      parents: static tuple (J,) of parent indices, -1 for the root.
    Returns:
      (global_rotations (..., J, 4), global_positions (..., J, 3)).
    Joints sharing a depth are computed together: with JAX inputs one block per tree level (no loop,
    differentiable), with NumPy inputs joint by joint into preallocated arrays.
    """
    parents = tuple(parents)
    xp = R.array_module(local_rotations, local_positions)
    if xp is np:
        return _forward_kinematics_numpy(local_rotations, local_positions, parents)
    return _forward_kinematics_jax(local_rotations, local_positions, parents)


class GlobalTransforms:
    """Mixin for containers of local frames: ``rotations`` (..., J, 4), ``positions`` (..., J, 3) and a
    ``skeleton`` attribute (``bvh.Motion``: (T, J, ...), ``windows.Windows``: (N, T, J, ...))."""

    def global_transforms(self):
        """(global rotations (..., J, 4), global positions (..., J, 3)) by forward kinematics."""
        return forward_kinematics(self.rotations, self.positions, self.skeleton.parents)

    def global_positions(self) -> np.ndarray:
        """(..., J, 3) joint positions in the world, file units."""
        return self.global_transforms()[1]

    def global_rotations(self) -> np.ndarray:
        """(..., J, 4) joint orientations in the world."""
        return self.global_transforms()[0]


@lru_cache(maxsize=None)
def _level_plan(parents: tuple):
    """FK by depth: (roots, ((joints, parent slots in the previous depth's list), ...), order), with order
    the position of each joint in the concatenation of all depths' lists."""
    roots = tuple(j for j, p in enumerate(parents) if p < 0)
    slot = {j: k for k, j in enumerate(roots)}
    plan, listed = [], list(roots)
    for joints, pars in _levels(parents):
        plan.append((np.asarray(joints, np.int32), np.asarray([slot[p] for p in pars], np.int32)))
        slot = {j: k for k, j in enumerate(joints)}
        listed += joints
    order = np.argsort(np.asarray(listed)).astype(np.int32)
    return np.asarray(roots, np.int32), tuple(plan), order


def _forward_kinematics_jax(local_rotations, local_positions, parents):
    """JAX FK one tree depth at a time: each depth gathers its parents from the depth above and is kept as
    its own array; the joints are put back in order by one gather at the end. No loop and no in-place
    writes (a ``lax.scan`` over depths writing into the joint arrays cost loop-buffer copies in the train
    step, benchmarks/README.md), and the traced program stays one small block per depth."""
    import jax.numpy as jnp

    batch = jnp.broadcast_shapes(local_rotations.shape[:-1], local_positions.shape[:-1])
    local_rotations = jnp.broadcast_to(local_rotations, batch + (4,))
    local_positions = jnp.broadcast_to(local_positions, batch + (3,))
    roots, plan, order = _level_plan(parents)
    if not plan:  # every joint a root: local is global
        return local_rotations, local_positions
    rotations = [jnp.take(local_rotations, roots, axis=-2)]
    positions = [jnp.take(local_positions, roots, axis=-2)]
    for joints, slots in plan:
        parent_rotation = jnp.take(rotations[-1], slots, axis=-2)
        rotations.append(R.quat_mul(parent_rotation, jnp.take(local_rotations, joints, axis=-2)))
        positions.append(R.quat_rotate(parent_rotation, jnp.take(local_positions, joints, axis=-2))
                         + jnp.take(positions[-1], slots, axis=-2))
    return (jnp.take(jnp.concatenate(rotations, axis=-2), order, axis=-2),
            jnp.take(jnp.concatenate(positions, axis=-2), order, axis=-2))


def _forward_kinematics_numpy(local_rotations, local_positions, parents):
    """NumPy FK writing into preallocated arrays (the data pipeline's float64 path)."""
    local_rotations = np.asarray(local_rotations)
    local_positions = np.asarray(local_positions)
    shape = np.broadcast_shapes(local_rotations.shape[:-1], local_positions.shape[:-1])
    dtype = np.result_type(local_rotations, local_positions)
    grot = np.empty(shape + (4,), dtype)
    gpos = np.empty(shape + (3,), dtype)
    grot[..., 0, :] = local_rotations[..., 0, :]
    gpos[..., 0, :] = local_positions[..., 0, :]
    for j in range(1, len(parents)):
        p = parents[j]
        grot[..., j, :] = R.quat_mul(grot[..., p, :], local_rotations[..., j, :])
        gpos[..., j, :] = R.quat_rotate(grot[..., p, :], local_positions[..., j, :]) + gpos[..., p, :]
    return grot, gpos


def inverse_kinematics(global_rotations, global_positions, parents):
    """Global joint transforms to local ones; the inverse of :func:`forward_kinematics`.

    Args:
      global_rotations: (..., J, 4) unit quaternions; global_positions: (..., J, 3).
      parents: static tuple (J,) of parent indices.
    Returns:
      (local_rotations (..., J, 4), local_positions (..., J, 3)).
    """
    parents = tuple(parents)
    xp = R.array_module(global_rotations, global_positions)
    par = np.array([max(p, 0) for p in parents])
    prot = global_rotations[..., par, :]
    pinv = R.quat_conjugate(prot)
    local_rot = R.quat_mul(pinv, global_rotations)
    local_pos = R.quat_rotate(pinv, global_positions - global_positions[..., par, :])
    root = np.array([p < 0 for p in parents])[:, None]
    local_rot = xp.where(root, global_rotations, local_rot)
    local_pos = xp.where(root, global_positions, local_pos)
    return local_rot, local_pos
