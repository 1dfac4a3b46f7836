"""Window arithmetic, foot contacts, centring + facing alignment and time reversal (synthetic data)."""
import numpy as np
import pytest

from stitchjax import rotations as R
from stitchjax.skeleton import (LAFAN1_FEET, LAFAN1_PARENTS, forward_kinematics, inverse_kinematics,
                                lafan1_skeleton)
from stitchjax.data.windows import (Windows, center_and_face, center_and_face_global, clip_moments, clip_windows,
                               clips_statistics, concatenate_clips, foot_contacts, window_indices, window_starts,
                               window_statistics)

J = len(LAFAN1_PARENTS)


def random_motion(rng, shape, joints=J):
    """Random local rotations (shape + (J, 4)) and positions with a wandering root (cm)."""
    rot = R.quat_normalize(rng.normal(size=shape + (joints, 4)))
    pos = np.broadcast_to(rng.normal(scale=20.0, size=(joints, 3)), shape + (joints, 3)).copy()
    pos[..., 0, :] = rng.normal(scale=100.0, size=shape + (3,))
    return rot, pos


@pytest.mark.parametrize("frames, window, offset", [
    (50, 50, 20), (51, 50, 20), (70, 50, 20), (71, 50, 20), (72, 50, 20), (4918, 50, 20),
    (5391, 65, 40), (105, 65, 40), (106, 65, 40), (10, 50, 20), (0, 5, 1)])
def test_window_starts_match_formula(frames, window, offset):
    starts = window_starts(frames, window, offset)
    expected = (frames - window - 1) // offset + 1 if frames > window else 0
    assert len(starts) == expected
    # Brute force of the official loop: i = 0; while i + window < T: ...; i += offset.
    brute, i = [], 0
    while i + window < frames:
        brute.append(i)
        i += offset
    np.testing.assert_array_equal(starts, brute)
    if len(starts):
        assert starts[-1] + window < frames  # strict: the last frame of the file is never used


def test_window_starts_rejects_bad_arguments():
    with pytest.raises(ValueError, match="positive"):
        window_starts(100, 0, 20)


def test_window_indices():
    idx = window_indices(np.array([0, 20]), 3)
    np.testing.assert_array_equal(idx, [[0, 1, 2], [20, 21, 22]])


def test_foot_contacts_stationary_foot():
    t = 12
    pos = np.zeros((t, J, 3))
    pos[:, 3] = [5.0, 0.0, 0.0]  # LeftFoot still for the whole clip
    pos[:, 4, 0] = np.arange(t) * 1.0  # LeftToe moves 1 cm per frame: 1 cm² > 0.02
    pos[:, 7, 0] = np.arange(t) * 0.1  # RightFoot moves 0.1 cm per frame: 0.01 cm² < 0.02
    pos[:6, 8, 2] = np.arange(6) * 0.2  # RightToe: 0.04 cm² for frames 0-4, then still from frame 5
    pos[6:, 8, 2] = 1.0
    c = foot_contacts(pos, LAFAN1_FEET)
    assert c.shape == (t, 4)
    assert c.dtype == np.float64
    np.testing.assert_array_equal(c[:, 0], 1.0)
    np.testing.assert_array_equal(c[:, 1], 0.0)
    np.testing.assert_array_equal(c[:, 2], 1.0)
    # |p6 - p5|² = 0, so contact from frame 5 on; frames 0-4 move 0.04 cm² per frame.
    np.testing.assert_array_equal(c[:, 3], [0, 0, 0, 0, 0] + [1] * 7)


def test_foot_contacts_last_frame_repeats_previous():
    pos = np.zeros((2, 5, 4, J, 3))
    pos[..., -1, 3, 1] = 10.0  # only the last step moves: frame t-2 sees it, and t-1 repeats t-2
    c = foot_contacts(pos, LAFAN1_FEET)
    assert c.shape == (2, 5, 4, 4)
    np.testing.assert_array_equal(c[..., :2, 0], 1.0)
    np.testing.assert_array_equal(c[..., 2:, 0], 0.0)


def official_center_and_face(rot, pos, parents, frame=9):
    """The official order written out: centre the root, FK, rotate all globals, IK."""
    pos = pos.copy()
    mean = pos[:, :, 0, ::2].mean(axis=1, keepdims=True)
    pos[:, :, 0, 0] -= mean[..., 0]
    pos[:, :, 0, 2] -= mean[..., 1]
    grot, gpos = forward_kinematics(rot, pos, parents)
    fwd = R.quat_rotate(grot[:, frame:frame + 1, 0:1], np.array([0.0, 1.0, 0.0])) * [1, 0, 1]
    fwd /= np.linalg.norm(fwd, axis=-1, keepdims=True)
    yrot = R.quat_between(np.array([1.0, 0.0, 0.0]), fwd)
    inv = R.quat_conjugate(yrot)
    return inverse_kinematics(R.quat_mul(inv, grot), R.quat_rotate(inv, gpos), parents)


def test_center_and_face_centres_and_faces_plus_x():
    rng = np.random.default_rng(0)
    rot, pos = random_motion(rng, (7, 30))
    rot2, pos2 = center_and_face(rot, pos, LAFAN1_PARENTS, frame=9)
    grot, gpos = forward_kinematics(rot2, pos2, LAFAN1_PARENTS)
    np.testing.assert_allclose(pos2[:, :, 0, [0, 2]].mean(axis=1), 0.0, atol=1e-9)
    fwd = R.quat_rotate(grot[:, 9, 0], np.array([0.0, 1.0, 0.0]))
    fwd[:, 1] = 0
    fwd /= np.linalg.norm(fwd, axis=-1, keepdims=True)
    np.testing.assert_allclose(fwd, np.tile([1.0, 0.0, 0.0], (7, 1)), atol=1e-6)
    # Heights are untouched and the pose itself (relative to the root) is unchanged.
    np.testing.assert_allclose(pos2[..., 0, 1], pos[..., 0, 1])
    np.testing.assert_array_equal(rot2[..., 1:, :], rot[..., 1:, :])
    np.testing.assert_array_equal(pos2[..., 1:, :], pos[..., 1:, :])
    # The window's own shape is preserved: pairwise joint distances are the same.
    _, graw = forward_kinematics(rot, pos, LAFAN1_PARENTS)
    d_raw = np.linalg.norm(graw[:, :, :, None] - graw[:, :, None], axis=-1)
    d_new = np.linalg.norm(gpos[:, :, :, None] - gpos[:, :, None], axis=-1)
    np.testing.assert_allclose(d_new, d_raw, atol=1e-9)


def test_center_and_face_equals_official_fk_rotate_ik():
    rng = np.random.default_rng(1)
    rot, pos = random_motion(rng, (5, 20))
    rot2, pos2 = center_and_face(rot, pos, LAFAN1_PARENTS)
    rot_ref, pos_ref = official_center_and_face(rot, pos, LAFAN1_PARENTS)
    np.testing.assert_allclose(rot2, rot_ref, atol=1e-12)
    np.testing.assert_allclose(pos2, pos_ref, atol=1e-10)
    # IK/FK consistency of the aligned windows, and the FK-free global positions agree with FK.
    grot, gpos = forward_kinematics(rot2, pos2, LAFAN1_PARENTS)
    lrot, lpos = inverse_kinematics(grot, gpos, LAFAN1_PARENTS)
    np.testing.assert_allclose(lrot, rot2, atol=1e-12)
    np.testing.assert_allclose(lpos, pos2, atol=1e-10)
    _, graw = forward_kinematics(rot, pos, LAFAN1_PARENTS)
    np.testing.assert_allclose(center_and_face_global(graw, pos[..., 0, :], rot[..., 0, :]), gpos,
                               atol=1e-10)


def test_center_and_face_facing_opposite_plus_x():
    # Root's local +Y pointing along -X at frame 9: the half turn about +Y, not a degenerate quaternion.
    rot = np.zeros((1, 12, J, 4))
    rot[..., 0] = 1.0
    rot[:, :, 0] = R.quat_from_axis_angle(np.array([0.0, 0.0, 1.0]), np.array(np.pi / 2))
    pos = np.zeros((1, 12, J, 3))
    pos[..., 1:, 1] = 10.0
    rot2, pos2 = center_and_face(rot, pos, LAFAN1_PARENTS)
    fwd = R.quat_rotate(rot2[0, 9, 0], np.array([0.0, 1.0, 0.0]))
    np.testing.assert_allclose(fwd, [1.0, 0.0, 0.0], atol=1e-9)
    assert np.all(np.isfinite(rot2))


def make_windows(rng, n=3, t=8):
    rot, pos = random_motion(rng, (n, t))
    contacts = (rng.random((n, t, 4)) < 0.5).astype(float)
    skeleton = lafan1_skeleton(pos[0, 0])
    return Windows(rot, pos, contacts, skeleton, 30.0, [f"clip:{i}" for i in range(n)])


def test_reversed_twice_is_identity_and_reverses_time():
    w = make_windows(np.random.default_rng(2))
    r = w.reversed()
    np.testing.assert_array_equal(r.rotations[:, 0], w.rotations[:, -1])
    np.testing.assert_array_equal(r.contacts[:, 0], w.contacts[:, -1])
    np.testing.assert_array_equal(r.global_positions()[:, 0], w.global_positions()[:, -1])
    rr = r.reversed()
    for name in ("rotations", "positions", "contacts"):
        np.testing.assert_array_equal(getattr(rr, name), getattr(w, name))
    assert rr.sources == w.sources


def test_windows_indexing_and_validation():
    w = make_windows(np.random.default_rng(3), n=4)
    sub = w[[1, 3]]
    assert len(sub) == 2 and sub.sources == ["clip:1", "clip:3"]
    np.testing.assert_array_equal(sub.positions, w.positions[[1, 3]])
    assert len(w[2]) == 1
    with pytest.raises(ValueError, match="sources"):
        Windows(w.rotations, w.positions, w.contacts, w.skeleton, 30.0, ["a"])


def test_window_statistics_match_direct_computation():
    w = make_windows(np.random.default_rng(4), n=5, t=6)
    stats = window_statistics(w)
    g = w.global_positions().reshape(-1, J * 3)
    np.testing.assert_allclose(stats.mean, g.mean(axis=0), rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(stats.std, g.std(axis=0), rtol=1e-12)
    np.testing.assert_array_equal(stats.offsets[1:], w.positions[0, 0, 1:])
    np.testing.assert_array_equal(stats.offsets[0], 0.0)


def test_clip_windows_and_their_statistics_agree_with_the_window_functions():
    rng = np.random.default_rng(5)
    clips = [random_motion(rng, (t,)) for t in (30, 12, 41)]  # the 12-frame clip has no 12-frame window
    cut = [clip_windows(rot, pos, LAFAN1_PARENTS, 12, 8, LAFAN1_FEET, frame=3) for rot, pos in clips]
    assert [len(c["starts"]) for c in cut] == [3, 0, 4]
    assert cut[1]["rotations"].shape == (0, 12, J, 4) and cut[1]["contacts"].shape == (0, 12, len(LAFAN1_FEET))
    rot, pos = clips[2]
    idx = window_indices(window_starts(41, 12, 8), 12)
    expected = center_and_face(rot[idx], pos[idx], LAFAN1_PARENTS, 3)
    np.testing.assert_array_equal(cut[2]["rotations"], expected[0])
    np.testing.assert_array_equal(cut[2]["positions"], expected[1])
    np.testing.assert_array_equal(cut[2]["contacts"],
                                  foot_contacts(forward_kinematics(rot[idx], pos[idx], LAFAN1_PARENTS)[1], LAFAN1_FEET))
    arrays = concatenate_clips(cut)
    assert arrays["rotations"].shape == (7, 12, J, 4)
    windows = Windows(arrays["rotations"], arrays["positions"], arrays["contacts"], lafan1_skeleton(clips[0][1][0]),
                      30.0, [str(i) for i in range(7)])
    stats = clips_statistics([clip_moments(rot, pos, LAFAN1_PARENTS, 12, 8, frame=3) for rot, pos in clips])
    direct = window_statistics(windows)
    np.testing.assert_allclose(stats.mean, direct.mean, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(stats.std, direct.std, rtol=1e-9)
    np.testing.assert_allclose(stats.offsets, direct.offsets, atol=1e-9)
    with pytest.raises(ValueError, match="no clip"):
        clips_statistics([clip_moments(rot, pos, LAFAN1_PARENTS, 50, 8) for rot, pos in clips])


# ----------------------------------------------------------------------------- random starts, mirroring


def _prepared(rng, frames=70, window=12, offset=5, extra_frames=0):
    """A random clip's (carried) windows as the training arrays, in float64 (no phase labels needed)."""
    from stitchjax.data import features, windows as windows_lib
    from stitchjax.config import DataConfig

    rot, pos = random_motion(rng, (frames,))
    cut = clip_windows(rot, pos, LAFAN1_PARENTS, window, offset, LAFAN1_FEET, frame=3, extra_frames=extra_frames)
    n, t = cut["rotations"].shape[:2]
    windows = Windows(cut["rotations"], cut["positions"], cut["contacts"], lafan1_skeleton(pos[0]), 30.0,
                      [str(i) for i in range(n)])
    data = features.prepare_dataset(windows, None, DataConfig(window=window, offset=offset),
                                    phase_labels=np.zeros((n, t, 8)))
    _, global_positions = forward_kinematics(cut["rotations"], cut["positions"], LAFAN1_PARENTS)
    data.update(rotations=cut["rotations"], root_positions=cut["positions"][:, :, 0],
                global_positions=global_positions)  # float64 for exact comparisons
    data["facing"] = windows_lib.facing_per_frame(cut["rotations"][:, :, 0], turns=cut.get("turns"))
    return rot, pos, cut, data


def test_carried_windows_start_with_the_plain_windows_and_count_every_start():
    rng = np.random.default_rng(11)
    rot, pos, cut, _ = _prepared(rng, frames=70, window=12, offset=5, extra_frames=4)
    plain = clip_windows(rot, pos, LAFAN1_PARENTS, 12, 5, LAFAN1_FEET, frame=3)
    np.testing.assert_array_equal(cut["rotations"][:, :12], plain["rotations"])
    np.testing.assert_array_equal(cut["positions"][:, :12], plain["positions"])
    np.testing.assert_array_equal(cut["contacts"][:, :11], plain["contacts"][:, :11])
    starts = (cut["starts"][:, None] + np.arange(5)[None, :])[np.arange(5)[None, :] < cut["start_counts"][:, None]]
    np.testing.assert_array_equal(np.sort(starts), window_starts(70, 12, 1))  # every start, each once


def test_a_random_start_window_is_the_window_at_that_frame_with_its_keyframes_first_and_last():
    """cut_windows(i, s) equals the benchmark window starting at frame starts[i] + s (centred over it, faced at
    its frame 3): its first frame is that start keyframe and its last frame the frame window - 1 later."""
    from stitchjax.data import features

    rng = np.random.default_rng(12)
    window, offset = 12, 5
    rot, pos, cut, data = _prepared(rng, frames=70, window=window, offset=offset, extra_frames=offset - 1)
    index = np.array([0, 1, 2, len(cut["starts"]) - 1, 3])
    shift = np.minimum(np.array([0, 3, 4, 4, 1]), cut["start_counts"][index] - 1)
    got = features.cut_windows(data, index, shift, window, facing_frame=3)
    begin = cut["starts"][index] + shift
    expected_rot, expected_pos = center_and_face(rot[window_indices(begin, window)], pos[window_indices(begin, window)],
                                                 LAFAN1_PARENTS, 3)
    np.testing.assert_allclose(got["rotations"], expected_rot, atol=1e-9)
    np.testing.assert_allclose(got["root_positions"], expected_pos[:, :, 0], atol=1e-8)
    _, expected_global = forward_kinematics(expected_rot, expected_pos, LAFAN1_PARENTS)
    np.testing.assert_allclose(got["global_positions"], expected_global, atol=1e-8)
    # the keyframes: the window's first and last frames are the clip's frames begin and begin + window - 1
    for k, b in enumerate(begin):
        first, last = expected_rot[k, 0, 1:], expected_rot[k, -1, 1:]
        np.testing.assert_array_equal(first, rot[b, 1:])
        np.testing.assert_array_equal(last, rot[b + window - 1, 1:])
        np.testing.assert_allclose(got["rotations"][k, [0, -1], 1:], rot[[b, b + window - 1], 1:], atol=1e-12)


def test_random_start_batch_draws_every_start_uniformly_on_device():
    import jax
    import jax.numpy as jnp

    from stitchjax.data import features

    rng = np.random.default_rng(13)
    _, _, cut, data = _prepared(rng, frames=40, window=12, offset=5, extra_frames=4)
    data = {k: jnp.asarray(v, jnp.float32) for k, v in data.items()}
    data["start_counts"] = jnp.asarray(cut["start_counts"], jnp.int32)[:, None]
    batch = jax.jit(lambda d, k: features.random_start_batch(d, k, 4000, 12, 3))(data, jax.random.PRNGKey(0))
    assert batch["rotations"].shape == (4000, 12, J, 4) and batch["offsets"].shape == (4000, 1, J, 3)
    assert set(batch) == {"rotations", "root_positions", "contacts", "global_positions", "phase", "offsets"}
    # root rotation at the facing frame faces +X: its forward (local +Y) has no z component
    forward = R.quat_rotate(np.asarray(batch["rotations"][:, 3, 0], np.float64), np.array([0.0, 1.0, 0.0]))
    assert np.abs(forward[:, 2]).max() < 1e-4 and forward[:, 0].min() > 0
    np.testing.assert_allclose(np.mean(np.asarray(batch["root_positions"])[:, :, [0, 2]], axis=1), 0.0, atol=1e-3)


def test_mirroring_twice_gives_the_window_back_bit_for_bit_and_swaps_sides():
    from stitchjax.data import mirror
    from stitchjax.skeleton import LAFAN1_JOINTS

    rng = np.random.default_rng(14)
    rot, pos = random_motion(rng, (3, 9))
    contacts = rng.integers(0, 2, size=(3, 9, 4)).astype(np.float64)
    joint_map = mirror.mirror_joint_map(LAFAN1_JOINTS)
    contact_map = mirror.mirror_contact_map(LAFAN1_FEET, joint_map)
    names = list(LAFAN1_JOINTS)
    assert names[joint_map[names.index("LeftToe")]] == "RightToe"
    assert joint_map[names.index("Spine1")] == names.index("Spine1")
    np.testing.assert_array_equal(contact_map, [2, 3, 0, 1])
    once = mirror.mirror_arrays(rot, pos, contacts, joint_map, contact_map)
    twice = mirror.mirror_arrays(*once, joint_map, contact_map)
    for a, b in zip(twice, (rot, pos, contacts)):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(once[2][..., 0], contacts[..., 2])  # the left foot's contact was the right's
    # the mirror image's FK positions are the original's reflected across z = 0, with the sides swapped
    _, g = forward_kinematics(rot, pos, LAFAN1_PARENTS)
    _, gm = forward_kinematics(once[0], once[1], LAFAN1_PARENTS)
    np.testing.assert_allclose(gm, (g * np.array([1.0, 1.0, -1.0]))[..., joint_map, :], atol=1e-9)


def test_mirroring_refuses_an_asymmetric_skeleton_and_unpaired_names():
    from stitchjax.data import mirror
    from stitchjax.skeleton import LAFAN1_JOINTS

    with pytest.raises(ValueError, match="no twin"):
        mirror.mirror_joint_map(["Hips", "LeftLeg"])
    offsets = np.zeros((J, 3))
    offsets[1:] = [1.0, 2.0, 3.0]  # both legs on the same side
    with pytest.raises(ValueError, match="not left/right symmetric"):
        mirror.check_mirror_symmetry(offsets, mirror.mirror_joint_map(LAFAN1_JOINTS), LAFAN1_JOINTS)
