"""Metric values on tiny hand-computed inputs."""
import numpy as np
import pytest

from stitchjax.eval import metrics


def _random_quats(shape, seed=0):
    q = np.random.default_rng(seed).normal(size=shape + (4,))
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def test_l2q_of_known_difference():
    gt = _random_quats((2, 3, 5))  # (B, T, J, 4)
    pred = gt.copy()
    pred[:, 0, 1, 2] += 3.0  # frame 0: |(3, 4)| = 5
    pred[:, 0, 4, 0] += 4.0
    pred[:, 1, 0, 3] -= 1.0  # frame 1: 1, frame 2: 0
    assert metrics.l2q(pred, gt) == pytest.approx((5.0 + 1.0 + 0.0) / 3)
    np.testing.assert_allclose(metrics.l2q_per_window(pred, gt), [2.0, 2.0])


def test_l2p_normalises_with_training_statistics():
    rng = np.random.default_rng(1)
    gt = rng.normal(size=(3, 4, 2, 3)) * 50  # (B, T, J, 3) cm
    mean = rng.normal(size=6)
    std = np.full(6, 2.0)
    pred = gt.copy()
    pred[..., 1, :] += np.array([3.0, 4.0, 0.0])  # z-scored: (1.5, 2, 0) -> norm 2.5 every frame
    assert metrics.l2p(pred, gt, mean, std) == pytest.approx(2.5)
    # joint-major flattening: the std of joint 1's y coordinate is entry 1*3 + 1
    std2 = std.copy()
    std2[4] = 4.0
    assert metrics.l2p(pred, gt, mean, std2) == pytest.approx(np.hypot(1.5, 1.0))


def test_npss_identical_sequences_is_zero():
    gt = _random_quats((2, 8, 3), seed=2)
    assert metrics.npss(gt, gt) == pytest.approx(0.0, abs=1e-12)


def test_npss_hand_computed_and_power_weighted():
    # channel 0: gt [1, 0] -> |FFT|^2 [1, 1] (total 2), cdf [.5, 1]; pred [1, 1] -> [4, 0], cdf [1, 1]
    #   emd 0.5, weight 2.  channel 1: gt = pred = [0, 2] -> emd 0, weight 8.
    gt = np.array([[[1.0, 0.0], [0.0, 2.0]]])  # (B=1, T=2, D=2)
    pred = np.array([[[1.0, 0.0], [1.0, 2.0]]])
    assert metrics.npss(pred, gt) == pytest.approx((0.5 * 2 + 0.0 * 8) / 10)
    weighted, power = metrics.npss_parts(pred, gt)
    np.testing.assert_allclose(weighted, [1.0])
    np.testing.assert_allclose(power, [10.0])


def test_npss_parts_combine_chunks_exactly():
    gt = _random_quats((6, 10, 4), seed=3)
    pred = _random_quats((6, 10, 4), seed=4)
    w1, p1 = metrics.npss_parts(pred[:2], gt[:2])
    w2, p2 = metrics.npss_parts(pred[2:], gt[2:])
    combined = (w1.sum() + w2.sum()) / (p1.sum() + p2.sum())
    assert combined == pytest.approx(metrics.npss(pred, gt))


def test_ade_ade_best_and_slde_of_known_offsets():
    gt = np.random.default_rng(5).normal(size=(2, 4, 3, 3)) * 100  # (B, T, J, 3) cm
    off = gt + np.array([3.0, 4.0, 0.0])  # 5 cm everywhere
    samples = np.stack([off, gt])  # (S=2, B, T, J, 3)
    assert metrics.ade(samples, gt) == pytest.approx(0.025)  # metres, mean over samples
    assert metrics.ade_best(samples, gt) == pytest.approx(0.0)
    assert metrics.ade(off, gt, metres_per_unit=0.001) == pytest.approx(0.005)  # millimetre data
    last = gt.copy()
    last[:, -1, :, 2] += 10.0
    assert metrics.slde(last[None], gt) == pytest.approx(0.10)
    assert metrics.ade(last[None], gt) == pytest.approx(0.10 / 4)


def test_apd_of_known_distances():
    base = np.random.default_rng(6).normal(size=(2, 3, 2, 3))  # (B, T, J, 3)
    a = base.copy()
    a[:, 0, 0, 0] += 3.0
    a[:, 2, 1, 2] += 4.0  # flattened distance 5 cm from base
    assert metrics.apd(np.stack([base, a])) == pytest.approx(0.05)
    # three samples on a line at 0, 3, 6 cm: pair distances 3, 6, 3 -> mean 4 cm
    b = base.copy()
    b[:, 0, 0, 0] += 6.0
    c = base.copy()
    c[:, 0, 0, 0] += 3.0
    np.testing.assert_allclose(metrics.apd_per_window(np.stack([base, c, b])), [4.0, 4.0])
    assert metrics.apd(base[None]) == 0.0  # one sample: deterministic


def _sliding_foot(height_cm, frames=6, speed_cm=1.0, ground_cm=5.0):
    """(1, T, 2, 3): joint 0 a foot sliding along x at ``height_cm`` above the ground, joint 1 static."""
    x = np.zeros((1, frames, 2, 3))
    x[0, :, 0, 0] = speed_cm * np.arange(frames)
    x[0, :, 0, 1] = ground_cm + height_cm
    x[0, :, 1, 1] = 100.0  # not a foot
    return x


def test_foot_slide_on_ground_equals_speed():
    x = _sliding_foot(0.0, speed_cm=1.5)
    ground = metrics.ground_heights(x, feet=(0,))
    np.testing.assert_allclose(ground, [5.0])
    assert metrics.foot_slide(x, ground, feet=(0,)) == pytest.approx(1.5)


def test_foot_slide_lifted_foot_is_zero_and_half_height_is_weighted():
    ground = np.array([5.0])
    assert metrics.foot_slide(_sliding_foot(10.0), ground, feet=(0,)) == 0.0
    half = metrics.foot_slide(_sliding_foot(1.25), ground, feet=(0,))  # h = H/2
    assert half == pytest.approx(2.0 - np.sqrt(2.0))
    # metres per unit: the same motion in millimetres reads the same cm/frame
    mm = _sliding_foot(0.0, speed_cm=15.0, ground_cm=50.0)
    assert metrics.foot_slide(mm, np.array([50.0]), feet=(0,), metres_per_unit=0.001) == pytest.approx(1.5)


def test_foot_slide_counts_only_weighted_pairs():
    # two feet: one on the ground sliding 2 cm/frame, one lifted and sliding: average stays 2
    x = _sliding_foot(0.0, speed_cm=2.0)
    lifted = _sliding_foot(20.0, speed_cm=7.0)
    both = np.concatenate([x[:, :, :1], lifted[:, :, :1]], axis=2)
    assert metrics.foot_slide(both, np.array([5.0]), feet=(0, 1)) == pytest.approx(2.0)


def test_ground_penetration_and_swing_clearance_on_a_made_up_toe():
    """One toe (joint 0) planted, lifted to 10 cm while it moves 5 cm/frame, planted again; joint 1 still."""
    g = np.zeros((1, 10, 2, 3))
    g[0, :, 0, 0] = [0, 0, 5, 10, 15, 20, 20, 20, 20, 20]
    g[0, :, 0, 1] = [0, 0, 4, 10, 6, 0, 0, 0, 0, 0]
    clearance, swings = metrics.swing_clearance_parts(g, np.zeros(1), [0], swing_speed_cm_per_frame=2.0)
    assert swings[0] == 1 and clearance[0] == 10.0  # one swing, highest at 10 cm
    one_step = g.copy()
    one_step[0, :, 0, 0] = [0, 0, 0, 0, 0, 9, 9, 9, 9, 9]  # a single jump is no swing
    assert metrics.swing_clearance_parts(one_step, np.zeros(1), [0], 2.0)[1][0] == 0
    sunk = g - np.array([0.0, 3.0, 0.0])  # 3 cm lower: joint 1 below on all 10 frames, joint 0 on 7
    depth, below, total, deepest = metrics.ground_penetration_parts(sunk, np.zeros(1), [0, 1])
    assert (depth[0], below[0], total[0], deepest[0]) == (51.0, 17.0, 20.0, 3.0)
    assert metrics.ground_penetration_parts(g, np.zeros(1), [0, 1])[1][0] == 0


def _legs_pose(frames, knee_degrees):
    """(1, T, 5, 3) positions of one leg (root, hip, knee, ankle, toe): thigh straight down 40 cm, the shin turned
    back by 180 - knee_degrees[t] at the knee, the toe 10 cm ahead of the ankle."""
    g = np.zeros((1, frames, 5, 3))
    g[0, :, 0] = [0.0, 90.0, 0.0]
    g[0, :, 1] = [0.0, 85.0, 0.0]
    g[0, :, 2] = [0.0, 45.0, 0.0]
    bend = np.radians(180.0 - np.asarray(knee_degrees, np.float64))
    g[0, :, 3] = g[0, :, 2] + 40.0 * np.stack([np.zeros(frames), -np.cos(bend), -np.sin(bend)], -1)
    g[0, :, 4] = g[0, :, 3] + [0.0, 0.0, 10.0]
    return g


def test_leg_joints_knee_angles_and_the_fastest_knee_turn():
    parents = (-1, 0, 1, 2, 3)
    legs = metrics.leg_joints(parents, (3, 4))
    assert legs == ((1, 2, 3, 4),)
    lafan = (-1, 0, 1, 2, 3, 0, 5, 6, 7)
    assert metrics.leg_joints(lafan, (3, 4, 7, 8)) == ((1, 2, 3, 4), (5, 6, 7, 8))
    angles = [180.0, 170.0, 150.0, 150.0, 140.0]
    g = _legs_pose(5, angles)
    np.testing.assert_allclose(metrics.knee_angles(g, legs)[0, :, 0], angles, atol=1e-6)
    np.testing.assert_allclose(metrics.knee_turn_max(g, legs), [20.0], atol=1e-6)
    np.testing.assert_allclose(metrics.knee_turn_max(np.stack([g[0], _legs_pose(5, [90.0] * 5)[0]]), legs),
                               [20.0, 0.0], atol=1e-6)  # per window


def test_joint_jump_max_is_the_longest_step_of_any_joint():
    g = np.zeros((2, 4, 3, 3))
    g[0, 2:, 1, 0] = 3.0  # joint 1 of window 0 steps 3 units (cm) once
    g[1, 1:, 2] = [[0, 4, 0], [0, 4, 0], [0, 4, 0]]  # joint 2 of window 1 steps 4 once
    np.testing.assert_allclose(metrics.joint_jump_max(g), [3.0, 4.0])
    np.testing.assert_allclose(metrics.joint_jump_max(g * 10.0, metres_per_unit=0.001), [3.0, 4.0])  # mm data


def test_hover_counts_long_runs_off_the_ground_where_the_truth_stands():
    """The truth's foot stands (toe on the ground) throughout; a generated foot 6 cm up for 12 frames hovers, one 6 cm
    up for 9 frames or 4 cm up does not; nor does a foot up while the truth's is up too."""
    frames = 20
    truth = _legs_pose(frames, [160.0] * frames)
    truth[..., 1] -= truth[0, 0, 4, 1]  # the toe on y = 0, the window's ground
    legs = metrics.leg_joints((-1, 0, 1, 2, 3), (3, 4))
    ground = np.zeros(1)

    def share(lift, first, count, truth_lift=0.0):
        g, t = truth.copy(), truth.copy()
        g[0, first:first + count, 3:, 1] += lift
        t[0, first:first + count, 3:, 1] += truth_lift
        hovering, leg_frames = metrics.hover_parts(g[None], t, ground, legs)
        assert leg_frames[0, 0] == frames
        return hovering[0, 0]

    assert share(6.0, 4, 12) == 12.0
    assert share(6.0, 4, 9) == 0.0  # too short
    assert share(4.0, 4, 12) == 0.0  # not high enough
    assert share(6.0, 4, 12, truth_lift=6.0) == 0.0  # the truth's foot is up too
    assert share(6.0, 0, 20) == 20.0
