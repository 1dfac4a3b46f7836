"""Generator weight gradients formed after the rollout's scan (``train.weight_gradients_after_scan``).

What it buys (measured, benchmarks/README.md): differentiating a ``lax.scan`` makes every backward step form
and accumulate its own weight gradient x^T dy from one step's few rows (B = 32), a matmul CPUs and GPUs run
far below their peak. Instead the generators' kernels are held constant inside the scan, every product
``x @ W`` gets a zero probe added and records its input x (``networks.kernel_matmul``); the probes'
gradients are the products' output gradients dy, and after the scan each kernel's gradient is ONE matmul
x^T dy over all B x steps rows. Same gradients (tested against plain autodiff); train step -7 % and the
update's compile time 90 -> 25 s on a 2-core Zen 3 CPU.

:func:`gradients_after_scan` wraps any function of the generators that accepts probes; the rollout uses it.
"""
from __future__ import annotations

from collections.abc import Mapping

import jax
import jax.numpy as jnp

from stitchjax import networks

__all__ = ["zero_probes", "kernel_gradients", "add_kernel_gradients", "gradients_after_scan"]

KERNEL_NAMES = ("kernel", "input_kernel", "hidden_kernel")  # networks.kernel_matmul parameter names


def _kernels(tree: dict, fn) -> dict:
    """The sub-tree of ``tree`` (nested dicts) whose leaves are kernels, with ``fn`` applied to them."""
    out = {}
    for name, value in tree.items():
        if isinstance(value, Mapping):
            out[name] = _kernels(value, fn)
        elif name in KERNEL_NAMES:
            out[name] = fn(value)
    return out


def zero_probes(generators: dict, leading: tuple) -> dict:
    """Zero probes {"forward", "backward"}: per kernel (in, ...) of each generator a (*leading, out) array,
    out = kernel.size // in (an expert kernel (in, E, out') flattens to E * out')."""
    return {name: _kernels(params["params"], lambda k: jnp.zeros(leading + (k.size // k.shape[0],), k.dtype))
            for name, params in generators.items()}


def kernel_gradients(generators: dict, inputs: dict, probe_grads: dict, matmul_dtype: str = "float32") -> dict:
    """Kernel gradients {name: {"params": tree of kernel-shaped arrays}}: sum over all leading axes of
    x^T dy, with x the recorded matmul inputs (..., in) and dy the probes' gradients (..., out). Only the
    kernels whose matmul ran (recorded an input) appear. matmul_dtype: operand precision of these
    products (float32 accumulation either way)."""
    low = networks.MATMUL_DTYPES[matmul_dtype]

    def gradient(kernel, x, dy):
        x, dy = x.astype(low), dy.astype(low)
        dk = jnp.einsum("...i,...o->io", x, dy, preferred_element_type=jnp.float32)
        return dk.reshape(kernel.shape).astype(kernel.dtype)

    def walk(kernels, recorded, dy):
        return {name: (walk(kernels[name], value, dy[name]) if isinstance(value, Mapping)
                       else gradient(kernels[name], value, dy[name])) for name, value in recorded.items()}

    return {name: {"params": walk(generators[name]["params"], recorded, probe_grads[name])}
            for name, recorded in inputs.items()}


def add_kernel_gradients(grads: dict, kernel_grads: dict) -> dict:
    """grads with the arrays of the (sub-)tree kernel_grads added at the same places."""
    out = dict(grads)
    for name, value in kernel_grads.items():
        out[name] = add_kernel_gradients(grads[name], value) if isinstance(value, Mapping) else grads[name] + value
    return out


def gradients_after_scan(run, leading: tuple, matmul_dtype: str = "float32"):
    """``run`` with its generator kernel gradients formed after the scan.

    run(generators, inputs, constants, probes) -> output when probes is None, else (output, recorded
    matmul inputs {"forward", "backward"}); leading: the probes' leading shape (the rollout's: (scan steps,
    batch), the order its recorded inputs come out in).
    inputs: a pytree differentiated as usual; constants: a pytree of non-differentiable arrays (keys,
    integer lengths). Returns f(generators, inputs, constants) with run's value and the same gradients as
    plain autodiff of it.
    """
    @jax.custom_vjp
    def f(generators, inputs, constants):
        return run(generators, inputs, constants, None)

    def forward(generators, inputs, constants):
        probes = zero_probes(generators, leading)
        out, vjp_fn, recorded = jax.vjp(lambda g, x, p: run(g, x, constants, p), generators, inputs, probes,
                                        has_aux=True)
        return out, (vjp_fn, generators, recorded)

    def backward(residuals, cotangent):
        vjp_fn, generators, recorded = residuals
        d_generators, d_inputs, d_probes = vjp_fn(cotangent)
        d_generators = add_kernel_gradients(d_generators, kernel_gradients(generators, recorded, d_probes,
                                                                           matmul_dtype))
        return d_generators, d_inputs, None

    f.defvjp(forward, backward)
    return f
