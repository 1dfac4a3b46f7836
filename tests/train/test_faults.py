"""Faults and exit codes (issue 12, item 4): corrupt files, broken checkpoints, signals, bad arguments,
and the README's multi-host command, each through the user-facing entry point."""
import gzip
import json
import os
import pathlib
import shutil
import signal
import socket
import subprocess
import sys
import time

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from stitchjax import checkpoints
from stitchjax.data import bvh, bundled

from bin_scripts import load_cli

REPO = pathlib.Path(__file__).resolve().parents[2]
# A fast training run: the tiny model on 12-frame windows of the bundled sample.
FAST = ["--config", "tiny", "--no-progress", "data.window=12", "data.offset=8"]


def _env(**extra):
    return {**os.environ, "PYTHONPATH": str(REPO), **extra}


def _train(workdir, *args, timeout=300, **env):
    return subprocess.run([sys.executable, str(REPO / "bin" / "train"), "--workdir", str(workdir), *FAST,
                           *map(str, args)], capture_output=True, text=True, env=_env(**env), timeout=timeout)


def _main_here(name, capsys, *args):
    """bin/<name>'s main() in this process (no interpreter or jax start-up): (exit status, stderr)."""
    try:
        code = load_cli(name).main([str(a) for a in args])
    except SystemExit as exit_:  # argparse's own errors
        code = exit_.code
    return subprocess.CompletedProcess(args, code, "", capsys.readouterr().err)


def _train_here(capsys, workdir, *args):
    """bin/train's argument checks in this process: (exit status, stderr)."""
    return _main_here("train", capsys, "--workdir", workdir, *FAST, *args)


def _truncate_state(step_folder: pathlib.Path) -> None:
    """Cut every array data file of a checkpoint to a few bytes, as a crashed copy would leave it."""
    files = [p for p in (step_folder / "state").rglob("*") if p.is_file() and p.parent.name == "d"]
    assert files, f"no array files under {step_folder}"
    for path in files:
        path.write_bytes(path.read_bytes()[:20])


def test_corrupt_gzip_is_a_bvherror_naming_the_file(tmp_path):
    data = bundled.sample_files(["subject5"])[0].read_bytes()
    assert data[:2] == b"\x1f\x8b"
    broken = tmp_path / "broken_subject5.bvh.gz"
    broken.write_bytes(data[:40] + bytes(b ^ 0x5A for b in data[40:400]) + data[400:])
    with pytest.raises(bvh.BVHError, match=r"broken_subject5\.bvh\.gz: corrupt gzip data"):
        bvh.load(broken)
    cut = tmp_path / "cut_subject5.bvh.gz"
    cut.write_bytes(data[: len(data) // 2])  # truncated: gzip's EOFError
    with pytest.raises(bvh.BVHError, match=r"cut_subject5\.bvh\.gz: corrupt gzip data"):
        bvh.load(cut)


def _state(seed):
    return {"step": jnp.int32(seed), "w": jax.random.normal(jax.random.PRNGKey(seed), (3, 4))}


def test_broken_newest_checkpoint_falls_back_and_names_the_folder(tmp_path):
    manager = checkpoints.open_manager(tmp_path, async_save=False)
    for step in (1, 2):
        checkpoints.save(manager, step, _state(step), {"model": {}})
    _truncate_state(checkpoints.checkpoint_dir(tmp_path) / "2")
    messages = []
    state, _, _, step = checkpoints.restore_newest_good(manager, jax.eval_shape(lambda: _state(0)),
                                                        report=messages.append)
    assert step == 1 and int(state["step"]) == 1
    np.testing.assert_array_equal(np.asarray(state["w"]), np.asarray(_state(1)["w"]))
    assert len(messages) == 1 and str(checkpoints.checkpoint_dir(tmp_path) / "2") in messages[0]
    assert "falling back to step 1" in messages[0]
    _truncate_state(checkpoints.checkpoint_dir(tmp_path) / "1")
    with pytest.raises(checkpoints.CheckpointError, match=r"no checkpoint .* can be restored.*checkpoints/1"):
        checkpoints.restore_newest_good(manager, jax.eval_shape(lambda: _state(0)), report=None)
    checkpoints.close(manager)


def test_background_read_errors_are_quiet_during_every_attempt_and_after_a_failure_only(tmp_path, monkeypatch):
    # a failing read can log "Task exception was never retrieved" before the failure reaches restore_newest_good
    import logging

    manager = checkpoints.open_manager(tmp_path, async_save=False)
    for step in (1, 2):
        checkpoints.save(manager, step, _state(step), {"model": {}})
    loggers = [logging.getLogger(name) for name in ("asyncio", "concurrent.futures")]
    real_restore, levels_seen = checkpoints.restore, []

    def restore(manager, abstract_state, step, partial):
        levels_seen.append([logger.level for logger in loggers])
        return real_restore(manager, abstract_state, step, partial)

    monkeypatch.setattr(checkpoints, "restore", restore)
    before = [logger.level for logger in loggers]
    try:
        for logger in loggers:
            logger.setLevel(logging.WARNING)
        _, _, _, step = checkpoints.restore_newest_good(manager, jax.eval_shape(lambda: _state(0)), report=None)
        assert step == 2 and levels_seen == [[logging.CRITICAL] * 2]
        assert [logger.level for logger in loggers] == [logging.WARNING] * 2  # all good: as they were
        _truncate_state(checkpoints.checkpoint_dir(tmp_path) / "2")
        levels_seen.clear()
        _, _, _, step = checkpoints.restore_newest_good(manager, jax.eval_shape(lambda: _state(0)), report=None)
        assert step == 1 and levels_seen == [[logging.CRITICAL] * 2] * 2
        assert [logger.level for logger in loggers] == [logging.CRITICAL] * 2  # step 2's reads may still fail
    finally:
        for logger, level in zip(loggers, before):
            logger.setLevel(level)
        checkpoints.close(manager)


def test_inbetween_load_model_falls_back_over_a_broken_checkpoint(tiny_run, tmp_path, capsys):
    from stitchjax.sample import trained_model

    folder = checkpoints.checkpoint_dir(tmp_path)
    folder.mkdir(parents=True)
    for step in (5, 9):  # the session's tiny checkpoint as steps 5 and 9 (no new train state to compile)
        shutil.copytree(checkpoints.checkpoint_dir(tiny_run) / "0", folder / str(step))
    _truncate_state(folder / "9")
    model = trained_model.load_model(tmp_path)
    assert model.source.endswith("step 5")
    err = capsys.readouterr().err
    assert str(folder / "9") in err and "falling back to step 5" in err
    with pytest.raises(FileNotFoundError, match=r"checkpoints/9 cannot be restored"):
        trained_model.load_model(folder / "9")  # a step asked for by name: no silent fallback


@pytest.mark.slow
def test_train_cli_exit_codes_resume_message_and_checkpoint_fallback(tmp_path):
    run = tmp_path / "run"
    first = _train(run, "--max-steps", 2, "train.checkpoint_every_steps=1")
    assert first.returncode == 0, first.stderr[-2000:]
    assert sorted(p.name for p in (run / "checkpoints").iterdir()) == ["1", "2"]

    mismatch = _train(run, "--max-steps", 3, "model.latent_dim=8")  # a different model: refused, exit 2
    assert mismatch.returncode == 2
    assert mismatch.stderr.startswith("error:") and "model config differs" in mismatch.stderr

    _truncate_state(run / "checkpoints" / "2")
    resumed = _train(run, "--max-steps", 3, "train.checkpoint_every_steps=1")
    assert resumed.returncode == 0, resumed.stderr[-2000:]
    assert f"checkpoint {run / 'checkpoints' / '2'} cannot be restored" in resumed.stderr
    assert "falling back to step 1" in resumed.stderr and "resuming from step 1" in resumed.stderr
    # one warning line, no traceback: not even TensorStore's late "Event loop is closed" (stitchjax.checkpoints)
    assert "Traceback" not in resumed.stderr and "Event loop is closed" not in resumed.stderr, resumed.stderr[-3000:]
    names = sorted(p.name for p in (run / "checkpoints").iterdir())
    assert "2.broken" in names and "3" in names  # nothing deleted; training went on from step 1
    steps = [json.loads(line)["step"] for line in (run / "metrics.jsonl").read_text().splitlines()]
    assert steps == [1, 2, 3]

    # SIGTERM: the current step is saved, then exit 128 + 15 so a scheduler does not read "finished".
    proc = subprocess.Popen([sys.executable, str(REPO / "bin" / "train"), "--workdir", str(run), *FAST,
                             "--max-steps", "100000"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=_env())
    deadline = time.time() + 240
    while time.time() < deadline and proc.poll() is None:
        lines = (run / "metrics.jsonl").read_text().splitlines()
        if lines and json.loads(lines[-1])["step"] >= 5:
            break
        time.sleep(0.5)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 128 + signal.SIGTERM, err[-2000:]
    assert "resuming from step 3" in err
    saved = max(int(p.name) for p in (run / "checkpoints").iterdir() if p.name.isdigit())
    assert saved >= 5


def test_train_cli_checks_arguments_before_any_work(tmp_path, capsys):
    afile = tmp_path / "file.txt"
    afile.write_text("x")
    bad = _train_here(capsys, afile, "--max-steps", 1)
    assert bad.returncode == 2 and "--workdir" in bad.stderr and "is a file" in bad.stderr
    bad = _train_here(capsys, tmp_path / "run", "--data", tmp_path / "missing")
    assert bad.returncode == 2 and "--data" in bad.stderr and "no such folder" in bad.stderr
    bad = _train_here(capsys, tmp_path / "run", "--max-steps", 0)
    assert bad.returncode == 2 and "--max-steps 0" in bad.stderr
    assert not (tmp_path / "run").exists()  # nothing started
    bad = _train_here(capsys, tmp_path / "run", "--max-steps", 1, "model.posterior=none", "loss.free_bits=2")
    assert bad.returncode == 2 and "loss.free_bits changes nothing" in bad.stderr
    assert not (tmp_path / "run").exists()  # refused before any work
    bad = _train_here(capsys, tmp_path / "run", "--max-steps", 1, "model.noise_correlation=0.5")  # a removed field
    assert bad.returncode == 2 and "model.noise_correlation was removed" in bad.stderr
    assert not (tmp_path / "run").exists()
    # a fresh process: a bad multi-host setting is one error line before jax starts, not a traceback
    bad = _train(tmp_path / "run", "--max-steps", 1, JAX_COORDINATOR_ADDRESS="127.0.0.1:1", JAX_NUM_PROCESSES="2",
                 JAX_PROCESS_ID="x")
    assert bad.returncode == 2 and "JAX_PROCESS_ID='x'" in bad.stderr and "Traceback" not in bad.stderr


def test_evaluate_cli_names_the_flag(tmp_path, capsys):
    def evaluate(*args):
        return _main_here("evaluate", capsys, *args)

    data = str(bundled.sample_dir())
    bad = evaluate("model", "--baselines-only", "--data", data, "--lengths", "10,abc")
    assert bad.returncode == 2 and "--lengths" in bad.stderr and "'abc'" in bad.stderr
    bad = evaluate("model", "--baselines-only", "--data", data, "--samples", 0)
    assert bad.returncode == 2 and "--samples 0" in bad.stderr
    bad = evaluate("model", "--baselines-only", "--data", data, "--noise-ramp", -2)
    assert bad.returncode == 2 and "--noise-ramp -2" in bad.stderr
    bad = evaluate("model", "--baselines-only", "--data", data, "--noise-correlation", 1.5)
    assert bad.returncode == 2 and "--noise-correlation 1.5" in bad.stderr
    bad = evaluate("model", "--checkpoint", tmp_path / "nowhere", "--data", data)
    assert bad.returncode == 2 and "--checkpoint" in bad.stderr and "does not exist" in bad.stderr
    bad = evaluate("baselines", "--data", tmp_path / "nowhere")
    assert bad.returncode == 2 and "--data" in bad.stderr
    (tmp_path / "out").mkdir()
    bad = evaluate("baselines", "--data", data, "--json", tmp_path / "out")
    assert bad.returncode == 2 and "--json" in bad.stderr and "is a folder" in bad.stderr


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _two_hosts(workdir, max_steps):
    """The README's multi-host command, two processes on 127.0.0.1; returns their CompletedProcess-like
    (returncode, stdout, stderr) tuples."""
    port = _free_port()
    procs = [subprocess.Popen([sys.executable, str(REPO / "bin" / "train"), "--workdir", str(workdir), *FAST,
                               "--max-steps", str(max_steps)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              text=True, env=_env(JAX_COORDINATOR_ADDRESS=f"127.0.0.1:{port}", JAX_NUM_PROCESSES="2",
                                                  JAX_PROCESS_ID=str(rank)))
             for rank in (0, 1)]
    out = []
    for proc in procs:
        try:
            stdout, stderr = proc.communicate(timeout=400)
        except subprocess.TimeoutExpired:
            for p in procs:
                p.kill()
            raise
        out.append((proc.returncode, stdout, stderr))
    return out


@pytest.mark.slow
def test_readme_multi_host_command_trains_checkpoints_and_resumes(tmp_path):
    run = tmp_path / "run"
    for rc, _, err in _two_hosts(run, 2):
        assert rc == 0, err[-3000:]
    assert sorted(p.name for p in (run / "checkpoints").iterdir()) == ["2"]  # one checkpoint for both
    assert [p.name for p in run.glob("*.jsonl")] == ["metrics.jsonl"]  # one metrics file (process 0)
    resumed = _two_hosts(run, 3)
    for rc, _, err in resumed:
        assert rc == 0, err[-3000:]
    assert "resuming from step 2" in resumed[0][2]
    steps = [json.loads(line)["step"] for line in (run / "metrics.jsonl").read_text().splitlines()]
    assert steps == [1, 2, 3]
    assert sorted(p.name for p in (run / "checkpoints").iterdir()) == ["2", "3"]
