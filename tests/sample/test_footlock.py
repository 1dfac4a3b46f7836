"""Foot locking (stitchjax.sample.footlock and its foot_spans, foot_easing, leg_ik) on a one-legged synthetic
skeleton: IK reach and bone lengths, the unreachable case, keyframes, planted feet, flickers and transitions without
contacts."""
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from stitchjax.sample import foot_easing, foot_spans, foot_speed, footlock, leg_ik
from stitchjax import rotations as R
from stitchjax.skeleton import Skeleton, forward_kinematics

NAMES = ("Hips", "LeftUpLeg", "LeftLeg", "LeftFoot", "LeftToe")
PARENTS = (-1, 0, 1, 2, 3)
OFFSETS = np.array([[0, 0, 0], [10, 0, 0], [0, -40, 0], [0, -40, 0], [0, -5, 10]], np.float64)
SKELETON = Skeleton(NAMES, PARENTS, OFFSETS)
FEET = (3, 4)


def _about_x(degrees):
    return np.array([np.cos(np.radians(degrees) / 2), np.sin(np.radians(degrees) / 2), 0, 0])


def _pose(frames, knee_degrees=60.0, step=0.5):
    """(rotations (T, 5, 4), root (T, 3)): the knee bent by knee_degrees (thigh forward, shin back), the
    root moving ``step`` cm per frame along +Z at a height putting the toe near y = 0."""
    rotations = np.tile(np.array([1.0, 0, 0, 0]), (frames, 5, 1))
    rotations[:, 1] = _about_x(-knee_degrees / 2)
    rotations[:, 2] = _about_x(knee_degrees)
    rotations[:, 3] = _about_x(-knee_degrees / 2)
    root = np.zeros((frames, 3))
    root[:, 2] = step * np.arange(frames)
    local = np.broadcast_to(OFFSETS, (frames, 5, 3)).copy()
    local[:, 0] = root
    root[:, 1] = -forward_kinematics(rotations, local, PARENTS)[1][0, 4, 1]
    return rotations, root


def _global_positions(rotations, root):
    local = np.broadcast_to(OFFSETS, np.shape(rotations)[:-1] + (3,)).copy()
    local[..., 0, :] = root
    return forward_kinematics(np.asarray(rotations, np.float64), local, PARENTS)[1]


def _solve(target, knee_degrees=40.0):
    """Two-bone IK of the synthetic leg to ``target``: the new global positions (5, 3)."""
    rotations, root = _pose(1, knee_degrees)
    local = np.broadcast_to(OFFSETS, (1, 5, 3)).copy()
    local[:, 0] = root
    g_rot, g_pos = forward_kinematics(rotations, local, PARENTS)
    g_rot, g_pos = jnp.asarray(g_rot[0], jnp.float32), jnp.asarray(g_pos[0], jnp.float32)
    hip_turn, knee_turn, _, _, _ = leg_ik.two_bone_ik(g_pos[1], g_pos[2], g_pos[3], jnp.asarray(target, jnp.float32),
                                                        jnp.float32(40.0), jnp.float32(40.0))
    hip = R.quat_mul(hip_turn, g_rot[1])
    knee = R.quat_mul(knee_turn, R.quat_mul(hip_turn, g_rot[2]))
    new = np.array(rotations[0])
    new[1] = np.asarray(R.quat_mul(R.quat_conjugate(g_rot[0]), hip))
    new[2] = np.asarray(R.quat_mul(R.quat_conjugate(hip), knee))
    new[3] = np.asarray(R.quat_mul(R.quat_conjugate(knee), g_rot[3]))  # the foot keeps its orientation
    return _global_positions(new[None], root[:1])[0], g_pos


def _bone_lengths(g):
    return np.linalg.norm(g[..., 1:, :] - g[..., np.array(PARENTS[1:]), :], axis=-1)


def test_ik_reaches_a_reachable_target_and_keeps_bone_lengths():
    _, before = _solve(np.zeros(3))
    target = np.asarray(before[1]) + np.array([5.0, -60.0, 20.0])  # 64 cm from the hip: reachable (80 cm leg)
    after, before = _solve(target)
    assert np.linalg.norm(after[3] - target) < 1e-3
    np.testing.assert_allclose(_bone_lengths(after), np.linalg.norm(OFFSETS[1:], axis=-1), atol=1e-4)
    # the knee bends the way it bent (towards +Z, its pole), no flip
    assert (after[2, 2] - after[1, 2]) * (np.asarray(before)[2, 2] - np.asarray(before)[1, 2]) > 0


def test_unreachable_target_leaves_the_leg_straight_not_stretched():
    _, before = _solve(np.zeros(3))
    hip = np.asarray(before[1], np.float64)
    target = hip + np.array([0.0, -120.0, 30.0])  # 124 cm away, the leg is 80
    after, _ = _solve(target)
    reach = np.linalg.norm(after[3] - after[1])
    assert reach <= 80.0 + 1e-3
    assert reach > 0.98 * 80.0
    direction = (target - hip) / np.linalg.norm(target - hip)
    np.testing.assert_allclose((after[3] - after[1]) / reach, direction, atol=1e-3)  # towards the target
    np.testing.assert_allclose(_bone_lengths(after), np.linalg.norm(OFFSETS[1:], axis=-1), atol=1e-4)


def _transition(frames=30, contact=1.0):
    rotations, root = _pose(frames)
    contacts = np.full((frames, 2), contact)
    contacts[0] = contacts[-1] = 0.0  # keyframes not in contact: the span plants at its own first frame
    return rotations, root, contacts


def test_planted_foot_does_not_move_and_keyframes_are_bit_identical():
    rotations, root, contacts = _transition()
    out = footlock.lock_feet(jnp.asarray(rotations, jnp.float32), jnp.asarray(root, jnp.float32),
                             jnp.asarray(contacts, jnp.float32), SKELETON, feet=FEET)
    planted = np.asarray(out["planted"][:, 0])
    assert planted.sum() >= 10  # the sliding foot was planted
    new = np.asarray(out["rotations"])
    for k in (0, -1):
        assert np.array_equal(new[k], np.asarray(rotations[k], np.float32))
    g = _global_positions(new, root)
    feet = g[planted][:, [3, 4]]  # ankle and toe of every planted frame
    assert np.abs(feet - feet[0]).max() < 1e-3
    before = _global_positions(rotations, root)
    assert np.abs(np.diff(before[planted][:, 3], axis=0)).max() > 0.4  # it slid before
    np.testing.assert_allclose(_bone_lengths(g), np.broadcast_to(np.linalg.norm(OFFSETS[1:], axis=-1), (30, 4)),
                               atol=1e-3)
    # float64 numpy path: keyframes and every joint the pass leaves alone keep their bits
    local = np.broadcast_to(OFFSETS, rotations.shape[:-1] + (3,)).copy()
    local[:, 0] = root
    locked, positions, stats = footlock.lock_transitions(rotations, local, contacts, SKELETON, FEET)
    assert locked.dtype == np.float64 and positions is not None
    assert np.array_equal(locked[[0, -1]], rotations[[0, -1]])
    assert np.array_equal(locked[:, [0, 4]], rotations[:, [0, 4]])
    assert stats["planted"].shape == (30, 1)


def test_no_contacts_and_flickers_leave_the_transition_unchanged():
    rotations, root, contacts = _transition(contact=0.0)
    flicker = contacts.copy()
    flicker[10] = 1.0  # one frame: no span
    batch = jnp.asarray(np.stack([rotations, rotations]), jnp.float32)
    roots = jnp.asarray(np.stack([root, root]), jnp.float32)
    out = jax.jit(lambda r, p, c: footlock.lock_feet(r, p, c, SKELETON, feet=FEET))(
        batch, roots, jnp.asarray(np.stack([contacts, flicker]), jnp.float32))
    assert np.array_equal(np.asarray(out["rotations"]), np.asarray(batch))
    assert np.array_equal(np.asarray(out["root_positions"]), np.asarray(roots))
    assert not np.asarray(out["planted"]).any() and not np.asarray(out["changed"]).any()


def test_spans_hysteresis_and_blend():
    score = jnp.asarray([0.0, 0.6, 0.4, 0.3, 0.1, 0.6, 0.0, 0.9, 0.9, 0.9, 0.0])
    on = np.asarray(foot_spans.hysteresis(score, 0.5, 0.25))
    assert on.tolist() == [0, 1, 1, 1, 0, 1, 0, 1, 1, 1, 0]
    kept = np.asarray(foot_spans.drop_short_spans(jnp.asarray(on), 3))
    assert kept.tolist() == [0, 1, 1, 1, 0, 0, 0, 1, 1, 1, 0]
    anchor = jnp.zeros(11, bool).at[jnp.asarray([0, 1, 2, 10])].set(True)
    offset = jnp.zeros((11, 3)).at[2].set(jnp.asarray([4.0, 0.0, 0.0]))
    turn = jnp.zeros((11, 4)).at[:, 0].set(1.0)
    blended, _, weight, arc = foot_easing.blended_corrections(anchor, offset, turn, blend_frames=4)
    x = np.asarray(blended[:, 0])
    assert x[2] == 4.0 and x[10] == 0.0 and x[7] == 0.0
    assert np.all(np.diff(x[2:8]) <= 0) and 0 < x[4] < 4.0  # eased out over 4 frames
    assert np.asarray(weight)[2] == 1.0 and np.abs(x[7:]).max() == 0.0
    assert np.asarray(arc)[2] == 0.0 and 0 < np.asarray(arc)[4] <= 4.0 + 1e-6  # a step: highest mid-ease


def test_before_after_figure(tmp_path):
    from stitchjax.eval import plots

    rotations, root, contacts = _transition()
    local = np.broadcast_to(OFFSETS, rotations.shape[:-1] + (3,)).copy()
    local[:, 0] = root
    locked, _, stats = footlock.lock_transitions(rotations, local, contacts, SKELETON, FEET)
    before, after = _global_positions(rotations, root), _global_positions(locked, root)
    fig = plots.foot_lock_before_after(before, after, stats["planted"], FEET, let_go=stats["let_go"],
                                       leg_names=("left",), dpi=50, path=tmp_path / "f.png")
    assert tuple(np.round(fig.get_size_inches() * fig.dpi)) == (400, 230)
    assert (tmp_path / "f.png").read_bytes()[:4] == b"\x89PNG"
    with pytest.raises(ValueError, match="planted must be"):
        plots.foot_lock_before_after(before, after, stats["planted"][:5], FEET)


def test_bridge_gaps_fills_short_gaps_between_spans_only():
    mask = jnp.asarray([0, 1, 1, 0, 1, 1, 0, 0, 0, 1, 0], bool)
    out = np.asarray(foot_spans.bridge_gaps(mask, 2)).astype(int).tolist()
    assert out == [0, 1, 1, 1, 1, 1, 0, 0, 0, 1, 0]  # the 1-frame gap filled, the 3-frame gap and the ends not
    assert np.array_equal(np.asarray(foot_spans.bridge_gaps(mask, 0)), np.asarray(mask))


def test_split_drifting_spans_cuts_a_skating_span_into_plants():
    frames = 30
    mask = jnp.zeros(frames, bool).at[2:28].set(True)
    skate = jnp.zeros((frames, 3)).at[:, 2].set(1.5 * jnp.arange(frames)).at[:, 1].set(jnp.arange(frames))
    out = np.asarray(foot_spans.split_drifting_spans(mask, skate, 10.0, 2))
    ids = np.asarray(foot_spans.span_ids(jnp.asarray(out)))
    assert ids.max() == 3 and not (out & ~np.asarray(mask)).any()  # three plants, all inside the span
    z = np.asarray(skate[:, 2])
    for k in range(1, ids.max() + 1):
        run = np.flatnonzero(ids == k)
        assert z[run].max() - z[run].min() <= 10.0  # each within the distance (horizontally: y rises 1/frame)
        if k > 1:
            assert run[0] - np.flatnonzero(ids == k - 1)[-1] - 1 == 2  # two frames between plants
    still = jnp.zeros((frames, 3))
    np.testing.assert_array_equal(np.asarray(foot_spans.split_drifting_spans(mask, still, 10.0, 2)), mask)
    np.testing.assert_array_equal(np.asarray(foot_spans.split_drifting_spans(mask, skate, 0.0, 2)), mask)


def test_plant_at_the_mean_of_the_span():
    mask = jnp.asarray([0, 0, 1, 1, 1, 1, 0, 0], bool)
    ankle = jnp.stack([jnp.arange(8.0), jnp.full(8, 5.0), jnp.zeros(8)], -1)
    rotation = jnp.zeros((8, 4)).at[:, 0].set(1.0)
    position, _ = foot_spans.span_targets(mask, ankle, rotation, floor=0.0, plant_at=-1.0)
    np.testing.assert_allclose(np.asarray(position[2:6, 0]), 3.5)  # mean of frames 2-5
    np.testing.assert_allclose(np.asarray(position[[0, 1, 6, 7], 0]), [0.0, 1.0, 6.0, 7.0])  # outside: the foot


def test_eased_plants_leave_a_plant_at_rest_and_leave_keyframes_alone():
    n = 16
    anchor = jnp.zeros(n, bool).at[:6].set(True).at[-1].set(True)
    free = jnp.zeros(n, bool).at[0].set(True).at[-1].set(True)  # keyframes plant nothing
    ankle = jnp.stack([3.0 * jnp.arange(n), jnp.zeros(n), jnp.zeros(n)], -1)  # the generated foot skates on
    target = jnp.where(anchor[:, None], jnp.asarray([3.0, 0.0, 0.0]), ankle)  # planted at frame 1's place
    identity = jnp.zeros((n, 4)).at[:, 0].set(1.0)
    offset, turn, weight, _ = foot_easing.eased_plants(anchor, free, target, identity, ankle, identity, blend_frames=6)
    foot = np.asarray(ankle + offset)[:, 0]
    assert np.abs(np.diff(foot[1:6])).max() < 1e-5  # held
    assert abs(foot[6] - foot[5]) < 1.0  # the first frame after the plant moves little (the skate: 3 cm/frame)
    assert np.all(np.diff(foot[5:]) >= -1e-5)  # then follows the generated foot, never back
    np.testing.assert_allclose(np.asarray(offset[-1]), 0.0)  # the keyframe takes no correction
    np.testing.assert_allclose(np.asarray(offset[13:]), 0.0, atol=1e-6)  # eased out within 6 frames + 1
    assert float(weight[5]) == 1.0 and float(weight[-1]) == 0.0


def test_clearance_lift_steps_a_moving_low_foot_and_needs_contact():
    n = 20
    anchor = jnp.zeros(n, bool).at[:4].set(True).at[-1].set(True)
    height, speed = jnp.zeros(n), jnp.full(n, 5.0)
    lift = np.asarray(foot_easing.clearance_lift(height, speed, jnp.ones(n), anchor, 4.0, 2.0, 2))
    assert np.all(lift[np.asarray(anchor)] == 0.0)
    np.testing.assert_allclose(lift[8:16], 4.0)  # lifted to the clearance away from the plants
    assert np.abs(np.diff(lift)).max() <= 4.0 * 0.75  # eased in and out, no jump to full height
    still = np.asarray(foot_easing.clearance_lift(height, jnp.full(n, 0.5), jnp.ones(n), anchor, 4.0, 2.0, 2))
    assert not still.any()  # a foot at rest is not lifted
    none = np.asarray(foot_easing.clearance_lift(height, speed, jnp.zeros(n), anchor, 4.0, 2.0, 2))
    assert not none.any()  # no predicted contact, no lift


def test_clearance_lift_from_below_reaches_the_clearance_and_the_ground():
    n = 20
    anchor = jnp.zeros(n, bool).at[:4].set(True).at[-1].set(True)
    height = jnp.full(n, -6.0)  # a foot 6 cm into the ground
    moving, still = jnp.full(n, 5.0), jnp.full(n, 0.2)
    capped = np.asarray(foot_easing.clearance_lift(height, moving, jnp.ones(n), anchor, 4.0, 2.0, 2))
    np.testing.assert_allclose(capped[8:16], 4.0)  # version 4: at most the clearance, still 2 cm below
    lifted = np.asarray(foot_easing.clearance_lift(height, moving, jnp.ones(n), anchor, 4.0, 2.0, 2, from_below=True))
    np.testing.assert_allclose(lifted[8:16], 10.0)  # to the clearance above the ground
    assert np.all(lifted[np.asarray(anchor)] == 0.0)
    out = np.asarray(foot_easing.clearance_lift(height, still, jnp.zeros(n), anchor, 4.0, 2.0, 2, from_below=True))
    np.testing.assert_allclose(out[8:16], 6.0)  # at rest and without contact: out of the ground, no higher
    capped = np.asarray(foot_easing.clearance_lift(height, moving, jnp.ones(n), anchor, 4.0, 2.0, 2, from_below=True,
                                                   max_lift=3.0))
    np.testing.assert_allclose(capped[8:16], 3.0)  # never more than max_lift
    above = np.asarray(foot_easing.clearance_lift(jnp.full(n, 1.0), still, jnp.ones(n), anchor, 4.0, 2.0, 2,
                                                  from_below=True))
    assert not above.any()  # a foot above the ground at rest is left alone
    for bad in ({"max_lift": -1.0}, {"key_clearance": -1.0}, {"clearance_key_frames": -1}, {"replant_gap": 0},
                {"jump_guard": -1}, {"jump_floor": -1.0}, {"share_distance": -1.0}):
        with pytest.raises(ValueError, match="foot lock"):
            footlock.FootLockConfig(**bad)


def test_clearance_lift_falls_to_the_key_clearance_next_to_keyframes():
    n = 30
    keyframe = jnp.zeros(n, bool).at[0].set(True).at[-1].set(True)
    anchor = keyframe.at[12:16].set(True)  # a plant in the middle
    args = (jnp.zeros(n), jnp.full(n, 5.0), jnp.ones(n), anchor, 4.0, 2.0, 2)
    near_plant = np.asarray(foot_easing.clearance_lift(*args))
    near_key = np.asarray(foot_easing.clearance_lift(*args, keyframe=keyframe, key_frames=5))
    assert near_key[1] < near_plant[1] and near_key[-2] < near_plant[-2]  # less lift next to the keyframes
    np.testing.assert_allclose(near_key[6:12], near_plant[6:12])  # away from them, the same
    np.testing.assert_allclose(near_key[16:18], near_plant[16:18])  # next to the plant, the same
    assert near_key[1] > 0.0 and np.abs(np.diff(near_key[:7])).max() < np.abs(np.diff(near_plant[:7])).max()
    low = np.asarray(foot_easing.clearance_lift(*args, keyframe=keyframe, key_frames=5, key_clearance=2.0))
    assert near_key[1] < low[1] < near_plant[1] and near_key[-2] < low[-2] < near_plant[-2]  # lifted, less high
    np.testing.assert_allclose(low[6:12], near_plant[6:12])


def test_a_foot_sunk_into_the_ground_is_lifted_out_with_lift_from_below():
    frames = 30
    rotations, root = _pose(frames, knee_degrees=60.0, step=0.3)  # slow: no clearance lift by speed
    root[:, 1] -= 6.0 * np.sin(np.pi * np.arange(frames) / (frames - 1))  # the body sinks 6 cm and comes back
    local = np.broadcast_to(OFFSETS, rotations.shape[:-1] + (3,)).copy()
    local[:, 0] = root
    contacts = np.zeros((frames, 2))  # no contact predicted: nothing is planted
    toe = {}
    for below in (False, True):
        config = footlock.FootLockConfig(lift_from_below=below)
        locked, _, _ = footlock.lock_transitions(rotations, local, contacts, SKELETON, FEET, config)
        toe[below] = _global_positions(locked, root)[:, 4, 1]
        np.testing.assert_array_equal(locked[[0, -1]], rotations[[0, -1]])  # keyframes bit for bit
        np.testing.assert_allclose(_bone_lengths(_global_positions(locked, root)),
                                   np.broadcast_to(np.linalg.norm(OFFSETS[1:], axis=-1), (frames, 4)), atol=1e-4)
    assert toe[False][12:18].max() < -4.0  # version 4 leaves the foot in the ground
    assert toe[True][12:18].min() > -0.05  # out of it, on the keyframes' ground (y = 0)
    assert toe[True].max() < 0.5  # and no higher


def test_pole_hint_bends_a_straight_leg_over_the_toes():
    hip, knee, ankle = jnp.asarray([0.0, 80.0, 0.0]), jnp.asarray([0.0, 40.0, 0.0]), jnp.asarray([0.0, 0.0, 0.0])
    target = jnp.asarray([0.0, 10.0, 0.0])  # 70 cm from the hip: the knee must bend, the straight leg has no plane
    for sign in (1.0, -1.0):
        _, _, new_knee, new_ankle, _ = leg_ik.two_bone_ik(hip, knee, ankle, target, jnp.float32(40.0),
                                                            jnp.float32(40.0), hint=jnp.asarray([0.0, 0.0, 3.0 * sign]))
        assert np.sign(float(new_knee[2])) == sign and float(new_knee[2]) * sign > 10.0
        np.testing.assert_allclose(np.asarray(new_ankle), np.asarray(target), atol=1e-3)


def test_skating_foot_is_planted_or_lifted():
    """A foot skating on the ground at 2.5 cm/frame with contact predicted: after the pass, the frames
    where a foot joint is within 2.5 cm of the ground (the foot-slide metric's) move far less."""
    frames = 40
    rotations, root = _pose(frames, step=2.5)
    contacts = np.ones((frames, 2))
    contacts[0] = contacts[-1] = 0.0  # keyframes not in contact: the foot is planted between them
    local = np.broadcast_to(OFFSETS, rotations.shape[:-1] + (3,)).copy()
    local[:, 0] = root
    locked, _, stats = footlock.lock_transitions(rotations, local, contacts, SKELETON, FEET)

    def slide(g):
        feet = g[1:, [3, 4]]
        ground = min(g[0, [3, 4], 1].min(), g[-1, [3, 4], 1].min())
        weight = np.clip(2.0 - 2.0 ** ((feet[:-1, :, 1] - ground) / 2.5), 0.0, 1.0)
        step = np.linalg.norm(np.diff(feet[..., [0, 2]], axis=0), axis=-1)
        return (weight * step).sum() / max((weight > 0).sum(), 1)

    before, after = slide(_global_positions(rotations, root)), slide(_global_positions(locked, root))
    # 0.44 cm/frame left with the full clearance next to the keyframes, 0.63 with the defaults' 3 cm there
    assert before > 2.0 and after < 0.3 * before
    assert stats["planted"].any() and stats["lifted"].any()
    assert np.array_equal(locked[[0, -1]], rotations[[0, -1]])
    g = _global_positions(locked, root)
    np.testing.assert_allclose(_bone_lengths(g), np.broadcast_to(np.linalg.norm(OFFSETS[1:], axis=-1), (frames, 4)),
                               atol=1e-3)


def test_limit_correction_speed_keeps_anchors_and_the_generated_top_speed():
    n = 24
    t = np.arange(n)
    speed = 0.5 + 7.5 * np.sin(np.pi * np.clip(t - 4, 0, 16) / 16) ** 2  # the generated foot speeds up and stops
    ankle = jnp.asarray(np.stack([np.cumsum(speed), np.zeros(n), np.zeros(n)], -1), jnp.float32)
    anchor = jnp.zeros(n, bool).at[:4].set(True).at[-1].set(True)
    offset = jnp.zeros((n, 3)).at[:4, 0].set(-6.0).at[4:12, 0].set(jnp.linspace(-6.0, 4.0, 8))  # a jerky ease
    limited = np.asarray(foot_speed.limit_correction_speed(offset, ankle, anchor, floor=1.0))
    assert np.array_equal(limited[np.asarray(anchor)], np.asarray(offset)[np.asarray(anchor)])
    step = np.linalg.norm(np.diff(np.asarray(ankle), axis=0), axis=-1)
    moved = np.linalg.norm(np.diff(np.asarray(ankle) + limited, axis=0), axis=-1)
    assert np.all(moved <= np.maximum(step.max(), step + 1.0) + 1e-4)
    unlimited = np.linalg.norm(np.diff(np.asarray(ankle + offset), axis=0), axis=-1)
    assert unlimited.max() > step.max() + 1.0  # the ease alone would outrun the foot
    zeros = foot_speed.limit_correction_speed(jnp.zeros((n, 3)), ankle, anchor, floor=1.0)
    assert not np.asarray(zeros).any()  # no correction stays no correction, exactly


def test_limit_knee_speed_bounds_the_solved_knee_angle_change():
    n = 12
    hip = jnp.zeros((n, 3)).at[:, 1].set(80.0)
    ankle = jnp.zeros((n, 3)).at[:, 1].set(80.0 - 60.0)  # the generated knee keeps its angle
    distance = jnp.asarray([60.0] * 4 + [79.0] * 4 + [60.0] * 4)  # the goal snaps the leg straight and back
    goal = hip - distance[:, None] * jnp.asarray([0.0, 1.0, 0.0])
    anchor = jnp.zeros(n, bool).at[0].set(True).at[-1].set(True)
    out = foot_speed.limit_knee_speed(hip, goal, ankle, jnp.float32(40.0), jnp.float32(40.0), anchor, 0.97, 6.0)
    reach = leg_ik.soft_reach(jnp.linalg.norm(out - hip, axis=-1), jnp.float32(80.0), 0.97)
    angle = np.degrees(np.asarray(foot_speed.knee_angle(reach, jnp.float32(40.0), jnp.float32(40.0))))
    assert np.abs(np.diff(angle)).max() <= 6.0 + 1e-3
    assert np.array_equal(np.asarray(out)[[0, -1]], np.asarray(goal)[[0, -1]])
    assert angle[7] >= angle[3] + 4 * 6.0 - 1e-3  # it still straightens, as fast as allowed


def test_easing_between_plants_adds_no_joint_jump_or_knee_snap():
    """A foot that stands, swings forward at up to 12 cm/frame and stands again: without the speed limits the
    eased foot whips between its plants; with them the largest joint step stays within 15 % of the generated
    one and the knee angle changes per frame by at most the generated change plus ``knee_step``."""
    frames = 40
    t = np.arange(frames)
    speed = 0.5 + np.where((t > 12) & (t < 28), 11.5 * np.sin(np.pi * (t - 12) / 16) ** 2, 0.0)
    rotations, root = _pose(frames, knee_degrees=60.0)
    root[:, 2] = np.concatenate([[0.0], np.cumsum(speed[1:])])
    contacts = np.ones((frames, 2))
    contacts[0] = contacts[-1] = 0.0
    local = np.broadcast_to(OFFSETS, rotations.shape[:-1] + (3,)).copy()
    local[:, 0] = root

    def knee(g):
        u, v = g[:, 1] - g[:, 2], g[:, 3] - g[:, 2]
        cos = (u * v).sum(-1) / np.linalg.norm(u, axis=-1) / np.linalg.norm(v, axis=-1)
        return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))

    def largest_jump(g):
        return np.linalg.norm(np.diff(g, axis=0), axis=-1).max()

    before = _global_positions(rotations, root)
    unlimited = footlock.FootLockConfig(correction_step=-1.0, knee_step=-1.0, jump_guard=0)
    old, _, _ = footlock.lock_transitions(rotations, local, contacts, SKELETON, FEET, unlimited)
    new, _, stats = footlock.lock_transitions(rotations, local, contacts, SKELETON, FEET)
    assert largest_jump(_global_positions(old, root)) > 1.5 * largest_jump(before)  # the artefact
    g = _global_positions(new, root)
    assert largest_jump(g) <= 1.15 * largest_jump(before)
    assert np.abs(np.diff(knee(g))).max() <= np.abs(np.diff(knee(before))).max() + 6.0 + 1e-3
    assert stats["planted"][:, 0].sum() >= 20  # both plants still held
    assert np.array_equal(new[[0, -1]], rotations[[0, -1]])
    np.testing.assert_allclose(_bone_lengths(g), np.broadcast_to(np.linalg.norm(OFFSETS[1:], axis=-1), (frames, 4)),
                               atol=1e-3)


def test_jump_guard_keeps_leg_steps_within_the_generated_largest_step():
    frames = 24
    generated, root = _pose(frames, knee_degrees=40.0, step=1.0)
    root[20:, 2] += 4.0  # the generated transition's longest step: 5 cm, every joint, frame 19 to 20
    local = np.broadcast_to(OFFSETS, generated.shape[:-1] + (3,)).copy()
    local[:, 0] = root
    generated = generated.astype(np.float32)  # the pass's precision, so frames returned exactly compare equal
    locked = generated.copy()
    locked[10:14, 2] = _about_x(100.0)  # a knee snapped to 100 degrees for four frames: a 20+ cm jump
    legs = leg_ik.leg_chains(SKELETON, FEET)
    step = lambda q: np.linalg.norm(np.diff(_global_positions(q, root), axis=0), axis=-1).max()  # noqa: E731
    bound = step(generated)
    assert step(locked) > bound + 10.0
    g_generated = forward_kinematics(jnp.asarray(generated), jnp.asarray(local, jnp.float32), PARENTS)
    guard = lambda q, rounds: np.asarray(foot_speed.guard_joint_jumps(  # noqa: E731
        jnp.asarray(q), jnp.asarray(generated), g_generated, jnp.asarray(OFFSETS, jnp.float32), legs, PARENTS, rounds))
    out = guard(locked, 12)
    assert step(out) <= bound + 0.05  # no step longer than the generated transition's longest
    np.testing.assert_array_equal(out[:5], locked[:5])  # frames away from the jump are returned exactly
    np.testing.assert_array_equal(out[-5:], locked[-5:])
    small = generated.copy()
    small[10:14, 2] = _about_x(41.0)  # a correction whose steps stay within the bound is left alone
    assert step(small) <= bound and np.abs(small - generated).max() > 1e-3
    np.testing.assert_array_equal(guard(small, 12), small)
    np.testing.assert_array_equal(guard(locked, 0), locked)  # 0: off
    angle = lambda q: np.degrees(2 * np.arccos(np.clip(np.abs(q[:, 2, 0]), 0.0, 1.0)))  # noqa: E731  the knee's turn
    # rounds of cuts leave no steep edge: the correction (60 degrees at the knee) changes by at most an eighth
    # (1 / (2 spread + 2)) per frame (the weight's slope limit: test_slope_limited_...)
    assert np.abs(np.diff(angle(out))).max() <= 60.0 / 8 + 0.5


def test_slope_limited_is_the_largest_sequence_below_with_that_slope():
    weight = jnp.asarray([1.0, 1.0, 1.0, 1.0, 0.0, 1.0, 1.0, 0.9, 1.0, 1.0])
    out = np.asarray(foot_speed.slope_limited(weight, 0.25, 4))
    np.testing.assert_allclose(out, [1.0, 0.75, 0.5, 0.25, 0.0, 0.25, 0.5, 0.75, 1.0, 1.0], atol=1e-6)
    assert np.all(out <= np.asarray(weight)) and np.abs(np.diff(out)).max() <= 0.25 + 1e-6
    smooth = jnp.linspace(0.0, 1.0, 9)[:, None] * jnp.ones((1, 2))  # already within the slope: unchanged
    np.testing.assert_array_equal(foot_speed.slope_limited(smooth, 0.25, 4), smooth)


def test_shared_scores_join_close_samples_only():
    ankle = jnp.zeros((4, 5, 3)).at[2].add(100.0).at[3].add(0.5)  # 0, 1, 3 within 1 cm; 2 a metre away
    score = jnp.arange(20.0).reshape(4, 5)
    shared, stay = foot_spans.shared_scores(score, 2 * score, ankle, 1.0)
    np.testing.assert_allclose(np.asarray(shared)[[0, 1, 3]], np.broadcast_to(np.asarray(score)[[0, 1, 3]].mean(0),
                                                                                (3, 5)), rtol=1e-6)
    np.testing.assert_allclose(np.asarray(shared)[2], np.asarray(score)[2])  # alone: its own
    np.testing.assert_allclose(np.asarray(stay), 2 * np.asarray(shared), rtol=1e-6)
    chain = jnp.zeros((3, 5, 3)).at[1, :, 0].add(0.8).at[2, :, 0].add(1.6)  # 0-1 and 1-2 linked, 0-2 only through 1
    linked, _ = foot_spans.shared_scores(score[:3], score[:3], chain, 1.0)
    assert np.allclose(np.asarray(linked), np.asarray(linked)[0])


def test_close_samples_plant_the_same_frames_distant_ones_their_own():
    """Two samples of one keyframe pair, the same motion, whose predicted contacts differ over frames 10-19:
    alone each plants its own frames; told the sample axis, they plant the same ones. A third sample a metre
    away keeps its own spans."""
    rotations, root, contacts = _transition()
    other = contacts.copy()
    other[10:20] = 0.0
    far_root = root + np.array([100.0, 0.0, 0.0])
    r = jnp.asarray(np.stack([rotations] * 3)[None], jnp.float32)  # (B=1, S=3, T, J, 4)
    p = jnp.asarray(np.stack([root, root, far_root])[None], jnp.float32)
    c = jnp.asarray(np.stack([contacts, other, other])[None], jnp.float32)
    alone = np.asarray(footlock.lock_feet(r, p, c, SKELETON, feet=FEET)["planted"])[0, ..., 0]
    shared = np.asarray(footlock.lock_feet(r, p, c, SKELETON, feet=FEET, sample_axis=1)["planted"])[0, ..., 0]
    assert not np.array_equal(alone[0], alone[1])
    assert np.array_equal(shared[0], shared[1]) and shared[0].sum() >= 10
    assert np.array_equal(shared[2], alone[2])
    apart = footlock.FootLockConfig(share_distance=0.0)
    unshared = np.asarray(footlock.lock_feet(r, p, c, SKELETON, feet=FEET, config=apart, sample_axis=1)["planted"])
    assert np.array_equal(unshared[0, ..., 0], alone)
