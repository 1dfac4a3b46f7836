"""Quaternion functions against scipy.spatial.transform.Rotation, in float32 and float64, numpy and jax."""
import itertools

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from stitchjax import rotations as R

jax.config.update("jax_enable_x64", False)

TAIT_BRYAN = ["".join(p) for p in itertools.permutations("xyz")]
PROPER = ["xyx", "xzx", "yxy", "yzy", "zxz", "zyz"]
DTYPES = [(np.float32, 2e-5), (np.float64, 1e-12)]


def random_quats(rng, n, dtype=np.float64):
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    return q.astype(dtype)


def to_scipy(q):
    return Rotation.from_quat(np.asarray(q, np.float64)[..., [1, 2, 3, 0]])


def from_scipy(r):
    return r.as_quat()[..., [3, 0, 1, 2]]


def same_rotation(a, b, tol):
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    return np.all(np.minimum(np.abs(a - b).max(-1), np.abs(a + b).max(-1)) < tol)


@pytest.mark.parametrize("dtype,tol", DTYPES)
@pytest.mark.parametrize("order", TAIT_BRYAN + PROPER)
def test_euler_to_quat_matches_scipy_every_channel_order(order, dtype, tol):
    rng = np.random.default_rng(0)
    angles = rng.uniform(-np.pi, np.pi, size=(64, 3)).astype(dtype)
    expected = from_scipy(Rotation.from_euler(order.upper(), angles.astype(np.float64)))
    got = R.euler_to_quat(angles, order)
    assert got.dtype == dtype
    assert same_rotation(got, expected, 50 * tol)
    got_jax = R.euler_to_quat(jnp.asarray(angles), order)
    assert isinstance(got_jax, jax.Array)
    assert same_rotation(got_jax, expected, 3e-6)


@pytest.mark.parametrize("order", TAIT_BRYAN + PROPER)
def test_quat_to_euler_inverts_euler_to_quat(order):
    rng = np.random.default_rng(1)
    q = random_quats(rng, 200)
    angles = R.quat_to_euler(q, order)
    assert same_rotation(R.euler_to_quat(angles, order), q, 1e-9)
    # And agrees with scipy's angles as a rotation.
    assert same_rotation(from_scipy(Rotation.from_euler(order.upper(), angles)), q, 1e-9)


def test_quat_to_euler_at_gimbal_lock():
    for order in ["zyx", "xyz", "zxz"]:
        mid = np.pi / 2 if order[0] != order[2] else 0.0
        angles = np.array([[0.3, mid, -0.7], [1.1, -mid, 0.2]])
        q = R.euler_to_quat(angles, order)
        assert same_rotation(R.euler_to_quat(R.quat_to_euler(q, order), order), q, 1e-7)


@pytest.mark.parametrize("dtype,tol", DTYPES)
def test_mul_rotate_inverse_match_scipy(dtype, tol):
    rng = np.random.default_rng(2)
    a, b = random_quats(rng, 100, dtype), random_quats(rng, 100, dtype)
    v = rng.normal(size=(100, 3)).astype(dtype)
    assert same_rotation(R.quat_mul(a, b), from_scipy(to_scipy(a) * to_scipy(b)), 10 * tol)
    np.testing.assert_allclose(R.quat_rotate(a, v), to_scipy(a).apply(v.astype(np.float64)), atol=20 * tol * 10)
    assert same_rotation(R.quat_inverse(a), from_scipy(to_scipy(a).inv()), 10 * tol)
    np.testing.assert_allclose(R.quat_mul(a, R.quat_conjugate(a)), np.tile([1, 0, 0, 0], (100, 1)), atol=10 * tol)
    # jax path, batched leading shape.
    aj, vj = jnp.asarray(a.reshape(10, 10, 4)), jnp.asarray(v.reshape(10, 10, 3))
    np.testing.assert_allclose(np.asarray(R.quat_rotate(aj, vj)).reshape(100, 3),
                               to_scipy(a).apply(v.astype(np.float64)), atol=1e-4)


@pytest.mark.parametrize("dtype,tol", DTYPES)
def test_matrix_conversions_match_scipy(dtype, tol):
    rng = np.random.default_rng(3)
    q = random_quats(rng, 300, dtype)
    m = R.quat_to_matrix(q)
    np.testing.assert_allclose(m, to_scipy(q).as_matrix(), atol=10 * tol)
    back = R.matrix_to_quat(to_scipy(q).as_matrix().astype(dtype))
    assert same_rotation(back, q, 1e3 * tol)
    assert np.all(back[..., 0] >= 0)


def test_slerp_matches_scipy_and_is_safe_at_degenerate_points():
    from scipy.spatial.transform import Slerp

    rng = np.random.default_rng(4)
    q0, q1 = random_quats(rng, 20), random_quats(rng, 20)
    q1 = np.where(np.sum(q0 * q1, -1, keepdims=True) < 0, -q1, q1)  # short way, as scipy takes it
    for i in range(20):
        t = np.linspace(0, 1, 7)
        expected = from_scipy(Slerp([0, 1], to_scipy(np.stack([q0[i], q1[i]])))(t))
        got = R.quat_slerp(np.repeat(q0[i:i + 1], 7, 0), np.repeat(q1[i:i + 1], 7, 0), t)
        assert same_rotation(got, expected, 1e-9)

    def total(q0, q1, t):
        return jnp.sum(R.quat_slerp(q0, q1, t) ** 2)

    q = jnp.asarray(q0[:3], jnp.float32)
    for other in (q, -q):  # equal and opposite endpoints
        t = jnp.full((3,), 0.3, jnp.float32)
        out = R.quat_slerp(q, other, t)
        assert np.all(np.isfinite(np.asarray(out)))
        np.testing.assert_allclose(np.linalg.norm(np.asarray(out), axis=-1), 1.0, atol=1e-5)
        grads = jax.grad(total, argnums=(0, 1, 2))(q, other, t)
        assert all(np.all(np.isfinite(np.asarray(g))) for g in grads)
    # Endpoints are reproduced exactly.
    np.testing.assert_allclose(R.quat_slerp(q0, q1, np.zeros(20)), q0, atol=1e-12)
    np.testing.assert_allclose(R.quat_slerp(q0, q1, np.ones(20)), q1, atol=1e-12)


def test_normalize_is_finite_with_finite_gradient_at_zero():
    z = jnp.zeros((2, 4))
    assert np.all(np.isfinite(np.asarray(R.quat_normalize(z))))
    g = jax.grad(lambda q: jnp.sum(R.quat_normalize(q)))(z)
    assert np.all(np.isfinite(np.asarray(g)))
    q = np.array([[2.0, 0, 0, 0], [0, 3.0, 4.0, 0]])
    np.testing.assert_allclose(R.quat_normalize(q), [[1, 0, 0, 0], [0, 0.6, 0.8, 0]], atol=1e-12)


def test_continuity_flips_to_the_previous_hemisphere():
    rng = np.random.default_rng(5)
    # A smooth trajectory with random sign flips.
    angles = np.linspace(0, 3, 50)
    q = R.quat_from_axis_angle(np.tile([0.0, 1.0, 0.0], (50, 1)), angles)
    flips = np.where(rng.uniform(size=(50, 1)) < 0.5, -1.0, 1.0)
    cont = R.quat_continuity(q * flips, axis=0)
    assert np.all(np.sum(cont[1:] * cont[:-1], -1) > 0)
    assert same_rotation(cont, q, 1e-12)
    cont_j = R.quat_continuity(jnp.asarray(q * flips)[:, None], axis=0)
    assert np.all(np.sum(np.asarray(cont_j)[1:] * np.asarray(cont_j)[:-1], -1) > 0)


def test_angle_between_expmap_roundtrip():
    rng = np.random.default_rng(6)
    a, b = random_quats(rng, 50), random_quats(rng, 50)
    expected = (to_scipy(a) * to_scipy(b).inv()).magnitude()
    np.testing.assert_allclose(R.quat_angle(a, b), expected, atol=1e-6)
    np.testing.assert_allclose(R.quat_angle(a, -a), 0.0, atol=1e-6)
    e = rng.normal(size=(50, 3))
    assert same_rotation(R.expmap_to_quat(e), from_scipy(Rotation.from_rotvec(e)), 1e-12)
    np.testing.assert_allclose(R.quat_to_expmap(R.expmap_to_quat(e * 0.3)), e * 0.3, atol=1e-9)
    g = jax.grad(lambda e: jnp.sum(R.expmap_to_quat(e)))(jnp.zeros((3,)))
    assert np.all(np.isfinite(np.asarray(g)))


def test_between_rotates_u_onto_v():
    rng = np.random.default_rng(7)
    u, v = rng.normal(size=(40, 3)), rng.normal(size=(40, 3))
    q = R.quat_between(u, v)
    rotated = R.quat_rotate(q, u / np.linalg.norm(u, axis=-1, keepdims=True))
    np.testing.assert_allclose(rotated, v / np.linalg.norm(v, axis=-1, keepdims=True), atol=1e-9)
