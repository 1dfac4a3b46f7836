"""``kernel_matmul``: the generator's products ``x @ W`` with zero probes and recorded inputs, the hooks of the
after-scan weight gradients (:mod:`stitchjax.accel.scan_gradients`) and of the taped replay
(:mod:`stitchjax.accel.tape`).
"""
from __future__ import annotations

import flax.linen as nn
import jax
import jax.numpy as jnp

from stitchjax.accel import tape
from stitchjax.accel.matmul import matmul

__all__ = ["SHARED_PROBES", "LSTM_GATES", "KERNEL_OUTPUT_TAPES", "kernel_matmul", "input_size"]

# Kernels whose product is only ever summed with another kernel's product (the LSTM's gates): they share
# that kernel's probe, whose gradient is the sum's output gradient, so the scan stacks it once.
SHARED_PROBES = {"hidden_kernel": "input_kernel"}
LSTM_GATES = ("input_gate", "forget_gate", "cell_input", "output_gate")  # the gate order i, f, g, o
# Replayed (train.scan_remat="taped"): each kernel's output gradient is the cotangent of these output-tape
# points of its module (tape.OUTPUT_TAPE), concatenated along the output axis in this order.
KERNEL_OUTPUT_TAPES = {"kernel": ("output",), "input_kernel": LSTM_GATES, "hidden_kernel": LSTM_GATES}


def kernel_matmul(module: nn.Module, x, kernel, name: str, dtype: str = "float32"):
    """``x @ kernel`` (kernel (in, ...) flattened to (in, out)) for ``module``'s parameter ``name``.

    x: (..., in), or a tuple of parts (..., in_i) whose concatenation is the input (the parts are recorded
    apart, so a part that is also another matmul's input or a taped value is recorded once).
    dtype: the operands' precision (see :func:`matmul`); the result is float32 either way.

    Plain matmul, except: with a mutable ``"inputs"`` collection the input (or its parts) is recorded under
    ``name``; with a ``"probes"`` collection holding ``name`` (gradient probing, ``rollout.rollout_batch``)
    the kernel is held constant and the zero probe (..., out) is added to the product (a kernel of
    SHARED_PROBES is held constant and adds none: the other kernel's probe serves both). Replaying a tape
    (``stitchjax.accel.tape``) the kernel is held constant too: its output tape's cotangent is the output gradient.
    The caller recovers the kernel gradient as x^T (output gradient) from the recorded inputs.
    """
    parts = _parts(x)
    x = parts[0] if len(parts) == 1 else jnp.concatenate(parts, axis=-1)
    flat = kernel.reshape(kernel.shape[0], -1)
    if module.is_mutable_collection("inputs") and not module.is_initializing():
        module.put_variable("inputs", name, parts if len(parts) > 1 else x)
    probe = SHARED_PROBES.get(name, name)
    if module.has_variable(tape.OUTPUT_TAPE, KERNEL_OUTPUT_TAPES[name][0]):  # replayed: the output tape probes
        return matmul(x, jax.lax.stop_gradient(flat), dtype)
    if not module.has_variable("probes", probe):
        return matmul(x, flat, dtype)
    y = matmul(x, jax.lax.stop_gradient(flat), dtype)
    return y if probe != name else y + module.get_variable("probes", name)


def _parts(x) -> tuple:
    """A matmul input as the tuple of its parts (:func:`kernel_matmul`): x itself, or the parts given."""
    return tuple(x) if isinstance(x, (tuple, list)) else (x,)


def input_size(x) -> int:
    """Last-axis size of a matmul input or of the concatenation of its parts (:func:`kernel_matmul`)."""
    return sum(part.shape[-1] for part in _parts(x))
