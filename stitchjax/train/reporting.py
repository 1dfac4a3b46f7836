"""A training run's record: WORKDIR/metrics.jsonl (one JSON object per logged step) and WORKDIR/report.md.

Records are flat dicts: "step" (int), the loss terms (means over the logging interval), "length" (the
transition length, frames), "epoch", "windows_per_s" and "time_s" (seconds since the loop started). Validation
records (``train.eval_every``) hold "val_<metric>_L<length>" and interpolation's "val_<metric>_L<length>_interp"
on the same windows; :func:`validation_curve` turns them into ratios against seconds of training loop.
"""

from __future__ import annotations

import json
import os
import pathlib


class MetricsLog:
    """Appends one JSON object per logged step to WORKDIR/metrics.jsonl (process 0 only)."""

    def __init__(self, path: str | os.PathLike, enabled: bool = True):
        self.path = pathlib.Path(path)
        self.enabled = enabled

    def truncate_after(self, step: int) -> None:
        """Drop records past `step` (left by a run that died after logging them but before saving)."""
        if not (self.enabled and self.path.is_file()):
            return
        kept = [line for line in self.path.read_text().splitlines()
                if line.strip() and json.loads(line).get("step", 0) <= step]
        self.path.write_text("".join(line + "\n" for line in kept))

    def write(self, record: dict) -> None:
        """Append `record` as one line (nothing when disabled)."""
        if not self.enabled:
            return
        with self.path.open("a") as f:
            f.write(json.dumps(record) + "\n")


def read_metrics(path: str | os.PathLike) -> list[dict]:
    """The records of a metrics.jsonl file ([] when there is none)."""
    path = pathlib.Path(path)
    if not path.is_file():
        return []
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def loop_seconds(records: list[dict]) -> list[float]:
    """Seconds of training loop at each record, summed across the processes of a resumed run (each process's
    "time_s" restarts at 0); records without "time_s" take the previous value (0 before any)."""
    out, done, last = [], 0.0, 0.0
    for record in records:
        if "time_s" in record:
            if record["time_s"] < last:  # a new process: its clock restarted
                done += last
            last = record["time_s"]
        out.append(done + last)
    return out


def validation_curve(records: list[dict]) -> list[dict]:
    """The validation points of a run: one dict per validation record, with "step", "time_s" (seconds of
    training loop, :func:`loop_seconds`) and "<metric>_L<length>_ratio" = the model's figure over
    interpolation's on the same windows (lower is better; 1 = interpolation), for every metric logged with its
    interpolation figure (a zero interpolation figure gives no ratio)."""
    points = []
    for record, seconds in zip(records, loop_seconds(records)):
        ratios = {}
        for key, value in record.items():
            if key.startswith("val_") and not key.endswith("_interp") and record.get(key + "_interp"):
                ratios[key[4:] + "_ratio"] = value / record[key + "_interp"]
        if ratios:
            points.append({"step": record["step"], "time_s": seconds, **ratios})
    return points


# configs that show the pipeline working end to end, not models to evaluate: their reports say so
SMOKE_TEST_CONFIGS = ("quickstart", "tiny")


def write_report(workdir: pathlib.Path, config_name: str, records: list[dict], summary: dict) -> None:
    """WORKDIR/report.md: steps, time, throughput, first and final value of every logged term; a smoke
    test's (a config of :data:`SMOKE_TEST_CONFIGS`) says so under the title.

    summary: the dict `train.train` returns (step, start_step, steps_run, setup_s, wall_s, compile_s in
    seconds, windows_per_s, devices, num_windows, batch_size, length, stop_reason, log_every).
    """
    lines = [f"# Training report: {config_name}", ""]
    if pathlib.Path(str(config_name)).stem in SMOKE_TEST_CONFIGS:
        lines += [f"**Smoke test.** The `{pathlib.Path(str(config_name)).stem}` config is a small model trained "
                  "briefly to show the pipeline working end to end (losses fall, checkpoints, this report); it "
                  "is not a model to evaluate or to draw conclusions from. For results train `lafan1_cpu` "
                  "(a 2-core CPU) or `lafan1` (a GPU) on the LAFAN1 files.", ""]
    lines += [
             f"- steps: {summary['step']} (this invocation: {summary['steps_run']}, "
             f"started at step {summary['start_step']})",
             f"- wall time (this invocation): {summary['setup_s']:.1f} s setup (data, phase pretraining, "
             f"init or restore) + {summary['wall_s']:.1f} s training loop, of which first-step compile "
             f"{summary['compile_s']:.1f} s",
             f"- throughput: {summary['windows_per_s']:.1f} windows/s; devices: {summary['devices']}",
             f"- training windows: {summary['num_windows']}; batch {summary['batch_size']}; "
             f"final transition length {summary['length']}",
             f"- stopped because: {summary['stop_reason']}", ""]
    if records:
        lines += [f"Loss terms at the first and the last logged step (means over the {summary['log_every']} "
                  "steps before it); validation (val_*, train.eval_every) at the first and last validated "
                  "step:", "", "| term | first logged | final |", "|---|---|---|"]
        for name in dict.fromkeys(n for r in records for n in r):
            if name in ("step", "time_s", "windows_per_s"):
                continue
            values = [r[name] for r in records if name in r]
            lines.append(f"| {name} | {values[0]:.5g} | {values[-1]:.5g} |")
    lines += ["", "Loss curves: loss_curves.png; every logged step: metrics.jsonl."]
    (workdir / "report.md").write_text("\n".join(lines) + "\n")
