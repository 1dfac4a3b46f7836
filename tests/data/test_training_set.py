"""The training set with the data.* options: validation split, extra training folders, random starts, mirroring."""
import shutil

import numpy as np
import pytest

from stitchjax.data import bvh, datasets, bundled
from stitchjax import config as C
from stitchjax.skeleton import LAFAN1_JOINTS, LAFAN1_PARENTS, forward_kinematics

from bin_scripts import load_cli

def tiny(*overrides):
    return C.apply_overrides(C.load_config("tiny"), ["data.window=14", "data.offset=10", *overrides])


@pytest.fixture(scope="module")
def sample_copy(tmp_path_factory):
    """A writable copy of the bundled sample (walk4_subject1, obstacles1_subject1, ..., obstacles1_subject5)."""
    folder = tmp_path_factory.mktemp("sample") / "lafan1"
    shutil.copytree(bundled.sample_dir(), folder)
    return folder


def _extra_folder(tmp_path, sample_copy, name):
    """A folder holding one sample take renamed `name` (as an extra clip of that take)."""
    folder = tmp_path / "extra"
    folder.mkdir(exist_ok=True)
    shutil.copy(sample_copy / "dance1_subject2.bvh.gz", folder / f"{name}.bvh.gz")
    return folder


def test_validation_takes_never_train_and_are_cut_as_test_windows(sample_copy):
    config = tiny("data.validation_files=walk4_subject1")
    data, stats = datasets.load_training_data(config.data, sample_copy)
    plain, _ = datasets.load_training_data(tiny().data, sample_copy)
    windows, _ = datasets.validation_windows(sample_copy, config.data)
    assert {s.split(":")[0] for s in windows.sources} == {"walk4_subject1.bvh.gz"}
    assert windows.window_length == 65  # as the test windows
    walk = bvh.load(sample_copy / "walk4_subject1.bvh.gz").num_frames
    assert len(plain["rotations"]) - len(data["rotations"]) == len(range(0, walk - 14, 10))


@pytest.mark.parametrize("name, words", [("obstacles1_subject5", "is a test file"),
                                         ("walk9_subject3", "is not a training file")])
def test_a_validation_take_outside_the_training_files_is_refused(sample_copy, name, words):
    with pytest.raises(ValueError, match=words):
        datasets.load_training_data(tiny(f"data.validation_files={name}").data, sample_copy)


def test_bin_train_refuses_a_validation_split_overlapping_the_test_files(sample_copy, tmp_path, capsys):
    code = load_cli("train").main(["--config", "tiny", "--workdir", str(tmp_path / "run"), "--data", str(sample_copy),
                                   "--no-progress", "data.validation_files=obstacles1_subject5"])
    err = capsys.readouterr().err
    assert code == 2, err
    assert "error: data.validation_files: 'obstacles1_subject5' is a test file" in err


@pytest.mark.parametrize("name, words", [
    ("obstacles1_subject5_walk_filtered", "test take 'obstacles1_subject5'"),
    ("walk4_subject1_walk_filtered", "take 'walk4_subject1', already a file of"),
    ("dance1_subject2_walk_filtered", "validation take 'dance1_subject2'")])
def test_an_extra_file_of_a_test_validation_or_main_take_is_refused(sample_copy, tmp_path, name, words):
    extra = _extra_folder(tmp_path, sample_copy, name)
    config = tiny(f"data.extra_train_dirs={extra}", "data.validation_files=dance1_subject2")
    with pytest.raises(ValueError, match=words):
        datasets.load_training_data(config.data, sample_copy)


def test_extra_clips_train_with_the_main_ones(sample_copy, tmp_path):
    extra = _extra_folder(tmp_path, sample_copy, "walk2_subject2_walk_filtered")
    data, _ = datasets.load_training_data(tiny(f"data.extra_train_dirs={extra}").data, sample_copy)
    plain, _ = datasets.load_training_data(tiny().data, sample_copy)
    dance = bvh.load(sample_copy / "dance1_subject2.bvh.gz").num_frames
    assert len(data["rotations"]) == len(plain["rotations"]) + len(range(0, dance - 14, 10))
    np.testing.assert_array_equal(data["rotations"][:len(plain["rotations"])], plain["rotations"])


def test_a_60fps_take_with_a_root_above_hips_keeps_its_even_frames_with_the_root_folded_in(shared_data):
    path = sorted((shared_data / "lafan1_filtered60").glob("*.bvh"))[0]
    motion = bvh.load(path)
    assert motion.fps == pytest.approx(60.0) and motion.skeleton.names[0] == "SimulationBone"
    conformed = datasets._conformed(motion, C.DataConfig(), LAFAN1_JOINTS, LAFAN1_PARENTS,
                                    bvh.load(shared_data / "lafan1" / "walk4_subject1.bvh").skeleton.offsets, str(path))
    assert conformed.fps == 30.0 and conformed.num_frames == (motion.num_frames + 1) // 2
    assert conformed.skeleton.names == LAFAN1_JOINTS
    grot, gpos = forward_kinematics(motion.rotations[::2], motion.positions[::2], motion.skeleton.parents)
    crot, cpos = forward_kinematics(conformed.rotations, conformed.positions, LAFAN1_PARENTS)
    index = [motion.skeleton.names.index(n) for n in LAFAN1_JOINTS]
    np.testing.assert_allclose(cpos, gpos[:, index], atol=1e-6)  # every joint where the original even frame has it
    np.testing.assert_allclose(np.abs(np.sum(crot * grot[:, index], axis=-1)), 1.0, atol=1e-9)


def test_mirrored_training_set_is_twice_as_large_with_mirrored_statistics(sample_copy):
    config = tiny("data.mirror=true")
    data, stats = datasets.load_training_data(config.data, sample_copy)
    plain, _ = datasets.load_training_data(tiny().data, sample_copy)
    n = len(plain["rotations"])
    assert len(data["rotations"]) == 2 * n
    np.testing.assert_array_equal(data["rotations"][:n], plain["rotations"])
    from stitchjax.data import mirror

    joint_map = mirror.mirror_joint_map(LAFAN1_JOINTS)
    mirrored = mirror.mirror_arrays(data["rotations"][:n], data["global_positions"][:n], data["contacts"][:n],
                                    joint_map, mirror.mirror_contact_map((3, 4, 7, 8), joint_map))
    np.testing.assert_array_equal(data["rotations"][n:], mirrored[0])
    np.testing.assert_allclose(data["global_positions"][n:], mirrored[1], atol=1e-3)  # FK of the mirror image
    np.testing.assert_array_equal(data["contacts"][n:], mirrored[2])
    mean = stats.mean.reshape(-1, 3)
    np.testing.assert_allclose(mean[:, 2], -mean[joint_map, 2], atol=1e-6)  # the set is its own mirror image
    np.testing.assert_allclose(stats.std.reshape(-1, 3), stats.std.reshape(-1, 3)[joint_map], rtol=1e-6)


def test_random_start_training_set_carries_every_start_and_trains(sample_copy, tmp_path):
    from stitchjax import specs
    from stitchjax.train import loop as train

    config = tiny("data.random_starts=true", "data.mirror=true", "train.max_length=8")
    data, stats = datasets.load_training_data(config.data, sample_copy)
    assert data["rotations"].shape[1] == 14 + 9 and data["facing"].shape == data["rotations"].shape[:2] + (4,)
    frames = sum(bvh.load(p).num_frames for p in sorted(sample_copy.glob("*_subject[1-4].bvh.gz")))
    files = len(list(sample_copy.glob("*_subject[1-4].bvh.gz")))
    assert int(data["start_counts"].sum()) == 2 * (frames - files * 14)  # every start, mirrored too
    summary = train.train(config, tmp_path / "run", max_steps=2, prepared=(data, stats), progress=False)
    assert summary["step"] == 2 and np.isfinite(summary["final"]["loss"])


def test_bin_evaluate_split_validation_scores_the_models_validation_takes(sample_copy, tmp_path, capsys):
    import jax

    from stitchjax import checkpoints, specs
    from stitchjax.train import loop as train

    cli = load_cli("evaluate")
    for split_files, run in (("walk4_subject1", tmp_path / "with_split"), ("", tmp_path / "without")):
        config = C.apply_overrides(C.load_config("tiny"), [f"data.validation_files={split_files}"])
        state = train.create_train_state(specs.train_spec(config), jax.random.PRNGKey(0))
        manager = checkpoints.open_manager(run, async_save=False)
        checkpoints.save(manager, 0, state, C.to_dict(config), {"config_name": "tiny"})
        checkpoints.close(manager)
    out = tmp_path / "validation.json"
    args = ["model", "--data", str(sample_copy), "--split", "validation", "--samples", "1", "--lengths", "5",
            "--noise-scales", "", "--json", str(out)]
    assert cli.main(["model", "--checkpoint", str(tmp_path / "with_split"), *args[1:]]) == 0
    import json

    results = json.loads(out.read_text())
    windows, _ = datasets.validation_windows(sample_copy, tiny("data.validation_files=walk4_subject1").data)
    assert results["split"] == "validation" and results["n_windows"] == windows.num_windows
    assert cli.main(["model", "--checkpoint", str(tmp_path / "without"), *args[1:]]) == 2
    assert "has no data.validation_files" in capsys.readouterr().err
