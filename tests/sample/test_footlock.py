"""Foot locking (stitchjax.sample.footlock: the pass, its plants and its legs) on a one-legged synthetic skeleton:
IK reach and bone lengths, keyframes kept exactly, plants standing on the keyframes' ground, steps to a new plant
instead of a hovering foot, the guard's bounds on joint steps and knee turns, samples sharing their plants."""
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from stitchjax import rotations as R
from stitchjax.eval import metrics
from stitchjax.sample import footlock
from stitchjax.sample.footlock import legs as leg_lib
from stitchjax.sample.footlock import plants
from stitchjax.skeleton import Skeleton, forward_kinematics

NAMES = ("Hips", "LeftUpLeg", "LeftLeg", "LeftFoot", "LeftToe")
PARENTS = (-1, 0, 1, 2, 3)
OFFSETS = np.array([[0, 0, 0], [10, 0, 0], [0, -40, 0], [0, -40, 0], [0, -5, 10]], np.float64)
SKELETON = Skeleton(NAMES, PARENTS, OFFSETS)
FEET = (3, 4)
LEG = metrics.leg_joints(PARENTS, FEET)  # ((hip, knee, ankle, toe),) = ((1, 2, 3, 4),)
BONES = np.linalg.norm(OFFSETS[1:], axis=-1)
FRAMES = 40  # every transition below: one compiled pass serves them all


def _about_x(degrees):
    return np.array([np.cos(np.radians(degrees) / 2), np.sin(np.radians(degrees) / 2), 0, 0])


def _pose(frames, knee_degrees=60.0, step=0.5):
    """(rotations (T, 5, 4), root (T, 3)): the knee bent by knee_degrees (thigh forward, shin back), the
    root moving ``step`` cm per frame along +Z at a height putting the toe on y = 0."""
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


def _local(rotations, root):
    local = np.broadcast_to(OFFSETS, np.shape(rotations)[:-1] + (3,)).copy()
    local[..., 0, :] = root
    return local


def _global_positions(rotations, root):
    return forward_kinematics(np.asarray(rotations, np.float64), _local(rotations, root), PARENTS)[1]


def _contacts(frames, contact=1.0):
    contacts = np.full((frames, 2), contact)
    contacts[0] = contacts[-1] = 0.0  # keyframes not in contact: the foot is planted between them
    return contacts


def _lock(rotations, root, contacts, config=footlock.DEFAULT_CONFIG):
    locked, _, stats = footlock.lock_transitions(rotations, _local(rotations, root), contacts, SKELETON, FEET, config)
    return locked, stats


def _plant_runs(planted):
    """[frames of each run of True in planted (T,)]."""
    ids = np.asarray(plants.span_ids(jnp.asarray(planted)))
    return [np.flatnonzero(ids == k) for k in range(1, ids.max() + 1)]


def _solve(target, knee_degrees=40.0):
    """Two-bone IK of the synthetic leg to ``target``: the new global positions (5, 3)."""
    rotations, root = _pose(1, knee_degrees)
    g_rot, g_pos = forward_kinematics(rotations, _local(rotations, root[:1]), PARENTS)
    g_rot, g_pos = jnp.asarray(g_rot[0], jnp.float32), jnp.asarray(g_pos[0], jnp.float32)
    hip_turn, knee_turn, _, _ = leg_lib.two_bone_ik(g_pos[1], g_pos[2], g_pos[3], jnp.asarray(target, jnp.float32),
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


def _knee_turns(g):
    return np.abs(np.diff(metrics.knee_angles(g, LEG)[..., 0], axis=0))


def _steps(g):
    return np.linalg.norm(np.diff(g, axis=0), axis=-1)


# ------------------------------------------------------------------------------------------ legs


def test_ik_reaches_a_reachable_target_and_keeps_bone_lengths():
    _, before = _solve(np.zeros(3))
    target = np.asarray(before[1]) + np.array([5.0, -60.0, 20.0])  # 64 cm from the hip: reachable (80 cm leg)
    after, before = _solve(target)
    assert np.linalg.norm(after[3] - target) < 1e-3
    np.testing.assert_allclose(_bone_lengths(after), BONES, atol=1e-4)
    # the knee bends the way it bent (towards +Z, its pole), no flip
    assert (after[2, 2] - after[1, 2]) * (np.asarray(before)[2, 2] - np.asarray(before)[1, 2]) > 0


def test_unreachable_target_leaves_the_leg_straight_not_stretched():
    _, before = _solve(np.zeros(3))
    hip = np.asarray(before[1], np.float64)
    target = hip + np.array([0.0, -120.0, 30.0])  # 124 cm away, the leg is 80
    after, _ = _solve(target)
    reach = np.linalg.norm(after[3] - after[1])
    assert 0.98 * 80.0 < reach <= 80.0 + 1e-3
    direction = (target - hip) / np.linalg.norm(target - hip)
    np.testing.assert_allclose((after[3] - after[1]) / reach, direction, atol=1e-3)  # towards the target
    np.testing.assert_allclose(_bone_lengths(after), BONES, atol=1e-4)


def test_pole_hint_bends_a_straight_leg_over_the_toes():
    hip, knee, ankle = jnp.asarray([0.0, 80.0, 0.0]), jnp.asarray([0.0, 40.0, 0.0]), jnp.asarray([0.0, 0.0, 0.0])
    target = jnp.asarray([0.0, 10.0, 0.0])  # 70 cm from the hip: the knee must bend, the straight leg has no plane
    for sign in (1.0, -1.0):
        _, _, new_knee, new_ankle = leg_lib.two_bone_ik(hip, knee, ankle, target, jnp.float32(40.0), jnp.float32(40.0),
                                                        hint=jnp.asarray([0.0, 0.0, 3.0 * sign]))
        assert np.sign(float(new_knee[2])) == sign and float(new_knee[2]) * sign > 10.0
        np.testing.assert_allclose(np.asarray(new_ankle), np.asarray(target), atol=1e-3)


def test_limit_correction_speed_keeps_anchors_and_the_generated_top_speed():
    n = 24
    t = np.arange(n)
    speed = 0.5 + 7.5 * np.sin(np.pi * np.clip(t - 4, 0, 16) / 16) ** 2  # the generated foot speeds up and stops
    ankle = jnp.asarray(np.stack([np.cumsum(speed), np.zeros(n), np.zeros(n)], -1), jnp.float32)
    anchor = jnp.zeros(n, bool).at[:4].set(True).at[-1].set(True)
    offset = jnp.zeros((n, 3)).at[:4, 0].set(-6.0).at[4:12, 0].set(jnp.linspace(-6.0, 4.0, 8))  # a jerky ease
    limited = np.asarray(leg_lib.limit_correction_speed(offset, ankle, anchor, floor=1.0))
    assert np.array_equal(limited[np.asarray(anchor)], np.asarray(offset)[np.asarray(anchor)])
    step = np.linalg.norm(np.diff(np.asarray(ankle), axis=0), axis=-1)
    moved = np.linalg.norm(np.diff(np.asarray(ankle) + limited, axis=0), axis=-1)
    assert np.all(moved <= np.maximum(step.max(), step + 1.0) + 1e-4)
    unlimited = np.linalg.norm(np.diff(np.asarray(ankle + offset), axis=0), axis=-1)
    assert unlimited.max() > step.max() + 1.0  # the ease alone would outrun the foot
    zeros = leg_lib.limit_correction_speed(jnp.zeros((n, 3)), ankle, anchor, floor=1.0)
    assert not np.asarray(zeros).any()  # no correction stays no correction, exactly


def test_limit_knee_speed_bounds_the_solved_knee_angle_change():
    n = 12
    hip = jnp.zeros((n, 3)).at[:, 1].set(80.0)
    ankle = jnp.zeros((n, 3)).at[:, 1].set(80.0 - 60.0)  # the generated knee keeps its angle
    distance = jnp.asarray([60.0] * 4 + [79.0] * 4 + [60.0] * 4)  # the goal snaps the leg straight and back
    goal = hip - distance[:, None] * jnp.asarray([0.0, 1.0, 0.0])
    anchor = jnp.zeros(n, bool).at[0].set(True).at[-1].set(True)
    out = leg_lib.limit_knee_speed(hip, goal, ankle, jnp.float32(40.0), jnp.float32(40.0), anchor, 6.0)
    reach = leg_lib.soft_reach(jnp.linalg.norm(out - hip, axis=-1), jnp.float32(80.0))
    angle = np.degrees(np.asarray(leg_lib.knee_angle(reach, jnp.float32(40.0), jnp.float32(40.0))))
    assert np.abs(np.diff(angle)).max() <= 6.0 + 1e-3
    assert np.array_equal(np.asarray(out)[[0, -1]], np.asarray(goal)[[0, -1]])
    assert angle[7] >= angle[3] + 4 * 6.0 - 1e-3  # it still straightens, as fast as allowed


def test_slope_limited_is_the_largest_sequence_below_with_that_slope():
    weight = jnp.asarray([1.0, 1.0, 1.0, 1.0, 0.0, 1.0, 1.0, 0.9, 1.0, 1.0])
    out = np.asarray(leg_lib.slope_limited(weight, 0.25, 4))
    np.testing.assert_allclose(out, [1.0, 0.75, 0.5, 0.25, 0.0, 0.25, 0.5, 0.75, 1.0, 1.0], atol=1e-6)
    assert np.all(out <= np.asarray(weight)) and np.abs(np.diff(out)).max() <= 0.25 + 1e-6
    smooth = jnp.linspace(0.0, 1.0, 9)[:, None] * jnp.ones((1, 2))  # already within the slope: unchanged
    np.testing.assert_array_equal(leg_lib.slope_limited(smooth, 0.25, 4), smooth)


def _guard(locked, generated, root):
    local = jnp.asarray(_local(generated, root), jnp.float32)
    posed = forward_kinematics(jnp.asarray(generated), local, PARENTS)
    return np.asarray(leg_lib.guard_legs(jnp.asarray(locked), jnp.asarray(generated), posed,
                                         jnp.asarray(OFFSETS, jnp.float32), leg_lib.leg_chains(SKELETON, FEET), PARENTS))


def test_guard_keeps_leg_steps_within_the_generated_largest_step():
    frames = FRAMES
    generated, root = _pose(frames, knee_degrees=40.0, step=1.0)
    root[20:, 2] += 14.0  # the generated transition's longest step: 15 cm, every joint, frame 19 to 20
    generated = generated.astype(np.float32)  # the pass's precision, so frames returned exactly compare equal
    locked = generated.copy()
    locked[10:14, 2] = _about_x(100.0)  # a knee snapped to 100 degrees for four frames: a 20+ cm jump
    step = lambda q: _steps(_global_positions(q, root)).max()  # noqa: E731
    bound = step(generated)
    assert step(locked) > bound + 10.0
    out = _guard(locked, generated, root)
    assert step(out) <= bound + 0.05  # no step longer than the generated transition's longest
    np.testing.assert_array_equal(out[:5], locked[:5])  # frames away from the jump are returned exactly
    np.testing.assert_array_equal(out[-5:], locked[-5:])
    small = generated.copy()
    small[10:14, 2] = _about_x(44.0)  # a correction within both bounds is left alone
    assert step(small) <= bound and np.abs(small - generated).max() > 1e-3
    np.testing.assert_array_equal(_guard(small, generated, root), small)


def test_guard_keeps_knee_turns_within_the_generated_fastest_or_the_floor():
    """A transition whose root jumps 60 cm in one frame and whose knee never turns: a knee turned by 30 degrees in
    one frame elsewhere moves no joint as far as that jump, yet the guard brings every knee turn within its floor."""
    frames = FRAMES
    generated, root = _pose(frames, knee_degrees=40.0, step=1.0)
    root[30:, 2] += 60.0
    generated = generated.astype(np.float32)
    locked = generated.copy()
    locked[8:16, 2] = _about_x(70.0)  # the knee from 40 to 70 degrees and back, one frame each way
    g = _global_positions(locked, root)
    assert _steps(g).max() <= _steps(_global_positions(generated, root)).max() + 1e-3  # no jump to catch ...
    assert _knee_turns(g).max() > 25.0  # ... but a knee snap
    out = _global_positions(_guard(locked, generated, root), root)
    assert _knee_turns(out).max() <= leg_lib.KNEE_FLOOR + 1e-2
    assert (metrics.knee_angles(out, LEG)[8:16, 0] > 45.0).all()  # the knee still bends further there


# ------------------------------------------------------------------------------------------ spans and plants


def test_spans_hysteresis_bridges_and_short_runs():
    score = jnp.asarray([0.0, 0.6, 0.4, 0.3, 0.1, 0.6, 0.0, 0.9, 0.9, 0.9, 0.0])
    on = np.asarray(plants.hysteresis(score, 0.5, 0.25))
    assert on.tolist() == [0, 1, 1, 1, 0, 1, 0, 1, 1, 1, 0]
    kept = np.asarray(plants.drop_short_spans(jnp.asarray(on), 3))
    assert kept.tolist() == [0, 1, 1, 1, 0, 0, 0, 1, 1, 1, 0]
    mask = jnp.asarray([0, 1, 1, 0, 1, 1, 0, 0, 0, 1, 0], bool)
    out = np.asarray(plants.bridge_gaps(mask, 2)).astype(int).tolist()
    assert out == [0, 1, 1, 1, 1, 1, 0, 0, 0, 1, 0]  # the 1-frame gap filled, the 3-frame gap and the ends not


def test_plant_runs_step_where_the_foot_drifts_or_the_hip_carries_it_out_of_reach():
    frames = 30
    spans = jnp.zeros(frames, bool).at[2:28].set(True)
    skate = jnp.zeros((frames, 3)).at[:, 2].set(1.5 * jnp.arange(frames)).at[:, 1].set(jnp.arange(frames))
    hip = skate.at[:, 1].add(70.0)  # the hip rides along: always within reach
    runs = np.asarray(plants.plant_runs(spans, skate, hip, 80.0, 10.0, 2))
    assert not (runs & ~np.asarray(spans)).any()
    z = np.asarray(skate[:, 2])
    found = _plant_runs(runs)
    assert len(found) == 3
    for k, run in enumerate(found):
        assert z[run].max() - z[run].min() <= 10.0  # each within the distance (horizontally: y rises 1/frame)
        if k:
            assert run[0] - found[k - 1][-1] - 1 == 2  # a step of two frames between plants
    still = jnp.zeros((frames, 3))
    np.testing.assert_array_equal(np.asarray(plants.plant_runs(spans, still, still.at[:, 1].set(70.0), 80.0, 10.0,
                                                               2)), spans)
    t = jnp.arange(frames, dtype=jnp.float32)
    lagging = jnp.zeros((frames, 3)).at[:, 2].set(2.0 * t)  # the foot drags behind a hip walking at 3 cm/frame
    hip = jnp.zeros((frames, 3)).at[:, 1].set(70.0).at[:, 2].set(3.0 * t)
    runs = np.asarray(plants.plant_runs(spans, lagging, hip, 80.0, 100.0, 2))  # drift allowed: only reach counts
    found = _plant_runs(runs)
    assert len(found) >= 2  # replanted where the hip leaves the plant out of reach
    for run in found:
        place = np.asarray(lagging)[run[0]]
        assert np.linalg.norm(np.asarray(hip)[run] - place, axis=-1).max() <= 80.0
        assert np.linalg.norm(np.asarray(hip)[run[-1] + 1] - place) > 80.0 or run[-1] + 1 >= 28  # cut there


def test_plants_hold_the_mean_place_on_the_ground_or_the_keyframes_foot():
    n = 8
    runs = jnp.asarray([0, 0, 1, 1, 1, 1, 0, 0], bool)
    ankle = jnp.stack([jnp.arange(8.0), jnp.full(8, 5.0), jnp.zeros(8)], -1)
    rotation = jnp.zeros((n, 4)).at[:, 0].set(1.0)
    toe = jnp.asarray([0.0, -4.0, 10.0])  # a flat foot: the toe 4 cm below the ankle
    position, _ = plants.plant_targets(runs, ankle, rotation, toe, (8.0, 2.0))
    np.testing.assert_allclose(np.asarray(position[2:6, 0]), 3.5)  # the mean of frames 2-5
    np.testing.assert_allclose(np.asarray(position[2:6, 1]), 8.0)  # raised onto the ground: ankle at 8, toe at 4
    outside = np.array([0, 1, 6, 7])
    np.testing.assert_allclose(np.asarray(position)[outside], np.asarray(ankle)[outside])  # outside: the foot
    down = plants.plant_targets(runs, ankle, rotation, toe, (0.0, -3.0))[0]
    np.testing.assert_allclose(np.asarray(down[2:6, 1]), 1.0)  # lowered until the toe (at -3) stands on its ground
    keyframed = jnp.asarray([1, 1, 1, 0, 0, 0, 1, 1], bool)
    position, _ = plants.plant_targets(keyframed, ankle, rotation, toe, (8.0, 2.0))
    np.testing.assert_array_equal(np.asarray(position[:3]), np.broadcast_to(np.asarray(ankle[0]), (3, 3)))
    np.testing.assert_array_equal(np.asarray(position[6:]), np.broadcast_to(np.asarray(ankle[-1]), (2, 3)))


def test_eased_plants_leave_a_plant_at_rest_and_leave_keyframes_alone():
    n = 16
    anchor = jnp.zeros(n, bool).at[:6].set(True).at[-1].set(True)
    free = jnp.zeros(n, bool).at[0].set(True).at[-1].set(True)  # keyframes plant nothing
    ankle = jnp.stack([3.0 * jnp.arange(n), jnp.zeros(n), jnp.zeros(n)], -1)  # the generated foot skates on
    target = jnp.where(anchor[:, None], jnp.asarray([3.0, 0.0, 0.0]), ankle)  # planted at frame 1's place
    identity = jnp.zeros((n, 4)).at[:, 0].set(1.0)
    offset, _, arc = plants.eased_plants(anchor, free, target, identity, ankle, identity, blend_frames=6)
    foot = np.asarray(ankle + offset)[:, 0]
    assert np.abs(np.diff(foot[1:6])).max() < 1e-5  # held
    assert abs(foot[6] - foot[5]) < 1.0  # the first frame after the plant moves little (the skate: 3 cm/frame)
    assert np.all(np.diff(foot[5:]) >= -1e-5)  # then follows the generated foot, never back
    np.testing.assert_allclose(np.asarray(offset[-1]), 0.0)  # the keyframe takes no correction
    np.testing.assert_allclose(np.asarray(offset[13:]), 0.0, atol=1e-6)  # eased out within 6 frames + 1
    assert float(arc[5]) == 0.0 and float(arc[8]) > 0.0  # a foot leaving its plant rises on an arc


def test_clearance_lift_steps_a_moving_low_foot_and_lifts_a_sunk_one_onto_the_ground():
    n = 30
    keyframe = jnp.zeros(n, bool).at[0].set(True).at[-1].set(True)
    anchor = keyframe.at[:4].set(True)
    moving, still = jnp.full(n, 5.0), jnp.full(n, 0.2)
    lift = np.asarray(plants.clearance_lift(jnp.zeros(n), moving, anchor, keyframe, 4.0))
    assert np.all(lift[np.asarray(anchor)] == 0.0)
    np.testing.assert_allclose(lift[10:20], 4.0)  # lifted to the clearance away from plants and keyframes
    assert lift[-2] < 4.0 and np.abs(np.diff(lift)).max() <= 4.0 * 0.75  # less next to a keyframe, never a jump
    assert not np.asarray(plants.clearance_lift(jnp.zeros(n), still, anchor, keyframe, 4.0)).any()  # at rest: none
    sunk = np.asarray(plants.clearance_lift(jnp.full(n, -6.0), still, anchor, keyframe, 4.0))
    np.testing.assert_allclose(sunk[8:-8], 6.0)  # at rest below the ground: onto it, no higher
    deep = np.asarray(plants.clearance_lift(jnp.full(n, -60.0), still, anchor, keyframe, 4.0))
    np.testing.assert_allclose(deep[8:-8], plants.MAX_LIFT)  # never more than MAX_LIFT
    only_out = np.asarray(plants.clearance_lift(jnp.full(n, -6.0), moving, anchor, keyframe, 0.0))
    np.testing.assert_allclose(only_out[8:-8], 6.0)  # clearance 0: feet are only kept out of the ground


def test_shared_scores_join_close_samples_only():
    ankle = jnp.zeros((4, 5, 3)).at[2].add(100.0).at[3].add(0.5)  # 0, 1, 3 within 1 cm; 2 a metre away
    score = jnp.arange(20.0).reshape(4, 5)
    shared = np.asarray(plants.shared_scores(score, ankle, 1.0))
    np.testing.assert_allclose(shared[[0, 1, 3]], np.broadcast_to(np.asarray(score)[[0, 1, 3]].mean(0), (3, 5)),
                               rtol=1e-6)
    np.testing.assert_allclose(shared[2], np.asarray(score)[2])  # alone: its own
    chain = jnp.zeros((3, 5, 3)).at[1, :, 0].add(0.8).at[2, :, 0].add(1.6)  # 0-1 and 1-2 linked, 0-2 only through 1
    linked = np.asarray(plants.shared_scores(score[:3], chain, 1.0))
    assert np.allclose(linked, linked[0])


# ------------------------------------------------------------------------------------------ the pass


def test_planted_foot_does_not_move_and_keyframes_are_bit_identical():
    frames = FRAMES
    rotations, root = _pose(frames)
    contacts = _contacts(frames)
    out = footlock.lock_feet(jnp.asarray(rotations, jnp.float32), jnp.asarray(root, jnp.float32),
                             jnp.asarray(contacts, jnp.float32), SKELETON, feet=FEET)
    planted = np.asarray(out["planted"][:, 0])
    assert planted.sum() >= 10  # the sliding foot was planted
    new = np.asarray(out["rotations"])
    for k in (0, -1):
        assert np.array_equal(new[k], np.asarray(rotations[k], np.float32))
    g, before = _global_positions(new, root), _global_positions(rotations, root)
    for run in _plant_runs(planted):
        feet = g[run][:, [3, 4]]  # ankle and toe of every frame of one plant
        assert np.abs(feet - feet[0]).max() < 1e-3
    assert np.abs(np.diff(before[planted][:, 3], axis=0)).max() > 0.4  # it slid before
    np.testing.assert_allclose(_bone_lengths(g), np.broadcast_to(BONES, (frames, 4)), atol=1e-3)
    # float64 numpy path: keyframes and every joint the pass leaves alone keep their bits
    locked, positions, stats = footlock.lock_transitions(rotations, _local(rotations, root), contacts, SKELETON, FEET)
    assert locked.dtype == np.float64 and positions is not None
    assert np.array_equal(locked[[0, -1]], rotations[[0, -1]])
    assert np.array_equal(locked[:, [0, 4]], rotations[:, [0, 4]])
    assert set(stats) == {"planted", "changed", "lifted"} and stats["planted"].shape == (frames, 1)


def test_no_contacts_and_flickers_leave_a_transition_on_the_ground_unchanged():
    frames = FRAMES
    rotations, root = _pose(frames)
    contacts = _contacts(frames, 0.0)
    flicker = contacts.copy()
    flicker[10] = 1.0  # one frame: no span
    batch = jnp.asarray(np.stack([rotations, rotations]), jnp.float32)
    roots = jnp.asarray(np.stack([root, root]), jnp.float32)
    out = jax.jit(lambda r, p, c: footlock.lock_feet(r, p, c, SKELETON, feet=FEET))(
        batch, roots, jnp.asarray(np.stack([contacts, flicker]), jnp.float32))
    assert np.array_equal(np.asarray(out["rotations"]), np.asarray(batch))
    assert np.array_equal(np.asarray(out["root_positions"]), np.asarray(roots))
    assert not np.asarray(out["planted"]).any() and not np.asarray(out["changed"]).any()


def test_planted_feet_stand_on_the_keyframes_ground_not_below_it():
    """The body sinks 4 cm mid-transition while the foot, flat at both keyframes, stands with its toe tipped 20
    degrees down: every planted frame has its lower foot joint exactly on that joint's ground (the keyframes'
    lowest ankle and toe), neither joint below it."""
    frames = FRAMES
    rotations, root = _pose(frames, step=0.1)
    sink = 4.0 * np.sin(np.pi * np.arange(frames) / (frames - 1))
    root[:, 1] -= sink
    tipped = np.clip(sink / 4.0 * 2.0, 0.0, 1.0)  # the toe tips down as the body sinks
    for t in range(1, frames - 1):
        rotations[t, 3] = R.quat_mul(_about_x(20.0 * tipped[t]), rotations[t, 3])
    locked, stats = _lock(rotations, root, _contacts(frames))
    g, before = _global_positions(locked, root), _global_positions(rotations, root)
    ankle_ground, toe_ground = before[[0, -1], 3, 1].min(), before[[0, -1], 4, 1].min()
    planted = stats["planted"][:, 0]
    assert planted.sum() >= 10
    assert before[planted, 4, 1].min() < toe_ground - 3.0  # the generated toe is well below its ground
    above = np.stack([g[planted, 3, 1] - ankle_ground, g[planted, 4, 1] - toe_ground], -1)
    assert above.min() > -0.02  # no planted joint below its ground
    np.testing.assert_allclose(above.min(axis=-1), 0.0, atol=0.05)  # and the lower one on it
    np.testing.assert_array_equal(locked[[0, -1]], rotations[[0, -1]])
    np.testing.assert_allclose(_bone_lengths(g), np.broadcast_to(BONES, (frames, 4)), atol=1e-3)


def test_a_sunk_foot_is_lifted_onto_the_ground():
    frames = FRAMES
    rotations, root = _pose(frames, knee_degrees=60.0, step=0.3)
    root[:, 1] -= 6.0 * np.sin(np.pi * np.arange(frames) / (frames - 1))  # the body sinks 6 cm and comes back
    locked, _ = _lock(rotations, root, np.zeros((frames, 2)))  # no contact predicted: nothing is planted
    toe = _global_positions(locked, root)[:, 4, 1]
    assert _global_positions(rotations, root)[12:18, 4, 1].max() < -4.0  # the generated foot is in the ground
    assert toe.min() > -0.05 and toe.max() < 0.5  # out of it, on the keyframes' ground (y = 0), no higher
    np.testing.assert_array_equal(locked[[0, -1]], rotations[[0, -1]])


def test_a_foot_out_of_reach_is_replanted_with_short_steps_not_held_in_the_air():
    """The hip travels 100 cm at 2.5 cm/frame and the generated foot skates along with it, on the ground, contact
    predicted throughout: no single plant can hold the foot, so it steps from plant to plant, low, and never
    hovers (more than metrics.HOVER_HEIGHT_CM up) in between."""
    frames = FRAMES
    rotations, root = _pose(frames, step=2.5)
    locked, stats = _lock(rotations, root, _contacts(frames))
    g = _global_positions(locked, root)
    ground = min(g[[0, -1], 3, 1].min(), g[[0, -1], 4, 1].min())
    lowest = np.minimum(g[:, 3, 1], g[:, 4, 1]) - ground
    assert lowest.max() <= footlock.MAX_STEP_HEIGHT + 0.5  # steps, never a hover
    assert lowest.max() < metrics.HOVER_HEIGHT_CM
    runs = _plant_runs(stats["planted"][:, 0])
    assert len(runs) >= 4 and stats["planted"].mean() > 0.25  # replanted again and again
    for a, b in zip(runs, runs[1:]):
        assert b[0] - a[-1] - 1 <= footlock.DEFAULT_CONFIG.step_frames + footlock.DEFAULT_CONFIG.blend_frames
    assert np.array_equal(locked[[0, -1]], rotations[[0, -1]])
    np.testing.assert_allclose(_bone_lengths(g), np.broadcast_to(BONES, (frames, 4)), atol=1e-3)


def _swing(frames=40, top_speed=11.5):
    """A foot that stands, swings forward at up to ``top_speed`` + 0.5 cm/frame and stands again."""
    t = np.arange(frames)
    speed = 0.5 + np.where((t > 12) & (t < 28), top_speed * np.sin(np.pi * (t - 12) / 16) ** 2, 0.0)
    rotations, root = _pose(frames, knee_degrees=60.0)
    root[:, 2] = np.concatenate([[0.0], np.cumsum(speed[1:])])
    return rotations, root


def test_the_pass_adds_no_joint_jump_and_no_knee_snap():
    """Stand-swing-stand and random wobbly legs: no joint of the result steps farther in a frame than the generated
    transition's longest step (or the guard's floor), and no knee turns faster than its fastest knee turn (or the
    floor)."""
    rng = np.random.default_rng(0)
    cases = [_swing()]
    for _ in range(6):
        frames = FRAMES
        rotations, root = _pose(frames, knee_degrees=50.0, step=float(rng.uniform(0.5, 6.0)))
        wobble = np.cumsum(rng.normal(0.0, 6.0, (frames, 3)), axis=0)  # degrees, a random walk per joint
        for t in range(1, frames - 1):
            for k, joint in enumerate((1, 2, 3)):
                rotations[t, joint] = R.quat_mul(rotations[t, joint], _about_x(wobble[t, k]))
        root[:, 1] += rng.uniform(-5.0, 2.0)  # the feet a few cm below or above the keyframes' ground
        root[0, 1] = root[-1, 1] = _pose(1, knee_degrees=50.0)[1][0, 1]
        cases.append((rotations, root))
    for rotations, root in cases:
        frames = len(rotations)
        locked, stats = _lock(rotations, root, _contacts(frames))
        g, before = _global_positions(locked, root), _global_positions(rotations, root)
        assert _steps(g).max() <= max(_steps(before).max(), leg_lib.JUMP_FLOOR) + 0.01
        assert _knee_turns(g).max() <= max(_knee_turns(before).max(), leg_lib.KNEE_FLOOR) + 0.01
        assert np.array_equal(locked[[0, -1]], rotations[[0, -1]])
        np.testing.assert_allclose(_bone_lengths(g), np.broadcast_to(BONES, (frames, 4)), atol=1e-3)
    swing, _ = _lock(*cases[0], _contacts(40))
    planted = footlock.lock_transitions(*cases[0][:1], _local(*cases[0]), _contacts(40), SKELETON, FEET)[2][
        "planted"][:, 0]
    starts = np.flatnonzero(np.diff(planted.astype(int)) == 1)
    assert len(starts) == 2 and planted.sum() >= 16  # both plants still held, 8 frames or more each
    assert np.abs(swing - cases[0][0]).max() > 1e-3


def test_close_samples_plant_the_same_frames_distant_ones_their_own():
    """Two samples of one keyframe pair, the same motion, whose predicted contacts differ over frames 10-19:
    alone each plants its own frames; told the sample axis, they plant the same ones. A third sample a metre
    away keeps its own spans."""
    frames = FRAMES
    rotations, root = _pose(frames)
    contacts = _contacts(frames)
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


def test_settings_are_checked_and_other_settings_change_the_result():
    for bad in ({"height": 0.0}, {"speed": -1.0}, {"replant_distance": 0.0}, {"step_frames": 0},
                {"blend_frames": -1}, {"clearance": -1.0}, {"up_axis": 3}):
        with pytest.raises(ValueError, match="foot lock"):
            footlock.FootLockConfig(**bad)
    frames = FRAMES
    rotations, root = _pose(frames, step=2.5)
    near, _ = _lock(rotations, root, _contacts(frames), footlock.FootLockConfig(replant_distance=5.0))
    far, _ = _lock(rotations, root, _contacts(frames), footlock.FootLockConfig(replant_distance=20.0))
    assert np.abs(near - far).max() > 1e-3


def test_before_after_figure(tmp_path):
    from stitchjax.eval import plots

    frames = FRAMES
    rotations, root = _pose(frames)
    locked, stats = _lock(rotations, root, _contacts(frames))
    before, after = _global_positions(rotations, root), _global_positions(locked, root)
    fig = plots.foot_lock_before_after(before, after, stats["planted"], FEET, leg_names=("left",), dpi=50,
                                       path=tmp_path / "f.png")
    assert tuple(np.round(fig.get_size_inches() * fig.dpi)) == (400, 230)
    assert (tmp_path / "f.png").read_bytes()[:4] == b"\x89PNG"
    with pytest.raises(ValueError, match="planted must be"):
        plots.foot_lock_before_after(before, after, stats["planted"][:5], FEET)
