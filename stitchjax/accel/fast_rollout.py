"""The training step's rollout of a batch: ``batch.rollout_batch`` with the fast paths of ``config.train``.

Same values and gradients as the plain rollout, less time (benchmarks/README.md):

- ``train.weight_gradients_after_scan`` (default): the generators' kernel gradients are formed after the scan,
  one matmul per kernel (:mod:`stitchjax.accel.scan_gradients`);
- ``train.scan_remat="taped"``: the scan runs twice, recording then replaying a tape, so that each value the
  backward pass needs is stacked once (:mod:`stitchjax.accel.tape`); the other values of ``train.scan_remat``
  are ``jax.checkpoint`` policies of the scan body (:data:`SCAN_REMAT`).

The training step (``train.loop.make_update_step``) builds :func:`training_rollout_batch` once and hands it to
the losses; the model's rollout sees only its runner and the hook (``rollout.StepHook``) it passes.
"""
from __future__ import annotations

import functools
from typing import Callable

import jax

from stitchjax.accel import probes as probes_lib
from stitchjax.accel import scan_gradients
from stitchjax.model import batch as batch_lib
from stitchjax.model.rollout import StepHook, num_steps, rollout

__all__ = ["SCAN_REMAT", "training_rollout_batch", "fast_runner"]

# train.scan_remat -> the jax.checkpoint policy of the rollout's scan body (None: none, every intermediate kept);
# "taped" checkpoints nothing either: the scan it differentiates replays a recorded tape (fast_runner).
SCAN_REMAT = {
    "none": None,
    "dots": jax.checkpoint_policies.dots_saveable,
    "nothing": jax.checkpoint_policies.nothing_saveable,
    "taped": None,
}


def training_rollout_batch(train_config) -> Callable:
    """``batch.rollout_batch`` as the training step runs it: with the runner of ``train_config``'s
    ``weight_gradients_after_scan`` and ``scan_remat`` (:func:`fast_runner`); the same signature and values."""
    runner = functools.partial(fast_runner, after_scan=train_config.weight_gradients_after_scan,
                               scan_remat=train_config.scan_remat)
    return functools.partial(batch_lib.rollout_batch, runner=runner)


def fast_runner(generators, inputs, constants, spec, max_length: int, *, after_scan: bool, scan_remat: str):
    """A runner of ``batch.rollout_batch`` (the arguments of ``batch.vmapped_rollout``) with the fast paths.

    after_scan: the generators' kernel gradients formed after the scan (``scan_gradients.gradients_after_scan``);
    scan_remat: a ``train.scan_remat`` value ("taped" needs after_scan).
    Returns ``vmapped_rollout``'s result, with the same values and gradients.
    """
    taped = scan_remat == "taped"
    _check_taped(after_scan, taped)
    policy = SCAN_REMAT[scan_remat]
    if not after_scan:
        return batch_lib.vmapped_rollout(generators, inputs, constants, spec, max_length, policy)
    run = functools.partial(_probed_run, spec=spec, max_length=max_length, checkpoint_policy=policy)
    leading = (num_steps(spec, max_length), constants[0].shape[0])
    run_probed = scan_gradients.gradients_after_scan(run, leading, spec.generator.matmul_dtype, taped)
    return run_probed(generators, inputs, constants)


def _check_taped(after_scan: bool, taped: bool) -> None:
    """ValueError for a ``train.scan_remat=taped`` that cannot run (see :func:`fast_runner`)."""
    if taped and not after_scan:
        raise ValueError("train.scan_remat=taped needs train.weight_gradients_after_scan=true (the tape is "
                         "recorded by the after-scan gradients' forward pass)")


def _probed_run(generators, inputs, constants, probes=None, tape=None, *, spec, max_length: int,
                checkpoint_policy=None):
    """``vmapped_rollout`` with probes and tape, the ``run`` of ``scan_gradients.gradients_after_scan``:
    each window's rollout runs with a ``probes.RecordingHook`` when probes or a tape are given."""
    phase_params, start, target, offsets, truth = inputs
    keys, length, use_prior = constants
    record = isinstance(tape, str)  # "record" (recorded_collections refuses any other string)
    recording = bool(probes_lib.recorded_collections(probes, tape))

    def one(s, t, o, k, g, u, p, taped):
        taped = "record" if record else taped
        hook = (StepHook(checkpoint_policy) if p is None and taped is None
                else probes_lib.RecordingHook(p, taped, checkpoint_policy))
        return rollout(generators, phase_params, (s, t, o), k, spec, length, max_length,
                       latent=batch_lib.latent_inputs(g, u), hook=hook)

    # Probes and taped values in, recorded values out stay step-major (steps, B, ...), the layout the
    # batched scan keeps them in, so the scan and the after-scan kernel gradients read them without a
    # transposing copy.
    return jax.vmap(one, in_axes=(0, 0, 0, 0, 0, 0, 1, 1), out_axes=(0, 1) if recording else 0)(
        start, target, offsets, keys, truth, use_prior, probes, None if record else tape)
