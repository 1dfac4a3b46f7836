"""Take-level in-betweening: keyframes picked from whole takes (any file, units, up axis, frame rate),
transitions returned as takes.

    model = trained_model.load_model("runs/quickstart")   # or None: the release model (stitchjax.pretrained())
    clips = inbetween_clip(model, motion, 100, 140, num_samples=8)   # whole takes, frames 101..139 replaced
    placed = inbetween_takes(model, take, 100, other, 50, length=20, offset=(300, 0, 0), turn_degrees=90)

Each take is brought onto the model's terms first (:func:`conform_take`: units, up axis, joints by name,
bone lengths checked), resampled to the model's frame rate anchored at its keyframe, the target take placed
by an offset and a turn, and the keyframes' foot contacts measured against their neighbouring frames; the
sampling itself is :func:`stitchjax.inbetween.inbetween`, and the result goes back to the takes' units and
up axis (:func:`from_model_frame`).
"""
from __future__ import annotations

import numpy as np

from stitchjax import conform
from stitchjax import rotations as R
from stitchjax.bvh import Motion
from stitchjax.inbetween import _check_request, _check_skeleton, check_length, inbetween, keyframe_contacts
from stitchjax.skeleton import forward_kinematics
from stitchjax.trained_model import InbetweenError, Model, model_or_pretrained

__all__ = ["OUTPUTS", "inbetween_takes", "inbetween_clip", "conform_take", "to_model_frame", "from_model_frame",
           "default_length"]


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
    frame rate is left alone (see :func:`stitchjax.conform.resample`, anchored at a keyframe)."""
    if not isinstance(motion, Motion):
        raise InbetweenError(f"{what} must be a stitchjax.bvh.Motion, got {type(motion).__name__}")
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
    _check_skeleton(model, motion.skeleton)
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
    """Frames to generate when none is given: the keyframes' distance in the model's frames, minus one."""
    if not same:
        raise InbetweenError("give the transition length (frames to generate) when the target keyframe "
                             "comes from another take")
    if target_frame <= start_frame:
        raise InbetweenError(f"end frame {target_frame} must come after start frame {start_frame}")
    gap = (target_frame - start_frame) * float(model.config.data.fps) / float(start_take.fps)
    length = int(round(gap)) - 1
    if length < 1:
        raise InbetweenError(f"frames {start_frame} and {target_frame} are adjacent: nothing to generate; "
                             f"give a length >= 1 or keyframes further apart")
    return length


def _resample_and_place(model: Model, start_take: Motion, start_frame: int, target_take: Motion,
                        target_frame: int, offset, turn_degrees: float, scale: float) -> tuple:
    """(start take, its keyframe, target take, its keyframe) at the model's frame rate (resampled anchored
    at the keyframes), the target take turned by ``turn_degrees`` about its keyframe's root and moved by
    ``offset`` (the takes' units and axes, before ``scale``)."""
    fps = float(model.config.data.fps)
    try:
        start_take, a = conform.resample(start_take, fps, int(start_frame))
        target_take, b = conform.resample(target_take, fps, int(target_frame))
        offset = np.asarray(offset, np.float64)
        if offset.shape != (3,):
            raise conform.ConformError(f"offset must be 3 numbers (x, y, z), got shape {offset.shape}")
        if np.any(offset != 0) or turn_degrees:
            shift = R.quat_rotate(conform.up_turn(model.up_axis), offset)  # the takes' axes -> +Y up
            target_take = conform.place(target_take, shift * scale * model.unit_scale, turn_degrees, pivot=b)
    except conform.ConformError as error:
        raise InbetweenError(str(error)) from None
    return start_take, a, target_take, b


def inbetween_takes(model: Model, start_take: Motion, start_frame: int, target_take: Motion, target_frame: int,
                    length: int | None = None, num_samples: int = 1, seed=0, search: int = 0, *,
                    offset=(0.0, 0.0, 0.0), turn_degrees: float = 0.0, output: str = "appended",
                    scale: float = 1.0, allow_extrapolation: bool = False, noise_scale: float = 1.0,
                    noise_ramp_steps: int = 0, noise_correlation: float | None = None) -> list:
    """Transitions from frame ``start_frame`` of one take to frame ``target_frame`` of another (or the same).
    ``model``: a :class:`Model`, or None for the release model (``stitchjax.pretrained()``); the same in
    :func:`inbetween_clip`.

    Both takes are brought onto the model's terms first (:func:`conform_take`: the training files' units and
    up axis to cm and +Y up, joints by name, units checked; ``scale`` multiplies their positions) and
    resampled to the model's frame rate, anchored at the keyframe so the keyframes are kept exactly. The
    target take is then placed: turned by ``turn_degrees`` about the up axis through its keyframe's root
    and moved by ``offset`` (x, y, z; in the takes' own units and axes, before ``scale``). The result is
    brought back to the takes' units and up axis (:func:`from_model_frame`; exact for cm, +Y-up models,
    else to float64 rounding).
    length: generated frames (default: the keyframes' distance in time minus one frame, when both come
      from one take; required otherwise).
    output: "transition" = the start keyframe, L generated frames, the placed target keyframe (L + 2 frames);
      "appended" = the start take's frames 0..start_frame, the L generated frames and the target keyframe;
      "clip" = "appended" followed by the rest of the (placed) target take.
    noise_scale, noise_ramp_steps, noise_correlation: how far the samples spread
    (:func:`stitchjax.inbetween.inbetween`).
    Returns ``num_samples`` Motions at the model's frame rate on the model's skeleton (the takes' own
    skeleton and channel layout when their joints already match), positions in the takes' units and axes.
    """
    model = model_or_pretrained(model)  # None: the release model
    if output not in OUTPUTS:
        raise InbetweenError(f"output {output!r}: use one of {', '.join(OUTPUTS)}")
    if not np.isfinite(scale) or scale <= 0:
        raise InbetweenError(f"scale must be a positive number, got {scale}")
    for what, take in (("start take", start_take), ("target take", target_take)):
        if not isinstance(take, Motion):
            raise InbetweenError(f"{what} must be a stitchjax.bvh.Motion, got {type(take).__name__}")
    _check_frame(start_take, start_frame, "start frame")
    _check_frame(target_take, target_frame, "target frame")
    same = target_take is start_take
    if length is None:
        length = default_length(model, start_take, start_frame, target_frame, same)
    _check_request(model, length, num_samples, search)
    check_length(model, length, allow_extrapolation)
    start_take = conform_take(model, start_take, "the start take", scale)
    target_take = start_take if same else conform_take(model, target_take, "the target take", scale)
    start_take, a, target_take, b = _resample_and_place(model, start_take, start_frame, target_take, target_frame,
                                                        offset, turn_degrees, scale)
    start_contacts = _neighbour_contacts(model, start_take, a, -1)
    target_contacts = _neighbour_contacts(model, target_take, b, +1)
    samples = inbetween(model, start_take[a], target_take[b], length, num_samples, seed, search,
                        start_contacts, target_contacts, allow_extrapolation=True, noise_scale=noise_scale,
                        noise_ramp_steps=noise_ramp_steps, noise_correlation=noise_correlation)
    out = []
    for s in samples:
        if output == "transition":
            motion = s
        else:
            tail = slice(b, b + 1) if output == "appended" else slice(b, None)
            motion = start_take.with_frames(
                np.concatenate([start_take.rotations[:a], s.rotations[:-1], target_take.rotations[tail]]),
                np.concatenate([start_take.positions[:a], s.positions[:-1], target_take.positions[tail]]))
        out.append(from_model_frame(model, motion, scale))
    return out


def inbetween_clip(model: Model, motion: Motion, start_frame: int, end_frame: int, length: int | None = None,
                   num_samples: int = 1, seed=0, search: int = 0, allow_extrapolation: bool = False, *,
                   noise_scale: float = 1.0, noise_ramp_steps: int = 0,
                   noise_correlation: float | None = None) -> list:
    """Replace the frames between two keyframes of a take by generated transitions.

    Keyframes: ``motion`` frames ``start_frame`` (A) and ``end_frame`` (B), A < B. length: generated
    frames (default B - A - 1, the frames replaced). Returns ``num_samples`` Motions: frames 0..A of
    ``motion``, L generated frames, frames B..end of ``motion`` (T - (B - A - 1) + L frames).
    Contacts of the keyframes: measured against frame A - 1 and B + 1 (the frames being replaced are
    never looked at), or the other side at the ends of the take.
    A take at another frame rate is resampled to the model's (the keyframes kept exactly; the result is at
    the model's rate and the default length counts the model's frames between the keyframes); joints are
    mapped by name and the units checked as in :func:`inbetween_takes`. A length beyond the model's
    training lengths is refused unless ``allow_extrapolation``. noise_scale, noise_ramp_steps,
    noise_correlation: how far the samples spread (:func:`stitchjax.inbetween.inbetween`).
    """
    if not isinstance(motion, Motion):
        raise InbetweenError(f"expected a stitchjax.bvh.Motion, got {type(motion).__name__}")
    _check_frame(motion, start_frame, "start frame")
    _check_frame(motion, end_frame, "end frame")
    if end_frame <= start_frame:
        raise InbetweenError(f"end frame {end_frame} must come after start frame {start_frame}")
    return inbetween_takes(model, motion, start_frame, motion, end_frame, length, num_samples, seed, search,
                           output="clip", allow_extrapolation=allow_extrapolation, noise_scale=noise_scale,
                           noise_ramp_steps=noise_ramp_steps, noise_correlation=noise_correlation)
