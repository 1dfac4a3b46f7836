"""Where each generator ends before stitching (stitchjax.eval.direction_ends), on a tiny random model."""
import json
import os
import pathlib
import subprocess
import sys

import jax
import numpy as np
import pytest

from stitchjax import config as C
from stitchjax.data import lafan1
from stitchjax.data.bundled import sample_dir
from stitchjax.eval import direction_ends
from stitchjax.model import rollout as RO
from stitchjax.sample import trained_model
from stitchjax.skeleton import forward_kinematics

LENGTH = 6  # the tiny config trains up to 8 frames
REPO = pathlib.Path(__file__).resolve().parents[2]


def model_of(*overrides):
    return trained_model.random_model(C.apply_overrides(C.load_config("tiny"), list(overrides)), seed=0)


@pytest.fixture(scope="module")
def windows():
    """Four subject5 windows of the bundled excerpt."""
    return lafan1.test_windows(sample_dir())[:4]


def one_rollout(model, seed=0):
    """A rollout of LENGTH frames between two keyframes of the bundled windows (the model's frame is irrelevant
    to the gaps: every one is a distance within one rollout)."""
    w = lafan1.test_windows(sample_dir())
    start = {"rotations": w.rotations[0, 9], "root_position": w.positions[0, 9, 0], "contacts": w.contacts[0, 9]}
    target = {"rotations": w.rotations[0, 9 + LENGTH + 1], "root_position": w.positions[0, 9 + LENGTH + 1, 0],
              "contacts": w.contacts[0, 9 + LENGTH + 1]}
    as32 = lambda tree: jax.tree.map(lambda x: np.asarray(x, np.float32), tree)  # noqa: E731
    return _jitted_rollout(model.params, model.phase_params, (as32(start), as32(target), as32(w.positions[0, 9])),
                           jax.random.PRNGKey(seed), model.rollout_spec, LENGTH, LENGTH)


_jitted_rollout = jax.jit(RO.rollout, static_argnums=(4, 5, 6))  # one program instead of op-by-op dispatch


def distance(a, b):
    return float(np.mean(np.linalg.norm(np.asarray(a, np.float64) - np.asarray(b, np.float64), axis=-1)))


def test_the_gaps_of_a_bidirectional_rollout_are_its_two_generators_at_the_frames_they_end_on():
    model = model_of()
    result = one_rollout(model)
    gaps = {k: float(v) for k, v in direction_ends.end_gaps(result, LENGTH, model.rollout_spec).items()}
    k = min(model.config.model.stitch_buffer, LENGTH // 2)
    h = LENGTH // 2
    forward, backward = result["forward"]["global_positions"], result["backward"]["global_positions"]
    # forward row i is frame i + 1; backward row i is frame L - i
    forward_last, backward_at_it = forward[h + k - 1], backward[LENGTH - (h + k)]
    backward_last, forward_at_it = backward[LENGTH - (h - k + 1)], forward[h - k]
    np.testing.assert_allclose(gaps["forward_end_gap"], distance(forward_last, backward_at_it), rtol=1e-5)
    np.testing.assert_allclose(gaps["backward_end_gap"], distance(backward_last, forward_at_it), rtol=1e-5)
    seam = np.mean([distance(forward[t - 1], backward[LENGTH - t]) for t in range(h - k + 1, h + k + 1)])
    np.testing.assert_allclose(gaps["seam_gap"], seam, rtol=1e-5)
    positions = result["global_positions"]
    np.testing.assert_allclose(gaps["target_step"], distance(positions[LENGTH], positions[LENGTH + 1]), rtol=1e-5)
    assert all(value > 0 for value in gaps.values())  # an untrained model's generators do not meet


def test_a_forward_only_rollout_ends_where_its_last_step_puts_it_and_has_no_seam():
    model = model_of("model.bidirectional=false")
    result = one_rollout(model)
    gaps = {k: float(v) for k, v in direction_ends.end_gaps(result, LENGTH, model.rollout_spec).items()}
    assert set(gaps) == {"target_step", "forward_end_gap"}
    target = result["global_positions"][LENGTH + 1]
    np.testing.assert_allclose(gaps["forward_end_gap"],
                               distance(result["forward"]["global_positions"][LENGTH - 1], target), rtol=1e-5)
    np.testing.assert_allclose(gaps["target_step"], gaps["forward_end_gap"], rtol=1e-6)  # nothing is stitched
    assert gaps["target_step"] > 0.5  # cm: the untrained forward generator does not land next to the target


def test_evaluate_direction_ends_averages_windows_and_samples_in_metres(windows):
    for overrides, backward in (((), True), (("model.bidirectional=false",), False)):
        model = model_of(*overrides)
        results = direction_ends.evaluate_direction_ends(model, windows, (LENGTH, 4), samples=3, batch_size=3)
        assert (results["n_windows"], results["samples"], list(results["lengths"])) == (4, 3, [str(LENGTH), "4"])
        entry = results["lengths"][str(LENGTH)]
        figures = entry["model"]
        assert set(figures) == set(direction_ends.GAP_KEYS)
        assert (figures["seam_gap"] is not None) == backward and (figures["backward_end_gap"] is not None) == backward
        assert all(np.isfinite(v) and v > 0 for v in figures.values() if v is not None)
        if not backward:
            np.testing.assert_allclose(figures["target_step"], figures["forward_end_gap"], rtol=1e-6)
        # the ground truth's own last step into the target keyframe, in metres
        _, truth = forward_kinematics(windows.rotations, windows.positions, model.parents)
        target = 9 + LENGTH + 1
        expected = np.linalg.norm(truth[:, target - 1] - truth[:, target], axis=-1).mean() * 0.01
        np.testing.assert_allclose(entry["ground_truth"]["target_step"], expected, rtol=1e-9)
    # the samples are drawn per window as sampling draws them: another seed, other figures
    other = direction_ends.evaluate_direction_ends(model, windows, (LENGTH,), samples=3, seed=1)
    assert other["lengths"][str(LENGTH)]["model"]["target_step"] != results["lengths"][str(LENGTH)]["model"][
        "target_step"]


def test_a_model_on_another_skeleton_is_refused(windows):
    h36m_model = trained_model.random_model(C.apply_overrides(C.load_config("h36m"), [
        "model.encoder_widths=8,8,8", "model.lstm_size=8", "model.decoder_widths=8,8"]))
    with pytest.raises(ValueError, match="skeleton"):
        direction_ends.evaluate_direction_ends(h36m_model, windows, (LENGTH,))


def _run_evaluate(*args):
    env = dict(os.environ, PYTHONPATH="")  # the script must find the package by itself
    return subprocess.run([sys.executable, str(REPO / "bin" / "evaluate"), *args], capture_output=True, text=True,
                          env=env, cwd=str(REPO.parent), timeout=600)


def test_bin_evaluate_adds_the_direction_ends_of_the_model_and_refuses_them_without_one(tiny_run, tmp_path):
    out = tmp_path / "ends.json"
    common = ["model", "--data", str(sample_dir()), "--samples", "2", "--lengths", str(LENGTH), "--noise-scales", ""]
    proc = _run_evaluate(*common, "--checkpoint", str(tiny_run), "--direction-ends", "--json", str(out))
    assert proc.returncode == 0, proc.stderr[-2000:]
    ends = json.loads(out.read_text())["direction_ends"]
    figures = ends["lengths"][str(LENGTH)]["model"]
    assert ends["samples"] == 2 and set(figures) == set(direction_ends.GAP_KEYS)
    assert all(np.isfinite(v) and v > 0 for v in figures.values())
    assert f"L = {LENGTH}: target_step {figures['target_step']:.4f}" in proc.stdout
    refused = _run_evaluate(*common, "--baselines-only", "--direction-ends")
    assert refused.returncode == 2 and "--direction-ends" in refused.stderr and "Traceback" not in refused.stderr
