"""Keyframes from anywhere (issue 12, items 2-3): another take, a placed target, another frame rate,
another scale, extra joints, transition lengths beyond training, and the CLI's up-front checks.

All rollouts use the tiny model's (length 8, 4 candidates), as tests/sample/test_inbetween.py does, so the
sampler compiles once."""
import dataclasses
import subprocess

import numpy as np
import pytest

from stitchjax import rotations as R
from stitchjax.data import bvh, conform, features, bundled
from stitchjax.sample import inbetween, takes, trained_model
from stitchjax import config as config_lib
from stitchjax.skeleton import Skeleton

from bin_scripts import load_cli

LENGTH, SAMPLES = 8, 4


@pytest.fixture(scope="module")
def take():
    return bvh.load(bundled.sample_files(["subject5"])[0])


@pytest.fixture(scope="module")
def model(tiny_run, take):
    """The tiny model, with the training skeleton's offsets a trained run saves (for the units check)."""
    loaded = trained_model.load_model(tiny_run)
    offsets = np.array(take.skeleton.offsets)
    offsets[0] = 0.0
    return dataclasses.replace(loaded, stats={**loaded.stats, "offsets": offsets})


def test_length_beyond_training_is_an_error_naming_both(model, take):
    assert model.trained_max_length == LENGTH
    with pytest.raises(inbetween.InbetweenError, match=r"length 9 is longer than the 8 frames"):
        inbetween.inbetween(model, take[100], take[110], LENGTH + 1, SAMPLES)
    with pytest.raises(inbetween.InbetweenError, match=r"length 19 is longer than the 8 frames.*allow_extrapolation"):
        takes.inbetween_clip(model, take, 100, 120, num_samples=SAMPLES)
    with pytest.raises(inbetween.InbetweenError, match=r"length 30 .* 8 frames"):
        takes.inbetween_takes(model, take, 100, take, 200, 30, SAMPLES)


def test_target_from_another_take_placed_by_offset_and_turn(model, take):
    other = bvh.load(bundled.sample_files(["subject1"])[0])
    samples = takes.inbetween_takes(model, take, 100, other, 50, LENGTH, SAMPLES, seed=0,
                                        offset=(300.0, 0.0, 0.0), turn_degrees=90.0, output="transition",
                                        offset_from="file", allow_fast=True)
    placed = conform.place(other, (300.0, 0.0, 0.0), 90.0, pivot=50)
    want_end = placed[50].global_positions()[0]
    # the placed target: root moved by 300 cm along x, the body turned a quarter about the vertical
    np.testing.assert_allclose(placed.positions[50, 0], other.positions[50, 0] + [300.0, 0.0, 0.0], atol=1e-9)
    heading = R.quat_rotate(placed.rotations[50, 0], np.array([0.0, 1.0, 0.0]))
    before = R.quat_rotate(other.rotations[50, 0], np.array([0.0, 1.0, 0.0]))
    angle = np.degrees(np.arctan2(before[2], before[0]) - np.arctan2(heading[2], heading[0])) % 360
    assert abs(angle - 90.0) < 1e-6
    for s in samples:
        assert s.num_frames == LENGTH + 2
        g = s.global_positions()
        assert np.abs(g[0] - take[100].global_positions()[0]).max() < 1e-4
        assert np.abs(g[-1] - want_end).max() < 1e-4
    appended = takes.inbetween_takes(model, take, 100, other, 50, LENGTH, 1, offset=(300.0, 0.0, 0.0),
                                         turn_degrees=90.0, output="appended", offset_from="file",
                                         allow_fast=True)[0]
    assert appended.num_frames == 100 + LENGTH + 2
    np.testing.assert_allclose(appended.global_positions()[:101], take[:101].global_positions(), atol=1e-9)
    np.testing.assert_allclose(appended.global_positions()[-1], want_end, atol=1e-4)


def test_take_in_metres_is_refused_with_the_ratio_and_the_fix(model, take):
    metres = conform.rescale(take, 0.01)
    with pytest.raises(inbetween.InbetweenError, match=r"0\.01 times as long.*rescale it by 100.*--scale 100"):
        takes.inbetween_clip(model, metres, 100, 100 + LENGTH + 1, num_samples=SAMPLES)
    with pytest.raises(inbetween.InbetweenError, match=r"rescale it by 10 on top of the scale 10 .*--scale 100"):
        takes.conform_take(model, metres, scale=10.0)  # the fix names the whole factor, not the missing part
    fixed = takes.inbetween_takes(model, metres, 100, metres, 100 + LENGTH + 1, None, SAMPLES, scale=100.0,
                                      output="clip")
    g = fixed[0].global_positions()
    want = metres.global_positions()
    assert fixed[0].num_frames == metres.num_frames
    assert np.abs(g[100] - want[100]).max() < 1e-6 and np.abs(g[109] - want[109]).max() < 1e-6  # metres out
    assert np.abs(g[101:109, 0, 1]).max() < 10.0  # generated frames in metres too (hips ~0.9, not ~90)


def test_model_of_z_up_files_takes_a_z_up_take_and_gives_it_back_z_up(model, take):
    """A model trained on Z-up files (in inches): the same request in those terms gives the same motion,
    turned and scaled back; the offset is in the take's axes (Z-up: the LAFAN1 +z offset is the file's -y)."""
    z_model = dataclasses.replace(model, up_axis=(0.0, 0.0, 1.0), unit_scale=2.54)
    z_take = conform.rescale(conform.from_y_up(take, (0.0, 0.0, 1.0)), 1 / 2.54)
    assert np.abs(z_take.global_positions()[100, 13, 2] - take.global_positions()[100, 13, 1] / 2.54) < 1e-9
    kw = dict(length=LENGTH, num_samples=2, turn_degrees=30.0, output="appended", allow_fast=True)
    y_out = takes.inbetween_takes(model, take, 100, take, 300, offset=(0.0, 0.0, 200.0), **kw)
    z_out = takes.inbetween_takes(z_model, z_take, 100, z_take, 300, offset=(0.0, -200 / 2.54, 0.0), **kw)
    for y, z in zip(y_out, z_out):
        back = conform.to_y_up(conform.rescale(z, 2.54), (0.0, 0.0, 1.0)).global_positions()
        np.testing.assert_allclose(back, y.global_positions(), atol=1e-3)  # float32 rollout, ~1e-5 cm apart
        np.testing.assert_allclose(z.positions[:101], z_take.positions[:101], rtol=0, atol=1e-9)


def test_take_at_120_fps_keeps_its_rate_frames_and_keyframes(model, take):
    fast, anchor = conform.resample(take[80:140], 120.0, 20)  # frame 100 of the take -> frame 80 at 120 fps
    assert fast.fps == 120.0 and anchor == 80 and fast.num_frames == 237
    np.testing.assert_array_equal(fast.rotations[80], take.rotations[100])
    a, b = 80, 80 + 4 * (LENGTH + 1)  # 36 frames apart at 120 fps: 0.3 s, 9 frame steps of the model
    assert takes.model_length(model, 120.0, b - a - 1) == LENGTH
    clips = takes.inbetween_clip(model, fast, a, b, num_samples=SAMPLES)
    out = clips[0]
    assert out.fps == 120.0 and out.num_frames == fast.num_frames  # the take's rate and frame count
    keep = np.r_[0:a + 1, b:fast.num_frames]  # every frame but the 35 between the keyframes, as they were
    np.testing.assert_array_equal(out.rotations[keep], fast.rotations[keep])
    np.testing.assert_array_equal(out.positions[keep], fast.positions[keep])
    g = out.global_positions()
    assert np.all(np.isfinite(g)) and np.abs(g[a + 1:b] - fast.global_positions()[a + 1:b]).max() > 1e-3
    # the generated frames move smoothly at 120 fps: no step is longer than the keyframes' whole gap
    steps = np.linalg.norm(np.diff(g[a:b + 1, 0], axis=0), axis=-1)
    assert steps.max() < max(np.linalg.norm(g[b, 0] - g[a, 0]), 1.0)


def test_placed_target_from_the_start_stays_within_the_data_speed_from_the_file_is_refused(model, take):
    """The 300 cm / 40-frame target turned 90 degrees: measured from the start keyframe's root it asks for
    2.2 m/s (under LAFAN1's 99th percentile, 3.31 m/s); from where its file has it, it is refused."""
    model = dataclasses.replace(model, config=config_lib.apply_overrides(model.config, ["train.max_length=40"]))
    other = bvh.load(bundled.sample_files(["subject1"])[0])
    kw = dict(length=40, num_samples=1, offset=(300.0, 0.0, 0.0), turn_degrees=90.0, output="transition")
    limit, _ = takes.root_speed_limit(model)  # a checkpoint without its own: LAFAN1's
    assert limit == takes.LAFAN1_ROOT_SPEED_P99
    out = takes.inbetween_takes(model, take, 100, other, 50, **kw)[0]
    root = out.positions[:, 0]
    assert out.num_frames == 42
    assert np.hypot(*(root[-1] - root[0])[[0, 2]]) == pytest.approx(300.0, abs=1e-6)
    assert takes.required_root_speed(root[0], root[-1], 40, 30.0) == pytest.approx(300.0 * 30 / 41)
    assert 300.0 * 30 / 41 < limit
    from_file = np.hypot(*(other.positions[50, 0] + [300.0, 0.0, 0.0] - take.positions[100, 0])[[0, 2]])
    assert from_file * 30 / 41 > limit  # the same target where its file has it is too far for 40 frames
    with pytest.raises(inbetween.InbetweenError, match=r"m/s .*faster than 3\.31 m/s.*more frames \(length \d+"
                                                          r".*--offset-from start.*--allow-fast"):
        takes.inbetween_takes(model, take, 100, other, 50, offset_from="file", **kw)
    # a limit saved at training time wins over LAFAN1's
    slow = dataclasses.replace(model, stats={**model.stats, "root_speed_p99": 100.0})
    with pytest.raises(inbetween.InbetweenError, match=r"faster than 1\.00 m/s, the 99th percentile of the "
                                                       r"training data"):
        takes.inbetween_takes(slow, take, 100, other, 50, **kw)


def test_root_speed_percentiles_of_windows():
    steps = np.zeros((2, 5, 3))
    steps[:, :, 0] = np.arange(5) * 2.0  # 2 cm per frame along x
    steps[1, :, 1] = np.arange(5) * 7.0  # height changes are not ground speed
    speed = features.root_speed_percentiles(steps, fps=30.0)
    assert speed == pytest.approx({"p50": 60.0, "p99": 60.0, "max": 60.0})


def _with_extra_root(motion):
    """The take under an extra root bone "Root" above Hips (as some LAFAN1-derived files have)."""
    sk = motion.skeleton
    names = ("Root",) + sk.names
    parents = (-1,) + tuple(p + 1 for p in sk.parents)
    offsets = np.concatenate([np.zeros((1, 3)), sk.offsets])
    rot = np.concatenate([np.broadcast_to(R.quat_identity((1,)), (motion.num_frames, 1, 4)), motion.rotations], 1)
    lift = np.array([0.0, 5.0, 0.0])  # the root bone sits 5 cm below, the hips keep their world position
    pos = np.concatenate([motion.positions[:, :1] - lift, motion.positions], 1)
    pos[:, 1] = lift
    offsets[1] = lift
    return bvh.Motion(rot, pos, Skeleton(names, parents, offsets), motion.fps)


def test_extra_joints_are_mapped_by_name_and_missing_ones_named(model, take):
    extra = _with_extra_root(take[90:120])
    np.testing.assert_allclose(extra.global_positions()[:, 1:], take[90:120].global_positions(), atol=1e-9)
    out = takes.inbetween_clip(model, extra, 10, 10 + LENGTH + 1, num_samples=SAMPLES)[0]
    assert out.skeleton.names == take.skeleton.names  # written on the model's skeleton
    np.testing.assert_allclose(out.global_positions()[[10, 19]], take[[100, 109]].global_positions(), atol=1e-4)
    sk = take.skeleton
    renamed = Skeleton(sk.names[:13] + ("Skull",) + sk.names[14:], sk.parents, sk.offsets)
    with pytest.raises(inbetween.InbetweenError, match=r"lacks joint Head .*has Skull instead"):
        takes.inbetween_clip(model, dataclasses.replace(take, skeleton=renamed), 100, 109, num_samples=SAMPLES)


def _cli_here(capsys, *args):
    """bin/inbetween's main() in this process (no interpreter or jax start-up): (exit status, stderr)."""
    module = load_cli("inbetween")
    try:
        code = module.main([str(a) for a in args])
    except SystemExit as exit_:  # argparse's own errors
        code = exit_.code
    return subprocess.CompletedProcess(args, code, "", capsys.readouterr().err)


def test_cli_refuses_out_on_a_file_long_lengths_and_bad_target_flags(tiny_run, tmp_path, capsys):
    source = bundled.sample_files(["subject5"])[0]
    existing = tmp_path / "existing.txt"
    existing.write_text("keep me")
    base = ["--checkpoint", tiny_run, "--bvh", source, "--start-frame", 100]
    result = _cli_here(capsys, *base, "--end-frame", 109, "--out", existing)
    assert result.returncode == 2 and "--out" in result.stderr and "is a file" in result.stderr
    assert result.stderr.strip().count("\n") == 0 and existing.read_text() == "keep me"
    result = _cli_here(capsys, *base, "--end-frame", 130, "--out", tmp_path / "o")
    assert result.returncode == 2 and "length 29 is longer than the 8 frames" in result.stderr
    assert "--allow-extrapolation" in result.stderr and not (tmp_path / "o").exists()
    result = _cli_here(capsys, *base, "--target-bvh", source, "--out", tmp_path / "o")
    assert result.returncode == 2 and "--target-frame" in result.stderr
    result = _cli_here(capsys, *base, "--target-bvh", source, "--target-frame", 50, "--out", tmp_path / "o")
    assert result.returncode == 2 and "--length" in result.stderr
    result = _cli_here(capsys, *base, "--target-bvh", source, "--target-frame", 50, "--length", 8,
                       "--target-offset", "3,x",
                       "--out", tmp_path / "o")
    assert result.returncode == 2 and "--target-offset" in result.stderr


def test_cli_target_from_another_take_with_offset_and_turn(tiny_run, tmp_path, capsys):
    source = bundled.sample_files(["subject5"])[0]
    other = bundled.sample_files(["subject1"])[0]
    result = _cli_here(capsys, "--checkpoint", tiny_run, "--bvh", source, "--start-frame", 100, "--target-bvh",
                       other, "--target-frame", 50, "--length", LENGTH, "--target-offset", "300,0,0", "--target-turn",
                       90, "--offset-from", "file", "--allow-fast",
                       "--samples", SAMPLES, "--output", "transition", "--out", tmp_path)
    assert result.returncode == 0, result.stderr
    files = sorted(tmp_path.glob("*.bvh"))
    assert len(files) == SAMPLES
    want = conform.place(bvh.load(other), (300.0, 0.0, 0.0), 90.0, pivot=50)[50].global_positions()[0]
    for path in files:
        g = bvh.load(path).global_positions()
        assert g.shape[0] == LENGTH + 2 and np.abs(g[-1] - want).max() < 1e-3


def test_cli_negative_offsets_parse_and_a_too_fast_target_is_refused(tiny_run, tmp_path, capsys):
    module = load_cli("inbetween")
    argv = ["--checkpoint", "c", "--bvh", "b", "--start-frame", "1", "--target-bvh", "t", "--target-frame", "2",
            "--target-offset", "-89.3,0,728.2", "--out", "o"]
    args = module.build_parser().parse_args(module._join_negative_values(argv))
    assert module._parse_offset(args.target_offset) == [-89.3, 0.0, 728.2] and args.offset_from == "start"
    source = bundled.sample_files(["subject5"])[0]
    other = bundled.sample_files(["subject1"])[0]
    base = ["--checkpoint", tiny_run, "--bvh", source, "--start-frame", 100, "--target-bvh", other,
            "--target-frame", 50, "--length", LENGTH, "--out", tmp_path / "o"]
    result = _cli_here(capsys, *base, "--target-offset", "-300,0,0", "--offset-from", "file")
    assert result.returncode == 2 and result.stderr.strip().count("\n") == 0
    assert "faster than 3.31 m/s" in result.stderr and "--allow-fast" in result.stderr
    assert not (tmp_path / "o").exists()


TINY_WIDTHS = ["model.encoder_widths=16,16,16", "model.lstm_size=16", "model.latent_dim=4", "model.decoder_widths=16,16",
               "model.gating_widths=8,8", "model.disc_widths=16,16", "phase.hidden_dim=16", "phase.num_layers=1"]


def test_cmu_take_at_120_fps_keeps_its_frame_numbers_rate_and_count(shared_data):
    """Frames 400 and 441 of the 120 fps CMU take: 40 frames between them at 120 fps in the output (9
    generated at the model's 30 fps, resampled back), the take's 2752 frames, every other frame as it was."""
    import jax

    from stitchjax.data import datasets
    from stitchjax import specs
    from stitchjax.train import loop as train

    folder = shared_data / "cmu"
    config = config_lib.apply_overrides(config_lib.load_config("cmu"), TINY_WIDTHS + ["train.max_length=10"])
    state = train.create_train_state(specs.train_spec(config), jax.random.PRNGKey(0))
    model = trained_model.model_from_state(config, state, None, datasets.skeleton_facts(folder, config.data), "test")
    cmu = bvh.load(folder / "01_01.bvh")
    assert cmu.fps == 120.0 and cmu.num_frames == 2752
    assert takes.model_length(model, cmu.fps, 441 - 400 - 1) == 9
    out = takes.inbetween_clip(model, cmu, 400, 441, num_samples=2)
    for motion in out:
        assert motion.fps == 120.0 and motion.num_frames == cmu.num_frames
        keep = np.r_[0:401, 441:cmu.num_frames]  # the keyframes and every frame outside the gap
        np.testing.assert_array_equal(motion.rotations[keep], cmu.rotations[keep])
        np.testing.assert_allclose(motion.positions[keep], cmu.positions[keep], rtol=0, atol=1e-9)  # units x 5.6444 and back
        gap = motion.positions[401:441, 0]
        assert np.all(np.isfinite(gap)) and np.abs(gap - cmu.positions[401:441, 0]).max() > 1e-3  # generated


def test_cli_filmstrip_shows_root_travel_and_names_the_model(tiny_run, tmp_path, capsys, monkeypatch):
    from stitchjax.eval import plots

    calls = []
    original = plots.filmstrip

    def recording(*args, **kwargs):
        calls.append(kwargs)
        return original(*args, **kwargs)

    monkeypatch.setattr(plots, "filmstrip", recording)
    source = bundled.sample_files(["subject5"])[0]
    result = _cli_here(capsys, "--checkpoint", tiny_run, "--bvh", source, "--start-frame", 100, "--end-frame",
                       100 + LENGTH + 1, "--samples", SAMPLES, "--out", tmp_path)
    assert result.returncode == 0, result.stderr
    assert len(calls) == 1 and calls[0]["travel"] is True  # figures where their roots are
    assert f"({tiny_run.name} step 0)" in calls[0]["title"]  # the run's name, not the config's


def test_cli_120_fps_take_written_at_its_rate_with_the_generated_count_stated(tiny_run, take, tmp_path, capsys):
    fast, _ = conform.resample(take[80:140], 120.0, 20)
    source = tmp_path / "fast.bvh"
    bvh.save(source, fast)
    fast = bvh.load(source)  # as written (6 decimals)
    result = _cli_here(capsys, "--checkpoint", tiny_run, "--bvh", source, "--start-frame", 80, "--end-frame", 116,
                       "--samples", 2, "--out", tmp_path / "o")
    assert result.returncode == 0, result.stderr
    assert "the model generates 8 frames at its 30 fps for the 35 frames between the keyframes" in result.stderr
    written = bvh.load(tmp_path / "o" / "fast_sample0.bvh")
    assert written.fps == 120.0 and written.num_frames == fast.num_frames
    g, want = written.global_positions(), fast.global_positions()
    np.testing.assert_allclose(g[[80, 116]], want[[80, 116]], atol=1e-4)  # the keyframes, as the file has them
    np.testing.assert_allclose(g[:80], want[:80], atol=1e-4)
