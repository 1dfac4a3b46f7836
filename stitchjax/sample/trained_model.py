"""A trained in-betweening model ready for inference: loaded from a training run, or freshly initialised.

Size (~430 lines): one job, a model to and from files; both readers and the writer share the parameter layout.

    model = pretrained()                              # the release model shipped in stitchjax/pretrained/
    model = load_model("runs/quickstart")            # a training run (or a checkpoint folder)
    model = load_model("stitchjax/pretrained/lafan1_cpu_release")   # an exported model folder (bin/export)
    model = random_model(config_lib.load_config("tiny"), seed=0)   # untrained: timing, tests, shapes
    fast = with_matmul_dtype(model, "bfloat16")      # same parameters, bfloat16 matmul operands

A :class:`Model` carries the config, the generators' (and phase network's) parameters, the training
statistics and the skeleton facts saved in the checkpoint (joint names, feet, up and forward axes, units).
Loading restores only what sampling needs: never the discriminators, the optimiser states or a train state.
An exported model folder (:func:`export_model`, ``bin/export``) holds just that: ``model.json`` (config, stats,
skeleton facts) and ``params.msgpack`` (the generators' and phase network's parameters, stored in float16).
:class:`InbetweenError` is the error of every request a model cannot serve, here and in
``stitchjax.sample.inbetween`` / ``takes`` / ``latent`` / ``evaluate`` (``inbetween.InbetweenError`` is this class).
"""
from __future__ import annotations

import dataclasses
import functools
import json
import logging
import os
import pathlib
from typing import Any, Sequence

import jax
import numpy as np

from stitchjax import checkpoints, parallel
from stitchjax.accel import matmul as accel_matmul
from stitchjax.data import conform, datasets, features, phase
from stitchjax.model import networks
from stitchjax.model import rollout as rollout_lib
from stitchjax import config as config_lib
from stitchjax.skeleton import LAFAN1_FEET

__all__ = ["InbetweenError", "Model", "RELEASE_MODEL", "SAMPLING_KEYS", "check_sampling", "export_model", "load_model", "model_from_state",
           "model_or_pretrained", "pretrained", "random_model", "with_matmul_dtype"]

MODELS_DIR = pathlib.Path(__file__).resolve().parent.parent / "pretrained"  # exported models shipped with the package
RELEASE_MODEL = config_lib.RELEASE_MODEL  # the folder of MODELS_DIR that pretrained() loads
SAMPLING_KEYS = ("noise_scale", "noise_correlation", "noise_ramp_steps")
MODEL_JSON, PARAMS_FILE = "model.json", "params.msgpack"  # an exported model folder's two files
FORMAT = "stitchjax-model"
FORMAT_VERSION = 1
STORED_DTYPES = ("float32", "float16", "bfloat16")


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
      default_sampling: {"noise_scale", "noise_correlation", "noise_ramp_steps"} that :func:`stitchjax.sample.inbetween.
        inbetween` and ``bin/inbetween`` use when not told otherwise (an exported model's ``model.json``
        "sampling"), or None for the paper's (:attr:`sampling` is it as a ``Sampling`` spec).
    up_axis, forward_axis and unit_scale come from the checkpoint (``extras["skeleton"]``, :func:`stitchjax.data.datasets.skeleton_facts`).
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
    default_sampling: dict | None = None

    @property
    def paper_sampling(self):
        """The paper's sampling (a :class:`stitchjax.sample.sampling.Sampling`): noise x1, full from the first
        frame, independent per frame, no search, no foot locking."""
        from stitchjax.sample.sampling import Sampling  # reason: sampling.py builds on this module

        return Sampling.paper()

    @property
    def sampling(self):
        """The sampling used when a call gives none (a :class:`stitchjax.sample.sampling.Sampling`): the noise of
        ``default_sampling`` over the paper's, no search, feet locked (``footlock.DEFAULT_CONFIG``)."""
        from stitchjax.sample.sampling import Sampling  # reason: sampling.py builds on this module

        return Sampling.from_json(self.default_sampling, foot_lock=True)

    @functools.cached_property
    def rollout_spec(self) -> rollout_lib.RolloutSpec:
        """The rollout's spec (sizes, switches, L's scan, K, the gamma schedule), resolved once from ``config``;
        the generator runs on ``accel.matmul``'s layers (``model.matmul_dtype``'s matmul)."""
        return accel_matmul.with_layers(rollout_lib.rollout_spec(self.config))

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


def _default_facts(data: config_lib.DataConfig) -> dict:
    """The skeleton facts of a checkpoint saved without them (before they were saved): those of its
    dataset (LAFAN1 / H36M), or for a BVH folder what its data config declares (joint names unknown)."""
    facts = datasets.skeleton_facts(None, data)
    if facts is not None and len(facts["joint_names"]) == len(data.parents):
        return facts
    return {"joint_names": None, "feet": list(LAFAN1_FEET), "up_axis": data.up_axis or "+y",
            "forward_axis": data.forward_axis or "+y", "unit_scale": float(data.unit_scale) or 1.0}


def _facts_fields(data: config_lib.DataConfig, facts: dict | None) -> dict:
    """Model fields (joint_names, feet, up_axis, forward_axis, unit_scale) from saved facts, else the defaults
    of the data config ``data``."""
    defaults = _default_facts(data)
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
    raise FileNotFoundError(f"{path} holds no checkpoints (expected {path / 'checkpoints'}/<step>/) and no "
                            f"exported model ({MODEL_JSON}): pass the folder given to bin/train --workdir, or one "
                            f"written by bin/export")


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


def _phase_init(data: config_lib.DataConfig, phase_config: config_lib.PhaseConfig, key):
    """Fresh phase network parameters for the character state of ``data``."""
    return phase.init_phase_params(key, features.state_dim(data.num_joints), phase_config)


@functools.lru_cache(maxsize=8)
def _initializer(spec: networks.ModelSpec, data: config_lib.DataConfig, phase_config: config_lib.PhaseConfig | None):
    """jit of key -> (generator and discriminator params, phase params or None) of `random_model`, compiled once
    per process for equal settings."""
    def init(key):
        phase_params = None if phase_config is None else _phase_init(data, phase_config, jax.random.fold_in(key, 1))
        return networks.init_params(spec, key), phase_params

    return jax.jit(init)


def _sampling_abstract(spec: networks.ModelSpec, data: config_lib.DataConfig,
                       phase_config: config_lib.PhaseConfig | None) -> dict:
    """Shapes (replicated) of what sampling restores from a train state: {"params": {"forward", "backward"}}
    of the networks of ``spec`` (``networks.model_spec``) and, with phase modulation (``phase_config`` not
    None), {"phase_params": ...}; no discriminator, no optimiser state."""
    key = jax.random.PRNGKey(0)
    generators = jax.eval_shape(lambda k: networks.init_params(spec, k), key)
    wanted = {"params": {"forward": generators["forward"], "backward": generators["backward"]}}
    if phase_config is not None:
        wanted["phase_params"] = jax.eval_shape(lambda k: _phase_init(data, phase_config, k), key)
    sharding = parallel.replicated(parallel.make_mesh())
    return jax.tree.map(lambda x: jax.ShapeDtypeStruct(x.shape, x.dtype, sharding=sharding), wanted)


def load_model(checkpoint, step: int | None = None) -> Model:
    """Load a model from a training run folder (its latest checkpoint, or ``step``) or an exported folder.

    ``checkpoint`` may be the run folder (``bin/train --workdir``), its ``checkpoints/`` folder, one
    ``checkpoints/<step>`` folder, or a folder written by :func:`export_model` (``bin/export``; ``step`` must
    then be None). The config saved beside the parameters says how to build the networks. Only the generators'
    (and phase network's) parameters are read: the discriminators and optimiser states stay on disk.
    Raises FileNotFoundError (``checkpoints.CheckpointError``) when there is no checkpoint.
    """
    folder = pathlib.Path(os.fspath(checkpoint)).expanduser()
    if (folder / MODEL_JSON).is_file():
        if step is not None:
            raise InbetweenError(f"{folder} is an exported model (one set of parameters): load it without a step")
        return _load_exported(folder)
    workdir, folder_step = _resolve_checkpoint(checkpoint)
    step = folder_step if step is None else int(step)
    absl_logger = logging.getLogger("absl")
    level = absl_logger.level
    absl_logger.setLevel(logging.ERROR)  # orbax warns that a read-only directory is read only
    try:
        config = config_lib.from_dict(_readable_config(workdir, step))
        manager = checkpoints.open_manager(workdir, read_only=True)
        try:
            abstract = _sampling_abstract(networks.model_spec(config.model, config.data), config.data,
                                          config.phase if config.model.phase_modulation else None)
            if step is None:  # the newest checkpoint that restores, naming any broken one on stderr
                state, _, extras, step = checkpoints.restore_newest_good(manager, abstract, partial=True)
            else:
                try:
                    state, _, extras = checkpoints.restore(manager, abstract, step, partial=True)
                except Exception as error:  # orbax / TensorStore: many types for a broken folder
                    raise checkpoints.CheckpointError(
                        f"checkpoint {checkpoints.checkpoint_dir(workdir) / str(step)} cannot be restored "
                        f"({checkpoints.short_error(error)}); pass the run folder to use the newest one that "
                        f"restores (steps saved: {checkpoints.saved_steps(workdir)})") from None
        finally:
            manager.close()
    finally:
        absl_logger.setLevel(level)
    return model_from_state(config, _SamplingState(state["params"], state.get("phase_params")),
                            extras.get("stats"), extras.get("skeleton"), f"{workdir} step {int(step)}")


@dataclasses.dataclass(frozen=True)
class _SamplingState:
    """What :func:`model_from_state` reads of a train state (``params``, ``phase_params``)."""

    params: dict
    phase_params: Any


# ----------------------------------------------------------------------------------- exported models


def _facts_json(model: Model) -> dict:
    """The model's skeleton facts in the form checkpoints save them (``extras["skeleton"]``)."""
    return {"joint_names": list(model.joint_names) if model.joint_names is not None else None,
            "feet": [int(j) for j in model.feet], "feet_names": list(model.feet_names or []),
            "up_axis": conform.axis_name(model.up_axis), "forward_axis": conform.axis_name(model.forward_axis),
            "unit_scale": float(model.unit_scale)}


def _stored_dtype(dtype: str):
    if dtype not in STORED_DTYPES:
        raise InbetweenError(f"parameter dtype {dtype!r}: use one of {', '.join(STORED_DTYPES)}")
    return jax.numpy.dtype(dtype)


def check_sampling(sampling: dict) -> dict:
    """``sampling`` ({"noise_scale" >= 0, "noise_correlation" in [0, 1], "noise_ramp_steps" >= 0 frames}, any
    subset) as floats and ints; InbetweenError naming the bad entry otherwise."""
    unknown = sorted(set(sampling) - set(SAMPLING_KEYS))
    if unknown:
        raise InbetweenError(f"sampling: unknown {', '.join(unknown)} (use {', '.join(SAMPLING_KEYS)})")
    out = {}
    if "noise_scale" in sampling:
        out["noise_scale"] = float(sampling["noise_scale"])
        if not (np.isfinite(out["noise_scale"]) and out["noise_scale"] >= 0):
            raise InbetweenError(f"noise_scale must be a finite number >= 0, got {sampling['noise_scale']}")
    if "noise_correlation" in sampling:
        out["noise_correlation"] = float(sampling["noise_correlation"])
        if not 0.0 <= out["noise_correlation"] <= 1.0:
            raise InbetweenError(f"noise_correlation must be in [0, 1], got {sampling['noise_correlation']}")
    if "noise_ramp_steps" in sampling:
        ramp = sampling["noise_ramp_steps"]
        if int(ramp) != ramp or ramp < 0:
            raise InbetweenError(f"noise_ramp_steps must be a whole number of frames >= 0, got {ramp}")
        out["noise_ramp_steps"] = int(ramp)
    return out


def export_model(model: Model, folder, dtype: str = "float16", notes: dict | None = None,
                 source: str | None = None, sampling: dict | None = None) -> pathlib.Path:
    """Write what sampling needs into ``folder`` (created): ``params.msgpack`` holds the generators' (and
    phase network's, when the model uses one) parameters cast to ``dtype``, ``model.json`` the full config
    (every field written out, so later changes of the defaults do not change the model), the normalisation
    statistics, the skeleton facts, ``source`` (default ``model.source``), ``sampling`` (the default sampling
    of :attr:`Model.sampling`; default ``model.default_sampling``, None = the paper's) and ``notes`` (JSON-able).
    No optimiser or train state.
    Returns the folder; :func:`load_model` reads it back (parameters as float32)."""
    from flax import serialization  # reason: only exporting / loading an exported folder needs it

    stored = _stored_dtype(dtype)
    sampling = check_sampling(model.default_sampling or {} if sampling is None else sampling)
    folder = pathlib.Path(os.fspath(folder)).expanduser()
    folder.mkdir(parents=True, exist_ok=True)
    tree = {"generators": {"forward": model.params["forward"], "backward": model.params["backward"]}}
    if model.phase_params is not None:
        tree["phase"] = model.phase_params
    tree = jax.tree.map(lambda x: np.asarray(x).astype(stored), tree)
    (folder / PARAMS_FILE).write_bytes(serialization.msgpack_serialize(tree))
    description = {
        "format": FORMAT, "version": FORMAT_VERSION, "name": model.config.name,
        "source": model.source if source is None else source,
        "param_dtype": dtype, "parameters": int(sum(np.size(x) for x in jax.tree.leaves(tree))),
        "config": config_lib.to_dict(model.config),
        "stats": {k: np.asarray(v).tolist() for k, v in model.stats.items()},
        "skeleton": _facts_json(model), "sampling": sampling or None, "notes": notes or {},
    }
    (folder / MODEL_JSON).write_text(json.dumps(description, indent=1) + "\n")
    return folder


def _load_exported(folder: pathlib.Path) -> Model:
    """The :class:`Model` of an exported folder (:func:`export_model`), parameters as float32."""
    from flax import serialization  # reason: only exporting / loading an exported folder needs it

    try:
        description = json.loads((folder / MODEL_JSON).read_text())
    except ValueError as error:
        raise InbetweenError(f"{folder / MODEL_JSON} is not valid JSON ({error}); export the model again "
                             f"(bin/export)") from None
    if description.get("format") != FORMAT or description.get("version") != FORMAT_VERSION:
        raise InbetweenError(f"{folder / MODEL_JSON}: not a {FORMAT} version {FORMAT_VERSION} folder (format "
                             f"{description.get('format')!r}, version {description.get('version')!r}); export "
                             f"the model again with this stitchjax (bin/export)")
    params_path = folder / PARAMS_FILE
    if not params_path.is_file():
        raise FileNotFoundError(f"{params_path} is missing: export the model again (bin/export)")
    config = config_lib.from_dict(description["config"])
    tree = serialization.msgpack_restore(params_path.read_bytes())
    expected = _sampling_abstract(networks.model_spec(config.model, config.data), config.data,
                                  config.phase if config.model.phase_modulation else None)
    stored = {"params": tree.get("generators", {})}
    if config.model.phase_modulation:
        stored["phase_params"] = tree.get("phase")
    shapes = lambda t: jax.tree.map(lambda x: tuple(np.shape(x)), t)  # noqa: E731
    if shapes(stored) != shapes(expected):
        raise InbetweenError(f"{params_path}: the parameters do not match the networks of its config "
                             f"({description.get('name')!r}); export the model again (bin/export)")
    stored = jax.tree.map(lambda x: jax.numpy.asarray(np.asarray(x, np.float32)), stored)
    try:
        sampling = check_sampling(description.get("sampling") or {}) or None
    except InbetweenError as error:
        raise InbetweenError(f"{folder / MODEL_JSON}: {error}; fix it or export the model again (bin/export)") from None
    model = model_from_state(config, _SamplingState(stored["params"], stored.get("phase_params")),
                             description.get("stats"), description.get("skeleton"),
                             f"{folder.name} (exported from {description.get('source', 'a training run')}, stored in {description['param_dtype']})")
    return dataclasses.replace(model, default_sampling=sampling)


def pretrained(name: str = RELEASE_MODEL) -> Model:
    """The release model shipped with the package, ready to sample (no training needed).

        model = stitchjax.pretrained()
        clips = stitchjax.sample.takes.inbetween_takes(model, take, 100, take, 140, num_samples=4)

    name: a folder of ``stitchjax/pretrained/`` (default :data:`RELEASE_MODEL`: ``lafan1_cpu_release``, the
    LAFAN1 skeleton at 30 fps in centimetres, trained from scratch by the config of that name). Parameters are
    stored in float16 and computed in float32. Made by ``bin/export``.
    """
    folder = MODELS_DIR / name
    if not (folder / MODEL_JSON).is_file():
        shipped = sorted(p.parent.name for p in MODELS_DIR.glob(f"*/{MODEL_JSON}"))
        raise FileNotFoundError(f"no model {name!r} in {MODELS_DIR} (shipped: {', '.join(shipped) or 'none'}); "
                                f"reinstall stitchjax, or export one with bin/export")
    return _load_exported(folder)


@functools.lru_cache(maxsize=4)
def _pretrained_once(name: str) -> Model:
    return pretrained(name)


def model_or_pretrained(model: Model | None) -> Model:
    """``model``, or the release model (:func:`pretrained`, loaded once per process) when it is None."""
    return _pretrained_once(RELEASE_MODEL) if model is None else model


def model_from_state(config, state, stats_json: dict | None, facts: dict | None, source: str) -> Model:
    """The `Model` of a train state (its generators and phase network), as a checkpoint saves it: with the
    normalisation statistics `stats_json` and skeleton facts `facts` of ``extras`` (either may be None)."""
    stats = {k: np.asarray(v, np.float64) for k, v in (stats_json or {}).items()}
    params = {"forward": state.params["forward"], "backward": state.params["backward"]}
    phase_params = state.phase_params if config.model.phase_modulation else None
    return Model(config, params, phase_params, stats=stats, source=source, **_facts_fields(config.data, facts))


def random_model(config, seed: int = 0, joint_names: Sequence[str] | None = None) -> Model:
    """A freshly initialised model (untrained): for timing, tests and shape checks."""
    phase_config = config.phase if config.model.phase_modulation else None
    params, phase_params = _initializer(networks.model_spec(config.model, config.data), config.data,
                                        phase_config)(jax.random.PRNGKey(seed))
    fields = _facts_fields(config.data, None)
    if joint_names is not None:
        fields["joint_names"] = tuple(joint_names)
    return Model(config, {"forward": params["forward"], "backward": params["backward"]}, phase_params,
                 stats={}, source=f"random init (seed {seed})", **fields)


def with_matmul_dtype(model: Model, dtype: str) -> Model:
    """The same model computing its matmuls on ``dtype`` operands ("float32" or "bfloat16", float32
    accumulation either way; see ``accel.matmul.matmul``). Parameters are unchanged, so a float32-trained
    model can sample in bfloat16, faster on CPUs with bfloat16 units (AMX / AVX512-BF16); with the same seed
    the joint positions move a little (benchmarks/README.md has the speed and the change)."""
    try:
        config = config_lib.apply_overrides(model.config, [f"model.matmul_dtype={dtype}"])
    except config_lib.ConfigError as err:
        raise InbetweenError(str(err)) from None
    return dataclasses.replace(model, config=config)
