"""Where a train step's time goes: its parts compiled and timed alone, with their matmul FLOPs.

    python benchmarks/step_parts.py                              # lafan1, batch 32, length 48, both precisions
    python benchmarks/step_parts.py --batch 128 --dtypes float32

Parts (each one jitted program, compiled ahead of time, timed after two warm-up calls; medians):

- rollout: both generators' bidirectional aligned rollout (one ``lax.scan``), forward only;
- generator loss + grad: rollout, every generator loss term (FK, stitching, KL, adversarial) and the
  backward pass, no optimiser;
- train step: ``train.make_train_step`` (batch sampling, the generator part above, AdamW on the generators,
  the discriminator update).

For each: ms per call, matmul FLOPs of the optimised HLO (loop trip counts included, ``flops.py``) and the
achieved GFLOP/s. Prints figures; asserts nothing. Data: synthetic windows as in ``run_all.py``.
"""
from __future__ import annotations

import argparse

import run_all  # sets the jax platform / compilation cache and sys.path

import flops as flops_lib


def parts(batch: int, length: int, dtype: str, reps: int) -> list:
    import jax

    from stitchjax import losses, rollout

    config = run_all.bench_config(batch, length, [f"model.matmul_dtype={dtype}"])
    whole = run_all.JaxTrain(config, length)
    state = whole.state
    sample = whole.sample(whole.dataset, state.key, state.step)
    key = jax.random.PRNGKey(3)
    generators = {name: state.params[name] for name in ("forward", "backward")}

    def forward(generators, phase_params, sample):
        out = rollout.rollout_batch(generators, phase_params, sample, key, config, length)
        return out["global_positions"]

    def loss(generators, phase_params, sample):
        return losses.generator_loss({**state.params, **generators}, phase_params, sample, key, config, length)[0]

    rows = []
    for name, fn in (("rollout", forward), ("generator loss + grad", jax.grad(loss))):
        compiled = jax.jit(fn).lower(generators, state.phase_params, sample).compile()
        seconds = run_all.timeit(lambda: jax.block_until_ready(compiled(generators, state.phase_params, sample)),
                                 warmup=2, reps=reps)["median_s"]
        rows.append((name, seconds, flops_lib.hlo_matmul_flops(compiled)["matmul_flops"]))
    seconds = run_all.timeit(whole.run, warmup=2, reps=reps)["median_s"]
    rows.append(("train step", seconds, flops_lib.hlo_matmul_flops(whole.compiled)["matmul_flops"]))
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--batch", type=int, default=run_all.TRAIN_BATCH, help="windows per step (default 32)")
    parser.add_argument("--length", type=int, default=run_all.TRAIN_LENGTH, help="transition length (default 48)")
    parser.add_argument("--dtypes", default="float32,bfloat16", help="model.matmul_dtype values to time")
    parser.add_argument("--reps", type=int, default=5, help="timed calls per part (default 5)")
    args = parser.parse_args(argv)
    peak = flops_lib.theoretical_peak_flops()["flops"]
    print(f"batch {args.batch}, transition length {args.length}; theoretical float32 peak {peak / 1e9:.1f} GFLOP/s")
    print(f"{'matmul dtype':<13} {'part':<22} {'ms':>8} {'GFLOP':>8} {'GFLOP/s':>8} {'% fp32 peak':>11}")
    for dtype in [d.strip() for d in args.dtypes.split(",") if d.strip()]:
        for name, seconds, flop in parts(args.batch, args.length, dtype, args.reps):
            print(f"{dtype:<13} {name:<22} {1e3 * seconds:8.0f} {flop / 1e9:8.1f} {flop / seconds / 1e9:8.1f} "
                  f"{100 * flop / seconds / peak:10.1f}%")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
