"""The generator's layers (flax.linen): ``Dense``, ``LSTMCell``, ``MLP``, ``MoEDense`` (gated experts), plain
float32 products ``x @ kernel`` and plain activations.

Each layer forms its products with its ``product`` method and applies its activation with ``activate``, so a
subclass with the same parameters may change how (``stitchjax.accel.matmul``: bfloat16 operands, the ELU's
derivative from its output) without changing the values' meaning or the parameter tree.
Every layer may take its input as a tuple of parts, joined along the last axis.
"""
from __future__ import annotations

from typing import Any

import flax.linen as nn
import jax
import jax.numpy as jnp


__all__ = ["elu", "LAYER_FUNCTIONS", "Layer", "Dense", "LSTMCell", "MLP", "MoEDense", "orthogonal_blocks",
           "expert_init"]


def elu(x):
    """ELU (alpha 1), the values of ``nn.elu``: x where x > 0, else exp(x) - 1."""
    return jnp.where(x > 0, x, jnp.expm1(jnp.minimum(x, 0)))


# What a layer may apply to its matmul output: the ELU of hidden layers, the identity / softmax of output layers.
LAYER_FUNCTIONS = {"elu": elu, "identity": lambda y: y, "softmax": lambda y: jax.nn.softmax(y, axis=-1)}

ModuleDef = Any  # a flax module class (or a functools.partial of one)


def _joined(x):
    """A layer input given as a tuple of parts (..., in_i) joined along the last axis; x itself otherwise."""
    return jnp.concatenate(x, axis=-1) if isinstance(x, (tuple, list)) else x


class Layer(nn.Module):
    """What the layers share: their product and their activation, methods a subclass may replace."""

    def product(self, x, kernel):
        """x (..., in) @ kernel (in, out) -> float32 (..., out)."""
        return x @ kernel

    def activate(self, name: str, y):
        """``LAYER_FUNCTIONS[name]`` applied to y."""
        return LAYER_FUNCTIONS[name](y)


class Dense(Layer):
    """Dense layer x (..., in) -> activation(x @ kernel + bias) (..., features), flax ``nn.Dense``
    initialisation and parameter names; x may be a tuple of parts, joined along the last axis.

    activation: "elu", "identity" or "softmax" (over the features; :data:`LAYER_FUNCTIONS`);
    matmul_dtype: the ``model.matmul_dtype`` setting, read by layers whose ``product`` honours it (the plain
    product is float32).
    """

    features: int
    matmul_dtype: str = "float32"
    activation: str = "identity"

    @nn.compact
    def __call__(self, x):
        x = _joined(x)
        kernel = self.param("kernel", nn.initializers.lecun_normal(), (x.shape[-1], self.features))
        bias = self.param("bias", nn.initializers.zeros, (self.features,))
        return self.activate(self.activation, self.product(x, kernel) + bias)


def orthogonal_blocks(key, shape, dtype=jnp.float32):
    """(H, n * H) kernel made of n independent orthogonal (H, H) blocks (one per LSTM gate)."""
    rows, cols = shape
    keys = jax.random.split(key, cols // rows)
    return jnp.concatenate([nn.initializers.orthogonal()(k, (rows, rows), dtype) for k in keys], axis=1)


class LSTMCell(Layer):
    """LSTM cell with fused gate kernels: carry (c, h) each (..., H), x (..., in) -> (carry, h).

    x may be a tuple of parts, joined along the last axis.
    gates = x @ input_kernel (in, 4H) + h @ hidden_kernel (H, 4H) + bias (4H), gate order i, f, g, o;
    c' = sigmoid(f) c + sigmoid(i) tanh(g), h' = sigmoid(o) tanh(c'). Initialisation as flax's LSTM
    cells (LeCun normal input kernel, orthogonal hidden kernel per gate, zero bias). Two matmuls per
    step and no per-gate concatenation inside the rollout's scan.
    """

    features: int
    matmul_dtype: str = "float32"

    @nn.compact
    def __call__(self, carry, x):
        c, h = carry
        x = _joined(x)
        hidden = self.features
        input_kernel = self.param("input_kernel", nn.initializers.lecun_normal(), (x.shape[-1], 4 * hidden))
        hidden_kernel = self.param("hidden_kernel", orthogonal_blocks, (hidden, 4 * hidden))
        bias = self.param("bias", nn.initializers.zeros, (4 * hidden,))
        gates = self.product(x, input_kernel) + self.product(h, hidden_kernel) + bias
        i, f, g, o = (fn(gate) for fn, gate in zip((jax.nn.sigmoid, jax.nn.sigmoid, jnp.tanh, jax.nn.sigmoid),
                                                  jnp.split(gates, 4, axis=-1)))
        c = f * c + i * g
        h = o * jnp.tanh(c)
        return (c, h), h


class MLP(nn.Module):
    """Dense layers of the given widths; activation after every layer but (optionally) the last, which then
    applies ``last_activation``."""

    widths: tuple
    activation: str = "elu"
    activate_last: bool = True
    matmul_dtype: str = "float32"
    last_activation: str = "identity"  # the last layer's, without activate_last ("softmax": gating)
    dense: ModuleDef = Dense

    @nn.compact
    def __call__(self, x):
        for i, width in enumerate(self.widths):
            last = i == len(self.widths) - 1
            activation = self.last_activation if last and not self.activate_last else self.activation
            x = self.dense(width, self.matmul_dtype, activation, name=f"dense_{i}")(x)
        return x


# The experts' kernels (in, E, out): LeCun normal per expert (fan in = in).
expert_init = nn.initializers.variance_scaling(1.0, "fan_in", "truncated_normal", in_axis=0, out_axis=-1,
                                               batch_axis=(1,))


class MoEDense(Layer):
    """Dense layer of E experts blended by per-example coefficients, then ``activation``.

    x (..., in), coefficients (..., E) -> (..., out) = activation(sum_e c_e (x @ W_e + b_e)). The kernel is
    stored as (in, E, out), so all experts' outputs come from one plain 2-D matmul x @ kernel.reshape(in, E*out)
    followed by the weighted sum over experts. That equals using the blended weights sum_e c_e W_e, never
    materialises a per-example weight matrix, and (unlike a 3-D einsum) leaves XLA no weight-sized
    transposes to do inside the rollout's scan (benchmarks/README.md has the train step's time).
    x may be a tuple of parts, joined along the last axis.
    """

    features: int
    num_experts: int
    matmul_dtype: str = "float32"
    activation: str = "identity"

    @nn.compact
    def __call__(self, x, coefficients):
        x = _joined(x)
        kernel = self.param("kernel", expert_init, (x.shape[-1], self.num_experts, self.features))
        bias = self.param("bias", nn.initializers.zeros, (self.num_experts, self.features))
        flat = self.product(x, kernel.reshape(kernel.shape[0], -1))
        expert_outputs = flat.reshape(flat.shape[:-1] + (self.num_experts, self.features)) + bias
        return self.activate(self.activation, jnp.einsum("...e,...eo->...o", coefficients, expert_outputs))
