"""Forward and inverse kinematics."""
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from stitchjax import rotations as R
from stitchjax.skeleton import (LAFAN1_JOINTS, LAFAN1_PARENTS, Skeleton, forward_kinematics,
                                inverse_kinematics, lafan1_skeleton)


def random_pose(rng, shape, parents):
    n = len(parents)
    q = rng.normal(size=shape + (n, 4))
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    pos = rng.normal(size=shape + (n, 3)) * 10
    return q, pos


def fk_reference(q, pos, parents):
    """Joint-by-joint FK with scipy rotations, for one pose."""
    n = len(parents)
    grot, gpos = [None] * n, [None] * n
    for j, p in enumerate(parents):
        r = Rotation.from_quat(q[j][[1, 2, 3, 0]])
        if p < 0:
            grot[j], gpos[j] = r, pos[j]
        else:
            grot[j] = grot[p] * r
            gpos[j] = grot[p].apply(pos[j]) + gpos[p]
    return np.stack([g.as_matrix() for g in grot]), np.stack(gpos)


def test_fk_matches_joint_by_joint_reference():
    rng = np.random.default_rng(0)
    q, pos = random_pose(rng, (5,), LAFAN1_PARENTS)
    grot, gpos = forward_kinematics(q, pos, LAFAN1_PARENTS)
    for b in range(5):
        ref_m, ref_p = fk_reference(q[b], pos[b], LAFAN1_PARENTS)
        np.testing.assert_allclose(gpos[b], ref_p, atol=1e-9)
        np.testing.assert_allclose(R.quat_to_matrix(grot[b]), ref_m, atol=1e-9)


def test_ik_inverts_fk_any_batch_shape_numpy_and_jax():
    rng = np.random.default_rng(1)
    q, pos = random_pose(rng, (2, 3), LAFAN1_PARENTS)
    grot, gpos = forward_kinematics(q, pos, LAFAN1_PARENTS)
    lq, lp = inverse_kinematics(grot, gpos, LAFAN1_PARENTS)
    assert np.all(np.minimum(np.abs(lq - q).max(-1), np.abs(lq + q).max(-1)) < 1e-9)
    np.testing.assert_allclose(lp, pos, atol=1e-9)

    fk = jax.jit(forward_kinematics, static_argnums=2)
    jgrot, jgpos = fk(jnp.asarray(q, jnp.float32), jnp.asarray(pos, jnp.float32), LAFAN1_PARENTS)
    np.testing.assert_allclose(np.asarray(jgpos), gpos, atol=1e-3)
    jq, jp = jax.jit(inverse_kinematics, static_argnums=2)(jgrot, jgpos, LAFAN1_PARENTS)
    np.testing.assert_allclose(np.asarray(jp), pos, atol=1e-3)


def test_fk_is_differentiable_and_vmappable():
    rng = np.random.default_rng(2)
    q, pos = random_pose(rng, (4,), LAFAN1_PARENTS)
    q, pos = jnp.asarray(q, jnp.float32), jnp.asarray(pos, jnp.float32)
    batched = jax.jit(jax.vmap(lambda a, b: forward_kinematics(a, b, LAFAN1_PARENTS)[1]))(q, pos)
    np.testing.assert_allclose(np.asarray(batched), np.asarray(forward_kinematics(q, pos, LAFAN1_PARENTS)[1]), atol=1e-4, rtol=1e-5)
    g = jax.jit(jax.grad(lambda q: jnp.sum(forward_kinematics(q, pos, LAFAN1_PARENTS)[1])))(q)
    assert g.shape == q.shape and np.all(np.isfinite(np.asarray(g)))


def test_skeleton_is_hashable_static_data():
    offsets = np.arange(66, dtype=float).reshape(22, 3)
    a, b = lafan1_skeleton(offsets), lafan1_skeleton(offsets.copy())
    assert a == b and hash(a) == hash(b)
    assert a != lafan1_skeleton(offsets + 1)
    assert a.num_joints == 22 and a.index("LeftToe") == 4 and a.children(11) == (12, 14, 18)
    assert a.depths[4] == 4 and a.names == LAFAN1_JOINTS
    with pytest.raises(ValueError, match="parents must come before"):
        Skeleton(("a", "b"), (-1, 2), np.zeros((2, 3)))
    with pytest.raises(KeyError, match="no joint named"):
        a.index("Tail")
