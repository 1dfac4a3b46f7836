"""Official benchmark, paper protocol and bin/evaluate, on the bundled LAFAN1 excerpt."""
import json
import os
import pathlib
import subprocess
import sys

import numpy as np
import pytest

from stitchjax.eval import evaluate, tables
from stitchjax.data import lafan1
from stitchjax.data.bundled import sample_dir
from stitchjax.skeleton import forward_kinematics

REPO = pathlib.Path(__file__).resolve().parents[2]
METRICS = set(evaluate.METRIC_KEYS)


@pytest.fixture(scope="module")
def sample():
    """(training Stats, subject5 test Windows) of the bundled excerpt."""
    return lafan1.train_statistics(sample_dir()), lafan1.test_windows(sample_dir())


def _ground_truth_method(windows, start, length, num_samples, seed):
    frames = slice(start + 1, start + 1 + length)
    return windows.rotations[None, :, frames], windows.positions[None, :, frames]


def _noisy_method(windows, start, length, num_samples, seed):
    """Ground truth with a random root offset (cm) per sample: known, seed-dependent diversity."""
    rng = np.random.default_rng(seed)
    r, p = _ground_truth_method(windows, start, length, num_samples, seed)
    p = np.repeat(p, num_samples, axis=0).copy()
    p[:, :, :, 0, :] += rng.normal(size=(num_samples, p.shape[1], 1, 3)) * 5.0
    return np.repeat(r, num_samples, axis=0), p


def test_benchmark_schema_and_baseline_ordering(sample):
    stats, windows = sample
    results = evaluate.benchmark_baselines(stats, windows)
    # the nesting of evaluate_protocol: lengths -> method -> metric, with units and settings
    assert set(results) == {"n_windows", "samples", "lengths", "units", "settings"}
    assert results["n_windows"] == windows.num_windows and results["samples"] == 1
    assert list(results["lengths"]) == ["5", "15", "30", "45"]
    assert {"l2q", "l2p", "npss"} <= set(results["units"]) and "unitless" in results["units"]["l2p"]
    for entry in results["lengths"].values():
        assert list(entry) == ["zerov", "interp"]
        for values in entry.values():
            assert set(values) == {"l2q", "l2p", "npss"}
            assert all(np.isfinite(v) and v > 0 for v in values.values())
    for n in ("15", "30", "45"):
        entry = results["lengths"][n]
        assert entry["zerov"]["l2p"] > entry["interp"]["l2p"]
        assert entry["zerov"]["l2q"] > entry["interp"]["l2q"]
    table = tables.format_benchmark_table(results)
    row = next(line for line in table.splitlines() if line.split()[:2] == ["30", "interp"])
    assert f"{results['lengths']['30']['interp']['l2p']:.4f}" in row and "l2p (-)" in table
    assert table.splitlines()[-1].startswith("units: ")


def test_protocol_interp_matches_the_benchmark(sample):
    stats, windows = sample
    bench = evaluate.benchmark_baselines(stats, windows, lengths=(15, 30))
    proto = evaluate.evaluate_protocol(
        evaluate.BASELINE_METHODS, windows, stats, lengths=(15, 30), samples=3, batch_size=7, progress=False
    )
    for n in ("15", "30"):
        for name in ("interp", "zerov"):
            for key in ("l2p", "l2q", "npss"):
                # the benchmark uses the training bone offsets, the protocol each window's own (1e-5 cm apart)
                assert proto["lengths"][n][name][key] == pytest.approx(bench["lengths"][n][name][key], rel=1e-6)


def test_protocol_schema_and_perfect_method(sample):
    stats, windows = sample
    methods = {"model": _ground_truth_method, **evaluate.BASELINE_METHODS}
    out = evaluate.evaluate_protocol(methods, windows[:6], stats, lengths=(10, 50), samples=2, progress=False)
    assert out["n_windows"] == 6 and out["samples"] == 2
    assert set(out["units"]) >= METRICS and out["units"]["ade"] == "m"
    assert list(out["lengths"]) == ["10", "50"]
    for entry in out["lengths"].values():
        assert set(entry) == {"model", "interp", "zerov", "ground_truth"}
        for name in ("model", "interp", "zerov"):
            assert set(entry[name]) == METRICS
        model = entry["model"]
        for key in ("apd", "ade", "ade_best", "slde", "npss", "l2p", "l2q"):
            assert model[key] == pytest.approx(0.0, abs=1e-9)
        assert model["foot_slide"] == pytest.approx(entry["ground_truth"]["foot_slide"])
        assert entry["zerov"]["ade"] > entry["interp"]["ade"] > 0
        assert entry["interp"]["apd"] == 0.0
    json.dumps(out)  # plain JSON types
    table = tables.format_protocol_table(out)  # the layout of the benchmark's table, units in the header
    assert "ade (m)" in table and "foot_slide (cm/f)" in table and table.splitlines()[-1].startswith("units: ")
    row = next(line for line in table.splitlines() if line.split()[:2] == ["50", "zerov"])
    assert f"{out['lengths']['50']['zerov']['ade']:.4f}" in row


def _sunk_method(windows, start, length, num_samples, seed):
    """Ground truth 5 cm lower: its feet go below the ground, its toes swing 5 cm lower."""
    r, p = _ground_truth_method(windows, start, length, num_samples, seed)
    p = p.copy()
    p[..., 0, 1] -= 5.0
    return r, p


def _lifted_method(windows, start, length, num_samples, seed):
    """Ground truth 10 cm higher: its feet hover wherever the truth's stand."""
    r, p = _ground_truth_method(windows, start, length, num_samples, seed)
    p = p.copy()
    p[..., 0, 1] += 10.0
    return r, p


def test_protocol_measures_ground_contact(sample):
    stats, windows = sample
    methods = {"model": _ground_truth_method, "sunk": _sunk_method, "lifted": _lifted_method,
               **evaluate.BASELINE_METHODS}
    out = evaluate.evaluate_protocol(methods, windows[:8], stats, lengths=(30,), samples=1, progress=False)
    entry = out["lengths"]["30"]
    truth = entry["ground_truth"]
    assert set(evaluate.CONTACT_KEYS) <= set(truth) and set(evaluate.CONTACT_KEYS) <= set(out["units"])
    # the window's ground is its lowest ground-truth foot joint: the truth never goes below it
    assert truth["penetration"] == 0.0 and truth["penetration_max"] == 0.0 and truth["penetration_share"] == 0.0
    assert 3.0 < truth["toe_clearance"] < 40.0  # cm: toes lift in swing
    for key in evaluate.CONTACT_KEYS:
        assert entry["model"][key] == pytest.approx(truth[key])
    sunk = entry["sunk"]
    assert 0.0 < sunk["penetration"] <= sunk["penetration_max"] <= 5.0 + 1e-9 and 0.0 < sunk["penetration_share"] < 1.0
    assert sunk["toe_clearance"] < truth["toe_clearance"]
    assert truth["hover_share"] == 0.0 and sunk["hover_share"] == 0.0 and entry["lifted"]["hover_share"] > 0.1
    assert 0.0 < truth["knee_turn_max"] < 90.0 and 0.0 < truth["joint_jump_max"] < 100.0
    assert entry["lifted"]["knee_turn_max"] == pytest.approx(truth["knee_turn_max"])  # a rigid lift turns no knee
    assert entry["lifted"]["joint_jump_max"] >= 10.0  # but steps 10 cm onto and off the keyframes
    table = tables.format_protocol_table(out)
    assert "penetration (cm)" in table and "toe_clearance (cm)" in table
    row = next(line for line in table.splitlines() if line.split()[:2] == ["30", "ground_truth"])
    assert f"{truth['toe_clearance']:.4f}" in row and f"{truth['foot_slide']:.4f}" in row


def test_protocol_diversity_and_best_of_n(sample):
    stats, windows = sample
    out = evaluate.evaluate_protocol({"noisy": _noisy_method}, windows[:5], stats, lengths=(10,),
                                     samples=4, batch_size=2, progress=False)
    noisy = out["lengths"]["10"]["noisy"]
    # a rigid root offset of N(0, 5 cm) per axis: ADE = E|offset| ~ 8 cm, APD > 0, best < mean
    assert 0.02 < noisy["ade"] < 0.2 and noisy["apd"] > 0.02
    assert noisy["ade_best"] < noisy["ade"]
    assert noisy["slde"] == pytest.approx(noisy["ade"])  # same offset on every frame


def test_baseline_methods_hold_and_reach_the_keyframes(sample):
    _, windows = sample
    w = windows[:3]
    start, length = 9, 12
    r, p = evaluate.zero_velocity_method(w, start, length, 5, 0)
    assert r.shape == (1, 3, length, 22, 4) and p.shape == (1, 3, length, 22, 3)
    np.testing.assert_array_equal(r[0, :, -1], w.rotations[:, start])
    np.testing.assert_array_equal(p[0, :, 0], w.positions[:, start])
    r, p = evaluate.interpolation_method(w, start, length, 5, 0)
    target = start + length + 1
    step = (w.positions[:, target, 0] - w.positions[:, start, 0]) / (length + 1)
    np.testing.assert_allclose(p[0, :, 0, 0], w.positions[:, start, 0] + step)
    np.testing.assert_allclose(p[0, :, -1, 0], w.positions[:, target, 0] - step)
    # the interpolated poses are valid input for forward kinematics
    _, gpos = forward_kinematics(r[0], p[0], w.skeleton.parents)
    assert np.all(np.isfinite(gpos))


def test_protocol_rejects_bad_lengths_and_bad_method_output(sample):
    stats, windows = sample
    with pytest.raises(ValueError, match="needs windows of at least"):
        evaluate.evaluate_protocol(evaluate.BASELINE_METHODS, windows[:2], stats, lengths=(60,), progress=False)

    def wrong(windows, start, length, num_samples, seed):
        return np.zeros((1, 2, length + 1, 22, 4)), np.zeros((1, 2, length + 1, 22, 3))

    with pytest.raises(ValueError, match="method 'wrong' returned"):
        evaluate.evaluate_protocol({"wrong": wrong}, windows[:2], stats, lengths=(10,), progress=False)


def _run_cli(*args):
    env = dict(os.environ, PYTHONPATH="")  # the script must find the package by itself
    return subprocess.run([sys.executable, str(REPO / "bin" / "evaluate"), *args], capture_output=True,
                          text=True, env=env, cwd=str(REPO.parent), timeout=300)


def _run_cli_here(capsys, *args):
    """bin/evaluate's main() in this process (no interpreter or jax start-up): (exit status, stdout, stderr)."""
    from bin_scripts import load_cli

    try:
        code = load_cli("evaluate").main(list(args))
    except SystemExit as exit_:  # argparse's own errors
        code = exit_.code
    captured = capsys.readouterr()
    return subprocess.CompletedProcess(args, code, captured.out, captured.err)


def test_cli_baselines_writes_the_schema(tmp_path):
    out = tmp_path / "baselines.json"
    proc = _run_cli("baselines", "--data", str(sample_dir()), "--json", str(out))
    assert proc.returncode == 0, proc.stderr
    results = json.loads(out.read_text())
    assert results["n_windows"] > 0
    assert set(results) == {"n_windows", "samples", "lengths", "units", "settings"}
    assert set(results["lengths"]) == {"5", "15", "30", "45"}
    assert set(results["lengths"]["15"]) == {"zerov", "interp"}
    value = results["lengths"]["15"]["interp"]["npss"]
    assert 0 < value < 1 and f"{value:.4f}" in proc.stdout and "units: " in proc.stdout


def test_cli_reports_a_folder_without_test_subject_in_one_line(tmp_path, capsys):
    for f in sample_dir().glob("*_subject1.bvh.gz"):
        (tmp_path / f.name).symlink_to(f)
    proc = _run_cli_here(capsys, "baselines", "--data", str(tmp_path))
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr
    error_lines = [line for line in proc.stderr.splitlines() if "error" in line]
    assert len(error_lines) == 1 and "subject5" in error_lines[0]


def test_cli_model_baselines_only(tmp_path, capsys):
    out = tmp_path / "protocol.json"
    proc = _run_cli_here(capsys, "model", "--baselines-only", "--data", str(sample_dir()), "--samples", "2",
                         "--lengths", "10,30", "--json", str(out))
    assert proc.returncode == 0, proc.stderr
    results = json.loads(out.read_text())
    assert results["samples"] == 2 and list(results["lengths"]) == ["10", "30"]
    assert set(results["lengths"]["30"]) == {"interp", "zerov", "ground_truth"}
    assert set(results["lengths"]["30"]["interp"]) == METRICS
    truth = results["lengths"]["30"]["ground_truth"]
    assert truth["penetration_share"] == 0.0 and truth["toe_clearance"] > 0.0


@pytest.mark.slow
def test_cli_model_evaluates_a_bvh_folder_model_on_its_test_files(shared_data, tmp_path, capsys):
    """A 2-step `cmu` model (data.dataset=bvh_folder, every file trains) evaluated on the CMU take with the
    protocol and the baselines: --dataset comes from the model, the test files from --test-files."""
    from stitchjax import config as config_lib
    from stitchjax.train import loop as train

    tiny = ["model.encoder_widths=16,16,16", "model.lstm_size=16", "model.latent_dim=4", "model.decoder_widths=16,16",
            "model.gating_widths=8,8", "model.disc_widths=16,16", "phase.hidden_dim=16", "phase.steps=20",
            "train.log_every=1", "train.batch_size=4"]
    config = config_lib.apply_overrides(config_lib.load_config("cmu"), tiny)
    run = tmp_path / "cmu"
    train.train(config, run, data_dir=shared_data / "cmu", max_steps=2, config_name="cmu", progress=False)
    from stitchjax.sample import takes, trained_model

    limit, source = takes.root_speed_limit(trained_model.load_model(run))  # saved at training time
    assert 30.0 < limit < 1000.0 and "training data" in source  # cm/s
    out = tmp_path / "cmu.json"
    args = ["model", "--checkpoint", str(run), "--data", str(shared_data / "cmu"), "--samples", "2",
            "--lengths", "10,30", "--noise-scales", "", "--json", str(out)]
    refused = _run_cli_here(capsys, *args[:-2])
    assert refused.returncode == 2 and "--test-files" in refused.stderr  # no data.test_files in the config
    proc = _run_cli_here(capsys, *args, "--test-files", "01_01.bvh")
    assert proc.returncode == 0, proc.stderr[-2000:]
    results = json.loads(out.read_text())
    assert results["n_windows"] == 16  # 2752 frames at 120 fps = 688 at 30: windows of 65 every 40
    for length in ("10", "30"):
        entry = results["lengths"][length]
        assert set(entry) == {"model", "interp", "zerov", "ground_truth"}
        assert set(entry["model"]) == METRICS and all(np.isfinite(entry["model"][k]) for k in ("ade", "npss", "apd"))
        assert entry["model"]["apd"] > 0 and entry["ground_truth"]["penetration_share"] == 0.0
    assert "ground_truth" in proc.stdout and "toe_clearance" in proc.stdout
