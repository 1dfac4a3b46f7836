"""The progressive length schedule (paper §4: transitions from 5 to 50 frames) and the run plan, in steps.

    per_epoch = steps_per_epoch(num_windows, batch_size)          # N_windows // batch_size
    length = transition_length(step, per_epoch, config.train)      # min_length + length_step per epochs_per_length
                                                                   # (then max_length, or a uniform draw)
    window = bucket_window(length, config.train)                   # the compiled window of that length

``train.length_buckets`` groups lengths into a few static windows (one compile each) instead of one
full-window step that masks the frames past the length.
"""
from __future__ import annotations

from typing import NamedTuple

import jax.numpy as jnp
import numpy as np

__all__ = ["ScheduleError", "steps_per_epoch", "transition_length", "total_steps", "RunPlan", "plan_run",
           "bucket_window", "check_lr_decay", "learning_rate_factor"]


class ScheduleError(ValueError):
    """train.length_buckets cannot hold the schedule's lengths."""


def steps_per_epoch(num_windows: int, batch_size: int) -> int:
    """Steps per pass over the training windows (at least 1)."""
    return max(1, num_windows // batch_size)


def transition_length(step: int, steps_per_epoch: int, train_config) -> int:
    """Progressive transition length: min_length, + length_step every `epochs_per_length` epochs, <= max_length.

    An epoch is `steps_per_epoch` steps (N_windows // batch_size). Once the schedule has reached max_length,
    ``train.length_after_schedule`` decides: "max" (the paper) keeps max_length; "uniform" draws each step's
    length uniformly from [min_length, max_length], a pure function of (train.seed, step) so a resumed run
    draws the same lengths.
    """
    grow = int(step) // max(1, int(round(train_config.epochs_per_length * steps_per_epoch)))
    length = int(min(train_config.max_length, train_config.min_length + grow * train_config.length_step))
    if length == train_config.max_length and train_config.length_after_schedule == "uniform":
        draw = np.random.default_rng([int(train_config.seed), int(step)])
        return int(draw.integers(train_config.min_length, train_config.max_length + 1))
    return length


def total_steps(steps_per_epoch: int, train_config) -> int:
    """train.max_steps when > 0, else train.num_epochs epochs."""
    return int(train_config.max_steps) if train_config.max_steps > 0 else int(train_config.num_epochs * steps_per_epoch)


class RunPlan(NamedTuple):
    """How long a run goes and when it saves, in steps."""

    steps_per_epoch: int  # N_windows // batch_size, at least 1
    max_steps: int  # train until this step
    checkpoint_every: int  # save every this many steps


def plan_run(num_windows: int, train_config, max_steps: int | None = None) -> RunPlan:
    """The `RunPlan` of `num_windows` training windows (max_steps None: `total_steps`).

    Raises ScheduleError when train.length_buckets has no bucket for train.max_length, or the learning-rate
    decay ends before it starts.
    """
    tc = train_config
    per_epoch = steps_per_epoch(num_windows, tc.batch_size)
    max_steps = total_steps(per_epoch, tc) if max_steps is None else int(max_steps)
    buckets = [int(b) for b in tc.length_buckets or ()]
    if buckets and max(buckets) < tc.max_length:
        raise ScheduleError(f"train.length_buckets={tuple(buckets)} must include a bucket >= train.max_length="
                            f"{tc.max_length} (or set train.length_buckets= to mask one full-window step)")
    check_lr_decay(tc)  # here, before any work, not when the step is first traced
    checkpoint_every = tc.checkpoint_every_steps or per_epoch  # 0: one checkpoint a training epoch
    return RunPlan(per_epoch, max_steps, checkpoint_every)


def bucket_window(length: int, train_config) -> int | None:
    """Static window (frames) for `length` when train.length_buckets is set, else None (full window)."""
    buckets = tuple(sorted(int(b) for b in train_config.length_buckets or ()))
    if not buckets:
        return None
    for bucket in buckets:
        if length <= bucket:
            return bucket + 2
    raise ScheduleError(f"transition length {length} exceeds the largest of train.length_buckets={buckets}")


def check_lr_decay(train_config) -> None:
    """ScheduleError when a decay is asked for (lr_decay_to != 1) with lr_decay_until_step not after
    lr_decay_from_step."""
    tc = train_config
    if tc.lr_decay_to != 1.0 and tc.lr_decay_until_step <= tc.lr_decay_from_step:
        raise ScheduleError(f"train.lr_decay_until_step={tc.lr_decay_until_step} must be after "
                            f"train.lr_decay_from_step={tc.lr_decay_from_step}")


def learning_rate_factor(step, train_config):
    """Factor on train.learning_rate at `step` (traced or int): 1 until ``lr_decay_from_step``, then linear
    to ``lr_decay_to`` at ``lr_decay_until_step``, then ``lr_decay_to``; 1 everywhere when lr_decay_to is 1."""
    tc = train_config
    if tc.lr_decay_to == 1.0:
        return jnp.ones((), jnp.float32)
    check_lr_decay(tc)
    done = (jnp.asarray(step, jnp.float32) - tc.lr_decay_from_step) / (tc.lr_decay_until_step - tc.lr_decay_from_step)
    return 1.0 + (tc.lr_decay_to - 1.0) * jnp.clip(done, 0.0, 1.0)
