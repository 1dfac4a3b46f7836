#!/usr/bin/env python3
"""Inference speed: latency of one transition and throughput of a batch of samples.

    python benchmarks/inference.py                       # lafan1 and quickstart configs, CPU
    python benchmarks/inference.py --configs lafan1 --length 50 --samples 64 --runs 7

For each config a freshly initialised model (random weights time the same as trained ones) generates
transitions between two keyframes of the bundled sample's subject5 clip through the public API
(``inbetween.transitions_in_frame``: alignment, one jitted vmapped rollout, mapping back, keyframe
overwrite). Printed: compile time of the first call, then the median (and min) over ``--runs`` timed
calls after warm-up of
  - latency: 1 sample of L frames;
  - throughput: ``--samples`` samples of L frames in one call (samples/s and generated frames/s).
Set JAX_PLATFORMS=cpu (the default here) or gpu to choose the device.
"""
from __future__ import annotations

import argparse
import os
import pathlib
import statistics
import sys
import time

os.environ.setdefault("JAX_PLATFORMS", "cpu")

try:
    import stitchjax  # noqa: F401
except ImportError:
    sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent))


def _time(fn, runs: int) -> tuple[float, float]:
    times = []
    for _ in range(runs):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), min(times)


def bench(config_name: str, length: int, samples: int, runs: int) -> dict:
    import jax

    from stitchjax.data import bvh, bundled
    from stitchjax.sample import inbetween, trained_model
    from stitchjax import config as config_lib

    config = config_lib.load_config(config_name)
    model = trained_model.random_model(config, seed=0)
    take = bvh.load(bundled.sample_files(["subject5"])[0])
    a, b = 100, 100 + length + 1
    keys = dict(start=inbetween.Keyframes(take.rotations[[a]], take.positions[[a]], [[1.0, 1.0, 0.0, 0.0]]),
                target=inbetween.Keyframes(take.rotations[[b]], take.positions[[b]], [[0.0, 0.0, 1.0, 1.0]]))
    params = sum(x.size for x in jax.tree.leaves(model.params))
    row = {"config": config_name, "generator_params": params, "device": str(jax.devices()[0])}
    for name, count in (("latency", 1), ("throughput", samples)):
        seed = iter(range(10_000))

        def call():
            return inbetween.transitions_in_frame(model, **keys, length=length, num_samples=count, seed=next(seed))

        t0 = time.perf_counter()
        call()
        row[f"{name}_first_call_s"] = time.perf_counter() - t0
        call()  # warm-up
        row[f"{name}_median_s"], row[f"{name}_min_s"] = _time(call, runs)
    row["samples_per_s"] = samples / row["throughput_median_s"]
    row["frames_per_s"] = samples * length / row["throughput_median_s"]
    return row


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--configs", default="lafan1,quickstart", help="comma-separated config names")
    parser.add_argument("--length", type=int, default=50, help="generated frames per transition (default 50)")
    parser.add_argument("--samples", type=int, default=64, help="samples in the throughput call (default 64)")
    parser.add_argument("--runs", type=int, default=5, help="timed runs after warm-up (default 5)")
    args = parser.parse_args(argv)
    import warnings

    from stitchjax import config as config_lib

    warnings.filterwarnings("ignore", message="transition length .* longer than")  # random weights anyway

    available = set(config_lib.available_configs())
    print(f"inference benchmark: L = {args.length} frames, {args.samples} samples, median of {args.runs} runs "
          f"after warm-up; {os.cpu_count()} CPU cores visible")
    for name in args.configs.split(","):
        if name not in available:
            print(f"{name}: no configs/{name}.py, skipped")
            continue
        r = bench(name, args.length, args.samples, args.runs)
        print(f"{r['config']:>11} ({r['generator_params'] / 1e6:.2f} M generator params, {r['device']}): "
              f"compile+first call {r['latency_first_call_s']:.1f} s / {r['throughput_first_call_s']:.1f} s; "
              f"latency 1 x {args.length} frames {r['latency_median_s'] * 1e3:.0f} ms "
              f"(min {r['latency_min_s'] * 1e3:.0f}); "
              f"{args.samples} x {args.length} frames {r['throughput_median_s'] * 1e3:.0f} ms "
              f"(min {r['throughput_min_s'] * 1e3:.0f}) = {r['samples_per_s']:.0f} samples/s, "
              f"{r['frames_per_s']:.0f} frames/s", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
