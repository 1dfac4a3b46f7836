"""benchmarks/flops.py reads matmul FLOPs and data movement off optimised HLO, loop trip counts included."""
import pathlib
import sys

import jax
import jax.numpy as jnp

BENCH = pathlib.Path(__file__).resolve().parent.parent / "benchmarks"
if str(BENCH) not in sys.path:
    sys.path.insert(0, str(BENCH))

import flops  # noqa: E402


def test_scan_counts_its_trip_count_for_matmuls_and_stacking():
    steps, rows, width = 12, 8, 64

    def fn(x, w):
        def body(carry, _):
            carry = jnp.tanh(carry @ w)
            return carry, carry  # stacked into a (steps, rows, width) buffer

        return jax.lax.scan(body, x, None, length=steps)[1]

    x, w = jnp.ones((rows, width)), jnp.ones((width, width)) * 0.01
    result = flops.hlo_matmul_flops(jax.jit(fn).lower(x, w).compile())
    assert result["matmul_flops"] == 2.0 * steps * rows * width * width
    # every step writes its (rows, width) float32 output into the stacked buffer at least once
    assert result["update_slice_bytes"] >= steps * rows * width * 4
    assert result["copy_bytes"] >= 0.0
    assert flops._bytes("f32[28,32,512]{2,1,0}") == 28 * 32 * 512 * 4
    assert flops._bytes("pred[3,4]") == 12
