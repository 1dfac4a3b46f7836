"""Bidirectional aligned rollout with stitching (paper section 3, Eq. 2), for one example; vmap for batches
(``batch.rollout_batch``). The latent noise is :mod:`stitchjax.model.noise`'s.

Frames of a transition of length L (L generated in-betweens): 0 = start keyframe, 1..L generated,
L + 1 = target keyframe. With h = L // 2 and k = min(K, h) (K = model.stitch_buffer):

- the forward generator makes frames 1 .. h + k (h + k steps), starting from the start keyframe;
- the backward generator (trained on time-reversed motion) makes frames L .. h - k + 1 (L - h + k steps),
  starting from the target keyframe;
- the 2k overlapping frames h - k + 1 .. h + k are blended frame by frame, the backward weight rising
  linearly (j + 1) / (2k + 1), j = 0..2k-1 (rotations by sign-aligned normalised lerp, root positions and
  contacts linearly); frames before come from the forward sequence, frames after from the backward one.

One ``lax.scan`` whose body does a forward step, then a backward step (bidirectional aligning):
f_{i+1} = G_fwd(f_i | target = latest backward frame), then f_{j-1} = G_bwd(f_j | target = f_{i+1}).
Ablations: ``model.bidirectional_aligning=False`` -> each generator targets the other keyframe;
``model.bidirectional=False`` -> the forward generator makes all L frames towards the target keyframe.

``length`` is traced: the scan runs over a static maximum (``(max_length + 1) // 2 + K`` steps, or
``max_length`` forward-only) and every quantity past the length is masked, so the progressive schedule
never recompiles. Once a generator has made its frames it holds its last frame (what the other one then
targets). The backward sequence uses its own time direction: its root velocities are reversed-time
velocities; a backward frame used as the forward generator's target gets its velocity negated.
Latent interpolation weight (:func:`interpolation_weight`) for the step that makes the n-th of the N frames of
a direction: gamma = n / N, 0 at the generator's start, 1 at the last frame it makes, next to the frame it
targets.

Update anchor (``model.update_anchor``): each step's predicted update (rotation update, root velocity) is added to
the current frame ("current", the paper's Eq. for the decoder's output), or to the next frame of the straight path
from the current frame to the frame it heads for ("interpolation", :func:`interpolation_anchor`; the delta mode of
the Delta-interpolator, an extension): with a zero update the rollout is then the interpolation of the keyframes.

Latent source: with the ground truth (training, ``model.posterior="next_frame"``) every step draws z from the
posterior q(z | h, ground-truth state of the frame it makes); without it z comes from the prior p (inference).
The latent noise is drawn as a ``noise.NoiseSpec`` says (scale, correlation, ramp: sampling settings).

Settings: every function reads a :class:`RolloutSpec` (L's scan, K, the generator's sizes and switches),
built once by :func:`rollout_spec` where the train step is made (``specs.train_spec``) or a model is loaded
(``trained_model.Model.rollout_spec``), never the whole Config.

The steps run the generator through a hook (:class:`StepHook`: the plain generator, no extras, every
intermediate kept for the backward pass); a caller may give another hook with per-step extras or a
``jax.checkpoint`` policy for the scan body (what the backward pass keeps). Neither changes the values.
"""
from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp

from stitchjax.data import features as F
from stitchjax.model import networks
from stitchjax.model import stitching
from stitchjax.model.noise import NoiseSpec, latent_noise
from stitchjax.data import phase as phase_lib
from stitchjax import rotations as R

__all__ = ["RolloutSpec", "rollout_spec", "rollout", "num_steps", "schedule", "interpolation_weight", "StepHook",
           "aligning_step", "keyframe_states", "interpolation_anchor"]


@dataclasses.dataclass(frozen=True)
class RolloutSpec:
    """What the rollout reads, resolved once from a Config (:func:`rollout_spec`; static, hashable).

    generator: the generators' sizes and switches (``networks.GeneratorSpec``). From ``config.model``:
    bidirectional, bidirectional_aligning (Eq. 2 ablations), stitch_buffer K, contact_input_gradient,
    update_anchor. From ``config.data``: parents, fps; position_scale, velocity_scale: ``features.POSITION_SCALE``,
    ``features.VELOCITY_SCALE``.
    prior_sample_fraction: ``loss.prior_sample_fraction``.
    """

    generator: networks.GeneratorSpec
    bidirectional: bool
    bidirectional_aligning: bool
    stitch_buffer: int
    contact_input_gradient: bool
    parents: tuple
    position_scale: float
    velocity_scale: float
    fps: float
    prior_sample_fraction: float
    update_anchor: str = "current"


def rollout_spec(config) -> RolloutSpec:
    """The :class:`RolloutSpec` of a Config: built once where the train step is made or a model is loaded."""
    m, data = config.model, config.data
    return RolloutSpec(
        generator=networks.generator_spec(m, data), bidirectional=m.bidirectional,
        bidirectional_aligning=m.bidirectional_aligning, stitch_buffer=m.stitch_buffer,
        contact_input_gradient=m.contact_input_gradient, parents=tuple(data.parents),
        position_scale=F.POSITION_SCALE, velocity_scale=F.VELOCITY_SCALE, fps=data.fps,
        prior_sample_fraction=config.loss.prior_sample_fraction, update_anchor=m.update_anchor)


def num_steps(spec, max_length: int) -> int:
    """Static scan length for transitions of at most ``max_length`` frames."""
    if spec.bidirectional:
        return (max_length + 1) // 2 + spec.stitch_buffer
    return max_length


def schedule(spec, length):
    """(h, k, n_forward, n_backward) for a (traced) length: split point, buffer, frames per direction."""
    length = jnp.asarray(length, jnp.int32)
    if not spec.bidirectional:
        return length, jnp.zeros((), jnp.int32), length, jnp.zeros((), jnp.int32)
    h = length // 2
    k = jnp.minimum(spec.stitch_buffer, h)
    return h, k, h + k, length - h + k


def interpolation_weight(frame_number, frames_in_direction):
    """Latent interpolation weight gamma (paper Eq. 1) for the step making a direction's ``frame_number``-th
    frame (1-based) of ``frames_in_direction``: n / N, in [0, 1]."""
    dtype = jnp.float32
    n = jnp.asarray(frame_number).astype(dtype)
    total = jnp.maximum(jnp.asarray(frames_in_direction).astype(dtype), 1.0)
    return jnp.clip(n / total, 0.0, 1.0)


def interpolation_anchor(current, target, distance, keyframe, keyframe_distance):
    """Where a zero update takes a generator with ``model.update_anchor="interpolation"``: the next frame of the
    straight path from ``current`` to the frame it heads for, 1 / (frames left) of the way: the root linearly,
    each local rotation by slerp the short way.

    current, target, keyframe: frame dicts ("rotations" (J, 4), "root" (3,)) in one time direction; it heads
    for ``target`` at ``distance`` frames (() int) while distance >= 1, and past the generators' meeting point
    (distance <= 0, on the stitching overlap) for ``keyframe`` (the other keyframe) at ``keyframe_distance``
    frames. Returns {"rotations" (J, 4), "root" (3,)}. Along an interpolation both goals lie on the same path,
    so zero updates reproduce it frame by frame.
    """
    ahead = distance >= 1
    goal = _hold(ahead, {"rotations": target["rotations"], "root": target["root"]},
                 {"rotations": keyframe["rotations"], "root": keyframe["root"]})
    dtype = current["root"].dtype
    frames_left = jnp.maximum(jnp.where(ahead, distance, keyframe_distance), 1).astype(dtype)
    fraction = 1.0 / frames_left
    rotations = current["rotations"]
    same_side = jnp.sum(rotations * goal["rotations"], axis=-1, keepdims=True) >= 0
    goal_rotations = jnp.where(same_side, goal["rotations"], -goal["rotations"])
    return {"rotations": R.quat_slerp(rotations, goal_rotations, fraction),
            "root": current["root"] + fraction * (goal["root"] - current["root"])}


def _phase(spec, phase_params, state):
    if not spec.generator.phase_modulation or phase_params is None:
        return jnp.zeros(state.shape[:-1] + (networks.phase_dim(spec.generator),), state.dtype)
    state = jax.lax.stop_gradient(state)  # the phase network is frozen and only conditions the gating
    return phase_lib.phase_features(phase_params, state)


class StepHook:
    """How the rollout's scan runs its generator steps (``rollout(..., hook=...)``); this one adds no per-step
    extras. Another hook may feed each step more inputs and take more out of it, with the same values.

    checkpoint_policy: the ``jax.checkpoint`` policy of the scan body (what differentiating the scan keeps for
    the backward pass); None: no checkpointing, every intermediate is kept.
    scan_inputs(truth): the pytree the scan slices per step (leading num_steps axis), holding the posterior
    inputs ``truth`` (or None); truth(xs_i): a step's posterior inputs from its slice; apply(generator spec,
    name, params, args, xs_i) -> ((carry, outputs), extras or None): generator ``name``'s step;
    stack(records): what the scan stacks of a step's {generator: extras}; finish(stacked): what rollout returns
    beside its result (None: the result alone).
    """

    def __init__(self, checkpoint_policy=None):
        self.checkpoint_policy = checkpoint_policy

    def scan_inputs(self, truth):
        return truth

    def truth(self, xs_i):
        return xs_i

    def apply(self, spec, name, params, args, xs_i):
        return networks.make_generator(spec).apply(params, *args), None

    def stack(self, records):
        return records

    def finish(self, stacked):
        return None


def _step(params, phase_params, spec, carry, current, target, inputs, apply=None, anchor=None):
    """One generator step: frame dicts (rotations (J,4), root (3,), velocity (3,), contacts (C,)).

    inputs: (distance, gamma, eps, next_state, use_prior): distance () the frames to ``target``; gamma ()
    the latent interpolation weight; eps (latent,) noise; next_state (S,) ground-truth state of the frame this
    step makes (posterior training) or None (prior); use_prior None or () bool, True = z from the prior even
    with next_state (``Generator``).
    anchor: None (the update is added to ``current``) or {"rotations", "root"}, the frame the update is added
    to (:func:`interpolation_anchor`); the new frame's velocity is then its root's movement from ``current``.
    apply: None (the plain generator), or apply(params, args) -> ((carry, outputs), extras), a hook's
    (:class:`StepHook`); the fourth output is the extras (None without a hook).
    """
    distance, gamma, eps, next_state, use_prior = inputs
    contacts, target_contacts = current["contacts"], target["contacts"]
    if not spec.contact_input_gradient:
        contacts, target_contacts = jax.lax.stop_gradient(contacts), jax.lax.stop_gradient(target_contacts)
    state = F.state_vector(current["rotations"], current["velocity"], contacts)
    target_state = F.state_vector(target["rotations"], target["velocity"], target_contacts)
    offset = F.offset_features(current["rotations"], current["root"], target["rotations"], target["root"],
                               spec.position_scale)
    offset = jnp.concatenate([offset, (distance / spec.fps)[None].astype(offset.dtype)])  # time to the target
    phase = _phase(spec, phase_params, state)
    args = (carry, state, target_state, offset, gamma, phase, eps, next_state, use_prior)
    if apply is None:
        (carry, out), recorded = networks.make_generator(spec.generator).apply(params, *args), None
    else:
        (carry, out), recorded = apply(params, args)
    update = out["rotation_update"].reshape(current["rotations"].shape)
    velocity = out["velocity"]
    base = current if anchor is None else anchor
    root = base["root"] + velocity * spec.velocity_scale
    if anchor is not None:
        velocity = (root - current["root"]) / spec.velocity_scale
    frame = {
        "rotations": R.quat_normalize(base["rotations"] + update),
        "root": root,
        "velocity": velocity,
        "contacts": jax.nn.sigmoid(out["contact_logits"]),
    }
    return carry, frame, {k: out[k] for k in networks.GAUSSIAN_KEYS}, recorded


def _frames_between(plan, name: str, i, aligned: bool):
    """() int: frames from the frame generator ``name`` makes its step-``i`` frame from to the frame it targets,
    counted on the transition's frames (the other generator may have stopped: it holds its last frame)."""
    length = plan["length"]
    if not aligned:
        return length + 1 - i
    if name == "forward":  # from frame i to the backward generator's latest frame
        return length + 1 - jnp.minimum(i, plan["n_backward"]) - i
    return length + 1 - i - jnp.minimum(i + 1, plan["n_forward"])  # from frame L + 1 - i to the forward's latest


def _reverse(frame):
    """A frame of one direction seen from the other (time reversed: velocity negated)."""
    return {**frame, "velocity": -frame["velocity"]}


def _hold(valid, new, old):
    return jax.tree.map(lambda a, b: jnp.where(valid, a, b), new, old)


def aligning_step(gen_params, phase_params, spec, carry, i, eps_i, plan, xs_i=None, hook=None):
    """One bidirectional aligning step (paper Eq. 2), the body of the rollout's scan.

    f_{i+1} = G_fwd(f_i | target = latest backward frame), then b_{i+1} = G_bwd(b_i | target = f_{i+1})
    (backward frames in reversed time). Without ``model.bidirectional_aligning`` each generator targets the
    other keyframe; forward-only models skip the backward step. A generator that has made its frames
    (``plan["n_forward"]`` / ``plan["n_backward"]``) holds its last frame.

    carry: (forward LSTM carry, backward LSTM carry, latest forward frame, latest backward frame);
    i: () step index; eps_i: (2, latent) noise; plan: {"length", "n_forward", "n_backward", "start",
    "target"} (keyframes as frame dicts, :func:`keyframe_states`: the target in reversed time), optionally
    "use_prior" (see :func:`rollout`); xs_i: this step's slice of the scan's per-step inputs (without a
    hook: the posterior inputs (forward, backward) or None); hook: None or a :class:`StepHook`. Returns
    (carry, outputs) with "forward" / "backward" frame dicts plus their Gaussians, and "records"
    ({generator: the hook's extras}, empty without them).
    """
    m = spec
    dtype = plan["start"]["rotations"].dtype
    length = plan["length"]
    truth_i = xs_i if hook is None else hook.truth(xs_i)
    truth_fwd, truth_bwd = (None, None) if truth_i is None else truth_i
    fwd_carry, bwd_carry, fwd, bwd = carry
    aligned = m.bidirectional and m.bidirectional_aligning
    if aligned:
        f_target, f_dist = _reverse(bwd), length + 1 - 2 * i
    else:
        f_target, f_dist = _reverse(plan["target"]), length + 1 - i
    out = {"records": {}}

    def direction_step(name, carry_d, frame, target, distance, eps, truth):
        """One step of one generator; it holds its frame once it has made plan["n_<name>"] frames."""
        count = plan[f"n_{name}"]
        gamma = interpolation_weight(i + 1, count).astype(dtype)
        apply = None if hook is None else (lambda params, args: hook.apply(spec.generator, name, params, args, xs_i))
        anchor = None
        if m.update_anchor == "interpolation":
            keyframe = _reverse(plan["target"] if name == "forward" else plan["start"])
            anchor = interpolation_anchor(frame, target, _frames_between(plan, name, i, aligned), keyframe,
                                          length + 1 - i)
        inputs = (distance, gamma, eps, truth, plan.get("use_prior"))
        new_carry, new_frame, gaussians, recorded = _step(gen_params[name], phase_params, spec, carry_d, frame,
                                                          target, inputs, apply, anchor)
        carry_d, frame = _hold(i < count, (new_carry, new_frame), (carry_d, frame))
        out[name] = {**frame, **gaussians}
        if recorded is not None:
            out["records"][name] = recorded
        return carry_d, frame

    fwd_carry, fwd = direction_step("forward", fwd_carry, fwd, f_target, f_dist, eps_i[0], truth_fwd)
    if m.bidirectional:
        if aligned:
            b_target, b_dist = _reverse(fwd), length - 2 * i
        else:
            b_target, b_dist = _reverse(plan["start"]), length + 1 - i
        bwd_carry, bwd = direction_step("backward", bwd_carry, bwd, b_target, b_dist, eps_i[1], truth_bwd)
    return (fwd_carry, bwd_carry, fwd, bwd), out


def rollout(gen_params, phase_params, keyframes, key, spec, length, max_length: int, noise=NoiseSpec(),
            latent=None, hook=None):
    """Generate one transition.

    Args:
      gen_params: {"forward": ..., "backward": ...} generator params (other keys ignored).
      phase_params: phase network params (``phase.init_phase_params``), or None for zero phase features.
      keyframes: (start, target, offsets): start and target dicts with "rotations" (J, 4) local quats,
        "root_position" (3,) file units, "contacts" (C,); offsets (J, 3) bone offsets (the root row is ignored).
      key: PRNG key for the latent noise.
      spec: :class:`RolloutSpec` (static).
      length: () int, traced: L generated frames, 1 <= L <= max_length (clipped into that range).
      max_length: static maximum L (training: window - 2).
      noise: a ``noise.NoiseSpec`` (static): the noise's scale (0 = every sample is the prior's / posterior's
        mean), its correlation from one step to the next and its ramp from each keyframe; the default is the
        paper's sampling.
      latent: optional dict of what the latent z is drawn from besides ``key``: "noise" (num_steps(spec,
        max_length), 2, latent_dim) standard normal noise ([:, 0] forward, [:, 1] backward) used instead of
        drawing it from ``key`` (latent search); "forward" and optionally "backward" (num_steps, S) the
        ground-truth states of the frames each step makes (``batch.next_frame_states``): z is drawn from the
        posterior (model.posterior must not be "none"); with them "use_prior" () bool: True draws z from
        the prior anyway, as at inference (``loss.prior_sample_fraction``), the posterior's Gaussians still
        returned. Without the ground truth z comes from the prior and no ground truth is read.
      hook: optional :class:`StepHook`: per-step extras of the generator steps (when its ``finish`` gives
        something, the result is (dict, that)) and the scan body's ``jax.checkpoint`` policy.
    Returns dict (T_out = max_length + 2):
      "rotations" (T_out, J, 4), "root_positions" (T_out, 3), "contacts" (T_out, C),
      "global_positions" (T_out, J, 3): the stitched motion, frame 0 = start and frame L + 1 = target
      exactly, frames past L + 1 repeat the target; "mask" (T_out,) bool, True for frames 0..L+1.
      "forward": per-step outputs (n = num_steps) of the forward generator, entry i = frame i + 1:
        "rotations" (n, J, 4), "root_positions" (n, 3), "velocities" (n, 3) scaled, "contacts" (n, C),
        "global_positions" (n, J, 3), "mask" (n,) bool, and the Gaussians ``networks.GAUSSIAN_KEYS`` (n, latent).
      "backward" (bidirectional only): the same in reversed time, entry i = frame L - i.
      "overlap": "forward_positions", "backward_positions" (2K', J, 3) FK positions of the two sequences
        on the overlapping frames (K' = max(K, 1)), "mask" (2K',) bool.
    """
    start, target, offsets = keyframes
    latent = {} if latent is None else latent
    length = jnp.clip(jnp.asarray(length, jnp.int32), 1, max_length)
    n = num_steps(spec, max_length)
    split = schedule(spec, length)
    eps = latent_noise(key, latent.get("noise"), (n, 2, spec.generator.latent_dim), start["rotations"].dtype, noise)
    truth = _posterior_inputs(spec, latent)
    plan = _plan(start, target, split, length, latent.get("use_prior"))
    hook = StepHook() if hook is None else hook
    seq = _scan(gen_params, phase_params, spec, plan, eps, truth, hook)
    result = stitching.stitched_result(seq, plan, split, start, target, offsets, spec, max_length + 2)
    extras = hook.finish(seq["records"])
    return result if extras is None else (result, extras)


def _posterior_inputs(spec, latent: dict):
    """(forward, backward) posterior inputs of :func:`rollout`'s ``latent``, or None (z from the prior)."""
    if "forward" not in latent:
        return None
    if spec.generator.posterior == "none":
        raise ValueError("ground truth given but model.posterior='none': the model has no posterior")
    return latent["forward"], latent.get("backward", latent["forward"])


def _plan(start, target, split, length, use_prior) -> dict:
    """The scan's plan (:func:`aligning_step`): length, frames per direction (split = :func:`schedule`'s),
    the keyframes as generator frames and, when given, use_prior."""
    start_frame, target_frame = keyframe_states(start, target)
    plan = {"length": length, "n_forward": split[2], "n_backward": split[3], "start": start_frame,
            "target": target_frame}
    if use_prior is not None:
        plan["use_prior"] = jnp.asarray(use_prior, bool)
    return plan


def _scan(gen_params, phase_params, spec, plan, eps, truth, hook) -> dict:
    """The rollout's ``lax.scan`` of :func:`aligning_step` over the num_steps steps of ``eps``: each output
    with a leading (num_steps,) axis, and "records" the hook's stacked extras; the body checkpointed by the
    hook's ``checkpoint_policy``."""
    def body(carry, xs):
        i, eps_i, xs_i = xs
        carry, out = aligning_step(gen_params, phase_params, spec, carry, i, eps_i, plan, xs_i, hook)
        out["records"] = hook.stack(out["records"])
        return carry, out

    if hook.checkpoint_policy is not None:
        body = jax.checkpoint(body, policy=hook.checkpoint_policy)

    carry0 = networks.initial_carry(spec.generator, plan["start"]["rotations"].dtype)
    steps = jnp.arange(eps.shape[0], dtype=jnp.int32)
    _, seq = jax.lax.scan(body, (carry0, carry0, plan["start"], plan["target"]),
                          (steps, eps, hook.scan_inputs(truth)))
    return seq


def keyframe_states(start: dict, target: dict) -> tuple[dict, dict]:
    """The keyframes as generator frames (rotations, root, contacts, root velocity 0: a keyframe is a pose): the
    start keyframe in forward time and the target keyframe in the backward generator's reversed time."""
    velocity = jnp.zeros_like(start["root_position"])

    def frame(keyframe, v):
        return {"rotations": keyframe["rotations"], "root": keyframe["root_position"], "velocity": v,
                "contacts": keyframe["contacts"]}

    return frame(start, velocity), frame(target, -velocity)
