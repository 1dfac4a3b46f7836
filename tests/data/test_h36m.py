"""Human3.6M exponential-map reading and windows (synthetic file + the shared walking files)."""
import numpy as np
import pytest

from stitchjax.data import h36m
from stitchjax import rotations as R
from stitchjax.skeleton import forward_kinematics
from stitchjax.data.windows import window_starts

SK = h36m.H36M_SKELETON


def bone_lengths(global_positions):
    parents = np.array([max(p, 0) for p in SK.parents])
    return np.linalg.norm(global_positions - global_positions[..., parents, :], axis=-1)


def write_walk(path, frames=120, step_mm=20.0):
    """A synthetic file: legs swinging about the hips' x axis, root moving 20 mm/frame along its
    forward axis (+z) while slowly turning about +y; all joints else still."""
    t = np.arange(frames)
    values = np.zeros((frames, 99))
    values[:, 2] = step_mm  # differential translation in the previous root frame
    values[1:, 4] = 0.01  # differential root rotation: 0.01 rad per frame about y
    swing = 0.4 * np.sin(2 * np.pi * t / 40)
    values[:, 3 + 3 * 1] = swing  # right hip (joint 1) about x
    values[:, 3 + 3 * 6] = -swing  # left hip (joint 6)
    np.savetxt(path, values, delimiter=",", fmt="%.7f")
    return values


def test_skeleton_and_feet():
    assert SK.num_joints == 21
    assert SK.names[0] == "Hips" and SK.parents[0] == -1
    assert [SK.names[j] for j in h36m.H36M_FEET] == ["LeftFoot", "LeftToeBase", "RightFoot",
                                                     "RightToeBase"]
    # cm: thigh bone 44.29 cm (442.894612 mm)
    assert SK.offsets[SK.index("RightLeg"), 1] == pytest.approx(-44.2894612)


def test_synthetic_file_reconstruction(tmp_path):
    (tmp_path / "S9").mkdir()
    path = tmp_path / "S9" / "walking_1.txt"
    write_walk(path)
    rot, pos = h36m.read_file(path)
    assert rot.shape == (60, 21, 4) and pos.shape == (60, 21, 3)  # 50 Hz -> 25 Hz
    _, g = forward_kinematics(rot, pos, SK.parents)
    lengths = bone_lengths(g)
    np.testing.assert_allclose(lengths, np.broadcast_to(lengths[0], lengths.shape), atol=1e-9)
    # Upright: head above hips above feet; ground fitted at y = 0 under the lowest foot joints.
    assert np.all(g[:, SK.index("Head"), 1] > g[:, 0, 1] + 30)
    feet = g[:, list(h36m.H36M_FEET), 1]
    assert abs(feet.min(axis=1).mean()) < 0.5  # plane fitted at 50 Hz, checked at 25 Hz
    # Speed: 20 mm per 50 Hz frame = 4 cm per 25 Hz frame, horizontally (on a circle of turn 0.02/frame).
    step = np.linalg.norm(np.diff(g[:, 0, [0, 2]], axis=0), axis=-1)
    np.testing.assert_allclose(step, 4.0, rtol=1e-3)
    # The root turns about +Y by 0.02 rad per 25 Hz frame and travels along its local +Z.
    fwd = R.quat_rotate(rot[:, 0], np.array([0.0, 0.0, 1.0]))
    vel = np.diff(g[:, 0], axis=0)
    cos = np.sum(fwd[:-1] * vel, -1) / np.linalg.norm(vel, axis=-1)
    assert np.all(cos > 0.99)


def test_load_windows_synthetic_aligned(tmp_path):
    (tmp_path / "S9").mkdir()
    write_walk(tmp_path / "S9" / "walking_1.txt", frames=300)
    w = h36m.test_windows(tmp_path, window=65, offset=40, cache_dir=False)
    assert len(w) == len(window_starts(150, 65, 40)) == 3
    assert w.fps == 25.0 and w.sources[1] == "S9/walking_1.txt:40"
    np.testing.assert_allclose(w.positions[:, :, 0, [0, 2]].mean(axis=1), 0.0, atol=1e-9)
    fwd = R.quat_rotate(w.rotations[:, 9, 0], np.array([0.0, 0.0, 1.0]))
    fwd[:, 1] = 0
    fwd /= np.linalg.norm(fwd, axis=-1, keepdims=True)
    np.testing.assert_allclose(fwd, np.tile([1.0, 0.0, 0.0], (3, 1)), atol=1e-6)


def test_missing_subjects_error(tmp_path):
    with pytest.raises(h36m.H36MNotFoundError, match="does not exist"):
        h36m.load_windows(tmp_path / "nowhere")
    with pytest.raises(h36m.H36MNotFoundError, match="S1, S5"):
        h36m.load_windows(tmp_path)


def test_shared_walking_files(shared_data, tmp_path):
    folder = shared_data / "h36m"
    files = h36m.list_files(folder)
    assert set(files) == {"S1", "S5", "S6", "S7", "S8", "S9", "S11"}
    values = np.loadtxt(files["S1"][0], delimiter=",")
    joints = values[:, 3:].reshape(len(values), 32, 3)
    np.testing.assert_array_equal(joints[:, list(h36m.CONSTANT_JOINTS)], 0.0)  # dropped: never move
    assert np.all(joints[:, list(h36m.KEPT_JOINTS)[1:]].std(axis=0).max(axis=-1) > 1e-4)
    rot, pos = h36m.read_file(files["S1"][0])
    _, g = forward_kinematics(rot, pos, SK.parents)
    lengths = bone_lengths(g)
    np.testing.assert_allclose(lengths, np.broadcast_to(lengths[0], lengths.shape), atol=1e-8)
    feet = g[:, list(h36m.H36M_FEET), 1].min(axis=1)
    assert abs(feet.mean()) < 0.1 and feet.std() < 1.5  # on the ground all along, cm
    assert 80 < g[:, 0, 1].mean() < 100  # hips ~ 90 cm up
    w = h36m.test_windows(folder, cache_dir=tmp_path)
    expected = sum(len(window_starts(len(h36m.read_file(p)[0]), 65, 40))
                   for s in h36m.TEST_SUBJECTS for p in files[s])
    assert len(w) == expected and w.rotations.shape[1:] == (65, 21, 4)
    assert 0.1 < w.contacts.mean() < 0.6
