"""Running a training run's steps: the loop with its logging, validation, periodic checkpoints, NaN guard and
Ctrl-C / SIGTERM save (:func:`run_loop`), and the run's summary, report and loss curves (:func:`finish`).
``train.loop.train`` sets a run up and calls them.
"""
from __future__ import annotations

import pathlib
import signal
import time
from typing import Callable

import jax
import jax.numpy as jnp
import numpy as np

from stitchjax import checkpoints
from stitchjax.eval import plots
from stitchjax.train import reporting, schedule

__all__ = ["TrainingError", "NonFiniteLossError", "check_finite", "Saver", "run_loop", "close", "finish"]


class TrainingError(RuntimeError):
    """Training cannot go on (bad data, bad config, non-finite loss)."""


class NonFiniteLossError(TrainingError):
    """A loss term became NaN or infinite; the message names the term and the step."""


def check_finite(metrics: dict, step: int) -> None:
    """Raise NonFiniteLossError naming the first non-finite metric (loss term) at `step`."""
    for name, value in metrics.items():
        if not np.all(np.isfinite(value)):
            raise NonFiniteLossError(
                f"loss term '{name}' is {float(np.asarray(value))} at step {step}: training stopped; the "
                "last good checkpoint is kept (lower train.learning_rate or check the data, then resume)")


class _StopFlag:
    """Turns the first SIGINT / SIGTERM into a request to save and stop; a second one interrupts."""

    def __init__(self):
        self.requested = None
        self._previous = {}

    def __enter__(self):
        for sig in (signal.SIGINT, signal.SIGTERM):
            try:
                self._previous[sig] = signal.signal(sig, self._handle)
            except ValueError:  # not the main thread: no signal handling
                pass
        return self

    def _handle(self, signum, frame):
        if self.requested is not None:
            raise KeyboardInterrupt
        self.requested = signal.Signals(signum).name

    def __exit__(self, *exc):
        for sig, handler in self._previous.items():
            signal.signal(sig, handler)
        return False


class Saver:
    """`saver(step, state)` writes a checkpoint with the run's config and extras; `saver.last`: the last
    step saved (or restored from), None before any."""

    def __init__(self, manager, config_json: dict, extras: dict, last: int | None):
        self.manager, self.config_json, self.extras, self.last = manager, config_json, extras, last

    def __call__(self, step: int, state) -> None:
        checkpoints.save(self.manager, step, state, self.config_json, self.extras)
        self.last = step


def run_loop(state, device_data: dict, step_for: Callable, plan: schedule.RunPlan, train_config,
             log: reporting.MetricsLog, saver: Saver, bar, t_start: float,
             validate: Callable | None = None) -> tuple:
    """Train from `state.step` to `plan.max_steps`, or until the first SIGINT / SIGTERM.

    Logs the means over each `train.log_every` steps (time_s: seconds since `t_start`), every
    `train.eval_every` steps also `validate(state)` (a record of its own; its time is not counted in
    windows_per_s), saves every
    `plan.checkpoint_every` steps (not the last: the caller saves it), advances `bar` (tqdm or None).
    Returns (state, {"start_step", "step", "length", "stop_reason", "compile_s"}); compile_s: the first
    step's seconds. Raises NonFiniteLossError at a NaN / inf metric.
    """
    tc = train_config
    start_step = step = int(state.step)
    stop_reason = "reached max_steps"
    compile_s = 0.0
    t_log, windows_since_log = time.perf_counter(), 0
    length = schedule.transition_length(step, plan.steps_per_epoch, tc)
    interval_sums, interval_count = {}, 0  # metrics are logged as means over the logging interval
    with _StopFlag() as stop:
        while step < plan.max_steps:
            length = schedule.transition_length(step, plan.steps_per_epoch, tc)
            t0 = time.perf_counter()
            state, metrics = step_for(length)(state, device_data, jnp.int32(length))
            metrics = jax.device_get(metrics)
            check_finite(metrics, step + 1)
            for name, value in metrics.items():
                interval_sums[name] = interval_sums.get(name, 0.0) + float(value)
            interval_count += 1
            if step == start_step:
                compile_s = time.perf_counter() - t0
                t_log, windows_since_log = time.perf_counter(), 0
            else:
                windows_since_log += tc.batch_size
            step += 1
            if step % tc.log_every == 0 or step == plan.max_steps:
                now = time.perf_counter()
                rate = windows_since_log / max(now - t_log, 1e-9)
                record = {"step": step, **{k: v / interval_count for k, v in interval_sums.items()},
                          "length": int(length), "epoch": step / plan.steps_per_epoch,
                          "windows_per_s": rate, "time_s": now - t_start}
                log.write(record)
                t_log, windows_since_log = now, 0
                interval_sums, interval_count = {}, 0
                if bar is not None:
                    bar.set_postfix(loss=f"{record['loss']:.4g}", L=length, win_s=f"{rate:.0f}")
            if validate is not None and step % tc.eval_every == 0:
                t_val = time.perf_counter()
                log.write({"step": step, **validate(state), "time_s": time.perf_counter() - t_start})
                t_log += time.perf_counter() - t_val
            if bar is not None:
                bar.update(1)
            if step % plan.checkpoint_every == 0 and step != plan.max_steps:
                saver(step, state)
            if stop.requested:
                stop_reason = f"{stop.requested} received"
                break
    return state, {"start_step": start_step, "step": step, "length": int(length), "stop_reason": stop_reason,
                   "compile_s": compile_s}


def close(bar, manager) -> None:
    if bar is not None:
        bar.close()
    checkpoints.close(manager)


def finish(workdir: pathlib.Path, config_name: str, outcome: dict, num_windows: int, train_config,
           t_begin: float, t_start: float) -> dict:
    """The run's summary (`outcome` of `run_loop` with timings in seconds since `t_begin` / `t_start`);
    process 0 adds the final record and writes report.md and loss_curves.png."""
    wall = time.perf_counter() - t_start
    timed = max(outcome["step"] - outcome["start_step"] - 1, 0)
    summary = {
        "step": outcome["step"], "start_step": outcome["start_step"],
        "steps_run": outcome["step"] - outcome["start_step"], "wall_s": wall, "setup_s": t_start - t_begin,
        "compile_s": outcome["compile_s"], "stop_reason": outcome["stop_reason"], "length": outcome["length"],
        "windows_per_s": (timed * train_config.batch_size / max(wall - outcome["compile_s"], 1e-9)
                          if timed else 0.0),
        "devices": f"{jax.device_count()} x {jax.devices()[0].platform}",
        "num_windows": num_windows, "batch_size": train_config.batch_size, "workdir": str(workdir),
        "log_every": train_config.log_every,
    }
    if jax.process_index() == 0:
        records = reporting.read_metrics(workdir / "metrics.jsonl")
        summary["final"] = next((r for r in reversed(records) if "loss" in r), {})  # not a validation record
        reporting.write_report(workdir, config_name or "config", records, summary)
        if records:
            plots.loss_curves(records, path=workdir / "loss_curves.png")
    return summary
