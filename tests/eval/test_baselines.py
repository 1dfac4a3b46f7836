"""Zero-velocity and interpolation baselines (docs/design.md §4)."""
import numpy as np
import pytest

from stitchjax.eval import baselines
from stitchjax.rotations import quat_angle, quat_from_axis_angle


def _random_pose(seed, joints=3):
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(2, joints, 4))  # (B, J, 4)
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    return q, rng.normal(size=(2, joints, 3)) * 10


def test_transition_weights_exclude_the_keyframes():
    np.testing.assert_allclose(baselines.transition_weights(3), [0.25, 0.5, 0.75])


def test_zero_velocity_holds_the_start_pose():
    q, p = _random_pose(0)
    r, x = baselines.zero_velocity(q, p, 4)
    assert r.shape == (2, 4, 3, 4) and x.shape == (2, 4, 3, 3)
    for t in range(4):
        np.testing.assert_array_equal(r[:, t], q)
        np.testing.assert_array_equal(x[:, t], p)


def test_interpolation_positions_are_linear_and_rotations_follow_the_geodesic():
    axis = np.array([0.0, 1.0, 0.0])
    q0 = quat_from_axis_angle(axis, np.array(0.2))[None, None]  # (1, 1, 4)
    q1 = quat_from_axis_angle(axis, np.array(1.4))[None, None]
    p0, p1 = np.zeros((1, 1, 3)), np.array([[[4.0, 0.0, 8.0]]])
    r, x = baselines.interpolation(q0, p0, q1, p1, 3)
    np.testing.assert_allclose(x[0, :, 0], [[1, 0, 2], [2, 0, 4], [3, 0, 6]])
    # angles from q0: 0.3, 0.6, 0.9 rad of the 1.2 rad arc
    np.testing.assert_allclose(quat_angle(r[0, :, 0], np.broadcast_to(q0[0, 0], (3, 4))), [0.3, 0.6, 0.9], atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(r, axis=-1), 1.0, atol=1e-12)


def test_interpolation_flips_the_target_into_the_start_hemisphere():
    q0, p0 = _random_pose(1)
    q1, p1 = _random_pose(2)
    r_pos, _ = baselines.interpolation(q0, p0, q1, p1, 5)
    r_neg, _ = baselines.interpolation(q0, p0, -q1, p1, 5)
    np.testing.assert_allclose(r_pos, r_neg, atol=1e-12)


def test_interpolation_endpoints_reach_the_keyframes():
    q0, p0 = _random_pose(3)
    q1, p1 = _random_pose(4)
    q1 = np.where(np.sum(q0 * q1, -1, keepdims=True) < 0, -q1, q1)
    ends = baselines.slerp_to_hemisphere(q0, q1, np.array([0.0, 1.0]))  # (2, B, J, 4)
    np.testing.assert_allclose(ends[0], q0, atol=1e-7)
    np.testing.assert_allclose(ends[1], q1, atol=1e-7)
    # many frames: the first and last generated frames approach the keyframes
    r, x = baselines.interpolation(q0, p0, q1, p1, 200)
    assert np.max(np.abs(r[:, 0] - q0)) < 0.05 and np.max(np.abs(r[:, -1] - q1)) < 0.05
    np.testing.assert_allclose(x[:, 0], p0 + (p1 - p0) / 201)


@pytest.mark.parametrize("threshold", [0.0, baselines.OFFICIAL_LINEAR_THRESHOLD])
def test_nearly_equal_rotations_interpolate_without_nan(threshold):
    q0, p0 = _random_pose(5)
    r, _ = baselines.interpolation(q0, p0, q0 + 1e-9, p0, 4, linear_threshold=threshold)
    assert np.all(np.isfinite(r))
    np.testing.assert_allclose(r, np.broadcast_to(q0[:, None], r.shape), atol=1e-7)
