#!/usr/bin/env python3
"""Foot locking's cost against sampling's: 64 transitions of 50 frames on the CPU.

    python benchmarks/footlock.py
    python benchmarks/footlock.py --checkpoint runs/lafan1 --runs 7

The model (the release model, ``stitchjax.pretrained()``, by default; ``--checkpoint random`` for a freshly
initialised lafan1 model) generates ``--samples`` transitions of ``--length`` frames between two keyframes of the bundled
subject5 sample clip through ``inbetween.transitions_in_frame``. Printed, as the median (min) of ``--runs``
timed calls after warm-up:
  - sampling: ``transitions_in_frame`` without the pass;
  - sampling + pass: the same call with ``foot_lock=True``;
  - the pass alone: ``footlock.lock_transitions`` (float64 numpy in and out) and ``footlock.lock_feet``
    (jitted, float32 arrays already on the device);
and the pass's share of sampling time.
"""
from __future__ import annotations

import argparse
import os
import pathlib
import sys
import time

os.environ.setdefault("JAX_PLATFORMS", "cpu")

try:
    import stitchjax  # noqa: F401
except ImportError:
    sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent))

from inference import _time  # noqa: E402  (median and best of the runs, as the sampler's benchmark)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--checkpoint", default=None, help="model folder, or 'random' (default: the release model)")
    parser.add_argument("--length", type=int, default=50)
    parser.add_argument("--samples", type=int, default=64)
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--json", default=None, help="also write the figures to this JSON file")
    args = parser.parse_args(argv)
    started = time.time()
    import jax
    import jax.numpy as jnp
    import numpy as np

    from stitchjax.data import bvh, bundled
    from stitchjax.sample import footlock, inbetween, trained_model
    from stitchjax import config as config_lib

    if args.checkpoint is None:
        model = trained_model.pretrained()
    elif args.checkpoint == "random":
        model = trained_model.random_model(config_lib.load_config("lafan1"), seed=0)
    else:
        model = trained_model.load_model(args.checkpoint)
    take = bvh.load(bundled.sample_files(["subject5"])[0])
    a, b = 100, 100 + args.length + 1
    keys = dict(start=inbetween.Keyframes(take.rotations[[a]], take.positions[[a]], [[1.0, 1.0, 0.0, 0.0]]),
                target=inbetween.Keyframes(take.rotations[[b]], take.positions[[b]], [[0.0, 0.0, 1.0, 1.0]]))
    seed = iter(range(10_000))
    counts = {}

    def sampling(lock):
        return inbetween.transitions_in_frame(model, **keys, length=args.length, num_samples=args.samples,
                                              seed=next(seed), sampling=inbetween.Sampling.paper(foot_lock=lock),
                                              foot_lock_counts=counts)

    rows = {}
    for name, lock in (("sampling", False), ("sampling + pass", True)):
        sampling(lock)
        sampling(lock)
        rows[name] = _time(lambda: sampling(lock), args.runs)

    captured = []
    real = inbetween._locked
    inbetween._locked = lambda m, r, p, c, cfg, n: captured.append((r, p, c)) or r
    sampling(True)
    inbetween._locked = real
    rotations, positions, contacts = captured[0]
    skeleton = take.skeleton
    footlock.lock_transitions(rotations, positions, contacts, skeleton, model.feet)
    rows["pass (numpy in/out)"] = _time(lambda: footlock.lock_transitions(rotations, positions, contacts, skeleton,
                                                                          model.feet), args.runs)
    r32, p32, c32 = (jnp.asarray(x, jnp.float32) for x in (rotations, positions[..., 0, :], contacts))
    o32 = jnp.asarray(positions[..., 0, :, :], jnp.float32)

    def jitted():
        jax.block_until_ready(footlock.lock_feet(r32, p32, c32, skeleton, offsets=o32, feet=model.feet))

    jitted()
    rows["pass (jitted, on device)"] = _time(jitted, args.runs)
    print(f"foot locking benchmark: {args.samples} x {args.length} frames, {args.checkpoint}, median (min) of "
          f"{args.runs} runs after warm-up; {os.cpu_count()} CPU cores visible, {jax.devices()[0]}")
    for name, (median, low) in rows.items():
        print(f"  {name:>26}: {median * 1e3:8.1f} ms ({low * 1e3:.1f})")
    base = rows["sampling"][0]
    print(f"  pass / sampling: {rows['pass (numpy in/out)'][0] / base:.1%} (numpy in/out), "
          f"{rows['pass (jitted, on device)'][0] / base:.1%} (jitted); sampling + pass / sampling: "
          f"{rows['sampling + pass'][0] / base:.3f}")
    share = counts.get("changed", 0) / max(counts.get("leg_frames", 1), 1)
    print(f"  leg-frames changed by the pass: {share:.1%}")
    if args.json:
        import json
        import platform
        import subprocess

        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
        with open(args.json, "w") as f:
            json.dump({"median_s": {k: v[0] for k, v in rows.items()}, "min_s": {k: v[1] for k, v in rows.items()},
                       "pass_share_of_sampling": rows["pass (numpy in/out)"][0] / base,
                       "changed_leg_frames_share": share, "samples": args.samples, "length": args.length,
                       "model": args.checkpoint, "command": "python " + " ".join(sys.argv), "commit": commit,
                       "machine": f"{platform.machine()}, {os.cpu_count()} CPUs (2-core AMD EPYC CPU VM)",
                       "wall_s": time.time() - started}, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
