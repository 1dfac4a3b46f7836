"""Taped replay of the generator step (``train.scan_remat="taped"``): what the rollout's scan saves for the
backward pass, once.

Differentiating a ``lax.scan`` stacks, per step, every intermediate the backward pass needs, and the
after-scan kernel gradients (``accel.scan_gradients``) stack every matmul input beside them: an activation that
feeds the next matmul is stacked twice, and the zero probes that carry the output gradients are a third
array per matmul. Taped, the rollout runs twice instead:

1. **record**: the scan runs undifferentiated; each *tape point* (an activation, a gate, the experts'
   outputs) stores its value, and each matmul its input. One array per distinct value is stacked
   (``accel.probes.unique_leaves``).
2. **replay**: the scan runs again, differentiated, with the tape as input. A tape point returns its taped
   value y instead of computing f(x), so the matmul that made x is dead code, and its backward pass forms
   f'(x) from y (:data:`DERIVATIVES`), reading y from the tape instead of stacking a copy. A tape point that
   takes a layer's matmul output (``OUTPUT_TAPE``) also hands that output's gradient back as the tape's
   own cotangent: these are the output gradients dy of the after-scan kernel gradients x^T dy, so no zero
   probes are needed.

Same gradients as plain autodiff (tests/model/test_rollout.py); the bytes copied and stacked per train step are
in benchmarks/README.md.
"""
from __future__ import annotations

import functools

import flax.linen as nn
import jax
import jax.numpy as jnp

__all__ = ["TAPE", "OUTPUT_TAPE", "DERIVATIVES", "tape_point"]

TAPE = "tape"  # taped values replayed as constants
OUTPUT_TAPE = "output_tape"  # taped values that take a matmul's output; their cotangent is its gradient

# The gradient of y = f(x) with respect to x from the output y and the output's gradient dy, for every kind
# of value a tape point holds (each Jacobian is symmetric, so this is also the tangent): the layers' functions
# (``layers.LAYER_FUNCTIONS``) and the LSTM's gates.
DERIVATIVES = {
    "identity": lambda y, dy: dy,
    "elu": lambda y, dy: dy * jnp.where(y > 0, 1, y + 1).astype(y.dtype),
    "sigmoid": lambda y, dy: dy * y * (1 - y),
    "tanh": lambda y, dy: dy * (1 - y * y),
    "softmax": lambda y, dy: y * (dy - jnp.sum(y * dy, axis=-1, keepdims=True)),
}


@functools.partial(jax.custom_vjp, nondiff_argnums=(0, 1))
def _replayed(kind, hands_back, x, y):
    """y (taped) in place of f(x): x's value is unused, so the work that made it is dead code."""
    del x
    return y


def _replayed_forward(kind, hands_back, x, y):
    del x
    return y, y  # the backward pass keeps y itself, a slice of the tape the scan reads, nothing derived


def _replayed_backward(kind, hands_back, y, dy):
    dx = DERIVATIVES[kind](y, dy)
    return dx, (dx if hands_back else None)


_replayed.defvjp(_replayed_forward, _replayed_backward)


def tape_point(module: nn.Module, name: str, kind: str, x, fn, takes_matmul_output: bool = False):
    """y = fn(x) for ``module``, taped under ``name``; kind: its :data:`DERIVATIVES` key.

    Plain (y = fn(x)) unless the apply call records or replays: with a mutable tape collection it stores y;
    with a tape holding ``name`` it returns the taped y (see the module docstring).
    takes_matmul_output: x is a matmul's output (plus bias), so the tape point belongs to ``OUTPUT_TAPE``
    and its cotangent is that matmul's output gradient.
    """
    collection = OUTPUT_TAPE if takes_matmul_output else TAPE
    if module.has_variable(collection, name):
        return _replayed(kind, takes_matmul_output, x, module.get_variable(collection, name))
    y = fn(x)
    if module.is_mutable_collection(collection) and not module.is_initializing():
        module.put_variable(collection, name, y)
    return y
