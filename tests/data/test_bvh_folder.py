"""The generic BVH-folder dataset (issue 12, item 1): declared / inferred feet and axes, resampling on
load, units checked against the training skeleton, and bin/train on the CMU file."""
import dataclasses
import json

import numpy as np
import pytest

from stitchjax import rotations
from stitchjax.data import bvh, bvh_folder, conform, bundled
from stitchjax.sample import inbetween, takes, trained_model
from stitchjax import config as config_lib
from stitchjax.skeleton import forward_kinematics

from bin_scripts import load_cli


def _data(**fields):
    base = config_lib.load_config("cmu").data
    return dataclasses.replace(base, **{"feet": (), "up_axis": "", "unit_scale": 0.0, "window": 12, "offset": 8,
                                        **fields})


@pytest.fixture(scope="module")
def lafan_slice():
    return bvh.load(bundled.sample_files(["subject1"])[0])[:120]


@pytest.fixture()
def cmu_folder(shared_data, tmp_path):
    folder = tmp_path / "cmu"
    folder.mkdir()
    (folder / "01_01.bvh").symlink_to(shared_data / "cmu" / "01_01.bvh")
    return folder


def test_cmu_feet_are_found_by_name_and_contacts_match_a_hand_count(cmu_folder):
    data = _data(unit_scale=5.6444, window=24)
    windows = bvh_folder.load_windows(cmu_folder, data, cache_dir=False)
    names = windows.skeleton.names
    assert [names[j] for j in windows.resolved.feet] == ["LeftFoot", "LeftToeBase", "RightFoot", "RightToeBase"]
    assert windows.resolved.forward == (0.0, 0.0, 1.0) and windows.fps == 30.0
    assert names[3] == "LeftLeg"  # what the LAFAN1 indices (3, 4, 7, 8) would have picked
    # Hand count on the first 8 frames of window 0: the raw take (cm, 30 fps), foot by foot.
    take, _ = bvh_folder.load_take(cmu_folder / "01_01.bvh", data)
    _, g = forward_kinematics(take.rotations[:9], take.positions[:9], take.skeleton.parents)
    hand = np.zeros((8, 4))
    for t in range(8):
        for c, joint in enumerate(("LeftFoot", "LeftToeBase", "RightFoot", "RightToeBase")):
            d = g[t + 1, names.index(joint)] - g[t, names.index(joint)]
            hand[t, c] = float(d @ d < 0.02)
    np.testing.assert_array_equal(windows.contacts[0, :8], hand)
    fraction = windows.contacts.mean(axis=(0, 1))
    assert np.all((fraction > 0.05) & (fraction < 0.95)), fraction  # walking: feet both planted and moving


def test_cmu_units_must_be_declared(cmu_folder):
    with pytest.raises(bvh_folder.BVHFolderError, match=r"cannot tell the files' units.*data.unit_scale"):
        bvh_folder.load_windows(cmu_folder, _data(), cache_dir=False)


def test_lafan1_facts_are_inferred_and_a_metres_file_is_refused(lafan_slice, tmp_path):
    bvh.save(tmp_path / "a_cm.bvh", lafan_slice)
    windows = bvh_folder.load_windows(tmp_path, _data(parents=lafan_slice.skeleton.parents), cache_dir=False)
    assert windows.resolved.feet == (3, 4, 7, 8) and windows.resolved.forward == (0.0, 1.0, 0.0)
    assert windows.resolved.unit_scale == 1.0
    bvh.save(tmp_path / "b_metres.bvh", conform.rescale(lafan_slice, 0.01))
    with pytest.raises(bvh_folder.BVHFolderError, match=r"b_metres\.bvh has bones 0\.01 times as long.*rescale"):
        bvh_folder.load_windows(tmp_path, _data(), cache_dir=False)
    alone = tmp_path / "metres"
    alone.mkdir()
    (tmp_path / "b_metres.bvh").rename(alone / "b_metres.bvh")  # alone, a metres folder is read as metres
    metres = bvh_folder.load_windows(alone, _data(), cache_dir=False)
    assert metres.resolved.unit_scale == 100.0
    np.testing.assert_allclose(metres.positions, windows.positions, atol=1e-3)  # 6 decimals of metres


def test_120_fps_file_is_resampled_on_load(lafan_slice, tmp_path):
    fast, _ = conform.resample(lafan_slice, 120.0, 0)
    for name, motion in (("slow", lafan_slice), ("fast", fast)):
        (tmp_path / name).mkdir()
        bvh.save(tmp_path / name / "take.bvh", motion)
    slow = bvh_folder.load_windows(tmp_path / "slow", _data(), cache_dir=False)
    quick = bvh_folder.load_windows(tmp_path / "fast", _data(), cache_dir=False)
    assert quick.fps == 30.0 and quick.num_windows == slow.num_windows == 14
    np.testing.assert_allclose(quick.positions, slow.positions, atol=1e-3)  # BVH text keeps 6 decimals
    np.testing.assert_array_equal(quick.contacts, slow.contacts)


def test_split_by_patterns_and_missing_feet(lafan_slice, tmp_path):
    for name in ("walk_a.bvh", "walk_b.bvh", "run_test.bvh"):
        bvh.save(tmp_path / name, lafan_slice)
    data = _data(test_files=("*_test.bvh",))
    assert [p.name for p in bvh_folder.split_files(tmp_path, data, "train")] == ["walk_a.bvh", "walk_b.bvh"]
    assert [p.name for p in bvh_folder.split_files(tmp_path, data, "test")] == ["run_test.bvh"]
    with pytest.raises(bvh_folder.BVHFolderError, match="no train files"):
        bvh_folder.split_files(tmp_path, _data(train_files=("nothing*",)), "train")
    with pytest.raises(bvh_folder.BVHFolderError, match=r"data.feet: no joint named 'LeftAnkle'"):
        bvh_folder.resolve(lafan_slice, _data(feet=("LeftAnkle", "LeftToe", "RightFoot", "RightToe")))


CMU_FEET = ["LeftFoot", "LeftToeBase", "RightFoot", "RightToeBase"]


@pytest.fixture(scope="module")
def cmu_run(shared_data, tmp_path_factory):
    """bin/train --config cmu on the CMU file for 2 steps of a tiny model (one run for the tests below)."""
    folder = tmp_path_factory.mktemp("cmu_data")
    (folder / "01_01.bvh").symlink_to(shared_data / "cmu" / "01_01.bvh")
    run = tmp_path_factory.mktemp("cmu_run") / "run"
    tiny = ["model.encoder_widths=16,16,16", "model.lstm_size=16", "model.latent_dim=4", "model.decoder_widths=16,16",
            "model.gating_widths=8,8", "model.disc_widths=16,16", "model.disc_long_window=4", "phase.steps=20",
            "phase.hidden_dim=16", "data.window=12", "train.max_length=8", "train.batch_size=4", "train.log_every=1"]
    # bin/train's main() in this process: the command's own code path without another interpreter and jax start-up
    code = load_cli("train").main(["--config", "cmu", "--workdir", str(run), "--data", str(folder),
                                   "--max-steps", "2", "--no-progress", *tiny])
    assert code == 0
    return run


@pytest.mark.slow
def test_bin_train_on_the_cmu_file_trains_and_checkpoints(cmu_run):
    assert (cmu_run / "checkpoints" / "2").is_dir()
    saved = config_lib.from_dict(json.loads((cmu_run / "checkpoints" / "2" / "config" / "metadata").read_text()))
    assert saved.data.dataset == "bvh_folder" and saved.data.feet[0] == "LeftFoot"
    facts = json.loads((cmu_run / "checkpoints" / "2" / "extras" / "metadata").read_text())["skeleton"]
    assert facts["feet_names"] == CMU_FEET and [facts["joint_names"][j] for j in facts["feet"]] == CMU_FEET
    assert (facts["up_axis"], facts["forward_axis"], facts["unit_scale"]) == ("+y", "+z", 5.6444)


@pytest.mark.slow
def test_cmu_model_samples_a_transition_from_the_cmu_file_ending_on_the_target(cmu_run, shared_data):
    model = trained_model.load_model(cmu_run)
    take = bvh.load(shared_data / "cmu" / "01_01.bvh")  # 120 fps, CMU units (1/0.45 inch)
    assert model.joint_names == take.skeleton.names and model.feet_names == tuple(CMU_FEET)
    assert model.forward_axis == (0.0, 0.0, 1.0) and model.unit_scale == 5.6444
    out = takes.inbetween_takes(model, take, 40, take, 68, num_samples=2, output="transition")
    assert takes.model_length(model, take.fps, 68 - 40 - 1) == 6  # 28 frame steps at 120 fps: 6 frames at 30
    assert [m.num_frames for m in out] == [29, 29] and out[0].fps == 120.0  # resampled back to the file's rate
    for m in out:  # in the file's units again, on the keyframes to float64 rounding
        np.testing.assert_allclose(m.positions[[0, -1]], take.positions[[40, 68]], rtol=0, atol=1e-9)
        np.testing.assert_allclose(m.rotations[[0, -1]], take.rotations[[40, 68]], rtol=0, atol=1e-12)
    # the start keyframe is faced as the training windows were: the root's local +Z (not LAFAN1's +Y) onto +X
    k = takes.to_model_frame(model, take[40:41])
    aligned, _, _, _ = inbetween.align_keyframes(k.rotations, k.positions, k.rotations, k.positions, model.parents,
                                            model.forward_axis)
    forward = rotations.quat_rotate(aligned[0, 0, 0], np.array(model.forward_axis))
    np.testing.assert_allclose(forward / np.linalg.norm(forward[[0, 2]]) * [1, 0, 1], [1, 0, 0], atol=1e-9)
