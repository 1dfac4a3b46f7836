"""How transitions are sampled, as one frozen spec: the latent noise, the latent-pair search and foot locking.

    sampling = Sampling.paper()                                   # noise x1, independent per frame, no ramp
    sampling = model.sampling                                     # the model's default (model.json "sampling")
    wide = sampling.replace(noise_scale=2.0, search=4)            # a changed copy, checked again
    samples = inbetween(model, start, target, 30, num_samples=8, sampling=wide)

Built once (by ``bin/inbetween``, ``bin/evaluate`` or :attr:`stitchjax.sample.trained_model.Model.sampling`) and
passed down through ``stitchjax.sample.inbetween`` / ``takes`` and ``stitchjax.eval.evaluate.model_method``.
Hashable, so it can key compiled samplers.
"""
from __future__ import annotations

import dataclasses
import math
from typing import Mapping

from stitchjax.sample import footlock
from stitchjax.sample.footlock import FootLockConfig
from stitchjax.sample.trained_model import InbetweenError, SAMPLING_KEYS, check_sampling

__all__ = ["Sampling"]


@dataclasses.dataclass(frozen=True)
class Sampling:
    """The sampling of transitions.

    noise_scale: factor on the latent noise, >= 0 (1: the model's own spread, the paper's; 0: every sample the
      same, the prior's mean path).
    noise_correlation: the noise's correlation from one frame to the next, in [0, 1] (0: independent per frame,
      the paper's; ``noise.correlated_noise``).
    noise_ramp_steps: frames over which the noise rises from 0 next to each keyframe to full, >= 0 (0: full from
      the first frame, the paper's; ``noise.noise_ramp``).
    search: 0 = plain sampling; M >= 1 = M latent pairs tried per wanted sample, the lowest stitching losses kept.
    foot_lock: False (the transitions as the model made them), True (``footlock.DEFAULT_CONFIG``) or a
      ``footlock.FootLockConfig``: plant the feet where the model predicts contact (:mod:`stitchjax.sample.footlock`).
    A bad value is an InbetweenError naming it.
    """

    noise_scale: float = 1.0
    noise_correlation: float = 0.0
    noise_ramp_steps: int = 0
    search: int = 0
    foot_lock: bool | FootLockConfig = False

    def __post_init__(self):
        noise = check_sampling({k: getattr(self, k) for k in SAMPLING_KEYS})  # InbetweenError naming a bad one
        for key, value in noise.items():
            object.__setattr__(self, key, value)
        search = self.search
        if isinstance(search, bool) or not isinstance(search, (int, float)) or not math.isfinite(search) \
                or int(search) != search or search < 0:
            raise InbetweenError(f"search must be 0 (no search) or the number of latent pairs tried per "
                                 f"sample (>= 1), got {search}")
        object.__setattr__(self, "search", int(search))
        lock = False if self.foot_lock is None else self.foot_lock
        if not isinstance(lock, (bool, FootLockConfig)):
            raise InbetweenError(f"foot_lock must be False, True or a footlock.FootLockConfig, got "
                                 f"{type(lock).__name__} {lock!r}")
        object.__setattr__(self, "foot_lock", lock)

    @classmethod
    def paper(cls, search: int = 0, foot_lock: bool | FootLockConfig = False) -> "Sampling":
        """The paper's sampling: noise x1, independent per frame, full from the first frame (no foot locking)."""
        return cls(search=search, foot_lock=foot_lock)

    @classmethod
    def from_json(cls, sampling: Mapping | None, search: int = 0,
                  foot_lock: bool | FootLockConfig = False) -> "Sampling":
        """The sampling of a model.json "sampling" entry ({"noise_scale", "noise_correlation",
        "noise_ramp_steps"}, any subset, or None): the paper's for each one missing."""
        chosen = check_sampling(dict(sampling or {}))
        return cls(search=search, foot_lock=foot_lock, **chosen)

    def replace(self, **changes) -> "Sampling":
        """A copy with ``changes`` (field name -> value; a None value keeps the field), checked again."""
        unknown = sorted(set(changes) - {f.name for f in dataclasses.fields(self)})
        if unknown:
            raise InbetweenError(f"sampling: unknown {', '.join(unknown)} (use "
                                 f"{', '.join(f.name for f in dataclasses.fields(self))})")
        return dataclasses.replace(self, **{k: v for k, v in changes.items() if v is not None})

    @property
    def noise(self) -> dict:
        """{"noise_scale", "noise_correlation", "noise_ramp_steps"}: the noise part, as model.json stores it."""
        return {k: getattr(self, k) for k in SAMPLING_KEYS}

    @property
    def locks_feet(self) -> bool:
        """Whether foot locking runs after sampling."""
        return self.foot_lock is not False

    @property
    def foot_lock_config(self) -> FootLockConfig | None:
        """The ``FootLockConfig`` foot locking runs with (True: ``footlock.DEFAULT_CONFIG``), or None when off."""
        if self.foot_lock is True:
            return footlock.DEFAULT_CONFIG
        return self.foot_lock or None
