"""A trained in-betweening model ready for inference: loaded from a training run, or freshly initialised.

    model = load_model("runs/quickstart")            # a training run (or a checkpoint folder)
    model = random_model(config_lib.load_config("tiny"), seed=0)   # untrained: timing, tests, shapes
    fast = with_matmul_dtype(model, "bfloat16")      # same parameters, bfloat16 matmul operands

A :class:`Model` carries the config, the generators' (and phase network's) parameters, the training
statistics and the skeleton facts saved in the checkpoint (joint names, feet, up and forward axes, units).
:class:`InbetweenError` is the error of every request a model cannot serve, here and in
``stitchjax.inbetween`` / ``takes`` / ``latent`` / ``evaluate`` (``inbetween.InbetweenError`` is this class).
"""
from __future__ import annotations

import dataclasses
import logging
import os
import pathlib
from typing import Any, Sequence

import jax
import numpy as np

from stitchjax import checkpoints, conform, datasets, features, networks, phase, train
from stitchjax import config as config_lib
from stitchjax.skeleton import LAFAN1_FEET

__all__ = ["InbetweenError", "Model", "load_model", "model_from_state", "random_model", "with_matmul_dtype"]


class InbetweenError(ValueError):
    """A request the model cannot serve (bad length, skeleton mismatch, frames out of range, ...)."""


# ---------------------------------------------------------------------------------------------- model


@dataclasses.dataclass(frozen=True, eq=False)
class Model:
    """A trained (or freshly initialised) in-betweening model, ready for inference.

    Attributes:
      config: the experiment ``Config`` it was trained with (static, hashable).
      params: {"forward", "backward"} generator params (discriminators are not needed).
      phase_params: the frozen phase network's params (or None without phase modulation).
      joint_names: joint names of the training skeleton (checked against requests), or None.
      feet: joint indices of the contact channels (LAFAN1: LeftFoot, LeftToe, RightFoot, RightToe).
      stats: training statistics as numpy arrays ("mean", "std" (J*3,), "offsets" (J, 3)), may be {}.
      source: where it came from ("<workdir> step <n>" or "random init (seed s)").
      up_axis: (3,) the training files' up axis (takes are turned from it to +Y for the model, and back).
      forward_axis: (3,) the root's local forward axis the training windows were faced by (LAFAN1: +Y).
      unit_scale: centimetres per unit of the training files (takes are scaled by it, and back).
    The last three come from the checkpoint (``extras["skeleton"]``, :func:`stitchjax.datasets.skeleton_facts`).
    """

    config: Any
    params: dict
    phase_params: Any
    joint_names: tuple | None
    feet: tuple
    stats: dict
    source: str
    up_axis: tuple = (0.0, 1.0, 0.0)
    forward_axis: tuple = (0.0, 1.0, 0.0)
    unit_scale: float = 1.0

    @property
    def parents(self) -> tuple:
        return tuple(int(p) for p in self.config.data.parents)

    @property
    def num_joints(self) -> int:
        return len(self.parents)

    @property
    def feet_names(self) -> tuple | None:
        """Names of the contact joints (None when the joint names are unknown)."""
        return None if self.joint_names is None else tuple(self.joint_names[j] for j in self.feet)

    @property
    def trained_max_length(self) -> int:
        """Longest transition seen in training (longer ones work but are extrapolation)."""
        return int(self.config.train.max_length)

    def __repr__(self):
        return f"Model({self.config.name!r}, {self.num_joints} joints, {self.source})"


def _default_facts(config) -> dict:
    """The skeleton facts of a checkpoint saved without them (before they were saved): those of its
    dataset (LAFAN1 / H36M), or for a BVH folder what its config declares (joint names unknown)."""
    data = config.data
    facts = datasets.skeleton_facts(None, data)
    if facts is not None and len(facts["joint_names"]) == len(data.parents):
        return facts
    return {"joint_names": None, "feet": list(LAFAN1_FEET), "up_axis": data.up_axis or "+y",
            "forward_axis": data.forward_axis or "+y", "unit_scale": float(data.unit_scale) or 1.0}


def _facts_fields(config, facts: dict | None) -> dict:
    """Model fields (joint_names, feet, up_axis, forward_axis, unit_scale) from saved facts, else defaults."""
    defaults = _default_facts(config)
    facts = {**defaults, **{k: v for k, v in (facts or {}).items() if v not in (None, "", [])}}
    names = tuple(facts["joint_names"]) if facts["joint_names"] else None
    feet = tuple(int(j) for j in facts["feet"])
    if names is not None and facts.get("feet_names") and [names[j] for j in feet] != list(facts["feet_names"]):
        raise InbetweenError(f"checkpoint skeleton facts disagree: feet {feet} are {[names[j] for j in feet]}, "
                             f"saved as {list(facts['feet_names'])}; retrain or fix extras/skeleton")
    try:
        up, forward = conform.parse_axis(facts["up_axis"]), conform.parse_axis(facts["forward_axis"])
    except conform.ConformError as error:
        raise InbetweenError(f"checkpoint skeleton facts: {error}") from None
    return {"joint_names": names, "feet": feet, "up_axis": tuple(float(x) for x in up),
            "forward_axis": tuple(float(x) for x in forward), "unit_scale": float(facts["unit_scale"])}


def _resolve_checkpoint(path) -> tuple[pathlib.Path, int | None]:
    """(training workdir, step or None) from a workdir, its checkpoints/ folder or one step folder."""
    path = pathlib.Path(os.fspath(path)).expanduser().resolve()
    if not path.exists():
        raise FileNotFoundError(f"checkpoint {path} does not exist: pass a training run folder "
                                f"(bin/train --workdir DIR) or one of its checkpoints/<step> folders")
    if (path / "checkpoints").is_dir():
        return path, None
    if path.name == "checkpoints":
        return path.parent, None
    if path.name.isdigit() and path.parent.name == "checkpoints":
        return path.parent.parent, int(path.name)
    raise FileNotFoundError(f"{path} holds no checkpoints (expected {path / 'checkpoints'}/<step>/): pass "
                            f"the folder given to bin/train --workdir")


def _readable_config(workdir, step):
    """The saved config JSON of checkpoint ``step``, or (step None) of the newest one whose config reads."""
    if step is not None:
        return checkpoints.read_config_json(workdir, step)
    steps = checkpoints.saved_steps(workdir)
    for candidate in reversed(steps[1:]):
        try:
            return checkpoints.read_config_json(workdir, candidate)
        except (OSError, ValueError):
            continue
    return checkpoints.read_config_json(workdir, steps[0] if steps else None)


def load_model(checkpoint, step: int | None = None) -> Model:
    """Load a model from a training run folder (its latest checkpoint, or ``step``).

    ``checkpoint`` may be the run folder (``bin/train --workdir``), its ``checkpoints/`` folder or one
    ``checkpoints/<step>`` folder. The config saved beside the state says how to build the networks.
    Raises FileNotFoundError (``checkpoints.CheckpointError``) when there is no checkpoint.
    """
    workdir, folder_step = _resolve_checkpoint(checkpoint)
    step = folder_step if step is None else int(step)
    absl_logger = logging.getLogger("absl")
    level = absl_logger.level
    absl_logger.setLevel(logging.ERROR)  # orbax warns that a read-only directory is read only
    try:
        config = config_lib.from_dict(_readable_config(workdir, step))
        manager = checkpoints.open_manager(workdir, read_only=True)
        try:
            abstract = train.abstract_train_state(config)
            if step is None:  # the newest checkpoint that restores, naming any broken one on stderr
                state, _, extras, step = checkpoints.restore_newest_good(manager, abstract)
            else:
                try:
                    state, _, extras = checkpoints.restore(manager, abstract, step)
                except Exception as error:  # orbax / TensorStore: many types for a broken folder
                    raise checkpoints.CheckpointError(
                        f"checkpoint {checkpoints.checkpoint_dir(workdir) / str(step)} cannot be restored "
                        f"({checkpoints._short(error)}); pass the run folder to use the newest one that "
                        f"restores (steps saved: {checkpoints.saved_steps(workdir)})") from None
        finally:
            manager.close()
    finally:
        absl_logger.setLevel(level)
    return model_from_state(config, state, extras.get("stats"), extras.get("skeleton"),
                            f"{workdir} step {int(step)}")


def model_from_state(config, state, stats_json: dict | None, facts: dict | None, source: str) -> Model:
    """The `Model` of a train state (its generators and phase network), as a checkpoint saves it: with the
    normalisation statistics `stats_json` and skeleton facts `facts` of ``extras`` (either may be None)."""
    stats = {k: np.asarray(v, np.float64) for k, v in (stats_json or {}).items()}
    params = {"forward": state.params["forward"], "backward": state.params["backward"]}
    phase_params = state.phase_params if config.model.phase_modulation else None
    return Model(config, params, phase_params, stats=stats, source=source, **_facts_fields(config, facts))


def random_model(config, seed: int = 0, joint_names: Sequence[str] | None = None) -> Model:
    """A freshly initialised model (untrained): for timing, tests and shape checks."""
    key = jax.random.PRNGKey(seed)
    params = jax.jit(lambda k: networks.init_params(config, k))(key)
    phase_params = None
    if config.model.phase_modulation:
        phase_params = phase.init_phase_params(jax.random.fold_in(key, 1), features.state_dim(config), config)
    fields = _facts_fields(config, None)
    if joint_names is not None:
        fields["joint_names"] = tuple(joint_names)
    return Model(config, {"forward": params["forward"], "backward": params["backward"]}, phase_params,
                 stats={}, source=f"random init (seed {seed})", **fields)


def with_matmul_dtype(model: Model, dtype: str) -> Model:
    """The same model computing its matmuls on ``dtype`` operands ("float32" or "bfloat16", float32
    accumulation either way; see ``networks.matmul``). Parameters are unchanged, so a float32-trained
    model can sample in bfloat16: ~1.8x faster on CPUs with AMX / AVX512-BF16 (benchmarks/README.md); with
    the same seed, joint positions move by ~0.2 cm on average (up to ~1 cm mid-transition)."""
    try:
        config = config_lib.apply_overrides(model.config, [f"model.matmul_dtype={dtype}"])
    except config_lib.ConfigError as err:
        raise InbetweenError(str(err)) from None
    return dataclasses.replace(model, config=config)
