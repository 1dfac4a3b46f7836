"""Experiment configuration: frozen dataclasses holding every hyperparameter.

Size (~530 lines): the single list of every field, its default, its reason and its allowed values, in one place.

``Config(data, model, loss, train, phase)``. Each section lists the paper's fields first (``# paper``, section
4.4 of Ren et al. 2023, each default the paper's value), then the choices the paper leaves open (each with a
one-line ``# reason``), then the extensions (:data:`EXTENSIONS`): mechanisms the paper does not have, all off by
default, so the defaults train the paper's model. Named experiments live in the repository's ``configs/NAME.py``
(each defines ``get_config()``); load them with :func:`load_config` and change fields with
:func:`apply_overrides`::

    config = apply_overrides(load_config("lafan1"), ["model.latent_dim=32", "train.batch_size=8"])

Transition-length convention (docs/design.md §6): L = number of generated in-between frames; the start
keyframe is frame 0 of a training window and the target keyframe is frame L + 1.
"""
from __future__ import annotations

import dataclasses
import importlib.util
import json
import os
import pathlib
import sys
import typing

__all__ = [
    "DataConfig", "ModelConfig", "LossConfig", "TrainConfig", "PhaseConfig", "Config",
    "load_config", "apply_overrides", "to_dict", "from_dict", "configs_dir", "ConfigError", "variant", "CHOICES",
    "POSTERIOR_ONLY_FIELDS", "inert_fields", "check_overrides_take_effect", "EXTENSIONS", "ABLATION_SWITCHES",
    "extensions_on", "RETIRED_FIELDS", "Retired", "RetiredFieldError",
]


class ConfigError(ValueError):
    """A config name, field or value is wrong; the message says which and how to fix it."""


class RetiredFieldError(ConfigError):
    """A saved config sets a removed field (:data:`RETIRED_FIELDS`) to a value the code no longer has."""


@dataclasses.dataclass(frozen=True)
class DataConfig:
    """Which motion files train, and how they are cut into windows and scaled."""
    # --- the paper (section 4.1)
    train_subjects: tuple = ("subject1", "subject2", "subject3", "subject4")  # paper (the RMIB LAFAN1 split)
    window: int = 52  # paper: transitions of up to L = 50 generated frames, plus the 2 keyframes (docs/design.md §6)
    offset: int = 20  # paper: window offset 20
    fps: float = 30.0  # paper: LAFAN1's frame rate
    # --- choices the paper leaves open
    dataset: str = "lafan1"  # reason: which loader builds the windows (stitchjax.data.datasets: lafan1, h36m, bvh_folder)
    data_dir: str = ""  # reason: empty = ../shared/data/<dataset> relative to the repo, or set it
    parents: tuple = (-1, 0, 1, 2, 3, 0, 5, 6, 7, 0, 9, 10, 11, 12, 11, 14, 15, 16, 11, 18, 19, 20)
    # reason: FK inside the losses needs static parents; LAFAN1's 22 joints (the h36m and cmu configs set theirs)
    # --- dataset "bvh_folder" only (any folder of BVH files; stitchjax/data/bvh_folder.py)
    feet: tuple = ()  # reason: contact joints by name (left foot, left toe, right foot, right toe); () = common names
    up_axis: str = ""  # reason: the files' up axis ("+y", "+z", ...); "" = inferred
    forward_axis: str = ""  # reason: the root's local forward axis; "" = inferred from the upper legs and the up axis
    train_files: tuple = ()  # reason: glob patterns of training files under --data; () = the files of
    # train_subjects (folders or *_<subject> stems), else every file not in test_files
    test_files: tuple = ()  # reason: glob patterns of test files (kept out of training)
    unit_scale: float = 0.0  # reason: centimetres per file unit; 0 = inferred from the skeleton's height (CMU: 5.6444)
    # --- extensions (off by default; config.EXTENSIONS)
    validation_files: tuple = ()  # takes (file names without .bvh) held out whole as the validation split, scored by
    # train.eval_every and `bin/evaluate --split validation`; () = no split (validation uses the test windows)
    extra_train_dirs: tuple = ()  # more folders of training takes on the same skeleton, conformed on load
    # (datasets.training_set); relative paths are to --data; a test, validation or main take is refused
    random_starts: bool = False  # True: a training window may start at any frame (features.random_start_batch)
    mirror: bool = False  # True: every training window also trains as its left/right mirror (mirror.mirror_arrays)

    @property
    def num_joints(self) -> int:
        return len(self.parents)


@dataclasses.dataclass(frozen=True)
class ModelConfig:
    """The two generators (encoders, LSTM, latent Gaussians, phase-gated experts) and the discriminators."""
    # --- the paper (sections 3 and 4.4); the six switches are the ablations of section 5.3 and Appendix D
    bidirectional: bool = True  # paper; False = forward generator only, targets the end keyframe
    latent_interpolation: bool = True  # paper; False = sample from the current-frame Gaussian only
    bidirectional_aligning: bool = True  # paper; False = each generator targets the given end keyframe
    phase_modulation: bool = True  # paper; False = plain MLP decoder (no gating, no phase input)
    discriminators: bool = True  # paper; False = no discriminators: no L_G, no L_D, no discriminator update
    lstm: bool = True  # paper; False = the concatenated encoder embeddings go straight to the latent heads
    num_experts: int = 4  # paper
    disc_short_window: int = 2  # paper (RMIB short discriminator: 2 frames)
    disc_long_window: int = 10  # paper (RMIB long discriminator: 10 frames)
    # --- choices the paper leaves open
    encoder_widths: tuple = (512, 512, 256)  # reason: 3 FC layers each (paper); RMIB-like 512/256 widths
    lstm_size: int = 512  # reason: one LSTM layer over the 3x256 concatenated embeddings (RMIB scale)
    latent_dim: int = 32  # reason: small latent keeps KL cheap; diversity comes from per-frame sampling
    decoder_widths: tuple = (512, 512)  # reason: MANN-style 3-layer experts (2 hidden layers of 512)
    gating_widths: tuple = (64, 64)  # reason: MANN gating network is a small 3-layer MLP on the phase
    posterior: str = "next_frame"  # reason: z drawn from the prior at training carries nothing (docs/design.md §5.5).
    # "next_frame": at training z ~ q(z | h, ground-truth next frame) with KL(q || p), at inference z ~ p;
    # "none": z ~ p at training too (Eq. 5 as written)
    stitch_buffer: int = 4  # reason: K (paper leaves it open); 2K = 8 overlap frames, clipped to L//2
    contact_input_gradient: bool = False  # reason: contact outputs fed back without gradient stay contacts
    disc_widths: tuple = (512, 256)  # reason: RMIB discriminators: temporal conv then 2 dense layers
    matmul_dtype: str = "float32"  # reason: full precision; "bfloat16" = generator matmuls on bfloat16 operands with
    # float32 accumulation (faster where the hardware has bfloat16 units); checkpoints work with either
    # --- extensions (off by default; config.EXTENSIONS)
    update_anchor: str = "current"  # "current": each generated frame is the current frame plus the predicted
    # update (the paper); "interpolation": the predicted update is added to the next frame of the straight path
    # from the current frame to its target (rollout.interpolation_anchor): a zero update interpolates


@dataclasses.dataclass(frozen=True)
class LossConfig:
    """Weights of the terms of Eq. 9 and of the extra terms (all off by default)."""
    # --- the paper (Eq. 9, section 4.4)
    beta_rotation: float = 1.0  # paper beta1
    beta_velocity: float = 1.0  # paper beta2
    beta_contact: float = 0.1  # paper beta3
    kl_weight: float = 1.0  # paper alpha1 (with model.posterior: the weight of KL(q || p))
    stitch_weight: float = 0.5  # paper alpha2 (0 = "no stitching loss" ablation)
    fk_weight: float = 0.5  # paper alpha3
    disc_weight: float = 0.1  # paper alpha4 (scales L_D in the discriminator update)
    gen_weight: float = 0.1  # paper alpha5 (scales L_G in the generator update)
    # --- extensions (off by default; config.EXTENSIONS)
    kl_warmup_steps: int = 0  # > 0 ramps the KL weight linearly from 0 over this many steps
    free_bits: float = 0.0  # nats per frame (summed over latent dims) of KL(q || p) that cost nothing (Kingma 2016)
    prior_sample_fraction: float = 0.0  # this fraction of each batch's windows is rolled out with z from the prior
    # p, as at inference, instead of from q, and every term scores them
    foot_skate_weight: float = 0.0  # > 0 adds losses.foot_skate_loss: the feet's movement where they are in contact
    foot_skate_contacts: str = "truth"  # which feet that term holds: "truth" = the ground truth's contact labels;
    # "height" = the generated foot near the ground (the foot-slide metric's weight); "height_either" = near the
    # ground at either end of the movement, so a foot cannot jump from the air onto the ground for free;
    # "predicted" = the contacts the generator predicts for its own frames (no gradient through the weights)
    foot_velocity_weight: float = 0.0  # > 0 adds losses.foot_velocity_loss: the feet's movement per frame
    # against the ground truth's
    ground_penetration_weight: float = 0.0  # > 0 adds losses.ground_penetration_loss: how far the generated
    # foot joints go below the window's ground


@dataclasses.dataclass(frozen=True)
class TrainConfig:
    """Optimiser, progressive transition-length schedule, checkpoints, validation and speed settings."""
    # --- the paper (section 4.4)
    learning_rate: float = 1e-4  # paper
    adam_b1: float = 0.5  # paper
    adam_b2: float = 0.9  # paper
    weight_decay: float = 1e-5  # paper
    batch_size: int = 32  # paper
    min_length: int = 5  # paper: progressive schedule starts at 5
    max_length: int = 50  # paper: progressive schedule up to 50; L counts generated frames (window - 2)
    length_step: int = 1  # paper: +1 ...
    epochs_per_length: int = 2  # paper: ... every 2 epochs
    # --- choices the paper leaves open
    num_epochs: int = 100  # reason: (5 -> 50 takes 90 epochs) + some epochs at the full length
    seed: int = 0  # reason: reproducibility
    # --- run control (stitchjax/train/loop.py)
    log_every: int = 100  # reason: steps between metric logs
    max_steps: int = 0  # reason: 0 = num_epochs epochs; > 0 caps the run (bin/train --max-steps)
    checkpoint_every_steps: int = 0  # reason: steps between checkpoints; 0 = one a training epoch
    eval_every: int = 0  # reason: > 0 runs stitchjax.eval.validation every this many steps (bin/train; 0 = off)
    eval_windows: int = 32  # reason: windows validated (of data.validation_files, else the test windows;
    # evenly spaced, the same every time): cheap
    eval_lengths: tuple = (30,)  # reason: the paper's mid length; (30, 50) adds the long one
    # --- speed (benchmarks/README.md)
    weight_gradients_after_scan: bool = True  # reason: same gradients, faster (one matmul per kernel after the scan)
    scan_remat: str = "none"  # reason: autodiff's default; what the rollout's scan keeps for the backward pass
    # (accel.fast_rollout.SCAN_REMAT): "none" = every intermediate; "dots" = only matmul outputs; "nothing" = only
    # the carry; "taped" = one undifferentiated scan records a tape that is replayed differentiated
    # (stitchjax/accel/tape.py; needs weight_gradients_after_scan and a tapeable model.activation); the same
    # gradients with each
    length_buckets: tuple = (12, 24, 50)  # reason: static scan lengths (one compile each) beat one masked length
    # (the window is cut to bucket + 2 frames); () = one traced length masked in the full window, one compile
    # --- extensions (off by default; config.EXTENSIONS)
    lr_decay_to: float = 1.0  # 1 = constant (the paper); < 1: the learning rate falls linearly to this fraction of
    # learning_rate from lr_decay_from_step to lr_decay_until_step, and stays there (schedule.learning_rate_factor)
    lr_decay_from_step: int = 0  # the step the decay starts at (with lr_decay_to < 1)
    lr_decay_until_step: int = 0  # the step it reaches lr_decay_to (must be after lr_decay_from_step)
    length_after_schedule: str = "max"  # "max": once the schedule reaches max_length, train there (the paper);
    # "uniform": each step then draws its length from [min_length, max_length] (schedule.transition_length)


@dataclasses.dataclass(frozen=True)
class PhaseConfig:
    """The phase network and its pretraining (stitchjax.data.phase; the paper uses local motion phases but gives
    none of these settings; the labels' fit is stitchjax.data.phase's named constants)."""
    # --- choices the paper leaves open
    hidden_dim: int = 128  # reason: small MLP from one frame's state to the 8 phase features
    num_layers: int = 2  # reason: two ELU hidden layers suffice for the phase regression
    steps: int = 5000  # reason: the phase regression converges quickly
    batch_size: int = 512  # reason: frames are cheap


@dataclasses.dataclass(frozen=True)
class Config:
    data: DataConfig = dataclasses.field(default_factory=DataConfig)
    model: ModelConfig = dataclasses.field(default_factory=ModelConfig)
    loss: LossConfig = dataclasses.field(default_factory=LossConfig)
    train: TrainConfig = dataclasses.field(default_factory=TrainConfig)
    phase: PhaseConfig = dataclasses.field(default_factory=PhaseConfig)
    name: str = "default"  # reason: experiment name (run folder, logs)


_SECTIONS = ("data", "model", "loss", "train", "phase")


# ---------------------------------------------------------------------------------------------
# Loading named configs


# The named config of the release model; bin/export ships that model as stitchjax/pretrained/<this name>.
RELEASE_MODEL = "lafan1_cpu_release"


def configs_dir() -> pathlib.Path:
    """The configs folder: $STITCHJAX_CONFIGS, else ``configs/`` beside the package."""
    env = os.environ.get("STITCHJAX_CONFIGS")
    if env:
        return pathlib.Path(env)
    return pathlib.Path(__file__).resolve().parent.parent / "configs"


def available_configs() -> list:
    folder = configs_dir()
    return sorted(p.stem for p in folder.glob("*.py") if not p.stem.startswith("_"))


def load_config(name: str) -> Config:
    """Import ``configs/NAME.py`` and return its ``get_config()``; NAME may also be a path to a .py."""
    path = pathlib.Path(name)
    if path.suffix != ".py":
        path = configs_dir() / f"{name}.py"
    if not path.is_file():
        raise ConfigError(
            f"no config named {name!r}: {path} does not exist. Available in {configs_dir()}: "
            f"{', '.join(available_configs()) or '(none)'}; set STITCHJAX_CONFIGS to another folder.")
    spec = importlib.util.spec_from_file_location(f"stitchjax_configs_{path.stem}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    if not hasattr(module, "get_config"):
        raise ConfigError(f"{path} defines no get_config() function")
    config = module.get_config()
    if not isinstance(config, Config):
        raise ConfigError(f"{path}: get_config() returned {type(config).__name__}, not stitchjax Config")
    return config


def variant(base: str, *overrides: str, name: str):
    """``get_config`` of config ``base`` with "section.field=value" overrides and a new name; a config file
    that changes a few fields is one line: ``get_config = variant("lafan1", "model.bidirectional=false",
    name="ablate_no_bidirectional")``. ``base`` is looked up beside the calling file first (so a configs folder
    loaded by path uses its own bases), then as :func:`load_config` finds it."""
    caller = sys._getframe(1).f_globals.get("__file__")
    sibling = pathlib.Path(caller).with_name(f"{base}.py") if caller and not base.endswith(".py") else None

    def get_config() -> Config:
        source = str(sibling) if sibling is not None and sibling.is_file() else base
        return dataclasses.replace(apply_overrides(load_config(source), list(overrides)), name=name)

    return get_config


# ---------------------------------------------------------------------------------------------
# Overrides


def _field_types(cls) -> dict:
    hints = typing.get_type_hints(cls)
    return {f.name: hints[f.name] for f in dataclasses.fields(cls)}


def _parse_bool(text: str) -> bool:
    low = text.strip().lower()
    if low in ("1", "true", "yes", "on"):
        return True
    if low in ("0", "false", "no", "off"):
        return False
    raise ValueError(f"{text!r} is not a boolean (use true/false)")


def inert_fields(posterior: str, extensions: tuple) -> tuple:
    """The ``extensions`` ("section.field", :func:`extensions_on` of a config) that change nothing with
    ``model.posterior`` = ``posterior``: the :data:`POSTERIOR_ONLY_FIELDS` among them when it is "none"."""
    if posterior != "none":
        return ()
    return tuple(name for name in extensions if tuple(name.split(".")) in POSTERIOR_ONLY_FIELDS)


def check_overrides_take_effect(inert: tuple, overrides) -> None:
    """Raise ConfigError when one of the "section.field=value" ``overrides`` sets a field of ``inert``
    (:func:`inert_fields` of the config with the overrides applied): a run would silently train without it."""
    inert = set(inert)
    given = [item.split("=", 1)[0].strip() for item in overrides or () if "=" in item]
    wasted = [key for key in given if key in inert]
    if wasted:
        verb = "changes" if len(wasted) == 1 else "change"
        raise ConfigError(f"{', '.join(wasted)} {verb} nothing with model.posterior=none (every z is drawn from "
                          "the prior, there is no posterior): drop the override, or train with "
                          "model.posterior=next_frame")


def _parse_value(text: str, kind, current):
    if kind is bool:
        return _parse_bool(text)
    if kind is int:
        return int(text)
    if kind is float:
        return float(text)
    if kind is str:
        return text
    if kind is tuple or typing.get_origin(kind) is tuple:
        stripped = text.strip().strip("()[]")
        parts = [p.strip() for p in stripped.split(",") if p.strip()]
        element = type(current[0]) if current else str
        if element is bool:
            return tuple(_parse_bool(p) for p in parts)
        return tuple(element(p) for p in parts)
    raise ValueError(f"cannot parse fields of type {kind}")


def apply_overrides(config: Config, overrides) -> Config:
    """Return a new Config with "section.field=value" overrides applied (values parsed by field type).

    Tuples are written comma separated: ``model.decoder_widths=256,256``. ``name=foo`` sets the name.
    """
    for item in overrides or ():
        if "=" not in item:
            raise ConfigError(f"override {item!r} must look like section.field=value, e.g. model.latent_dim=32")
        key, text = item.split("=", 1)
        key = key.strip()
        if key == "name":
            config = dataclasses.replace(config, name=text)
            continue
        section, _, field = key.partition(".")
        if section not in _SECTIONS or not field:
            raise ConfigError(f"override {item!r}: unknown section {section!r}; use one of {', '.join(_SECTIONS)}")
        sub = getattr(config, section)
        types_ = _field_types(type(sub))
        if field not in types_:
            retired = RETIRED_FIELDS.get((section, field))
            if retired is not None:
                raise ConfigError(f"override {item!r}: {section}.{field} was removed (it last lived in commit "
                                  f"{retired.commit})")
            raise ConfigError(f"override {item!r}: {section} has no field {field!r}; fields: {', '.join(types_)}")
        current = getattr(sub, field)
        try:
            value = _parse_value(text, types_[field], current)
        except ValueError as err:
            raise ConfigError(f"override {item!r}: {err}") from None
        choices = CHOICES.get((section, field))
        if choices is not None and value not in choices:
            raise ConfigError(f"override {item!r}: {section}.{field} must be one of {', '.join(choices)}")
        config = dataclasses.replace(config, **{section: dataclasses.replace(sub, **{field: value})})
    return config


# ---------------------------------------------------------------------------------------------
# Extensions a config turns on


def _default(section: str, field: str):
    cls = type(getattr(Config(), section))
    return next(f.default for f in dataclasses.fields(cls) if f.name == field)


def extensions_on(config: Config) -> tuple:
    """The :data:`EXTENSIONS` ("section.field") that ``config`` sets away from the paper's value (the default)."""
    on = []
    for name in EXTENSIONS:
        section, field = name.split(".")
        if getattr(getattr(config, section), field) != _default(section, field):
            on.append(name)
    return tuple(on)


# ---------------------------------------------------------------------------------------------
# Serialisation


def to_dict(config: Config) -> dict:
    """Plain JSON-ready dict (tuples become lists)."""
    return json.loads(json.dumps(dataclasses.asdict(config)))


def from_dict(d: dict) -> Config:
    """Inverse of :func:`to_dict`. Unknown keys raise ConfigError. A missing field of :data:`EXTENSIONS` or
    :data:`ABLATION_SWITCHES` takes its default (the paper's behaviour, which is also what a run did before the
    field existed); any other missing field raises ConfigError naming the fields to add (with the values the
    run was trained with). A field of :data:`RETIRED_FIELDS` is dropped when it holds the value the code now
    always uses, and refused (ConfigError naming it and the last commit that had it) when it holds another."""
    kwargs, missing = {}, []
    classes = {f.name: f.default_factory for f in dataclasses.fields(Config) if f.name in _SECTIONS}
    for key, value in d.items():
        if key == "name":
            kwargs["name"] = value
            continue
        if key not in classes:
            raise ConfigError(f"unknown config section {key!r}")
        cls = classes[key]
        types_ = _field_types(cls)
        fields = {}
        missing += [f"{key}.{name}" for name in types_
                    if name not in value and f"{key}.{name}" not in EXTENSIONS + ABLATION_SWITCHES]
        for name, v in value.items():
            if (key, name) in RETIRED_FIELDS:
                _check_retired(key, name, v)
                continue
            if name not in types_:
                raise ConfigError(f"unknown field {key}.{name} (saved by another stitchjax version?)")
            kind = types_[name]
            if kind is tuple or typing.get_origin(kind) is tuple:
                v = tuple(v)
            fields[name] = v
        kwargs[key] = cls(**fields)
    if missing:
        raise ConfigError(f"the saved config lacks {', '.join(missing)}: add {'it' if len(missing) == 1 else 'them'} "
                          "to the config JSON with the values the run was trained with (a field outside "
                          "config.EXTENSIONS has no value that is sure to mean what the run did)")
    return Config(**kwargs)


def _check_retired(section: str, field: str, value) -> None:
    """ConfigError when a saved config's retired ``section.field`` holds a value other than the one the code
    now always uses (:data:`RETIRED_FIELDS`)."""
    retired = RETIRED_FIELDS[(section, field)]
    if retired is None or _same_value(value, retired.value):
        return
    raise RetiredFieldError(
        f"the saved config sets {section}.{field}={value!r}, but stitchjax no longer has that field: it always "
        f"uses {retired.value!r} now. The run was made by an earlier version; load it with commit {retired.commit} "
        f"(the last that had {section}.{field}), e.g. `git worktree add ../stitchjax_{retired.commit} "
        f"{retired.commit}`")


def _same_value(saved, value) -> bool:
    """A JSON value (lists for tuples) equal to a field value."""
    if isinstance(value, tuple):
        return isinstance(saved, (list, tuple)) and tuple(saved) == value
    return saved == value and isinstance(saved, bool) == isinstance(value, bool)


# ---------------------------------------------------------------------------------------------
# Bookkeeping tables (read by the functions above and by other modules)


EXTENSIONS = (
    # data: the paper trains on every window of subjects 1-4, starting every 20 frames, unmirrored
    "data.validation_files", "data.extra_train_dirs", "data.random_starts", "data.mirror",
    # model
    "model.update_anchor",
    # loss: terms and weightings beyond Eq. 9
    "loss.kl_warmup_steps", "loss.free_bits", "loss.prior_sample_fraction", "loss.foot_skate_weight",
    "loss.foot_skate_contacts", "loss.foot_velocity_weight", "loss.ground_penetration_weight",
    # train: the paper keeps the learning rate constant and trains at max_length once the schedule reaches it
    "train.lr_decay_to", "train.lr_decay_from_step", "train.lr_decay_until_step", "train.length_after_schedule",
)
"""Every mechanism the paper does not have ("section.field"), off at its default; :func:`extensions_on`."""

ABLATION_SWITCHES = ("model.discriminators", "model.lstm")
"""Switches that turn a part of the paper's model off (Appendix D), added after runs were saved with the part on:
:func:`from_dict` gives a saved config without one its default (on)."""

CHOICES = {
    ("data", "dataset"): ("lafan1", "h36m", "bvh_folder"),  # stitchjax.data.datasets.REGISTRY has one entry each
    ("model", "matmul_dtype"): ("float32", "bfloat16"),
    ("model", "posterior"): ("next_frame", "none"),
    ("model", "update_anchor"): ("current", "interpolation"),
    ("loss", "foot_skate_contacts"): ("truth", "height", "height_either", "predicted"),
    ("train", "scan_remat"): ("none", "dots", "nothing", "taped"),  # accel.fast_rollout.SCAN_REMAT: one each
    ("train", "length_after_schedule"): ("max", "uniform"),  # schedule.transition_length
}
"""The values a string field takes, checked by :func:`apply_overrides` before any work starts."""

POSTERIOR_ONLY_FIELDS = (("loss", "free_bits"), ("loss", "prior_sample_fraction"))
"""Extensions that act only through the posterior q (or on windows drawn from the prior instead of q): inert
with model.posterior="none" (:func:`inert_fields`)."""


@dataclasses.dataclass(frozen=True)
class Retired:
    """A removed field: value, the one the code now always uses (what a saved config may hold); commit, the last
    commit that had the field."""

    value: typing.Any
    commit: str


_LAST = "656e31b"  # the last commit with the fields removed from the extensions and unused choices
_LAST_BEFORE_CONSTANTS = "9baff53"  # the last commit with the near-keyframe weight and the settings now constants
RETIRED_FIELDS = {
    # read nowhere: any saved value is dropped
    ("train", "length_counts_keyframes"): None,
    ("train", "output_dir"): None,
    # extensions that neither the release recipe nor an open study uses
    ("model", "keyframe_velocity"): Retired("zero", _LAST),
    ("model", "noise_correlation"): Retired(0.0, _LAST),  # at training; sampling keeps its own correlation
    ("model", "posterior_horizon"): Retired(1, _LAST),
    ("loss", "prior_kl_weight"): Retired(0.0, _LAST),
    ("loss", "prior_rollout"): Retired(False, _LAST),
    ("loss", "prior_sample_reconstruction_weight"): Retired(1.0, _LAST),
    ("loss", "prior_best_of"): Retired(1, _LAST),
    # choices no config or study set away from the value kept
    ("model", "gamma_schedule"): Retired("direction", _LAST),
    ("model", "activation"): Retired("elu", _LAST),
    ("model", "z_every_layer"): Retired(True, _LAST),
    ("model", "decoder_uses_lstm"): Retired(False, _LAST),
    ("model", "time_to_target_input"): Retired(True, _LAST),
    ("model", "variance_blend"): Retired("std", _LAST),
    ("model", "stop_phase_gradient"): Retired(True, _LAST),
    ("model", "disc_features"): Retired("positions+velocity", _LAST),
    ("loss", "reduction"): Retired("sum", _LAST),
    ("train", "checkpoint_every"): Retired(1, _LAST),
    ("train", "max_to_keep"): Retired(3, _LAST),
    ("phase", "window_seconds"): Retired(1.0, _LAST),
    ("phase", "min_frequency"): Retired(0.25, _LAST),
    ("phase", "max_frequency"): Retired(4.0, _LAST),
    ("phase", "num_frequencies"): Retired(31, _LAST),
    ("phase", "smoothing_seconds"): Retired(0.05, _LAST),
    ("phase", "ridge"): Retired(1.0, _LAST),
    ("phase", "learning_rate"): Retired(1e-3, _LAST),
    ("phase", "include_reversed"): Retired(True, _LAST),
    # the near-keyframe weight: its last study closed as superseded; the value kept weighs every frame alike
    ("loss", "near_keyframe_weight"): Retired(1.0, _LAST_BEFORE_CONSTANTS),
    ("loss", "near_keyframe_frames"): Retired(1, _LAST_BEFORE_CONSTANTS),
    # settings no config or study set away from the value kept, now named constants where the code reads them
    ("data", "position_scale"): Retired(100.0, _LAST_BEFORE_CONSTANTS),  # data.features.POSITION_SCALE
    ("data", "velocity_scale"): Retired(10.0, _LAST_BEFORE_CONSTANTS),  # data.features.VELOCITY_SCALE
    ("data", "num_contacts"): Retired(4, _LAST_BEFORE_CONSTANTS),  # data.features.NUM_CONTACTS
    ("train", "eval_samples"): Retired(4, _LAST_BEFORE_CONSTANTS),  # eval.validation.VALIDATION_SAMPLES
}
"""Removed fields, (section, field) -> :class:`Retired` (None: read nowhere, any value dropped). :func:`from_dict`
drops one that a saved config holds at the value the code now always uses, and refuses any other value."""
