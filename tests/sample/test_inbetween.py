"""Inference: checkpoint loading, diverse transitions that hit the keyframes, latent-pair search,
frame handling, the evaluation method, bin/inbetween end to end, clear errors.

One tiny freshly initialised model saved as an orbax checkpoint serves every test; all rollouts use
the same (length, candidates, batch) so the whole module compiles the sampler once.
"""
import dataclasses
import subprocess

import jax
import numpy as np
import pytest

from stitchjax import rotations as R
from stitchjax.data import bvh, bundled
from stitchjax.eval import evaluate
from stitchjax.sample import inbetween, latent, takes, trained_model
from stitchjax.skeleton import Skeleton
from stitchjax.data.windows import Windows, foot_contacts

LENGTH = 8  # every rollout below: 8 generated frames ...
CANDIDATES = 4  # ... and 4 candidates per keyframe pair (plain 4 samples, or 2 samples x search 2)
TOL_CM = 1e-4

@pytest.fixture(scope="session")
def model(tiny_run):
    return trained_model.load_model(tiny_run)


@pytest.fixture(scope="session")
def take():
    return bvh.load(bundled.sample_files(["subject5"])[0])


def _global(motion):
    return motion.global_positions()


def test_load_model_from_run_step_folder_and_errors(tiny_run, model, tmp_path):
    assert model.num_joints == 22 and model.joint_names[0] == "Hips"
    again = trained_model.load_model(tiny_run / "checkpoints" / "0")
    for a, b in zip(jax.tree.leaves(model.params), jax.tree.leaves(again.params)):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    with pytest.raises(FileNotFoundError, match="does not exist"):
        trained_model.load_model(tmp_path / "nowhere")
    with pytest.raises(FileNotFoundError, match="no checkpoints"):
        trained_model.load_model(tmp_path)


def test_samples_differ_and_end_exactly_on_the_keyframes(model, take):
    start, target = take[99:101], take[110:112]  # keyframes 100 and 110 (with a neighbour each)
    samples = inbetween.inbetween(model, start, target, LENGTH, num_samples=CANDIDATES, seed=0)
    assert len(samples) == CANDIDATES
    g_start, g_target = _global(take[100])[0], _global(take[110])[0]
    generated = []
    for s in samples:
        assert s.num_frames == LENGTH + 2 and s.skeleton == take.skeleton and s.fps == take.fps
        g = _global(s)
        assert np.all(np.isfinite(g))
        assert np.abs(g[0] - g_start).max() < TOL_CM
        assert np.abs(g[-1] - g_target).max() < TOL_CM
        generated.append(g[1:-1])
    for i in range(CANDIDATES):
        for j in range(i + 1, CANDIDATES):
            assert np.abs(generated[i] - generated[j]).max() > 1e-3, f"samples {i} and {j} are identical"
    # Same seed, same samples; non-root local positions are the take's bone offsets.
    again = inbetween.inbetween(model, start, target, LENGTH, num_samples=CANDIDATES, seed=0)
    np.testing.assert_array_equal(again[2].rotations, samples[2].rotations)
    np.testing.assert_allclose(samples[0].positions[:, 1:], np.broadcast_to(take.positions[100, 1:], (LENGTH + 2, 21, 3)))


def test_noise_scale_and_ramp_reach_the_animator_calls(model, take):
    start, target = take[99:101], take[110:112]
    still = inbetween.inbetween(model, start, target, LENGTH, num_samples=3, seed=0, noise_scale=0.0)
    for s in still[1:]:  # no noise: one motion
        np.testing.assert_array_equal(s.rotations, still[0].rotations)
    plain = inbetween.inbetween(model, start, target, LENGTH, num_samples=3, seed=0)
    ramped = inbetween.inbetween(model, start, target, LENGTH, num_samples=3, seed=0, noise_ramp_steps=2)
    assert np.abs(_global(ramped[0]) - _global(ramped[1])).max() > 1e-3  # still diverse ...
    assert np.abs(_global(ramped[0]) - _global(plain[0])).max() > 1e-3  # ... and not the paper's draw
    clips = takes.inbetween_clip(model, take, 100, 110, length=LENGTH, num_samples=2, noise_scale=0.0)
    np.testing.assert_array_equal(clips[0].rotations, clips[1].rotations)
    with pytest.raises(inbetween.InbetweenError, match="noise_ramp_steps"):
        inbetween.inbetween(model, start, target, LENGTH, num_samples=2, noise_ramp_steps=-1)
    # the noise's correlation: None is 0 (the paper's draw), another value another draw
    same = inbetween.inbetween(model, start, target, LENGTH, num_samples=3, seed=0, noise_correlation=0.0)
    np.testing.assert_array_equal(same[1].rotations, plain[1].rotations)
    clips = takes.inbetween_clip(model, take, 100, 110, length=LENGTH, num_samples=2, noise_correlation=1.0)
    default = takes.inbetween_clip(model, take, 100, 110, length=LENGTH, num_samples=2)
    assert np.abs(_global(clips[1]) - _global(default[1])).max() > 1e-3
    with pytest.raises(inbetween.InbetweenError, match="noise_correlation"):
        inbetween.inbetween(model, start, target, LENGTH, num_samples=2, noise_correlation=1.5)


def test_bfloat16_matmuls_give_nearby_transitions_that_still_end_on_the_keyframes(model, take):
    low = trained_model.with_matmul_dtype(model, "bfloat16")
    assert low.config.model.matmul_dtype == "bfloat16" and model.config.model.matmul_dtype == "float32"
    assert low.params is model.params
    start, target = take[99:101], take[110:112]
    exact = inbetween.inbetween(model, start, target, LENGTH, num_samples=CANDIDATES, seed=0)
    rounded = inbetween.inbetween(low, start, target, LENGTH, num_samples=CANDIDATES, seed=0)
    g_start, g_target = _global(take[100])[0], _global(take[110])[0]
    for a, b in zip(exact, rounded):
        g_a, g_b = _global(a), _global(b)
        assert np.abs(g_b[0] - g_start).max() < TOL_CM and np.abs(g_b[-1] - g_target).max() < TOL_CM
        difference = np.abs(g_b - g_a).max()
        assert 0 < difference < 5.0, difference  # cm: same noise, rounded matmul operands
    with pytest.raises(inbetween.InbetweenError, match="float16"):
        trained_model.with_matmul_dtype(model, "float16")


def test_result_follows_the_keyframes_when_the_world_turns(model, take):
    """Alignment in and out: turning and shifting the input turns and shifts the transitions."""
    turn = R.quat_from_axis_angle(np.array([0.0, 1.0, 0.0]), np.array(2.1))
    shift = np.array([250.0, 0.0, -400.0])
    moved = take[95:115]
    rot, pos = moved.rotations.copy(), moved.positions.copy()
    rot[:, 0] = R.quat_mul(np.broadcast_to(turn, rot[:, 0].shape), rot[:, 0])
    pos[:, 0] = R.quat_rotate(np.broadcast_to(turn, rot[:, 0].shape), pos[:, 0]) + shift
    moved = moved.with_frames(rot, pos)
    a = inbetween.inbetween(model, take[99:101], take[110:112], LENGTH, CANDIDATES, seed=3)
    b = inbetween.inbetween(model, moved[4:6], moved[15:17], LENGTH, CANDIDATES, seed=3)
    expected = R.quat_rotate(np.broadcast_to(turn, _global(a[1]).shape[:-1] + (4,)), _global(a[1])) + shift
    np.testing.assert_allclose(_global(b[1]), expected, atol=0.05)  # cm; float32 model


def test_search_keeps_the_lowest_stitching_losses(model, take):
    keys = dict(start=inbetween.Keyframes(take.rotations[[100]], take.positions[[100]], np.ones((1, 4))),
                target=inbetween.Keyframes(take.rotations[[110]], take.positions[[110]], np.zeros((1, 4))))
    rot_all, pos_all, loss_all = inbetween.transitions_in_frame(model, **keys, length=LENGTH,
                                                                num_samples=CANDIDATES, seed=7)
    rot, pos, loss = inbetween.transitions_in_frame(model, **keys, length=LENGTH, num_samples=2, seed=7,
                                                    sampling=inbetween.Sampling.paper(search=CANDIDATES // 2))
    assert loss_all.shape == (1, CANDIDATES) and loss.shape == (1, 2)
    assert np.all(loss_all > 0) and len(np.unique(loss_all)) == CANDIDATES
    order = np.argsort(loss_all[0])[:2]
    np.testing.assert_allclose(loss[0], loss_all[0, order], rtol=1e-6)
    np.testing.assert_allclose(pos[0], pos_all[0, order], atol=1e-6)
    assert loss[0, 0] <= loss[0, 1] and loss[0, 1] <= np.sort(loss_all[0])[2]


def test_clip_replaces_only_the_frames_between_the_keyframes(model, take):
    clips = takes.inbetween_clip(model, take, 100, 120, length=LENGTH, num_samples=CANDIDATES, seed=1)
    expected_frames = take.num_frames - 19 + LENGTH
    full = _global(take)
    for c in clips:
        assert c.num_frames == expected_frames
        np.testing.assert_array_equal(c.rotations[:101], take.rotations[:101])
        np.testing.assert_array_equal(c.rotations[101 + LENGTH:], take.rotations[120:])
        g = _global(c)
        assert np.abs(g[100] - full[100]).max() < TOL_CM and np.abs(g[101 + LENGTH] - full[120]).max() < TOL_CM


def _one_window(take, first=200):
    frames = take[first:first + 12]
    return Windows(frames.rotations[None], frames.positions[None],
                   foot_contacts(_global(frames)[None], (3, 4, 7, 8)), take.skeleton, take.fps, [f"t:{first}"])


def test_rollout_details_uses_the_given_noise(model, take):
    """The latent-space helpers feed the rollout the noise they are given (same noise, same motion)."""
    start, target, offsets = latent.window_keyframes(model, _one_window(take), 1, LENGTH)
    plain = inbetween.sample_transitions(model, start, target, offsets, LENGTH, CANDIDATES, seed=4)
    window_key = jax.random.split(jax.random.PRNGKey(4), 1)[0]
    shape = latent.noise_shape(model, LENGTH)
    noise = np.stack([jax.random.normal(k, shape) for k in jax.random.split(window_key, CANDIDATES)])[None]
    details = latent.rollout_details(model, start, target, offsets, LENGTH, noise)
    np.testing.assert_allclose(details["global_positions"], plain["global_positions"], atol=1e-3)
    np.testing.assert_allclose(details["stitch_loss"], plain["stitch_loss"], rtol=1e-4)
    assert details["forward"]["mu_blend"].shape[:2] == (1, CANDIDATES)


def test_evaluation_method_shapes(model, take):
    windows = _one_window(take)
    method = evaluate.model_method(model)
    rot, pos = method(windows, 1, LENGTH, CANDIDATES, 11)
    assert rot.shape == (CANDIDATES, 1, LENGTH, 22, 4) and pos.shape == (CANDIDATES, 1, LENGTH, 22, 3)
    assert np.all(np.isfinite(rot)) and np.allclose(np.linalg.norm(rot, axis=-1), 1.0, atol=1e-5)
    with pytest.raises(ValueError, match="outside windows"):
        method(windows, 5, LENGTH, CANDIDATES, 0)


def test_bad_requests_raise_clear_errors(model, take):
    with pytest.raises(inbetween.InbetweenError, match="length"):
        inbetween.inbetween(model, take[100], take[110], 0, 2)
    with pytest.raises(inbetween.InbetweenError, match="num_samples"):
        inbetween.inbetween(model, take[100], take[110], 4, 0)
    with pytest.raises(inbetween.InbetweenError, match="out of range"):
        takes.inbetween_clip(model, take, 100, take.num_frames + 5)
    with pytest.raises(inbetween.InbetweenError, match="after start frame"):
        takes.inbetween_clip(model, take, 120, 100)
    sk = take.skeleton
    renamed = Skeleton(("Root",) + sk.names[1:], sk.parents, sk.offsets)
    with pytest.raises(inbetween.InbetweenError, match="joint names differ"):
        inbetween.inbetween(model, dataclasses.replace(take[100], skeleton=renamed), take[110], 4, 2)
    parents = list(sk.parents)
    parents[13] = 0
    other = Skeleton(sk.names, parents, sk.offsets)
    with pytest.raises(inbetween.InbetweenError, match="skeleton mismatch"):
        inbetween.inbetween(model, dataclasses.replace(take[100], skeleton=other), take[110], 4, 2)


def _cli_here(capsys, *args):
    """bin/inbetween's main() in this process (no interpreter or jax start-up): (exit status, stderr)."""
    from bin_scripts import load_cli

    try:
        code = load_cli("inbetween").main([str(a) for a in args])
    except SystemExit as exit_:  # argparse's own errors
        code = exit_.code
    return subprocess.CompletedProcess(args, code, "", capsys.readouterr().err)


def test_cli_writes_bvh_and_png(tiny_run, take, tmp_path, capsys):
    source = bundled.sample_files(["subject5"])[0]
    result = _cli_here(capsys, "--checkpoint", tiny_run, "--bvh", source, "--start-frame", 100,
                       "--end-frame", 100 + LENGTH + 1, "--samples", CANDIDATES, "--seed", 5, "--out", tmp_path)
    assert result.returncode == 0, result.stderr
    files = sorted(tmp_path.glob("*.bvh"))
    assert len(files) == CANDIDATES
    full = _global(take)
    for path in files:
        written = bvh.load(path)
        assert written.num_frames == take.num_frames and written.fps == take.fps
        assert written.skeleton.names == take.skeleton.names
        g = _global(written)
        assert np.abs(g[100] - full[100]).max() < TOL_CM
        assert np.abs(g[100 + LENGTH + 1] - full[100 + LENGTH + 1]).max() < TOL_CM
        assert np.abs(g[:95] - full[:95]).max() < 1e-3  # frames outside the transition kept
    png = next(tmp_path.glob("*_filmstrip.png"))
    assert png.stat().st_size > 1000 and png.read_bytes()[:4] == b"\x89PNG"


def test_cli_errors_are_one_line(tiny_run, tmp_path, capsys):
    source = bundled.sample_files(["subject5"])[0]
    result = _cli_here(capsys, "--checkpoint", tiny_run, "--bvh", source, "--start-frame", 100, "--end-frame", 99999,
                       "--out", tmp_path)
    assert result.returncode == 2
    assert result.stderr.strip().count("\n") == 0 and "out of range" in result.stderr
    result = _cli_here(capsys, "--checkpoint", tmp_path / "missing", "--bvh", source, "--start-frame", 1,
                       "--end-frame", 9, "--out", tmp_path)
    assert result.returncode == 2 and "does not exist" in result.stderr
    result = _cli_here(capsys, "--checkpoint", tiny_run, "--bvh", source, "--start-frame", 100, "--end-frame", 109,
                       "--noise-ramp", -1, "--out", tmp_path)
    assert result.returncode == 2 and "--noise-ramp -1" in result.stderr
    result = _cli_here(capsys, "--checkpoint", tiny_run, "--bvh", source, "--start-frame", 100, "--end-frame", 109,
                       "--noise-correlation", 2, "--out", tmp_path)
    assert result.returncode == 2 and "--noise-correlation 2" in result.stderr


def test_foot_lock_moves_only_the_legs_and_keeps_the_keyframes(model, take):
    from stitchjax.sample import footlock

    start, target = take[150:152], take[159:161]  # a pair whose untrained transitions hold plants
    plain = inbetween.inbetween(model, start, target, LENGTH, num_samples=CANDIDATES, seed=0, foot_lock=False)
    eager = footlock.FootLockConfig(speed=50.0, height=50.0)
    locked = inbetween.inbetween(model, start, target, LENGTH, num_samples=CANDIDATES, seed=0, foot_lock=eager)
    legs = [1, 2, 3, 5, 6, 7]  # hips, knees and ankles of both legs
    others = [j for j in range(22) if j not in legs]
    moved = 0
    for a, b in zip(plain, locked):
        np.testing.assert_array_equal(a.positions, b.positions)
        np.testing.assert_array_equal(a.rotations[:, others], b.rotations[:, others])
        np.testing.assert_array_equal(a.rotations[[0, -1]], b.rotations[[0, -1]])
        moved += int(np.abs(a.rotations - b.rotations).max() > 1e-6)
    assert moved > 0
    method = evaluate.model_method(model, foot_lock=eager)
    method(_one_window(take), 1, LENGTH, CANDIDATES, 11)
    counts = method.foot_lock_counts
    assert counts["leg_frames"] == CANDIDATES * LENGTH * 2 and 0 < counts["changed"] <= counts["leg_frames"]


def test_foot_lock_is_on_by_default_in_the_api_and_foot_lock_false_turns_it_off(model, take):
    start, target = take[99:101], take[110:112]
    kw = dict(num_samples=CANDIDATES, seed=3)
    default = inbetween.inbetween(model, start, target, LENGTH, **kw)
    locked = inbetween.inbetween(model, start, target, LENGTH, foot_lock=True, **kw)
    plain = inbetween.inbetween(model, start, target, LENGTH, foot_lock=False, **kw)
    for a, b in zip(default, locked):
        np.testing.assert_array_equal(a.rotations, b.rotations)
    assert max(np.abs(a.rotations - b.rotations).max() for a, b in zip(default, plain)) > 1e-6
    clip = takes.inbetween_clip(model, take, 100, 100 + LENGTH + 1, **kw)  # the take-level API too
    plain_clip = takes.inbetween_clip(model, take, 100, 100 + LENGTH + 1, foot_lock=False, **kw)
    locked_clip = takes.inbetween_clip(model, take, 100, 100 + LENGTH + 1, foot_lock=True, **kw)
    for a, b, c in zip(clip, locked_clip, plain_clip):
        np.testing.assert_array_equal(a.rotations, b.rotations)
    assert max(np.abs(a.rotations - c.rotations).max() for a, c in zip(clip, plain_clip)) > 1e-6


def test_cli_locks_feet_by_default_and_no_foot_lock_turns_it_off():
    from bin_scripts import load_cli

    parser = load_cli("inbetween").build_parser()
    required = ["--bvh", "take.bvh", "--start-frame", "1", "--end-frame", "9", "--out", "out"]
    assert parser.parse_args(required).foot_lock is True
    assert parser.parse_args(required + ["--no-foot-lock"]).foot_lock is False
    assert parser.parse_args(required + ["--foot-lock"]).foot_lock is True  # still accepted


def test_evaluate_default_sampling_samples_both_model_rows_as_inbetween_does(model):
    from bin_scripts import load_cli

    cli = load_cli("evaluate")
    chosen = dataclasses.replace(model, default_sampling={"noise_scale": 2.5, "noise_correlation": 0.9,
                                                          "noise_ramp_steps": 4})
    args = ["model", "--checkpoint", "run", "--data", "data"]
    parse = cli.build_parser().parse_args
    Sampling = inbetween.Sampling
    assert cli.model_sampling(parse(args), chosen) == Sampling.paper()
    assert cli.model_sampling(parse(args + ["--default-sampling"]), chosen) == Sampling(2.5, 0.9, 4)
    assert cli.model_sampling(parse(args + ["--default-sampling", "--noise-ramp", "0", "--search", "2"]),
                              chosen) == Sampling(2.5, 0.9, 0, search=2)


def test_cli_foot_lock_flag_keeps_the_keyframes(tiny_run, take, tmp_path, capsys):
    source = bundled.sample_files(["subject5"])[0]
    result = _cli_here(capsys, "--checkpoint", tiny_run, "--bvh", source, "--start-frame", 100,
                       "--end-frame", 100 + LENGTH + 1, "--samples", 1, "--foot-lock", "--gif", "--out", tmp_path)
    assert result.returncode == 0, result.stderr
    g, full = _global(bvh.load(next(tmp_path.glob("*.bvh")))), _global(take)
    for frame in (100, 100 + LENGTH + 1):
        assert np.abs(g[frame] - full[frame]).max() < TOL_CM
    assert next(tmp_path.glob("*.gif")).stat().st_size > 1000 and next(tmp_path.glob("*_filmstrip.png"))
