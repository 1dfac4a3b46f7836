"""Train-step benchmark: throughput (windows/s), compile time, peak memory; masked length vs static buckets.

    python benchmarks/train_step.py                          # lafan1 config, batch 32, length 48, on CPU
    python benchmarks/train_step.py --config quickstart --batch 16
    python benchmarks/train_step.py --buckets 12,24,36,48 --epoch-steps 300

Prints figures; asserts nothing. Transition length: 48, the longest a 50-frame training window allows
(start keyframe at frame 0, target at L + 1 = 49; the paper's schedule says "to 50"). Runs on the bundled
LAFAN1 sample (the step's cost does not depend on how many windows there are). Phase params are random
(pretraining is not part of the step).

Masking vs buckets. With a traced `length`, one compiled step scans the full window and masks frames past
the length, so a step costs the same at L = 5 as at L = 48. With static buckets (train.length_buckets) the
window is cut to bucket + 2 frames and the scan is shorter, at the price of one compile per bucket. The
script times a step at every bucket and projects the total time of the progressive schedule
(min_length -> max_length, +1 every 2 epochs, then the remaining epochs at max_length) both ways.
"""

from __future__ import annotations

import argparse
import pathlib
import resource
import sys
import time

try:
    import stitchjax  # noqa: F401
except ImportError:
    sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent))

import jax
import jax.numpy as jnp
import numpy as np

from stitchjax import config as config_lib
from stitchjax import parallel, specs
from stitchjax.data import datasets
from stitchjax.train import loop as train


def peak_rss_mib() -> float:
    """Peak resident memory of this process so far (Linux reports KiB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def device_memory() -> str:
    stats = jax.devices()[0].memory_stats()
    if not stats:
        return "n/a on this backend"
    peak = stats.get("peak_bytes_in_use", 0) / 2**20
    return f"peak {peak:.0f} MiB in use"


def time_step(spec, data, length: int, steps: int, window: int | None, mesh, initial_state):
    """(compile_s, seconds per step) of train_step at `length` with the window cut to `window` frames
    (spec: the run's ``specs.TrainSpec``)."""
    state = jax.tree.map(jnp.copy, initial_state)  # the update donates its state argument
    device_data = parallel.shard_dataset(data, mesh)
    sample = train.make_sampler(spec, mesh, window)
    batch = sample(device_data, state.key, state.step)
    update = train.make_update_step(spec, mesh)
    t0 = time.perf_counter()
    compiled = update.lower(state, batch, jnp.int32(length)).compile()
    compile_s = time.perf_counter() - t0
    state, metrics = compiled(state, batch, jnp.int32(length))  # warm up
    jax.block_until_ready(metrics)
    t0 = time.perf_counter()
    for _ in range(steps):
        state, metrics = compiled(state, sample(device_data, state.key, state.step), jnp.int32(length))
    jax.block_until_ready((state, metrics))
    per_step = (time.perf_counter() - t0) / steps
    loss = float(metrics["loss"])
    if not np.isfinite(loss):
        print(f"  warning: loss is {loss}")
    return compile_s, per_step


def schedule_lengths(tc, epochs: int) -> list[int]:
    """Transition length of each epoch of the progressive schedule."""
    return [min(tc.max_length, tc.min_length + (e // tc.epochs_per_length) * tc.length_step) for e in range(epochs)]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--config", default="lafan1")
    parser.add_argument("--batch", type=int, default=32)
    parser.add_argument("--length", type=int, default=48, help="transition length (<= window - 2)")
    parser.add_argument("--steps", type=int, default=5, help="timed steps per measurement")
    parser.add_argument("--buckets", default="12,24,36,48", help="static buckets to compare ('' to skip)")
    parser.add_argument("--epoch-steps", type=int, default=None,
                        help="steps per epoch for the projection (default: the full LAFAN1 release, "
                             "20212 training windows / batch)")
    parser.add_argument("overrides", nargs="*")
    args = parser.parse_args()

    config = config_lib.apply_overrides(config_lib.load_config(args.config),
                                        [f"train.batch_size={args.batch}"] + args.overrides)
    mesh = parallel.make_mesh()
    data, _ = datasets.load_training_data(config.data, None)
    spec = specs.train_spec(config)
    print(f"config {args.config}: batch {args.batch}, transition length {args.length}, window "
          f"{config.data.window} frames; {jax.device_count()} x {jax.devices()[0].device_kind} "
          f"({jax.devices()[0].platform}); jax {jax.__version__}")

    t0 = time.perf_counter()
    initial_state = train.create_train_state(spec, jax.random.PRNGKey(0), None, mesh)
    jax.block_until_ready(initial_state)
    print(f"create_train_state (jit init, compile included): {time.perf_counter() - t0:.1f} s")
    compile_s, per_step = time_step(spec, data, args.length, args.steps, None, mesh, initial_state)
    print(f"masked (traced length, full window): compile {compile_s:.1f} s; {per_step * 1e3:.0f} ms/step; "
          f"{args.batch / per_step:.1f} windows/s")
    print(f"peak host RSS {peak_rss_mib():.0f} MiB; device memory: {device_memory()}")

    buckets = [int(b) for b in args.buckets.split(",") if b.strip()]
    if not buckets:
        return
    tc = config.train
    bucket_cost = {}
    for bucket in buckets:
        if bucket + 2 >= config.data.window:  # the full window: the masked step above
            b_compile, b_step = compile_s, per_step
        else:
            b_compile, b_step = time_step(spec, data, min(args.length, bucket), args.steps, bucket + 2, mesh,
                                          initial_state)
        bucket_cost[bucket] = (b_compile, b_step)
        print(f"bucket {bucket:2d} (window {bucket + 2}): compile {b_compile:.1f} s; {b_step * 1e3:.0f} ms/step; "
              f"{args.batch / b_step:.1f} windows/s")
    epoch_steps = args.epoch_steps or max(1, 20212 // args.batch)
    lengths = schedule_lengths(tc, tc.num_epochs)
    masked_total = compile_s + len(lengths) * epoch_steps * per_step

    def bucket_of(length):
        return next(b for b in sorted(buckets) if length <= b)

    bucketed_total = sum(bucket_cost[b][0] for b in {bucket_of(n) for n in lengths})
    bucketed_total += sum(epoch_steps * bucket_cost[bucket_of(n)][1] for n in lengths)
    print(f"projected schedule ({tc.num_epochs} epochs x {epoch_steps} steps, lengths {tc.min_length}->"
          f"{tc.max_length}): masked {masked_total / 3600:.2f} h, buckets {buckets} {bucketed_total / 3600:.2f} h "
          f"({masked_total / bucketed_total:.2f}x)")


if __name__ == "__main__":
    main()
