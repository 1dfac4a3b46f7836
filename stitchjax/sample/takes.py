"""Take-level in-betweening: keyframes picked from whole takes (any file, units, up axis, frame rate),
transitions returned as takes.

    model = trained_model.load_model("runs/quickstart")   # or None: the release model (stitchjax.pretrained())
    clips = inbetween_clip(model, motion, 100, 140, num_samples=8)   # whole takes, frames 101..139 replaced
    placed = inbetween_takes(model, take, 100, other, 50, length=20, offset=(300, 0, 0), turn_degrees=90)
    # the target's root 300 cm from the start keyframe's root (offset_from="start", the default)
    proposal = propose_take_length(model, take, 100, other, 50)   # frames (low..high) for these keyframes
    clips = inbetween_clip(model, motion, 100, 140, length="auto")   # the proposed frames between, not 39

Each take is brought onto the model's terms first (:func:`conform_take`: units, up axis, joints by name,
bone lengths checked), the target take placed by an offset (from the start keyframe's root, or from where
its own file has it) and a turn, both resampled to the model's frame rate anchored at their keyframes, and
the keyframes' foot contacts measured against their neighbouring frames. A transition that would have to
travel faster than the training data's root speed (its 99th percentile, :func:`root_speed_limit`) is
refused with the fix. The sampling itself is :func:`stitchjax.sample.inbetween.inbetween`; the generated frames go
back to the start take's frame rate (:func:`stitchjax.data.conform.retime`), units and up axis
(:func:`from_model_frame`), so frame numbers and durations are the files' own.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from stitchjax.data import conform
from stitchjax import rotations as R
from stitchjax.data.bvh import Motion
from stitchjax.sample import length as length_lib
from stitchjax.sample.inbetween import (check_request, check_skeleton, check_length, inbetween, keyframe_contacts,
                                       resolve_sampling)
from stitchjax.sample.sampling import Sampling
from stitchjax.skeleton import forward_kinematics
from stitchjax.sample.trained_model import InbetweenError, Model, model_or_pretrained

__all__ = ["OUTPUTS", "OFFSET_FROM", "TakeOptions", "inbetween_takes", "inbetween_clip", "conform_take",
           "to_model_frame", "from_model_frame", "default_length", "model_length", "root_speed_limit", "fewest_frames",
           "required_root_speed", "check_root_speed", "propose_take_length", "LAFAN1_ROOT_SPEED_P99"]

# cm/s: the 99th percentile of the horizontal root speed of LAFAN1's training windows (subjects 1-4 of the
# 27 files, windows 50 / offset 20 at 30 fps). The limit of
# checkpoints saved before bin/train recorded their own (stats["root_speed_p99"]).
LAFAN1_ROOT_SPEED_P99 = 330.8


def to_model_frame(model: Model, motion: Motion, scale: float = 1.0) -> Motion:
    """A take in the training files' units and up axis -> the model's (cm, +Y up): positions times
    ``scale * model.unit_scale``, then the world turned so that ``model.up_axis`` becomes +Y. LAFAN1 /
    H36M models (cm, +Y up) with ``scale`` 1: returned unchanged."""
    factor = float(scale) * float(model.unit_scale)
    motion = conform.rescale(motion, factor) if factor != 1.0 else motion
    return conform.to_y_up(motion, model.up_axis)


def from_model_frame(model: Model, motion: Motion, scale: float = 1.0) -> Motion:
    """Inverse of :func:`to_model_frame` (to float64 rounding): +Y up back to ``model.up_axis``, then
    positions divided by ``scale * model.unit_scale``."""
    motion = conform.from_y_up(motion, model.up_axis)
    factor = float(scale) * float(model.unit_scale)
    return conform.rescale(motion, 1.0 / factor) if factor != 1.0 else motion


def conform_take(model: Model, motion: Motion, what: str = "the take", scale: float = 1.0) -> Motion:
    """A take on the model's terms: in its units and up axis (:func:`to_model_frame`: positions times
    ``scale * model.unit_scale``, turned to +Y up), joints mapped by name onto the model's skeleton (extra
    joints folded away, missing ones refused), and its bone lengths checked against the model's training
    skeleton (``stats["offsets"]``) — another scale is refused with the measured ratio and the fix. The
    frame rate is left alone (see :func:`stitchjax.data.conform.resample`, anchored at a keyframe)."""
    if not isinstance(motion, Motion):
        raise InbetweenError(f"{what} must be a stitchjax.data.bvh.Motion, got {type(motion).__name__}")
    try:
        motion = to_model_frame(model, motion, scale)
        if model.joint_names is not None and (tuple(motion.skeleton.names) != tuple(model.joint_names)
                                              or tuple(motion.skeleton.parents) != model.parents):
            motion = conform.map_joints(motion, model.joint_names, model.parents, what)
        reference = model.stats.get("offsets") if model.stats else None
        if reference is not None and np.shape(reference) == (model.num_joints, 3):
            conform.check_scale(motion.skeleton.offsets, reference, what, "the model's training skeleton",
                                "bin/inbetween --scale {factor} (Python: scale={factor})", applied=scale)
    except conform.ConformError as error:
        raise InbetweenError(str(error)) from None
    check_skeleton(model, motion.skeleton)
    return motion


def _neighbour_contacts(model: Model, motion: Motion, frame: int, prefer: int):
    """Contacts of keyframe ``frame`` measured against frame ``frame + prefer`` (or the other side)."""
    total = motion.num_frames
    other = frame + prefer if 0 <= frame + prefer < total else (frame - prefer if 0 <= frame - prefer < total else None)
    frames = [frame] if other is None else [frame, other]
    _, gpos = forward_kinematics(motion.rotations[frames], motion.positions[frames], motion.skeleton.parents)
    return keyframe_contacts(gpos[0], model.feet, None if other is None else gpos[1])


def _check_frame(motion: Motion, frame, name: str):
    total = motion.num_frames
    if int(frame) != frame or not 0 <= frame < total:
        raise InbetweenError(f"{name} {frame} is out of range: the motion has {total} frames (0..{total - 1})")


OUTPUTS = ("transition", "appended", "clip")


def default_length(model: Model, start_take: Motion, start_frame: int, target_frame: int, same: bool) -> int:
    """Frames to generate when none is given, in the take's own frames: the frames between the keyframes."""
    if not same:
        raise InbetweenError("give the transition length (frames to generate) when the target keyframe "
                             "comes from another take")
    if target_frame <= start_frame:
        raise InbetweenError(f"end frame {target_frame} must come after start frame {start_frame}")
    length = int(target_frame) - int(start_frame) - 1
    if length < 1:
        raise InbetweenError(f"frames {start_frame} and {target_frame} are adjacent: nothing to generate; "
                             f"give a length >= 1 or keyframes further apart")
    model_length(model, start_take.fps, length)  # refuses keyframes closer than one frame of the model
    return length


def model_length(model: Model, take_fps: float, length: int) -> int:
    """The frames the model generates for ``length`` frames of a take at ``take_fps``: the same duration,
    (length + 1) frame steps, at the model's rate, rounded (``length`` itself when the rates agree)."""
    ratio = float(model.config.data.fps) / float(take_fps)
    if abs(ratio - 1.0) <= 1e-9:
        return int(length)
    generated = int(round((int(length) + 1) * ratio)) - 1
    if generated < 1:
        raise InbetweenError(
            f"{length} frames at {float(take_fps):g} fps last {(length + 1) / float(take_fps):.3f} s: less than two "
            f"frames of the model's {float(model.config.data.fps):g} fps, nothing to generate; give a longer "
            f"transition (at least {int(np.ceil(1.5 / ratio))} frames of the take)")
    return generated


def root_speed_limit(model: Model) -> tuple[float, str]:
    """(cm/s, where it comes from): the fastest mean horizontal root speed a transition may ask for — the 99th
    percentile of the training windows' root speed, saved by ``bin/train`` as ``stats["root_speed_p99"]``;
    for checkpoints saved before that, LAFAN1's (:data:`LAFAN1_ROOT_SPEED_P99`)."""
    saved = model.stats.get("root_speed_p99") if model.stats else None
    if saved is not None and np.isfinite(float(saved)) and float(saved) > 0:
        return float(saved), "the 99th percentile of the training data's root speed"
    return LAFAN1_ROOT_SPEED_P99, ("the 99th percentile of LAFAN1's training root speed (this checkpoint "
                                   "predates the saved limit)")


def required_root_speed(start_root, target_root, length: int, fps: float) -> float:
    """Mean horizontal root speed (cm/s) a transition of ``length`` generated frames at ``fps`` needs to go
    from ``start_root`` to ``target_root`` ((3,) cm, +Y up): their x-z distance over (length + 1) frames."""
    gap = np.asarray(target_root, np.float64) - np.asarray(start_root, np.float64)
    return float(np.hypot(gap[0], gap[2])) * float(fps) / (int(length) + 1)


def fewest_frames(distance, limit: float, fps: float):
    """The fewest frames between two keyframes ``distance`` cm apart over the ground (a number or an array)
    at ``fps`` that keep the mean root speed at or under ``limit`` cm/s: ceil(distance * fps / limit) - 1."""
    return np.ceil(np.asarray(distance, np.float64) * float(fps) / float(limit)) - 1


def check_root_speed(model: Model, start_root, target_root, length: int, take_fps: float | None = None,
                     allow_fast: bool = False) -> float:
    """The required mean root speed (cm/s) of a transition of ``length`` frames at the model's rate, refused
    (InbetweenError with the speed, the limit and the fixes) above :func:`root_speed_limit` unless
    ``allow_fast``. take_fps: the rate the user counts frames at (the fix's frame count is in it)."""
    fps = float(model.config.data.fps)
    speed = required_root_speed(start_root, target_root, length, fps)
    limit, source = root_speed_limit(model)
    if speed > limit and not allow_fast:
        gap = np.asarray(target_root, np.float64) - np.asarray(start_root, np.float64)
        distance = float(np.hypot(gap[0], gap[2]))
        take_fps = fps if take_fps is None else float(take_fps)
        frames = int(fewest_frames(distance, limit, take_fps))
        raise InbetweenError(
            f"the transition must carry the root {distance:.0f} cm over the ground in {(length + 1) / fps:.2f} s: "
            f"{speed / 100:.2f} m/s ({speed / fps:.1f} cm/frame at {fps:g} fps) on average, faster than "
            f"{limit / 100:.2f} m/s, {source}; give it more frames (length {frames} or more at {take_fps:g} fps), "
            f"place the target nearer (offset from the start keyframe: --offset-from start, Python "
            f"offset_from='start'), or force it (--allow-fast, Python allow_fast=True)")
    return speed


OFFSET_FROM = ("start", "file")


@dataclasses.dataclass(frozen=True)
class TakeOptions:
    """How :func:`inbetween_takes` places the target take and what it returns.

    offset: (x, y, z) from the start keyframe's root (``offset_from="start"``: horizontally, the height as
      given) or from where the target take's own file has it (``"file"``) to the target keyframe's root; the
      takes' units and axes, before ``scale``. turn_degrees: turn of the target take about the up axis through
      its keyframe's root. scale: factor on both takes' positions. output: one of :data:`OUTPUTS`.
    allow_extrapolation: allow a transition longer than the model's training lengths.
    allow_fast: allow a transition faster than the training data's root speed (:func:`check_root_speed`).
    """

    offset: tuple = (0.0, 0.0, 0.0)
    turn_degrees: float = 0.0
    offset_from: str = "start"
    scale: float = 1.0
    output: str = "appended"
    allow_extrapolation: bool = False
    allow_fast: bool = False


def _split_overrides(options: TakeOptions | None, overrides: dict) -> tuple:
    """(TakeOptions with the keywords that name its fields, the remaining keywords: Sampling fields)."""
    names = {f.name for f in dataclasses.fields(TakeOptions)}
    options = dataclasses.replace(options or TakeOptions(), **{k: v for k, v in overrides.items() if k in names})
    return options, {k: v for k, v in overrides.items() if k not in names}


def _placed_target(model: Model, start_take: Motion, start_frame: int, target_take: Motion, target_frame: int,
                   options: TakeOptions, same: bool) -> Motion:
    """The target take (model terms, its own frame rate) turned by ``options.turn_degrees`` about its keyframe's
    root and moved so that its keyframe's root lies ``options.offset`` (the takes' units and axes, before
    ``options.scale``) from the start keyframe's root (``offset_from="start"``; horizontally, the height offset as
    given) or from where its own file has it (``"file"``). A target keyframe of the start take itself with no
    offset stays where it is (turned about its root, if asked); unmoved with ``"file"`` and neither."""
    offset, turn_degrees, scale, offset_from = options.offset, options.turn_degrees, options.scale, options.offset_from
    try:
        offset = np.asarray(offset, np.float64)
        if offset.shape != (3,):
            raise conform.ConformError(f"offset must be 3 numbers (x, y, z), got shape {offset.shape}")
        moved = np.any(offset != 0) or bool(turn_degrees)
        if not moved and (same or offset_from == "file"):
            return target_take
        shift = R.quat_rotate(conform.up_turn(model.up_axis), offset) * scale * model.unit_scale  # +Y up, cm
        if offset_from == "start" and (np.any(offset != 0) or not same):  # the take's own target: only turned
            gap = start_take.positions[start_frame, 0] - target_take.positions[target_frame, 0]
            shift = shift + np.array([gap[0], 0.0, gap[2]])
        return conform.place(target_take, shift, turn_degrees, pivot=int(target_frame))
    except conform.ConformError as error:
        raise InbetweenError(str(error)) from None


def _at_rate(take: Motion, fps: float, frame: int) -> tuple:
    """(take at ``fps``, index of ``frame`` in it): resampled anchored at ``frame`` (kept exactly)."""
    try:
        return conform.resample(take, fps, int(frame))
    except conform.ConformError as error:
        raise InbetweenError(str(error)) from None


def _proposal_at(proposal: length_lib.Proposal, fps: float) -> length_lib.Proposal:
    """``proposal`` counted at ``fps``: the same durations, (frames + 1) frame steps each, rounded."""
    ratio = float(fps) / proposal.fps
    if abs(ratio - 1.0) <= 1e-9:
        return proposal
    frames = [max(int(round((n + 1) * ratio)) - 1, 1) for n in (proposal.low, proposal.frames, proposal.high)]
    return dataclasses.replace(proposal, low=frames[0], frames=frames[1], high=frames[2], fps=float(fps))


def propose_take_length(model: Model, start_take: Motion, start_frame: int, target_take: Motion,
                        target_frame: int, *, offset=(0.0, 0.0, 0.0), turn_degrees: float = 0.0, scale: float = 1.0,
                        offset_from: str = "start", length_model: length_lib.LengthModel | None = None
                        ) -> length_lib.Proposal:
    """The proposed transition length between two keyframes, placed as :func:`inbetween_takes` places them
    (same arguments), counted at the start take's frame rate: a :class:`stitchjax.sample.length.Proposal`
    (frames, plausible low..high, the root distance and turn). length_model: default the one shipped for the
    model's skeleton (:func:`stitchjax.sample.length.length_model_for`; InbetweenError for another skeleton).
    Every number is at least the fewest frames that keep the root under :func:`root_speed_limit`."""
    model = model_or_pretrained(model)
    _check_takes_request(start_take, start_frame, target_take, target_frame, "transition", offset_from, scale)
    if length_model is None:
        try:
            length_model = length_lib.length_model_for(model.joint_names, model.forward_axis)
        except length_lib.LengthModelError as error:
            raise InbetweenError(str(error)) from None
    same = target_take is start_take
    start_take = conform_take(model, start_take, "the start take", scale)
    target_take = start_take if same else conform_take(model, target_take, "the target take", scale)
    target_take = _placed_target(model, start_take, start_frame, target_take, target_frame,
                                 TakeOptions(offset, turn_degrees, offset_from, scale), same)
    poses = []
    for take, frame in ((start_take, start_frame), (target_take, target_frame)):
        rotations, positions = forward_kinematics(take.rotations[[frame]], take.positions[[frame]],
                                                  take.skeleton.parents)
        poses += [positions[0], rotations[0, 0]]
    gap = poses[2][0] - poses[0][0]
    limit, _ = root_speed_limit(model)
    floor = int(fewest_frames(np.hypot(gap[0], gap[2]), limit, length_model.fps))
    proposal = length_lib.propose_length(length_model, *poses, min_frames=floor)
    return _proposal_at(proposal, float(start_take.fps))


def _check_takes_request(start_take, start_frame, target_take, target_frame, output: str, offset_from: str,
                         scale: float) -> None:
    """InbetweenError naming the first bad argument of :func:`inbetween_takes`."""
    if output not in OUTPUTS:
        raise InbetweenError(f"output {output!r}: use one of {', '.join(OUTPUTS)}")
    if offset_from not in OFFSET_FROM:
        raise InbetweenError(f"offset_from {offset_from!r}: use one of {', '.join(OFFSET_FROM)}")
    if not np.isfinite(scale) or scale <= 0:
        raise InbetweenError(f"scale must be a positive number, got {scale}")
    for what, take in (("start take", start_take), ("target take", target_take)):
        if not isinstance(take, Motion):
            raise InbetweenError(f"{what} must be a stitchjax.data.bvh.Motion, got {type(take).__name__}")
    _check_frame(start_take, start_frame, "start frame")
    _check_frame(target_take, target_frame, "target frame")


def _take_outputs(model: Model, samples: list, start_take: Motion, start_frame: int, target_take: Motion,
                  target_frame: int, generated: int, length: int, take_fps: float, options: TakeOptions) -> list:
    """The generated ``samples`` (``generated`` frames at the model's rate) put between the takes' frames as
    ``options.output`` says, ``length`` frames at the start take's rate ``take_fps``, in the takes' own units
    and axes (``options.scale`` undone). start_take, target_take: on the model's terms (:func:`conform_take`,
    the target placed)."""
    output, scale = options.output, options.scale
    fps = float(model.config.data.fps)
    # the target take at the start take's rate, its keyframe at index b_out
    target_out, b_out = _at_rate(target_take, take_fps, target_frame)
    a_out = int(start_frame)
    out = []
    for s in samples:
        if generated != length or abs(take_fps - fps) > 1e-9 * fps:
            s = conform.retime(s, length + 2, take_fps)  # back onto the take's frames
        head = slice(a_out, a_out + 1) if output == "transition" else slice(0, a_out + 1)
        tail = slice(b_out, None) if output == "clip" else slice(b_out, b_out + 1)
        motion = start_take.with_frames(
            np.concatenate([start_take.rotations[head], s.rotations[1:-1], target_out.rotations[tail]]),
            np.concatenate([start_take.positions[head], s.positions[1:-1], target_out.positions[tail]]))
        out.append(from_model_frame(model, motion, scale))
    return out


def inbetween_takes(model: Model, start_take: Motion, start_frame: int, target_take: Motion, target_frame: int,
                    length: int | str | None = None, num_samples: int = 1, seed=0, *,
                    options: TakeOptions | None = None, sampling: Sampling | None = None, **overrides) -> list:
    """Transitions from frame ``start_frame`` of one take to frame ``target_frame`` of another (or the same).
    ``model``: a :class:`Model`, or None for the release model (``stitchjax.pretrained()``); the same in
    :func:`inbetween_clip`.

    options: a :class:`TakeOptions` (placement, output, what to allow; default ``TakeOptions()``); sampling: a
    :class:`stitchjax.sample.sampling.Sampling` (default ``model.sampling``, the model's default, feet locked).
    overrides: fields of either given as keywords on top of them (``offset=(300, 0, 0)``, ``search=4``,
    ``foot_lock=False``, ...; a None sampling field keeps it).

    Both takes are brought onto the model's terms first (:func:`conform_take`: the training files' units and
    up axis to cm and +Y up, joints by name, units checked; ``scale`` multiplies their positions). The
    target take is then placed: turned by ``turn_degrees`` about the up axis through its keyframe's root
    and moved so its keyframe's root lies ``offset`` (x, y, z; the takes' own units and axes, before
    ``scale``) from the start keyframe's root (``offset_from="start"``, the default: horizontally, the height
    as given) or from where its own file has it (``"file"``); a target keyframe of the start take itself
    with no offset stays where it is (turned about its root, if asked). Both are resampled to the model's
    frame rate anchored at their keyframes (kept exactly), and a transition whose mean root speed would
    exceed the training data's (:func:`check_root_speed`) is refused unless ``allow_fast``.
    length: frames between the keyframes in the output, counted at the start take's frame rate (default:
      the frames between them when both come from one take; required otherwise), or "auto": the proposal of
      :func:`propose_take_length` for these keyframes, placed. The model generates
      :func:`model_length` frames at its own rate for the same duration; at another rate than the take's
      they are resampled back onto the ``length`` frames (:func:`stitchjax.data.conform.retime`).
    output: "transition" = the start keyframe, L generated frames, the placed target keyframe (L + 2 frames);
      "appended" = the start take's frames 0..start_frame, the L generated frames and the target keyframe;
      "clip" = "appended" followed by the rest of the (placed) target take.
    The sampling: noise (how far the samples spread), latent-pair search and foot locking as in
    :func:`stitchjax.sample.inbetween.inbetween`.
    Returns ``num_samples`` Motions at the start take's frame rate on the model's skeleton (the takes' own
    skeleton and channel layout when their joints already match), positions in the takes' units and axes
    (exact for cm, +Y-up models, else to float64 rounding); the takes' own frames, keyframes included, are
    kept as they are.
    """
    model = model_or_pretrained(model)  # None: the release model
    options, sampling_overrides = _split_overrides(options, overrides)
    sampling = resolve_sampling(model, sampling, **sampling_overrides)
    _check_takes_request(start_take, start_frame, target_take, target_frame, options.output, options.offset_from,
                         options.scale)
    same = target_take is start_take
    take_fps, fps = float(start_take.fps), float(model.config.data.fps)
    if isinstance(length, str):
        if length != "auto":
            raise InbetweenError(f"length {length!r}: give a number of frames, or 'auto' to have it proposed")
        length = propose_take_length(model, start_take, start_frame, target_take, target_frame,
                                     offset=options.offset, turn_degrees=options.turn_degrees, scale=options.scale,
                                     offset_from=options.offset_from).frames
    if length is None:
        length = default_length(model, start_take, start_frame, target_frame, same)
    generated = model_length(model, take_fps, length)
    check_request(model, generated, num_samples, sampling.search)
    check_length(model, generated, options.allow_extrapolation)
    start_take = conform_take(model, start_take, "the start take", options.scale)
    target_take = start_take if same else conform_take(model, target_take, "the target take", options.scale)
    target_take = _placed_target(model, start_take, start_frame, target_take, target_frame, options, same)
    start_m, a = _at_rate(start_take, fps, start_frame)
    target_m, b = _at_rate(target_take, fps, target_frame)
    check_root_speed(model, start_m.positions[a, 0], target_m.positions[b, 0], generated, take_fps,
                     options.allow_fast)
    start_contacts = _neighbour_contacts(model, start_m, a, -1)
    target_contacts = _neighbour_contacts(model, target_m, b, +1)
    samples = inbetween(model, start_m[a], target_m[b], generated, num_samples, seed, sampling=sampling,
                        start_contacts=start_contacts, target_contacts=target_contacts, allow_extrapolation=True)
    return _take_outputs(model, samples, start_take, start_frame, target_take, target_frame, generated, length,
                         take_fps, options)


def inbetween_clip(model: Model, motion: Motion, start_frame: int, end_frame: int, length: int | str | None = None,
                   num_samples: int = 1, seed=0, *, sampling: Sampling | None = None, **overrides) -> list:
    """Replace the frames between two keyframes of a take by generated transitions.

    Keyframes: ``motion`` frames ``start_frame`` (A) and ``end_frame`` (B), A < B. length: generated
    frames (default B - A - 1, the frames replaced; "auto": proposed from the keyframes,
    :func:`propose_take_length`). Returns ``num_samples`` Motions: frames 0..A of
    ``motion``, L generated frames, frames B..end of ``motion`` (T - (B - A - 1) + L frames).
    Contacts of the keyframes: measured against frame A - 1 and B + 1 (the frames being replaced are
    never looked at), or the other side at the ends of the take.
    Frame numbers, ``length`` and the result are the take's own: a take at another frame rate than the
    model's is resampled to it for sampling (the keyframes kept exactly), and the generated frames are
    resampled back, so the result keeps the take's frame rate and (with the default length) its frame
    count; :func:`model_length` says how many frames the model generates. Joints are
    mapped by name and the units checked as in :func:`inbetween_takes`. A length beyond the model's
    training lengths is refused unless ``allow_extrapolation=True``; a transition faster than the training
    data's root speed unless ``allow_fast=True``. sampling, and Sampling fields as keywords (noise_scale,
    noise_correlation, noise_ramp_steps, search, foot_lock): as in :func:`inbetween_takes` (default
    ``model.sampling``, feet locked).
    """
    if not isinstance(motion, Motion):
        raise InbetweenError(f"expected a stitchjax.data.bvh.Motion, got {type(motion).__name__}")
    _check_frame(motion, start_frame, "start frame")
    _check_frame(motion, end_frame, "end frame")
    if end_frame <= start_frame:
        raise InbetweenError(f"end frame {end_frame} must come after start frame {start_frame}")
    return inbetween_takes(model, motion, start_frame, motion, end_frame, length, num_samples, seed,
                           sampling=sampling, output="clip", **overrides)
