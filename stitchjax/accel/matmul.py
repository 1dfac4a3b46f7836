"""The generator's layers with two custom derivatives that change what the backward pass keeps, never the
values: the matmul on ``model.matmul_dtype`` operands and the ELU whose derivative comes from its output.

``Dense``, ``LSTMCell`` and ``MoEDense`` are ``stitchjax.model.layers``' with these ``product`` and
``activate``: the same parameters. :func:`with_layers` puts them into a rollout spec's generator; the training
step (``specs.train_spec``) and the sampler's model loader (``sample.trained_model``) run the generator on them.
"""
from __future__ import annotations

import dataclasses
import functools

import jax
import jax.numpy as jnp

from stitchjax.config import CHOICES
from stitchjax.model import layers

__all__ = ["MATMUL_DTYPES", "matmul", "elu", "LAYER_FUNCTIONS", "Dense", "LSTMCell", "MoEDense", "LAYERS",
           "with_layers"]


elu = jax.custom_jvp(layers.elu)
elu.__doc__ = """ELU (alpha 1), the values of ``layers.elu``; its derivative is formed from the output y (1 where
y > 0, else y + 1 = exp(x)), so the backward pass keeps one array per layer instead of x's exponential and two
masks (benchmarks/README.md, copies and stacking per step)."""


@elu.defjvp
def _elu_jvp(primals, tangents):
    (x,), (dx,) = primals, tangents
    y = elu(x)
    return y, dx * jnp.where(y > 0, 1, y + 1).astype(y.dtype)


MATMUL_DTYPES = {name: jnp.dtype(name) for name in CHOICES[("model", "matmul_dtype")]}

# The layers' functions (``layers.LAYER_FUNCTIONS``) with the ELU above.
LAYER_FUNCTIONS = {**layers.LAYER_FUNCTIONS, "elu": elu}


def matmul(x, kernel, dtype: str = "float32"):
    """x (..., in) @ kernel (in, out) -> float32 (..., out).

    dtype "float32": plain float32 matmul. "bfloat16": both operands rounded to bfloat16, products
    accumulated in float32, and the same for the two gradient products (output gradient rounded to
    bfloat16): only the matmuls' operands lose precision; everything between them stays float32.
    """
    if dtype not in MATMUL_DTYPES:
        raise ValueError(f"model.matmul_dtype={dtype!r}: use one of {', '.join(MATMUL_DTYPES)}")
    if dtype == "float32":
        return x @ kernel
    return _low_precision_matmul(x, kernel, dtype)


@functools.partial(jax.custom_vjp, nondiff_argnums=(2,))
def _low_precision_matmul(x, kernel, dtype):
    return _low_precision_matmul_forward(x, kernel, dtype)[0]


def _low_precision_matmul_forward(x, kernel, dtype):
    low = MATMUL_DTYPES[dtype]
    x, kernel = x.astype(low), kernel.astype(low)
    return jnp.matmul(x, kernel, preferred_element_type=jnp.float32), (x, kernel)


def _low_precision_matmul_backward(dtype, residuals, dy):
    # Written out because autodiff of the forward would run both products on float32 operands.
    x, kernel = residuals
    dy = dy.astype(x.dtype)
    dx = jax.lax.dot_general(dy, kernel, (((dy.ndim - 1,), (1,)), ((), ())), preferred_element_type=jnp.float32)
    leading = tuple(range(x.ndim - 1))
    dkernel = jax.lax.dot_general(x, dy, ((leading, leading), ((), ())), preferred_element_type=jnp.float32)
    return dx, dkernel


_low_precision_matmul.defvjp(_low_precision_matmul_forward, _low_precision_matmul_backward)


class _Fast:
    """``product`` on ``self.matmul_dtype`` operands (:func:`matmul`), ``activate`` with :data:`LAYER_FUNCTIONS`."""

    def product(self, x, kernel):
        """x (..., in) @ kernel (in, out) -> float32 (..., out), on ``matmul_dtype`` operands."""
        return matmul(x, kernel, self.matmul_dtype)

    def activate(self, name: str, y):
        """``LAYER_FUNCTIONS[name]`` applied to y."""
        return LAYER_FUNCTIONS[name](y)


class Dense(_Fast, layers.Dense):
    """``layers.Dense`` on :func:`matmul` and :data:`LAYER_FUNCTIONS`."""


class LSTMCell(_Fast, layers.LSTMCell):
    """``layers.LSTMCell`` on :func:`matmul`."""


class MoEDense(_Fast, layers.MoEDense):
    """``layers.MoEDense`` on :func:`matmul` and :data:`LAYER_FUNCTIONS`."""


LAYERS = (Dense, LSTMCell, MoEDense)  # networks.Generator's (dense, lstm_cell, moe_dense)


def with_layers(spec):
    """A ``rollout.RolloutSpec`` whose generator runs on :data:`LAYERS` (``GeneratorSpec.layers``)."""
    return dataclasses.replace(spec, generator=dataclasses.replace(spec.generator, layers=LAYERS))
