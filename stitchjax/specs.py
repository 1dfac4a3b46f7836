"""Small frozen specs resolved once from the ``Config`` where a train step or a loaded model starts.

Below that point functions take the spec they read, not the whole ``Config``:

- :class:`SkeletonSpec`: the skeleton facts the losses and metrics need (parents, feet, up axis, scales),
  read once from the dataset entry (``stitchjax.data.datasets``) and ``config.data``;
- :class:`LossSpec`: the loss section (the weights of paper Eq. 9 and the extensions' switches) and the
  model switches that decide which terms exist (posterior, directions, discriminators);
- :class:`TrainSpec`: what one train step's objective reads: the two above and the rollout's
  ``rollout.RolloutSpec`` (L's scan, K, the gamma schedule, the generator's sizes and switches).

Every spec is a frozen, hashable dataclass, so a jitted function may close over it or take it as a static
argument. Built by :func:`skeleton_spec`, :func:`loss_spec` and :func:`train_spec`.
"""
from __future__ import annotations

import dataclasses
from typing import Any

from stitchjax.accel import matmul as accel_matmul
from stitchjax.data import conform, datasets
from stitchjax.model import networks
from stitchjax.model import rollout as rollout_lib

__all__ = ["SkeletonSpec", "LossSpec", "TrainSpec", "skeleton_spec", "loss_spec", "train_spec"]


@dataclasses.dataclass(frozen=True)
class SkeletonSpec:
    """The skeleton of the training windows, as the losses read it.

    dataset: ``config.data.dataset`` (named in messages); parents: (J,) parent index per joint (-1 root);
    feet: the contact joints in the order of the contact channels, None when the dataset reads them per file;
    up_axis: the loaded windows' up axis ("+y", ...), up_index its coordinate (0, 1, 2) and up_sign +1 / -1;
    position_scale: data units per loss unit (LAFAN1: cm -> m, 100); velocity_scale: the same for the root
    velocity (cm / frame).
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
    """What one train step's objective reads: rollout, the ``rollout.RolloutSpec`` (the model);
    loss: :class:`LossSpec`; skeleton: :class:`SkeletonSpec`."""

    rollout: rollout_lib.RolloutSpec
    loss: LossSpec
    skeleton: SkeletonSpec


def skeleton_spec(config) -> SkeletonSpec:
    """The :class:`SkeletonSpec` of ``config.data.dataset``: feet and up axis from its registry entry,
    parents and scales from ``config.data``. ValueError for an unknown dataset name."""
    data = config.data
    entry = datasets.get(data.dataset)
    up = conform.parse_axis(entry.up_axis)
    up_index = int(abs(up).argmax())
    return SkeletonSpec(dataset=data.dataset, parents=tuple(data.parents),
                        feet=None if entry.feet is None else tuple(entry.feet), up_axis=entry.up_axis,
                        up_index=up_index, up_sign=1 if up[up_index] > 0 else -1,
                        position_scale=data.position_scale, velocity_scale=data.velocity_scale)


def loss_spec(config) -> LossSpec:
    """The :class:`LossSpec` of `config` (``config.loss`` and the model switches the objective reads)."""
    m = config.model
    return LossSpec(loss=config.loss, posterior=m.posterior, bidirectional=m.bidirectional,
                    discriminators=networks.discriminator_spec(config) if m.discriminators else None)


def train_spec(config) -> TrainSpec:
    """The :class:`TrainSpec` of `config`: built once where the train step is made. Its generator runs on
    ``accel.matmul``'s layers (the ``model.matmul_dtype`` matmul, the ELU's derivative from its output)."""
    return TrainSpec(rollout=accel_matmul.with_layers(rollout_lib.rollout_spec(config)), loss=loss_spec(config),
                     skeleton=skeleton_spec(config))
