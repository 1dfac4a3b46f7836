"""The generator's layers with probes and tape points: the hooks of the after-scan weight gradients
(:mod:`stitchjax.accel.scan_gradients`) and of the taped replay (:mod:`stitchjax.accel.tape`).

``kernel_matmul`` is a product ``x @ W`` that can add a zero probe and record its input; ``ProbedDense``,
``ProbedLSTMCell`` and ``ProbedMoEDense`` are ``accel.matmul``'s layers (same parameters, same values) built on
it, and :func:`probed_generator` the generator made of them, which the training step's rollout runs.
"""
from __future__ import annotations

import flax.linen as nn
import jax
import jax.numpy as jnp

from stitchjax.model import layers, networks
from stitchjax.accel import matmul as matmul_lib
from stitchjax.accel import tape as tape_lib
from stitchjax.accel.matmul import matmul

__all__ = ["SHARED_PROBES", "LSTM_GATES", "KERNEL_OUTPUT_TAPES", "kernel_matmul", "input_size", "ProbedDense",
           "ProbedLSTMCell", "ProbedMoEDense", "probed_generator", "RecordingHook"]

# Kernels whose product is only ever summed with another kernel's product (the LSTM's gates): they share
# that kernel's probe, whose gradient is the sum's output gradient, so the scan stacks it once.
SHARED_PROBES = {"hidden_kernel": "input_kernel"}
LSTM_GATES = ("input_gate", "forget_gate", "cell_input", "output_gate")  # the gate order i, f, g, o
# Replayed (train.scan_remat="taped"): each kernel's output gradient is the cotangent of these output-tape
# points of its module (tape_lib.OUTPUT_TAPE), concatenated along the output axis in this order.
KERNEL_OUTPUT_TAPES = {"kernel": ("output",), "input_kernel": LSTM_GATES, "hidden_kernel": LSTM_GATES}


def kernel_matmul(module: nn.Module, x, kernel, name: str, dtype: str = "float32"):
    """``x @ kernel`` (kernel (in, ...) flattened to (in, out)) for ``module``'s parameter ``name``.

    x: (..., in), or a tuple of parts (..., in_i) whose concatenation is the input (the parts are recorded
    apart, so a part that is also another matmul's input or a taped value is recorded once).
    dtype: the operands' precision (see ``accel.matmul.matmul``); the result is float32 either way.

    Plain matmul, except: with a mutable ``"inputs"`` collection the input (or its parts) is recorded under
    ``name``; with a ``"probes"`` collection holding ``name`` (gradient probing, ``fast_rollout``)
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
    if module.has_variable(tape_lib.OUTPUT_TAPE, KERNEL_OUTPUT_TAPES[name][0]):  # replayed: the output tape probes
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


class ProbedDense(matmul_lib.Dense):
    """:class:`layers.Dense` whose matmul is a :func:`kernel_matmul` and whose output (activation included)
    is the output-tape point "output" (``stitchjax.accel.tape``)."""

    @nn.compact
    def __call__(self, x):
        kernel = self.param("kernel", nn.initializers.lecun_normal(), (input_size(x), self.features))
        bias = self.param("bias", nn.initializers.zeros, (self.features,))
        y = kernel_matmul(self, x, kernel, "kernel", self.matmul_dtype) + bias
        activation = matmul_lib.LAYER_FUNCTIONS[self.activation]
        return tape_lib.tape_point(self, "output", self.activation, y, activation, True)


class ProbedLSTMCell(matmul_lib.LSTMCell):
    """:class:`layers.LSTMCell` with :func:`kernel_matmul` products; each gate's nonlinearity is an
    output-tape point (``LSTM_GATES``) and the cell's tanh a tape point "cell_tanh"."""

    @nn.compact
    def __call__(self, carry, x):
        c, h = carry
        hidden = self.features
        input_kernel = self.param("input_kernel", nn.initializers.lecun_normal(), (input_size(x), 4 * hidden))
        hidden_kernel = self.param("hidden_kernel", layers.orthogonal_blocks, (hidden, 4 * hidden))
        bias = self.param("bias", nn.initializers.zeros, (4 * hidden,))
        gates = (kernel_matmul(self, x, input_kernel, "input_kernel", self.matmul_dtype)
                 + kernel_matmul(self, h, hidden_kernel, "hidden_kernel", self.matmul_dtype) + bias)
        i, f, g, o = (tape_lib.tape_point(self, name, kind, gate, fn, True) for name, kind, fn, gate in zip(
            LSTM_GATES, ("sigmoid", "sigmoid", "tanh", "sigmoid"),
            (jax.nn.sigmoid, jax.nn.sigmoid, jnp.tanh, jax.nn.sigmoid), jnp.split(gates, 4, axis=-1)))
        c = f * c + i * g
        h = o * tape_lib.tape_point(self, "cell_tanh", "tanh", c, jnp.tanh)
        return (c, h), h


class ProbedMoEDense(matmul_lib.MoEDense):
    """:class:`layers.MoEDense` with a :func:`kernel_matmul` product; the experts' outputs are the
    output-tape point "output" and the activation after the blend (if any) the tape point "activation"."""

    @nn.compact
    def __call__(self, x, coefficients):
        kernel = self.param("kernel", layers.expert_init, (input_size(x), self.num_experts, self.features))
        bias = self.param("bias", nn.initializers.zeros, (self.num_experts, self.features))
        flat = kernel_matmul(self, x, kernel, "kernel", self.matmul_dtype)
        expert_outputs = flat.reshape(flat.shape[:-1] + (self.num_experts, self.features)) + bias
        expert_outputs = tape_lib.tape_point(self, "output", "identity", expert_outputs,
                                         matmul_lib.LAYER_FUNCTIONS["identity"], True)
        y = jnp.einsum("...e,...eo->...o", coefficients, expert_outputs)
        if self.activation == "identity":
            return y
        activation = matmul_lib.LAYER_FUNCTIONS[self.activation]
        return tape_lib.tape_point(self, "activation", self.activation, y, activation)


def probed_generator(spec) -> networks.Generator:
    """The generator of a ``networks.GeneratorSpec`` built from the probed layers: the same parameters and
    values as ``networks.make_generator(spec)``, plus the probes, recorded inputs and tape points."""
    return networks.Generator(spec, dense=ProbedDense, lstm_cell=ProbedLSTMCell, moe_dense=ProbedMoEDense)


class RecordingHook:
    """The rollout's per-step extras for the fast paths (``rollout.rollout(..., hook=...)``; the protocol is
    ``rollout.StepHook``'s): zero probes or a recorded tape in, with a leading (num_steps,) axis; the
    generators' recorded matmul inputs and tape out. Each step runs :func:`probed_generator`.

    probes: None or {"forward", "backward"} zero probes (``scan_gradients.zero_probes``); then (without tape)
    rollout returns (result, {"inputs": the generators' kernel-matmul inputs per step, {"forward", "backward"}
    trees of (num_steps, in) arrays, or tuples of the input's parts (:func:`kernel_matmul`)}).
    tape: None; "record": rollout returns (result, {"inputs": ..., "tape": ..., "output_tape": ...}), the
    kernel-matmul inputs and the values the generator steps tape (``stitchjax.accel.tape``), each distinct
    array recorded once; or {"tape": ..., "output_tape": ...} as recorded, to replay (``train.scan_remat=
    "taped"``: the steps' nonlinearities and matmuls are not recomputed, their derivatives come from the tape).
    checkpoint_policy: the scan body's ``jax.checkpoint`` policy (``rollout.StepHook``'s).
    """

    def __init__(self, probes=None, tape=None, checkpoint_policy=None):
        self.checkpoint_policy = checkpoint_policy
        self.record = recorded_collections(probes, tape)
        self.probes = probes
        self.replay = None if tape is None or isinstance(tape, str) else tape
        self._layout = {}

    def scan_inputs(self, truth):
        return (self.probes, truth, self.replay)

    def truth(self, xs_i):
        return xs_i[1]

    def apply(self, spec, name, params, args, xs_i):
        """Generator ``name``'s step: ((carry, outputs), {collection: recorded tree} or None)."""
        probes_i, _, tape_i = xs_i
        probe = None if probes_i is None else probes_i.get(name)
        taped = None if tape_i is None else {collection: t[name] for collection, t in tape_i.items() if name in t}
        variables = {**params, **({} if probe is None else {"probes": probe}), **(taped or {})}
        generator = probed_generator(spec)
        if not self.record:
            return generator.apply(variables, *args), None
        out, recorded = generator.apply(variables, *args, mutable=list(self.record))
        return out, {collection: recorded.get(collection, {}) for collection in self.record}

    def stack(self, records):
        """A step's records as their distinct arrays (:func:`unique_leaves`), what the scan stacks."""
        return unique_leaves(records, self._layout)

    def finish(self, stacked):
        """{collection: {generator: tree}} of the stacked records; None when nothing is recorded."""
        if not self.record:
            return None
        layout = self._layout
        records = jax.tree.unflatten(layout["treedef"], [stacked[j] for j in layout["where"]])
        return {collection: {name: by_collection[collection] for name, by_collection in records.items()}
                for collection in self.record}


def recorded_collections(probes, tape) -> tuple:
    """The variable collections a rollout records (see :class:`RecordingHook`): () when it returns its
    result alone."""
    if isinstance(tape, str) and tape != "record":
        raise ValueError(f"tape={tape!r}: use None, 'record' or a recorded tape")
    if tape == "record":
        return ("inputs", tape_lib.TAPE, tape_lib.OUTPUT_TAPE)
    return ("inputs",) if probes is not None and tape is None else ()


def unique_leaves(tree, layout: dict) -> list:
    """The distinct arrays of ``tree`` (by identity: one value recorded under several names, e.g. an
    activation that is also the next matmul's input, is stacked by the scan once); ``layout`` gets the
    treedef and each leaf's index in the returned list, to rebuild the tree after the scan."""
    leaves, layout["treedef"] = jax.tree.flatten(tree)
    index, unique = {}, []
    for leaf in leaves:
        if id(leaf) not in index:
            index[id(leaf)] = len(unique)
            unique.append(leaf)
    layout["where"] = [index[id(leaf)] for leaf in leaves]
    return unique
