"""Small frozen specs resolved once from the ``Config`` where training or a loaded model starts.

Below that point functions take the spec they read, not the whole ``Config``:

- :class:`SkeletonSpec`: the skeleton facts the losses and metrics need (parents, feet, up axis, scales),
  read once from the dataset entry (``stitchjax.data.datasets``) and ``config.data``;
- :class:`LossSpec`: the loss section (the weights of paper Eq. 9 and the extensions' switches) and the
  model switches that decide which terms exist (posterior, directions, discriminators);
- :class:`TrainSpec`: what training reads below ``train.loop.train``: the two above, the rollout's
  ``rollout.RolloutSpec`` (L's scan, K, the generator's sizes and switches), the networks to initialise
  (``networks.ModelSpec``), the optimiser, schedule and run settings (``config.train``), the phase network
  (``config.phase``) and how a training batch is cut (window, random starts).

Every spec is a frozen, hashable dataclass, so a jitted function may close over it or take it as a static
argument. Built by :func:`train_spec` (the one builder here that reads the whole ``Config``) from
:func:`skeleton_spec`, :func:`loss_spec` and ``networks.model_spec`` (each of the config sections it reads)
and ``rollout.rollout_spec``; a loaded model builds its own (``sample.trained_model``).
"""
from __future__ import annotations

import dataclasses
from typing import Any

from stitchjax.accel import matmul as accel_matmul
from stitchjax.data import conform, datasets, features
from stitchjax.model import networks
from stitchjax.model import rollout as rollout_lib

__all__ = ["SkeletonSpec", "LossSpec", "TrainSpec", "skeleton_spec", "loss_spec", "train_spec"]


@dataclasses.dataclass(frozen=True)
class SkeletonSpec:
    """The skeleton of the training windows, as the losses read it.

    dataset: ``config.data.dataset`` (named in messages); parents: (J,) parent index per joint (-1 root);
    feet: the contact joints in the order of the contact channels, None when the dataset reads them per file;
    up_axis: the loaded windows' up axis ("+y", ...), up_index its coordinate (0, 1, 2) and up_sign +1 / -1;
    position_scale: data units per loss unit (cm -> m, ``features.POSITION_SCALE``); velocity_scale: the same
    for the root velocity (cm / frame, ``features.VELOCITY_SCALE``).
    """

    dataset: str
    parents: tuple
    feet: tuple | None
    up_axis: str
    up_index: int
    up_sign: int
    position_scale: float
    velocity_scale: float

    @property
    def num_joints(self) -> int:
        return len(self.parents)


@dataclasses.dataclass(frozen=True)
class LossSpec:
    """The objective's settings (paper Eq. 9 and the extensions beyond it).

    loss: ``config.loss`` (frozen: betas, alphas, reduction, KL and prior settings, foot terms);
    posterior: ``model.posterior`` ("none" = the paper's KL(p || N(0, I))); bidirectional: both generators
    are scored; discriminators: the two discriminators (``networks.DiscriminatorSpec``), None without them
    (``model.discriminators=false``: no adversarial terms, no discriminator update).
    """

    loss: Any
    posterior: str
    bidirectional: bool
    discriminators: networks.DiscriminatorSpec | None


@dataclasses.dataclass(frozen=True)
class TrainSpec:
    """What training reads. The objective's: rollout, the ``rollout.RolloutSpec`` (the model, on accel's
    layers); loss: :class:`LossSpec`; skeleton: :class:`SkeletonSpec`. The run's: model, the
    ``networks.ModelSpec`` the parameters are initialised from; train: ``config.train`` (optimiser, length
    schedule, checkpoints, validation, fast paths); phase: ``config.phase`` (the phase network and its
    pretraining); window: frames of a training window (``data.window``); random_starts:
    ``data.random_starts`` (a batch's windows start at any frame)."""

    rollout: rollout_lib.RolloutSpec
    loss: LossSpec
    skeleton: SkeletonSpec
    model: networks.ModelSpec
    train: Any
    phase: Any
    window: int
    random_starts: bool


def skeleton_spec(data) -> SkeletonSpec:
    """The :class:`SkeletonSpec` of a config's ``data`` section: feet and up axis from the registry entry of
    ``data.dataset``, parents from ``data``, the scales of ``features``. ValueError for an unknown dataset name."""
    entry = datasets.get(data.dataset)
    up = conform.parse_axis(entry.up_axis)
    up_index = int(abs(up).argmax())
    return SkeletonSpec(dataset=data.dataset, parents=tuple(data.parents),
                        feet=None if entry.feet is None else tuple(entry.feet), up_axis=entry.up_axis,
                        up_index=up_index, up_sign=1 if up[up_index] > 0 else -1,
                        position_scale=features.POSITION_SCALE, velocity_scale=features.VELOCITY_SCALE)


def loss_spec(model, loss, num_joints: int) -> LossSpec:
    """The :class:`LossSpec` of a config's ``loss`` section and the switches of its ``model`` section the
    objective reads, for a skeleton of ``num_joints`` joints."""
    discriminators = networks.discriminator_spec(model, num_joints) if model.discriminators else None
    return LossSpec(loss=loss, posterior=model.posterior, bidirectional=model.bidirectional,
                    discriminators=discriminators)


def train_spec(config) -> TrainSpec:
    """The :class:`TrainSpec` of `config`: built once where training starts. Its generator runs on
    ``accel.matmul``'s layers (the ``model.matmul_dtype`` matmul, the ELU's derivative from its output)."""
    return TrainSpec(rollout=accel_matmul.with_layers(rollout_lib.rollout_spec(config)),
                     loss=loss_spec(config.model, config.loss, config.data.num_joints),
                     skeleton=skeleton_spec(config.data), model=networks.model_spec(config.model, config.data),
                     train=config.train, phase=config.phase, window=config.data.window,
                     random_starts=config.data.random_starts)
