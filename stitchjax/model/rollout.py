"""Bidirectional aligned rollout with stitching (paper section 3, Eq. 2), for one example; vmap for batches.

Size (~680 lines): one job, the rollout; half of it is docstrings of the frame conventions and of each
named paper step (``aligning_step``, ``interpolation_weight``, ``stitch``), kept beside the code they fix.

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
a direction: gamma = n / N (``model.gamma_schedule="direction"``: 0 at the generator's start, 1 at the last
frame it makes, next to the frame it targets) or n / (L + 1) ("transition").

Latent source: with ``ground_truth`` (training, ``model.posterior="next_frame"``) every step draws z from the
posterior q(z | h, ground-truth state of the frame it makes); without it z comes from the prior p (inference).

Settings: every function reads a :class:`RolloutSpec` (L's scan, K, the gamma schedule, the generator's
sizes and switches), built once by :func:`rollout_spec` where the train step is made (``specs.train_spec``)
or a model is loaded (``trained_model.Model.rollout_spec``), never the whole Config.

Gradients: :func:`rollout_batch` (the training step's rollout) takes the fast paths of ``stitchjax.accel``: with
``train.weight_gradients_after_scan`` (default) the generators' kernel gradients are formed after the scan, one
matmul per kernel; with ``train.scan_remat="taped"`` the scan runs twice, recording then replaying a tape, so
that each value the backward pass needs is stacked once. Same numbers, less time. The steps themselves see
only a hook (:class:`StepHook`), which runs the plain generator unless a fast path gives another.
"""
from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np

from stitchjax.data import features as F
from stitchjax.model import networks
from stitchjax.data import phase as phase_lib
from stitchjax import rotations as R
from stitchjax import skeleton as skel
from stitchjax.accel import probes as probes_lib
from stitchjax.accel import scan_gradients
from stitchjax.accel import tape as tape_lib
from stitchjax.config import CHOICES

__all__ = ["RolloutSpec", "rollout_spec", "rollout", "rollout_batch", "keyframes_from_batch", "num_steps",
           "schedule", "interpolation_weight", "StepHook", "aligning_step", "stitch", "keyframe_velocity",
           "keyframe_states", "direction_frames", "next_frame_states", "correlated_noise", "prior_sample_flags",
           "GAUSSIAN_KEYS"]

_ACTIVATION_NAMES = CHOICES[("model", "activation")]
GAUSSIAN_KEYS = ("mu", "logvar", "mu_target", "logvar_target", "mu_blend", "logvar_blend", "mu_posterior",
                 "logvar_posterior")


@dataclasses.dataclass(frozen=True)
class RolloutSpec:
    """What the rollout reads, resolved once from a Config (:func:`rollout_spec`; static, hashable).

    generator: the generators' sizes and switches (``networks.GeneratorSpec``). From ``config.model``:
    bidirectional, bidirectional_aligning (Eq. 2 ablations), stitch_buffer K, gamma_schedule (Eq. 1's
    gamma: "direction" or "transition"), keyframe_velocity, contact_input_gradient, stop_phase_gradient,
    noise_correlation, posterior_horizon. From ``config.data``: parents, position_scale, velocity_scale, fps.
    prior_sample_fraction: ``loss.prior_sample_fraction``. weight_gradients_after_scan, scan_remat: the
    training fast path (``config.train``).
    """

    generator: networks.GeneratorSpec
    bidirectional: bool
    bidirectional_aligning: bool
    stitch_buffer: int
    gamma_schedule: str
    keyframe_velocity: str
    contact_input_gradient: bool
    stop_phase_gradient: bool
    noise_correlation: float
    posterior_horizon: int
    parents: tuple
    position_scale: float
    velocity_scale: float
    fps: float
    prior_sample_fraction: float
    weight_gradients_after_scan: bool
    scan_remat: str


def rollout_spec(config) -> RolloutSpec:
    """The :class:`RolloutSpec` of a Config: built once where the train step is made or a model is loaded."""
    m, data, train = config.model, config.data, config.train
    return RolloutSpec(
        generator=networks.generator_spec(config), bidirectional=m.bidirectional,
        bidirectional_aligning=m.bidirectional_aligning, stitch_buffer=m.stitch_buffer,
        gamma_schedule=m.gamma_schedule, keyframe_velocity=m.keyframe_velocity,
        contact_input_gradient=m.contact_input_gradient, stop_phase_gradient=m.stop_phase_gradient,
        noise_correlation=m.noise_correlation, posterior_horizon=m.posterior_horizon, parents=tuple(data.parents),
        position_scale=data.position_scale, velocity_scale=data.velocity_scale, fps=data.fps,
        prior_sample_fraction=config.loss.prior_sample_fraction,
        weight_gradients_after_scan=train.weight_gradients_after_scan, scan_remat=train.scan_remat)


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


def interpolation_weight(spec, frame_number, frames_in_direction, length):
    """Latent interpolation weight gamma (paper Eq. 1) for the step making a direction's ``frame_number``-th
    frame (1-based) of ``frames_in_direction``: n / N ("direction") or n / (L + 1) ("transition"), in [0, 1]."""
    dtype = jnp.float32
    n = jnp.asarray(frame_number).astype(dtype)
    if spec.gamma_schedule == "transition":
        total = jnp.asarray(length).astype(dtype) + 1.0
    elif spec.gamma_schedule == "direction":
        total = jnp.maximum(jnp.asarray(frames_in_direction).astype(dtype), 1.0)
    else:
        raise ValueError(f"model.gamma_schedule={spec.gamma_schedule!r}: use 'direction' or 'transition'")
    return jnp.clip(n / total, 0.0, 1.0)


def _phase(spec, phase_params, state):
    if not spec.generator.phase_modulation or phase_params is None:
        return jnp.zeros(state.shape[:-1] + (networks.phase_dim(spec.generator),), state.dtype)
    if spec.stop_phase_gradient:
        state = jax.lax.stop_gradient(state)
    return phase_lib.phase_features(phase_params, state)


class StepHook:
    """The rollout's hook for per-step extras of its generator steps (``rollout(..., hook=...)``); this one adds
    none. A hook may feed each step more inputs and take more out of it (the training step's fast paths do:
    ``accel.probes.RecordingHook``).

    scan_inputs(truth): the pytree the scan slices per step (leading num_steps axis), holding the posterior
    inputs ``truth`` (or None); truth(xs_i): a step's posterior inputs from its slice; apply(generator spec,
    name, params, args, xs_i) -> ((carry, outputs), extras or None): generator ``name``'s step;
    stack(records): what the scan stacks of a step's {generator: extras}; finish(stacked): what rollout returns
    beside its result (None: the result alone).
    """

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


def _step(params, phase_params, spec, carry, current, target, distance, gamma, eps, next_state=None,
          use_prior=None, apply=None):
    """One generator step: frame dicts (rotations (J,4), root (3,), velocity (3,), contacts (C,)).

    next_state: (S,) ground-truth state of the frame this step makes (posterior training) or None (prior);
    use_prior: None or () bool, True = z from the prior even with next_state (``Generator``).
    apply: None (the plain generator), or apply(params, args) -> ((carry, outputs), extras), a hook's
    (:class:`StepHook`); the fourth output is the extras (None without a hook).
    """
    contacts, target_contacts = current["contacts"], target["contacts"]
    if not spec.contact_input_gradient:
        contacts, target_contacts = jax.lax.stop_gradient(contacts), jax.lax.stop_gradient(target_contacts)
    state = F.state_vector(current["rotations"], current["velocity"], contacts)
    target_state = F.state_vector(target["rotations"], target["velocity"], target_contacts)
    offset = F.offset_features(current["rotations"], current["root"], target["rotations"], target["root"],
                               spec.position_scale)
    if spec.generator.time_to_target_input:
        offset = jnp.concatenate([offset, (distance / spec.fps)[None].astype(offset.dtype)])
    phase = _phase(spec, phase_params, state)
    args = (carry, state, target_state, offset, gamma, phase, eps, next_state, use_prior)
    if apply is None:
        (carry, out), recorded = networks.make_generator(spec.generator).apply(params, *args), None
    else:
        (carry, out), recorded = apply(params, args)
    update = out["rotation_update"].reshape(current["rotations"].shape)
    velocity = out["velocity"]
    frame = {
        "rotations": R.quat_normalize(current["rotations"] + update),
        "root": current["root"] + velocity * spec.velocity_scale,
        "velocity": velocity,
        "contacts": jax.nn.sigmoid(out["contact_logits"]),
    }
    return carry, frame, {k: out[k] for k in GAUSSIAN_KEYS}, recorded


def _reverse(frame):
    """A frame of one direction seen from the other (time reversed: velocity negated)."""
    return {**frame, "velocity": -frame["velocity"]}


def _hold(valid, new, old):
    return jax.tree.map(lambda a, b: jnp.where(valid, a, b), new, old)


def _take(tree, index):
    return jax.tree.map(lambda x: jnp.take(x, index, axis=0, mode="clip"), tree)


def _stack_first(first, rest):
    return jax.tree.map(lambda a, b: jnp.concatenate([a[None], b], axis=0), first, rest)


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
        gamma = interpolation_weight(spec, i + 1, count, length).astype(dtype)
        apply = None if hook is None else (lambda params, args: hook.apply(spec.generator, name, params, args, xs_i))
        new_carry, new_frame, gaussians, recorded = _step(gen_params[name], phase_params, spec, carry_d, frame,
                                                          target, distance, gamma, eps, truth,
                                                          plan.get("use_prior"), apply)
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


def stitch(fwd_all, bwd_all, length, h, k, num_frames: int, bidirectional: bool = True):
    """Linear stitch blend of the two sequences into ``num_frames`` frames (paper section 3.1).

    fwd_all / bwd_all: frame dicts with a leading axis, fwd_all[t] = frame t, bwd_all[r] = frame L + 1 - r.
    On the 2k overlapping frames h - k + 1 .. h + k the backward weight rises linearly (j + 1) / (2k + 1);
    before them the forward frames, after them the backward ones. Rotations by sign-aligned normalised
    lerp (the lighter-weighted sequence joins the other's hemisphere, so frames outside the overlap stay
    exact), root positions and contacts linearly. Returns (rotations (T, J, 4), root (T, 3), contacts (T, C)).
    """
    t = jnp.arange(num_frames, dtype=jnp.int32)
    from_fwd = _take(fwd_all, t)
    from_bwd = _take(bwd_all, length + 1 - t)
    dtype = from_fwd["root"].dtype
    if bidirectional:
        w = jnp.clip((t - (h - k)).astype(dtype) / (2 * k + 1).astype(dtype), 0.0, 1.0)
    else:
        w = jnp.zeros((num_frames,), dtype)
    q_f, q_b = from_fwd["rotations"], from_bwd["rotations"]
    sign = jnp.where(jnp.sum(q_f * q_b, axis=-1, keepdims=True) < 0, -1.0, 1.0).astype(dtype)
    w3 = w[:, None, None]
    q_f = jnp.where(w3 >= 0.5, sign * q_f, q_f)
    q_b = jnp.where(w3 < 0.5, sign * q_b, q_b)
    rot = R.quat_normalize((1 - w3) * q_f + w3 * q_b)
    root = (1 - w)[:, None] * from_fwd["root"] + w[:, None] * from_bwd["root"]
    contacts = (1 - w)[:, None] * from_fwd["contacts"] + w[:, None] * from_bwd["contacts"]
    return rot, root, contacts


def rollout(gen_params, phase_params, start, target, offsets, key, spec, length, max_length: int, noise=None,
            ground_truth=None, noise_scale=1.0, noise_correlation=None, use_prior=None, noise_ramp_steps: int = 0,
            hook=None):
    """Generate one transition.

    Args:
      gen_params: {"forward": ..., "backward": ...} generator params (other keys ignored).
      phase_params: phase network params (``phase.init_phase_params``), or None for zero phase features.
      start, target: keyframes, dicts with "rotations" (J, 4) local quats, "root_position" (3,) file
        units, "contacts" (C,).
      offsets: (J, 3) bone offsets (the root row is ignored).
      key: PRNG key for the latent noise.
      spec: :class:`RolloutSpec` (static).
      length: () int, traced: L generated frames, 1 <= L <= max_length (clipped into that range).
      max_length: static maximum L (training: window - 2).
      noise: optional (num_steps(spec, max_length), 2, latent_dim) standard normal latent noise
        ([:, 0] forward, [:, 1] backward) used instead of drawing it from ``key`` (latent search).
      ground_truth: optional {"forward", "backward"} (num_steps, S) ground-truth states of the frames each
        step makes (:func:`next_frame_states`): z is drawn from the posterior (model.posterior must not be
        "none"). None: z from the prior; the ground truth is never read.
      noise_scale: factor on the latent noise (0 = every sample is the prior's / posterior's mean).
      use_prior: optional () bool, with ground_truth: True draws z from the prior anyway, as at inference
        (``loss.prior_sample_fraction``); the posterior's Gaussians are still returned.
      noise_correlation: static rho in [0, 1], the correlation of each direction's noise from one step to
        the next (:func:`correlated_noise`); 0 = independent per frame, as in the paper; None = the
        model's ``model.noise_correlation`` (what training uses).
      noise_ramp_steps: static int >= 0; each direction's noise rises linearly from 0 at its first step to
        full at this step (:func:`noise_ramp`); 0 = full noise from the first step, as in the paper.
      hook: optional :class:`StepHook`, per-step extras of the generator steps; when its ``finish`` gives
        something, the result is (dict, that).
    Returns dict (T_out = max_length + 2):
      "rotations" (T_out, J, 4), "root_positions" (T_out, 3), "contacts" (T_out, C),
      "global_positions" (T_out, J, 3): the stitched motion, frame 0 = start and frame L + 1 = target
      exactly, frames past L + 1 repeat the target; "mask" (T_out,) bool, True for frames 0..L+1.
      "forward": per-step outputs (n = num_steps) of the forward generator, entry i = frame i + 1:
        "rotations" (n, J, 4), "root_positions" (n, 3), "velocities" (n, 3) scaled, "contacts" (n, C),
        "global_positions" (n, J, 3), "mask" (n,) bool, and the Gaussians GAUSSIAN_KEYS (n, latent).
      "backward" (bidirectional only): the same in reversed time, entry i = frame L - i.
      "overlap": "forward_positions", "backward_positions" (2K', J, 3) FK positions of the two sequences
        on the overlapping frames (K' = max(K, 1)), "mask" (2K',) bool.
    """
    m = spec
    dtype = start["rotations"].dtype
    length = jnp.clip(jnp.asarray(length, jnp.int32), 1, max_length)
    n = num_steps(spec, max_length)
    h, k, n_fwd, n_bwd = schedule(spec, length)
    if noise_correlation is None:
        noise_correlation = m.noise_correlation
    eps = _latent_noise(key, noise, (n, 2, m.generator.latent_dim), dtype, noise_scale, noise_correlation,
                        noise_ramp_steps)
    if ground_truth is not None and m.generator.posterior == "none":
        raise ValueError("ground_truth given but model.posterior='none': the model has no posterior")
    truth = (None if ground_truth is None else
             (ground_truth["forward"], ground_truth.get("backward", ground_truth["forward"])))
    start_frame, target_frame = keyframe_states(spec, start, target, length)
    plan = {"length": length, "n_forward": n_fwd, "n_backward": n_bwd, "start": start_frame, "target": target_frame}
    if use_prior is not None:
        plan["use_prior"] = jnp.asarray(use_prior, bool)

    hook = StepHook() if hook is None else hook

    def body(carry, xs):
        i, eps_i, xs_i = xs
        carry, out = aligning_step(gen_params, phase_params, spec, carry, i, eps_i, plan, xs_i, hook)
        out["records"] = hook.stack(out["records"])
        return carry, out

    policy = SCAN_REMAT[spec.scan_remat]
    if policy is not None:
        body = jax.checkpoint(body, policy=policy)

    carry0 = networks.initial_carry(spec.generator, dtype)
    steps = jnp.arange(n, dtype=jnp.int32)
    _, seq = jax.lax.scan(body, (carry0, carry0, start_frame, target_frame), (steps, eps, hook.scan_inputs(truth)))

    # Sequences including their keyframe at entry 0: fwd_all[t] = frame t, bwd_all[r] = frame L + 1 - r.
    fwd_all = _stack_first(start_frame, {key_: seq["forward"][key_] for key_ in _FRAME_KEYS})
    bwd_all = (_stack_first(target_frame, {key_: seq["backward"][key_] for key_ in _FRAME_KEYS})
               if m.bidirectional else fwd_all)
    t_out = max_length + 2
    rot, root, contacts = stitch(fwd_all, bwd_all, length, h, k, t_out, m.bidirectional)
    stitched = _pin_keyframes({"rotations": rot, "root_positions": root, "contacts": contacts}, start, target,
                              length, t_out)
    result = _with_positions(stitched, fwd_all, bwd_all, seq, offsets, spec, length, (h, k, n_fwd, n_bwd))
    extras = hook.finish(seq["records"])
    return result if extras is None else (result, extras)


_FRAME_KEYS = ("rotations", "root", "velocity", "contacts")


# train.scan_remat -> the jax.checkpoint policy of the scan body (None: no checkpointing, save everything).
# "taped" checkpoints nothing either: the scan it differentiates replays a recorded tape (rollout_batch).
SCAN_REMAT = {
    "none": None,
    "dots": jax.checkpoint_policies.dots_saveable,
    "nothing": jax.checkpoint_policies.nothing_saveable,
    "taped": None,
}


def keyframe_velocity(spec, start_root, target_root, length):
    """(3,) scaled root velocity both keyframes are given (``model.keyframe_velocity``), in forward time.

    "zero": 0, the paper's poses alone. "mean": the transition's mean root velocity,
    (target root - start root) / (L + 1) / data.velocity_scale, which the two keyframes and L determine.
    """
    if spec.keyframe_velocity == "zero":
        return jnp.zeros_like(start_root)
    steps = (jnp.asarray(length) + 1).astype(start_root.dtype)
    return (target_root - start_root) / (steps * spec.velocity_scale)


def keyframe_states(spec, start: dict, target: dict, length) -> tuple[dict, dict]:
    """The keyframes as generator frames (rotations, root, contacts, root velocity): the start keyframe in
    forward time and the target keyframe in the backward generator's reversed time (velocity negated)."""
    velocity = keyframe_velocity(spec, start["root_position"], target["root_position"], length)

    def frame(keyframe, v):
        return {"rotations": keyframe["rotations"], "root": keyframe["root_position"], "velocity": v,
                "contacts": keyframe["contacts"]}

    return frame(start, velocity), frame(target, -velocity)


def _latent_noise(key, noise, shape: tuple, dtype, noise_scale, noise_correlation=0.0, noise_ramp_steps=0):
    """The standard normal latent noise `shape` = (num_steps, 2, latent_dim), drawn from `key` unless
    `noise` is given, correlated over steps by `noise_correlation`, times `noise_scale` and times
    :func:`noise_ramp` per step."""
    if noise is None:
        eps = jax.random.normal(key, shape, dtype)
    else:
        eps = jnp.asarray(noise, dtype)
        if eps.shape != shape:
            raise ValueError(f"noise has shape {eps.shape}; rollout needs {shape} "
                             f"= (num_steps(spec, max_length), 2, latent_dim)")
    ramp = jnp.asarray(noise_ramp(shape[0], noise_ramp_steps), dtype)[:, None, None]
    return correlated_noise(eps, noise_correlation) * jnp.asarray(noise_scale, dtype) * ramp


def noise_ramp(num_steps: int, ramp_steps: int) -> np.ndarray:
    """(num_steps,) factors on each direction's latent noise: i / ramp_steps at step i (0-based), 1 from
    step ramp_steps on. Step 0 of each direction makes the frame next to its keyframe, so with a ramp those
    frames come from the prior's mean and the samples part towards mid-transition, where the keyframes
    constrain the motion least. ramp_steps = 0: 1 everywhere (the paper's sampling). Not in the paper: it
    is an inference setting (measured in results/README.md, "Noise ramp")."""
    if int(ramp_steps) != ramp_steps or ramp_steps < 0:  # a fraction would be truncated silently
        raise ValueError(f"noise_ramp_steps must be a whole number of steps >= 0, got {ramp_steps}")
    ramp_steps = int(ramp_steps)
    if ramp_steps == 0:
        return np.ones((num_steps,), np.float32)
    return np.minimum(np.arange(num_steps, dtype=np.float32) / ramp_steps, 1.0)


def correlated_noise(eps, rho: float):
    """Temporally correlated latent noise: the AR(1) filter e_0 = n_0, e_t = rho e_(t-1) + sqrt(1 - rho^2) n_t
    along axis 0 (steps) of standard normal noise ``eps`` (n, ...).

    Every e_t stays standard normal (so the prior's spread is unchanged) and corr(e_t, e_s) = rho^|t-s|:
    rho = 0 returns ``eps`` itself (independent per frame, the paper's sampling), rho = 1 repeats n_0 on
    every step (one draw per transition). Not in the paper: z from the posterior moves smoothly from frame
    to frame at training (q follows the ground truth), and independent prior noise per frame does not.
    rho: a static Python float in [0, 1].
    """
    rho = float(rho)
    if not 0.0 <= rho <= 1.0:
        raise ValueError(f"noise_correlation must be in [0, 1], got {rho}")
    if rho == 0.0:
        return eps
    n = eps.shape[0]
    t = np.arange(n)
    lag = t[:, None] - t[None, :]  # (n, n): t - s
    weights = np.where(lag >= 0, rho ** np.maximum(lag, 0), 0.0)
    weights[:, 1:] *= np.sqrt(1.0 - rho * rho)  # innovations n_s, s >= 1, carry sqrt(1 - rho^2)
    return jnp.tensordot(jnp.asarray(weights, eps.dtype), eps, axes=1)


def _pin_keyframes(stitched: dict, start: dict, target: dict, length, t_out: int) -> dict:
    """Frame 0 set to the start keyframe and frames L + 1 .. t_out - 1 to the target, exactly."""
    t = jnp.arange(t_out, dtype=jnp.int32)
    is_start, is_target = (t == 0), (t >= length + 1)

    def pin(x, first, last):
        shape = (t_out,) + (1,) * (x.ndim - 1)
        return jnp.where(is_start.reshape(shape), first[None], jnp.where(is_target.reshape(shape), last[None], x))

    return {"rotations": pin(stitched["rotations"], start["rotations"], target["rotations"]),
            "root_positions": pin(stitched["root_positions"], start["root_position"], target["root_position"]),
            "contacts": pin(stitched["contacts"], start["contacts"], target["contacts"])}


def _with_positions(stitched: dict, fwd_all: dict, bwd_all: dict, seq: dict, offsets, spec, length,
                    split: tuple) -> dict:
    """The rollout's result (see :func:`rollout`): FK positions of the forward, backward and stitched
    sequences in one call, the per-direction outputs and the overlap. split = (h, k, n_forward, n_backward)."""
    m = spec
    h, k, n_fwd, n_bwd = split
    n = fwd_all["rotations"].shape[0] - 1
    t_out = stitched["rotations"].shape[0]
    dtype = stitched["rotations"].dtype
    all_rot = jnp.concatenate([fwd_all["rotations"], bwd_all["rotations"], stitched["rotations"]], axis=0)
    all_root = jnp.concatenate([fwd_all["root"], bwd_all["root"], stitched["root_positions"]], axis=0)
    _, all_pos = skel.forward_kinematics(all_rot, F.local_positions(offsets.astype(dtype), all_root),
                                         tuple(spec.parents))
    pos_fwd, pos_bwd, pos_stitched = all_pos[:n + 1], all_pos[n + 1:2 * (n + 1)], all_pos[2 * (n + 1):]
    steps = jnp.arange(n, dtype=jnp.int32)

    def direction(seq_dir, positions, count):
        d = {"rotations": seq_dir["rotations"], "root_positions": seq_dir["root"],
             "velocities": seq_dir["velocity"], "contacts": seq_dir["contacts"],
             "global_positions": positions[1:], "mask": steps < count}
        d.update({key_: seq_dir[key_] for key_ in GAUSSIAN_KEYS})
        return d

    result = {**stitched, "global_positions": pos_stitched,
              "mask": jnp.arange(t_out, dtype=jnp.int32) <= length + 1,
              "forward": direction(seq["forward"], pos_fwd, n_fwd)}
    size = 2 * max(m.stitch_buffer, 1)
    j = jnp.arange(size, dtype=jnp.int32)
    frames = h - k + 1 + j
    if m.bidirectional:
        result["backward"] = direction(seq["backward"], pos_bwd, n_bwd)
        overlap_mask = j < 2 * k
    else:
        overlap_mask = jnp.zeros((size,), bool)
    result["overlap"] = {
        "forward_positions": jnp.take(pos_fwd, frames, axis=0, mode="clip"),
        "backward_positions": jnp.take(pos_bwd, length + 1 - frames, axis=0, mode="clip"),
        "mask": overlap_mask,
    }
    return result


def keyframes_from_batch(batch: dict, length):
    """(start, target, offsets) of a batch dict (B, T, ...): start = frame 0, target = frame length + 1."""
    index = jnp.asarray(length, jnp.int32) + 1

    def at(x, i):
        return jax.lax.dynamic_index_in_dim(x, i, axis=1, keepdims=False)

    def keyframe(i):
        return {"rotations": at(batch["rotations"], i), "root_position": at(batch["root_positions"], i),
                "contacts": at(batch["contacts"], i)}

    return keyframe(0), keyframe(index), batch["offsets"][:, 0]


def direction_frames(batch: dict, length, num_steps: int, backward: bool, scales, ahead: int = 1) -> dict:
    """Ground truth of one direction's per-step frames (entry i = forward frame i + 1, or backward frame
    L - i), in that direction's time: "rotations" (B, n, J, 4), "velocities" (B, n, 3) scaled (reversed
    time for the backward direction), "contacts" (B, n, C), "global_positions" (B, n, J, 3). scales: anything
    with the ``velocity_scale`` of the data (a :class:`RolloutSpec`, a ``specs.SkeletonSpec``, ``config.data``).

    ahead = k > 1: entry i is the frame k - 1 further on in that direction's time, clipped at the keyframe it
    heads for (frame L + 1 forward, frame 0 backward), and "velocities" the root's mean velocity over the k
    frames from the frame before entry i's own (so k = 1 is the frame's own velocity)."""
    length = jnp.asarray(length, jnp.int32)
    made = jnp.arange(1, num_steps + 1, dtype=jnp.int32)  # direction time of the frame each step makes
    step = made  # direction time of the frame each entry shows
    if ahead > 1:
        step = jnp.maximum(made, jnp.minimum(made + (ahead - 1), length + 1))
    frames = (length + 1 - step) if backward else step
    before = (length + 2 - made) if backward else made - 1  # the frame each step starts from

    def take(x, index=frames):
        return jnp.take(x, index, axis=1, mode="clip")

    root = batch["root_positions"]
    velocity = take(root) - take(root, before)
    if ahead > 1:  # per frame, over the span from `before`
        velocity = velocity / (step - made + 1).astype(root.dtype)[None, :, None]
    velocity = velocity / scales.velocity_scale
    return {"rotations": take(batch["rotations"]), "velocities": velocity, "contacts": take(batch["contacts"]),
            "global_positions": take(batch["global_positions"])}


def next_frame_states(batch: dict, length, num_steps: int, spec) -> dict:
    """Posterior inputs {"forward", "backward"}: (B, n, S) ground-truth state of the frame each step makes,
    or with ``model.posterior_horizon`` = k > 1 of the frame k - 1 further on (:func:`direction_frames`)."""
    ahead = spec.posterior_horizon
    if ahead < 1:
        raise ValueError(f"model.posterior_horizon must be >= 1 (1 = the next frame), got {ahead}")
    out = {}
    for name in ("forward", "backward"):
        d = direction_frames(batch, length, num_steps, name == "backward", spec, ahead)
        out[name] = F.state_vector(d["rotations"], d["velocities"], d["contacts"])
    return out


def rollout_batch(gen_params, phase_params, batch: dict, key, spec, length, max_length: int | None = None,
                  posterior: bool = True, prior_flags=None):
    """:func:`rollout` vmapped over a batch dict (from ``features.prepare_dataset``, leading B).

    Keyframes: frame 0 and frame ``length + 1`` of each window; max_length defaults to T - 2.
    Per-example noise from ``jax.random.split(key, B)``. posterior: draw z from the posterior on the
    batch's ground truth (when ``model.posterior`` has one); False = from the prior, as at inference. With
    ``loss.prior_sample_fraction`` > 0 each window draws z from the prior instead with that probability
    (:func:`prior_sample_flags`); prior_flags, a (B,) bool array, names those windows instead (with a
    posterior; ``losses.prior_copies``).
    Returns rollout's dict with a leading B axis, and "prior_sampled" (B,) bool: the windows whose z came
    from the prior (every window with posterior=False or posterior "none").
    Differentiable in gen_params, phase_params and the batch; with ``train.weight_gradients_after_scan``
    the generators' kernel gradients are formed after the scan (module docstring), same values.
    """
    num_frames = batch["rotations"].shape[1]
    max_length = num_frames - 2 if max_length is None else int(max_length)
    if max_length + 2 > num_frames:
        raise ValueError(f"max_length={max_length} needs windows of {max_length + 2} frames, batch has {num_frames}")
    start, target, offsets = keyframes_from_batch(batch, length)
    keys = jax.random.split(key, batch["rotations"].shape[0])
    generators = {name: gen_params[name] for name in ("forward", "backward")}
    length = jnp.asarray(length, jnp.int32)
    truth, use_prior = None, None
    if posterior and spec.generator.posterior != "none":
        truth = next_frame_states(batch, length, num_steps(spec, max_length), spec)
        if prior_flags is not None:
            use_prior = jnp.asarray(prior_flags, bool)
        elif spec.prior_sample_fraction != 0:  # prior_sample_flags refuses values outside [0, 1]
            use_prior = prior_sample_flags(key, keys.shape[0], spec.prior_sample_fraction)

    def run(generators, inputs, constants, probes=None, tape=None):
        phase_params, start, target, offsets, truth = inputs
        keys, length, use_prior = constants
        record = isinstance(tape, str)  # "record" (recorded_collections refuses any other string)
        recording = bool(probes_lib.recorded_collections(probes, tape))

        def one(s, t, o, k, g, u, p, taped):
            taped = "record" if record else taped
            hook = None if p is None and taped is None else probes_lib.RecordingHook(p, taped)
            return rollout(generators, phase_params, s, t, o, k, spec, length, max_length, ground_truth=g,
                           use_prior=u, hook=hook)

        # Probes and taped values in, recorded values out stay step-major (steps, B, ...), the layout the
        # batched scan keeps them in, so the scan and the after-scan kernel gradients read them without a
        # transposing copy.
        return jax.vmap(one, in_axes=(0, 0, 0, 0, 0, 0, 1, 1), out_axes=(0, 1) if recording else 0)(
            start, target, offsets, keys, truth, use_prior, probes, None if record else tape)

    inputs, constants = (phase_params, start, target, offsets, truth), (keys, length, use_prior)
    taped = spec.scan_remat == "taped"
    if taped and not spec.weight_gradients_after_scan:
        raise ValueError("train.scan_remat=taped needs train.weight_gradients_after_scan=true (the tape is "
                         "recorded by the after-scan gradients' forward pass)")
    if taped and spec.generator.activation not in tape_lib.DERIVATIVES:
        raise ValueError(f"train.scan_remat=taped cannot tape model.activation={spec.generator.activation!r}: use "
                         f"one of {', '.join(a for a in tape_lib.DERIVATIVES if a in _ACTIVATION_NAMES)}, "
                         "or another train.scan_remat")
    if spec.weight_gradients_after_scan:
        leading = (num_steps(spec, max_length), keys.shape[0])
        run_probed = scan_gradients.gradients_after_scan(run, leading, spec.generator.matmul_dtype, taped)
        out = run_probed(generators, inputs, constants)
    else:
        out = run(generators, inputs, constants, None)
    if truth is None:  # posterior=False or posterior "none": every window from the prior
        use_prior = jnp.ones(keys.shape[:1], bool)
    elif use_prior is None:
        use_prior = jnp.zeros(keys.shape[:1], bool)
    return {**out, "prior_sampled": use_prior}


def prior_sample_flags(key, batch_size: int, fraction: float):
    """(B,) bool: which windows of a training batch draw z from the prior p instead of the posterior q
    (``loss.prior_sample_fraction``), each with probability ``fraction``, from ``fold_in(key, 1)`` (the
    per-window noise keys come from ``split(key, B)``)."""
    if not 0.0 <= fraction <= 1.0:
        raise ValueError(f"loss.prior_sample_fraction must be in [0, 1], got {fraction}")
    return jax.random.bernoulli(jax.random.fold_in(key, 1), fraction, (batch_size,))
