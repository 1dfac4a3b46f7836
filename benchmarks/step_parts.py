"""Where a train step's time goes: its parts compiled and timed alone, with their matmul FLOPs.

    python benchmarks/step_parts.py                              # lafan1, batch 32, length 48, both precisions
    python benchmarks/step_parts.py --batch 128 --dtypes float32
    python benchmarks/step_parts.py --dtypes float32 --scan-remat none,taped --profile /tmp/trace   # train.scan_remat

Parts (each one jitted program, compiled ahead of time, timed after two warm-up calls; medians):

- rollout: both generators' bidirectional aligned rollout (one ``lax.scan``), forward only;
- generator loss + grad: rollout, every generator loss term (FK, stitching, KL, adversarial) and the
  backward pass, no optimiser;
- train step: ``train.make_train_step`` (batch sampling, the generator part above, AdamW on the generators,
  the discriminator update).

For each: ms per call, matmul FLOPs of the optimised HLO (loop trip counts included, ``flops.py``), the
achieved GFLOP/s, and the bytes its copies and its stacking (dynamic-update-slice) write. Prints figures; asserts nothing. Data: synthetic windows as in ``run_all.py``.

``--profile DIR`` also records a ``jax.profiler`` trace of the generator loss + gradient (open it in
Perfetto or TensorBoard) and prints the XLA operations that took the most time on the CPU compute
threads, grouped by kind ("ynn_fusion" = matmuls through YNNPACK), and how much of the threads' time
was busy.
"""
from __future__ import annotations

import argparse
import collections
import gzip
import json
import pathlib
import re

import run_all  # sets the jax platform / compilation cache and sys.path

import flops as flops_lib


PROFILE_CALLS = 3
_BOOKKEEPING = re.compile(r"^(end: |ThunkExecutor|ThreadpoolListener|SlinkyThreadPool)")
# operation kinds that only move data: copies (of parameters, gradients, loop buffers) and the stacking of
# per-step values into the scan's saved buffers
_DATA_MOVEMENT = re.compile(r"copy|dynamic-update-slice|dynamic_update_slice|broadcast")


def thread_time_by_op(trace_dir: pathlib.Path, calls: int = PROFILE_CALLS) -> tuple[dict, float, int]:
    """From the newest Perfetto trace under trace_dir: ({op kind: (ms per call, count per call)}, busy ms
    per call summed over the XLA compute threads, number of those threads)."""
    trace = max(trace_dir.rglob("perfetto_trace.json.gz"), key=lambda f: f.stat().st_mtime)
    events = json.load(gzip.open(trace))
    events = events["traceEvents"] if isinstance(events, dict) else events
    names = {(e["pid"], e["tid"]): e["args"]["name"] for e in events
             if e.get("ph") == "M" and e.get("name") == "thread_name"}
    compute = {key for key, name in names.items() if "XLAEigen" in name}
    total = collections.defaultdict(float)
    count = collections.Counter()
    for e in events:
        if e.get("ph") == "X" and (e["pid"], e["tid"]) in compute and not _BOOKKEEPING.match(e["name"]):
            kind = re.sub(r"\.\d+$", "", e["name"])
            total[kind] += e.get("dur", 0.0) / 1e3
            count[kind] += 1
    ops = {k: (v / calls, count[k] / calls) for k, v in sorted(total.items(), key=lambda kv: -kv[1])}
    return ops, sum(total.values()) / calls, len(compute)


def profile(compiled, args, trace_dir: pathlib.Path, wall_s: float, top: int = 10) -> None:
    import jax

    for _ in range(2):
        jax.block_until_ready(compiled(*args))
    with jax.profiler.trace(str(trace_dir), create_perfetto_trace=True):
        for _ in range(PROFILE_CALLS):
            jax.block_until_ready(compiled(*args))
    ops, busy_ms, threads = thread_time_by_op(trace_dir)
    if not threads:
        print(f"  trace in {trace_dir}: no XLA CPU compute threads found to summarise")
        return
    capacity = 1e3 * wall_s * threads
    print(f"  trace in {trace_dir}; {threads} compute threads busy {busy_ms:.0f} of {capacity:.0f} thread-ms "
          f"per call ({100 * busy_ms / capacity:.0f} %); top operations by thread time:")
    for kind, (ms, n) in list(ops.items())[:top]:
        print(f"    {ms:8.1f} ms  {n:7.0f} x  {kind}")
    moving = {kind: ms for kind, (ms, _) in ops.items() if _DATA_MOVEMENT.search(kind)}
    print(f"  copies and stacking (kinds matching {_DATA_MOVEMENT.pattern!r}): {sum(moving.values()):.1f} thread-ms "
          f"per call over {len(moving)} kinds")


def parts(batch: int, length: int, dtype: str, reps: int, profile_dir: pathlib.Path | None = None,
          scan_remat: str = "none") -> list:
    import jax

    from stitchjax import specs
    from stitchjax.accel import fast_rollout
    from stitchjax.model import batch as batch_lib
    from stitchjax.model import objective, rollout

    config = run_all.bench_config(batch, length, [f"model.matmul_dtype={dtype}", f"train.scan_remat={scan_remat}"])
    whole = run_all.JaxTrain(config, length)
    state = whole.state
    sample = whole.sample(whole.dataset, state.key, state.step)
    key = jax.random.PRNGKey(3)
    generators = {name: state.params[name] for name in ("forward", "backward")}
    spec, rollout_batch = specs.train_spec(config), fast_rollout.training_rollout_batch(config.train)

    def forward(generators, phase_params, sample):
        out = batch_lib.rollout_batch(generators, phase_params, sample, key, rollout.rollout_spec(config), length)
        return out["global_positions"]

    def loss(generators, phase_params, sample):
        return objective.generator_loss({**state.params, **generators}, phase_params, sample, key, spec, length,
                                        rollout_batch=rollout_batch)[0]

    rows = []
    for name, fn in (("rollout", forward), ("generator loss + grad", jax.grad(loss))):
        compiled = jax.jit(fn).lower(generators, state.phase_params, sample).compile()
        seconds = run_all.timeit(lambda: jax.block_until_ready(compiled(generators, state.phase_params, sample)),
                                 warmup=2, reps=reps)["median_s"]
        rows.append((name, seconds, flops_lib.hlo_matmul_flops(compiled)))
    if profile_dir is not None:  # the generator loss + grad compiled last
        print(f"{dtype}, scan_remat={scan_remat}: profiling the generator loss + grad ...")
        profile(compiled, (generators, state.phase_params, sample), profile_dir / f"{dtype}_{scan_remat}", seconds)
    seconds = run_all.timeit(whole.run, warmup=2, reps=reps)["median_s"]
    rows.append(("train step", seconds, flops_lib.hlo_matmul_flops(whole.compiled)))
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--batch", type=int, default=run_all.TRAIN_BATCH, help="windows per step (default 32)")
    parser.add_argument("--length", type=int, default=run_all.TRAIN_LENGTH, help="transition length (default 48)")
    parser.add_argument("--dtypes", default="float32,bfloat16", help="model.matmul_dtype values to time")
    parser.add_argument("--reps", type=int, default=5, help="timed calls per part (default 5)")
    parser.add_argument("--scan-remat", default="none",
                        help="train.scan_remat values to time, comma separated (none, dots, nothing, taped)")
    parser.add_argument("--profile", type=pathlib.Path, default=None, metavar="DIR",
                        help="also trace the generator loss + grad into DIR/<dtype>_<scan_remat> and print its top "
                             "operations")
    args = parser.parse_args(argv)
    peak = flops_lib.theoretical_peak_flops()["flops"]
    print(f"batch {args.batch}, transition length {args.length}; theoretical float32 peak {peak / 1e9:.1f} GFLOP/s")
    rows = []
    for dtype in [d.strip() for d in args.dtypes.split(",") if d.strip()]:
        for remat in [r.strip() for r in args.scan_remat.split(",") if r.strip()]:
            rows += [(dtype, remat, *row) for row in parts(args.batch, args.length, dtype, args.reps, args.profile,
                                                           remat)]
    print(f"{'matmul dtype':<13} {'scan_remat':<10} {'part':<22} {'ms':>8} {'GFLOP':>8} {'GFLOP/s':>8} "
          f"{'% fp32 peak':>11} {'copy MB':>8} {'stack MB':>8}")
    for dtype, remat, name, seconds, hlo in rows:
        flop = hlo["matmul_flops"]
        print(f"{dtype:<13} {remat:<10} {name:<22} {1e3 * seconds:8.0f} {flop / 1e9:8.1f} {flop / seconds / 1e9:8.1f} "
              f"{100 * flop / seconds / peak:10.1f}% {hlo['copy_bytes'] / 1e6:8.1f} "
              f"{hlo['update_slice_bytes'] / 1e6:8.1f}")
    print("copy MB / stack MB: bytes written per call by copy and dynamic-update-slice instructions of the optimised "
          "HLO (loop trip counts included; flops.hlo_matmul_flops)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
