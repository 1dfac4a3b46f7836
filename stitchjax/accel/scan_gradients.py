"""Generator weight gradients formed after the rollout's scan (``train.weight_gradients_after_scan``).

What it buys: differentiating a ``lax.scan`` makes every backward step form
and accumulate its own weight gradient x^T dy from one step's few rows (B = 32), a matmul CPUs and GPUs run
far below their peak. Instead the generators' kernels are held constant inside the scan, every product
``x @ W`` gets a zero probe added and records its input x (``accel.probes.kernel_matmul``); the probes'
gradients are the products' output gradients dy, and after the scan each kernel's gradient is ONE matmul
x^T dy over all B x steps rows. Same gradients (tested against plain autodiff), a shorter train step and a
smaller program to compile (benchmarks/README.md has both times).

:func:`gradients_after_scan` wraps any function of the generators that accepts probes; the training step's
rollout uses it (:mod:`stitchjax.accel.fast_rollout`).
"""
from __future__ import annotations

import math
from collections.abc import Mapping

import jax
import jax.numpy as jnp

from stitchjax.accel import tape
from stitchjax.accel.matmul import MATMUL_DTYPES
from stitchjax.accel.probes import KERNEL_OUTPUT_TAPES, SHARED_PROBES

__all__ = ["zero_probes", "kernel_gradients", "output_gradients", "add_kernel_gradients", "gradients_after_scan"]

KERNEL_NAMES = ("kernel", "input_kernel", "hidden_kernel")  # probes.kernel_matmul parameter names


def _kernels(tree: dict, fn) -> dict:
    """The sub-tree of ``tree`` (nested dicts) whose leaves are probed kernels (not those that share another
    kernel's probe, ``probes.SHARED_PROBES``), with ``fn`` applied to them."""
    out = {}
    for name, value in tree.items():
        if isinstance(value, Mapping):
            out[name] = _kernels(value, fn)
        elif name in KERNEL_NAMES and name not in SHARED_PROBES:
            out[name] = fn(value)
    return out


def zero_probes(generators: dict, leading: tuple) -> dict:
    """Zero probes {"forward", "backward"}: per kernel (in, ...) of each generator a (*leading, out) array,
    out = kernel.size // in (an expert kernel (in, E, out') flattens to E * out')."""
    return {name: _kernels(params["params"], lambda k: jnp.zeros(leading + (k.size // k.shape[0],), k.dtype))
            for name, params in generators.items()}


def kernel_gradients(generators: dict, inputs: dict, output_grads: dict, matmul_dtype: str = "float32") -> dict:
    """Kernel gradients {name: {"params": tree of kernel-shaped arrays}}: sum over all leading axes of
    x^T dy, with x the recorded matmul inputs (..., in) (or a tuple of the input's parts) and dy the output
    gradients (..., out), or a tuple of blocks of them along the output axis (:func:`output_gradients`).
    Only the kernels whose matmul ran (recorded an input) appear. matmul_dtype: operand precision of these
    products (float32 accumulation either way)."""
    low = MATMUL_DTYPES[matmul_dtype]

    def gradient(kernel, x, dy):
        parts = x if isinstance(x, tuple) else (x,)  # an input recorded as parts: one block of rows each
        blocks = dy if isinstance(dy, tuple) else (dy,)  # output gradients in blocks: one block of columns
        count = math.prod(parts[0].shape[:-1])  # the rows: every leading position (steps x batch)

        def rows(a):  # (..., n) -> (rows, n); an expert layer's (..., E, out) output gradient -> (rows, E * out)
            return a.reshape(count, -1).astype(low)

        # (rows, in) x (rows, out) contracted over the rows as one dot: no transposed copy of x beforehand
        dk = [[jax.lax.dot_general(rows(part), rows(block), (((0,), (0,)), ((), ())),
                                   preferred_element_type=jnp.float32) for block in blocks] for part in parts]
        dk = jnp.concatenate([row[0] if len(row) == 1 else jnp.concatenate(row, axis=1) for row in dk], axis=0)
        return dk.reshape(kernel.shape).astype(kernel.dtype)

    def walk(kernels, recorded, dy):
        return {name: (walk(kernels[name], value, dy[name]) if isinstance(value, Mapping)
                       else gradient(kernels[name], value, dy[name])) for name, value in recorded.items()}

    return {name: {"params": walk(generators[name]["params"], recorded, output_grads[name])}
            for name, recorded in inputs.items() if recorded}


def output_gradients(inputs: dict, grads: dict, taped: bool) -> dict:
    """The output gradient of every recorded kernel matmul, a tree like ``inputs`` (one entry per kernel).

    taped False: grads are the probes' gradients (a kernel of ``probes.SHARED_PROBES`` takes its partner's);
    True: grads are the output tape's cotangents (``stitchjax.accel.tape``), and a kernel's output gradient is the
    tuple of its module's ``probes.KERNEL_OUTPUT_TAPES`` entries, blocks along the output axis.
    """
    def walk(recorded, module_grads):
        out = {}
        for name, value in recorded.items():
            if isinstance(value, Mapping):
                out[name] = walk(value, module_grads[name])
            elif taped:
                out[name] = tuple(module_grads[t] for t in KERNEL_OUTPUT_TAPES[name])
            else:
                out[name] = module_grads[SHARED_PROBES.get(name, name)]
        return out

    return {name: walk(recorded, grads[name]) for name, recorded in inputs.items() if recorded}


def add_kernel_gradients(grads: dict, kernel_grads: dict) -> dict:
    """grads with the arrays of the (sub-)tree kernel_grads added at the same places."""
    out = dict(grads)
    for name, value in kernel_grads.items():
        out[name] = add_kernel_gradients(grads[name], value) if isinstance(value, Mapping) else grads[name] + value
    return out


def gradients_after_scan(run, leading: tuple, matmul_dtype: str = "float32", taped: bool = False):
    """``run`` with its generator kernel gradients formed after the scan.

    run(generators, inputs, constants, probes=None, tape=None) -> output when neither is given; with probes
    alone -> (output, {"inputs": recorded matmul inputs {"forward", "backward"}}); with tape="record" ->
    (output, {"inputs": ..., tape.TAPE: ..., tape.OUTPUT_TAPE: ...}) and with such a recorded tape (its two
    tape collections) -> output, replaying it (``stitchjax.accel.tape``). leading: the probes' leading shape (the
    rollout's: (scan steps, batch), the order its recorded values come out in).
    inputs: a pytree differentiated as usual; constants: a pytree of non-differentiable arrays (keys,
    integer lengths). Returns f(generators, inputs, constants) with run's value and the same gradients as
    plain autodiff of it.

    taped (``train.scan_remat="taped"``): the forward pass runs the scan twice, first undifferentiated,
    recording every matmul input and taped value once, then differentiated, replaying the tape; the output
    gradients come back as the output tape's cotangents instead of through zero probes (``stitchjax.accel.tape``).
    """
    @jax.custom_vjp
    def f(generators, inputs, constants):
        return run(generators, inputs, constants)

    def forward(generators, inputs, constants):
        if taped:
            _, records = run(generators, inputs, constants, tape="record")
            constant_tape = records[tape.TAPE]
            out, vjp_fn = jax.vjp(
                lambda g, x, t: run(g, x, constants, None, {tape.TAPE: constant_tape, tape.OUTPUT_TAPE: t}),
                generators, inputs, records[tape.OUTPUT_TAPE])
        else:
            probes = zero_probes(generators, leading)
            out, vjp_fn, records = jax.vjp(lambda g, x, p: run(g, x, constants, p), generators, inputs, probes,
                                           has_aux=True)
        return out, (vjp_fn, generators, records["inputs"])

    def backward(residuals, cotangent):
        vjp_fn, generators, recorded = residuals
        d_generators, d_inputs, d_outputs = vjp_fn(cotangent)
        dy = output_gradients(recorded, d_outputs, taped)
        d_generators = add_kernel_gradients(d_generators, kernel_gradients(generators, recorded, dy, matmul_dtype))
        return d_generators, d_inputs, None

    f.defvjp(forward, backward)
    return f
