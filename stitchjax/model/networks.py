"""Networks (flax.linen, pure init/apply): the S-CVAE generator and the LSGAN discriminators.

Generator (one per direction, paper section 3.1 / 4.1), one autoregressive step::

    state (S) ──► state encoder  (3 FC) ─┐
    offset (J*4+4) ─► offset encoder (3 FC) ─┼─ concat ─► LSTM cell ─► h ─┬─► FC ─► (mu, logvar)   current
    target (S) ─► target encoder (3 FC) ─┘                                    └─► FC ─► (mu_t, logvar_t) target
    (model.lstm=false: h = the concatenated embeddings, no LSTM cell)
    latent interpolation (Eq. 1): prior p = N((1-g) mu + g mu_t, sigma_g^2)
    posterior (training, model.posterior="next_frame"): q = N(mu_q, sigma_q^2) from [h, ground-truth next frame]
    z = mu + sigma * eps from q at training, from p at inference (and always with posterior "none")
    decoder: [z, state, target] ─► mixture of E experts (gating MLP on the phase features), z also fed
             to every later layer ─► (root velocity 3, quaternion update J*4, contact logits C)
    (ELU activations; the offset's last input is the time left to the target, RMIB's time-to-arrival)

The expert blend mixes each layer's expert *outputs* (``einsum`` over the expert axis), never a blended
weight matrix per example.

The layers are plain flax modules (:mod:`stitchjax.model.layers`: ``Dense``, ``LSTMCell``, ``MoEDense``).
The generator takes its layer classes as module attributes (``dense``, ``lstm_cell``, ``moe_dense``; chosen
by ``GeneratorSpec.layers``), as flax's ResNet takes ``conv``, so layers with the same parameters may stand in
for them.

Discriminators (RMIB style): a temporal convolution whose kernel spans the whole window (2 or 10 frames)
over per-frame features, then dense layers; one score per window position.

Sizes and switches come as frozen specs, not the Config: :class:`GeneratorSpec` and :class:`DiscriminatorSpec`
(:class:`ModelSpec` holds both), built once by :func:`model_spec` where training starts or a model is loaded.
"""
from __future__ import annotations

import dataclasses
import functools

import flax.linen as nn
import jax
import jax.numpy as jnp

from stitchjax.data import features
from stitchjax.model.layers import MLP, Dense, LSTMCell, ModuleDef, MoEDense

__all__ = [
    "GeneratorSpec", "generator_spec", "DiscriminatorSpec", "discriminator_spec", "ModelSpec", "model_spec",
    "Generator", "Posterior", "LatentMLP", "decode", "sample_latent", "Discriminator", "init_params",
    "make_generator", "make_discriminator", "initial_carry", "blend_gaussians", "disc_feature_dim", "phase_dim",
    "generator_input_dims", "GAUSSIAN_KEYS",
]

# The activation of every hidden layer of the generator (MANN's experts and gating use ELU).
ACTIVATION = "elu"

# The Gaussians a generator step outputs (:class:`Generator`): current and target heads, the prior p, the posterior q.
GAUSSIAN_KEYS = ("mu", "logvar", "mu_target", "logvar_target", "mu_blend", "logvar_blend", "mu_posterior",
                 "logvar_posterior")

def blend_gaussians(mu, logvar, mu_t, logvar_t, gamma):
    """Latent interpolation (paper Eq. 1): blend N(mu, s^2) and N(mu_t, s_t^2) with weight gamma.

    Mean (1-g) mu + g mu_t, sigma = (1-g) s + g s_t: the Wasserstein-2 geodesic between the diagonal
    Gaussians (sigma stays 1 when both are 1). Returns (mu_blend, logvar_blend).
    """
    mean = (1.0 - gamma) * mu + gamma * mu_t
    std = (1.0 - gamma) * jnp.exp(0.5 * logvar) + gamma * jnp.exp(0.5 * logvar_t)
    return mean, 2.0 * jnp.log(std)


def sample_latent(mu, logvar, eps):
    """Reparameterised draw z = mu + exp(logvar / 2) * eps (eps standard normal, same shape)."""
    return mu + jnp.exp(0.5 * logvar) * eps


@dataclasses.dataclass(frozen=True)
class GeneratorSpec:
    """The generator's sizes and switches, resolved once from a Config (:func:`generator_spec`).

    num_joints J, num_contacts C (``features.NUM_CONTACTS``): the state's sizes (S = J*4 + 3 + C); latent_dim,
    lstm_size, encoder_widths, decoder_widths, gating_widths, num_experts: layer sizes; matmul_dtype;
    switches of ``config.model``: latent_interpolation (Eq. 1), posterior, phase_modulation, lstm (False: the
    concatenated embeddings are ``h``, no recurrence; the carry passes through unchanged).
    layers: the generator's (dense, lstm_cell, moe_dense) layer classes (:class:`Generator`; () = the plain
    ones of :mod:`stitchjax.model.layers`), the choice of whoever runs the model.
    """

    num_joints: int
    num_contacts: int
    latent_dim: int
    lstm_size: int
    encoder_widths: tuple
    decoder_widths: tuple
    gating_widths: tuple
    num_experts: int
    matmul_dtype: str
    latent_interpolation: bool
    posterior: str
    phase_modulation: bool
    lstm: bool = True
    layers: tuple = ()


def generator_spec(model, data) -> GeneratorSpec:
    """The :class:`GeneratorSpec` of a config's ``model`` section and the joint count of its ``data`` section."""
    return GeneratorSpec(
        num_joints=data.num_joints, num_contacts=features.NUM_CONTACTS, latent_dim=model.latent_dim,
        lstm_size=model.lstm_size, encoder_widths=tuple(model.encoder_widths),
        decoder_widths=tuple(model.decoder_widths), gating_widths=tuple(model.gating_widths),
        num_experts=model.num_experts, matmul_dtype=model.matmul_dtype,
        latent_interpolation=model.latent_interpolation, posterior=model.posterior,
        phase_modulation=model.phase_modulation, lstm=model.lstm)


class Generator(nn.Module):
    """One S-CVAE step. See the module docstring; ``spec``: :class:`GeneratorSpec` (static, hashable).

    dense, lstm_cell, moe_dense: the layer classes (flax ``ModuleDef``s with the signatures of :class:`Dense`,
    :class:`LSTMCell`, :class:`MoEDense`); other classes with the same parameters may stand in for them.
    """

    spec: GeneratorSpec
    dense: ModuleDef = Dense
    lstm_cell: ModuleDef = LSTMCell
    moe_dense: ModuleDef = MoEDense

    @nn.compact
    def __call__(self, carry, state, target, offset, gamma, phase, eps, next_state=None, use_prior=None):
        """One step for one example (vmap for batches).

        Args:
          carry: LSTM carry (c (H,), h (H,)); returned unchanged without the LSTM (``model.lstm=false``).
          state, target: (S,) current and target character states.
          offset: (J*4 + 4) offset features and the time left to the target (seconds).
          gamma: () latent interpolation weight in [0, 1].
          phase: (P,) phase features of the current frame (ignored without phase modulation).
          eps: (latent_dim,) standard normal noise.
          next_state: (S,) ground-truth state of the frame this step makes (training only) or None. With
            ``model.posterior="next_frame"`` it feeds the recognition network q(z | h, next_state) and z is
            drawn from q; None draws z from the prior p (inference).
          use_prior: optional () bool, with next_state: True draws z from the prior p even so (the posterior
            q is still computed and returned, for the KL term; ``loss.prior_sample_fraction``).
        Returns:
          (new_carry, outputs) with outputs: "velocity" (3,), "rotation_update" (J*4,),
          "contact_logits" (C,), "mu", "logvar", "mu_target", "logvar_target", "mu_blend", "logvar_blend"
          (the prior p), "mu_posterior", "logvar_posterior" (q; equal to the prior's when z came from it)
          (latent_dim,) each.
        """
        m = self.spec
        latent = m.latent_dim
        dt = m.matmul_dtype
        encoder = functools.partial(MLP, tuple(m.encoder_widths), ACTIVATION, matmul_dtype=dt, dense=self.dense)
        e_state = encoder(name="state_encoder")(state)
        e_offset = encoder(name="offset_encoder")(offset)
        e_target = encoder(name="target_encoder")(target)
        if m.lstm:
            carry, h = self.lstm_cell(m.lstm_size, dt, name="lstm")(carry, (e_state, e_offset, e_target))
        else:  # model.lstm=false (Appendix D): no recurrence, the embeddings themselves feed the heads
            h = jnp.concatenate([e_state, e_offset, e_target], axis=-1)
        current_head = self.dense(2 * latent, dt, name="current_head")(h)
        target_head = self.dense(2 * latent, dt, name="target_head")(h)
        mu, logvar = current_head[..., :latent], current_head[..., latent:]
        mu_t, logvar_t = target_head[..., :latent], target_head[..., latent:]
        if m.latent_interpolation:
            mu_b, logvar_b = blend_gaussians(mu, logvar, mu_t, logvar_t, gamma)
        else:
            mu_b, logvar_b = mu, logvar
        if m.posterior == "next_frame" and next_state is not None:
            mu_q, logvar_q = Posterior(latent, m.encoder_widths[-1], dt, self.dense, name="posterior")(
                h, state, next_state)
        else:
            mu_q, logvar_q = mu_b, logvar_b
        z = sample_latent(mu_q, logvar_q, eps)
        if use_prior is not None:
            z = jnp.where(use_prior, sample_latent(mu_b, logvar_b, eps), z)

        y = (z, state, target)
        num_out = 3 + m.num_joints * 4 + m.num_contacts
        y = decode(y, z, phase, m, num_out, self.dense, self.moe_dense)
        n = m.num_joints * 4
        outputs = {
            "velocity": y[..., :3], "rotation_update": y[..., 3:3 + n], "contact_logits": y[..., 3 + n:],
            "mu": mu, "logvar": logvar, "mu_target": mu_t, "logvar_target": logvar_t,
            "mu_blend": mu_b, "logvar_blend": logvar_b, "mu_posterior": mu_q, "logvar_posterior": logvar_q,
        }
        return carry, outputs


class Posterior(nn.Module):
    """Recognition network q(z | h, next frame): [h, state, next_state - state] -> (mu_q, logvar_q).

    h (H,) LSTM output (it has seen the current frame, the target and their offset); state, next_state (S,).
    One hidden layer, then a linear head of 2 * latent_dim.
    """

    latent_dim: int
    width: int
    matmul_dtype: str = "float32"
    dense: ModuleDef = Dense

    @nn.compact
    def __call__(self, h, state, next_state):
        x = self.dense(self.width, self.matmul_dtype, ACTIVATION, name="hidden")(
            (h, next_state, next_state - state))
        out = self.dense(2 * self.latent_dim, self.matmul_dtype, name="head")(x)
        return out[..., :self.latent_dim], out[..., self.latent_dim:]


def decode(y, z, phase, spec, num_out: int, dense: ModuleDef = Dense, moe_dense: ModuleDef = MoEDense):
    """The decoder, called inside :class:`Generator` (with its layer classes ``dense`` and ``moe_dense``):
    y (in,) or a tuple of parts -> (num_out,).

    Phase modulation: a mixture of E experts per layer (``expert_0``, ...) whose coefficients come from the
    gating MLP (``gating``) on the phase features; otherwise a plain MLP (``decoder``). z is also
    concatenated to the input of every layer after the first (MANN / MVAE), so the latent reaches the output
    through every layer and is not washed out. spec: the :class:`GeneratorSpec`.
    """
    m = spec
    widths = tuple(m.decoder_widths) + (num_out,)
    dt = m.matmul_dtype
    if not m.phase_modulation:
        return LatentMLP(widths, dt, dense, name="decoder")(y, z)
    coefficients = MLP(tuple(m.gating_widths) + (m.num_experts,), ACTIVATION, activate_last=False,
                       matmul_dtype=dt, last_activation="softmax", dense=dense, name="gating")(phase)
    for i, width in enumerate(widths):
        if i > 0:
            y = (y, z)
        activation = ACTIVATION if i < len(widths) - 1 else "identity"
        y = moe_dense(width, m.num_experts, dt, activation, name=f"expert_{i}")(y, coefficients)
    return y


class LatentMLP(nn.Module):
    """MLP y -> out with z also concatenated to the input of every layer after the first; ELU between the
    layers, none after the last. Layers are named dense_0, dense_1, ... as in MLP."""

    widths: tuple
    matmul_dtype: str = "float32"
    dense: ModuleDef = Dense

    @nn.compact
    def __call__(self, y, z):
        for i, width in enumerate(self.widths):
            if i > 0:
                y = (y, z)
            activation = ACTIVATION if i < len(self.widths) - 1 else "identity"
            y = self.dense(width, self.matmul_dtype, activation, name=f"dense_{i}")(y)
        return y


class Discriminator(nn.Module):
    """LSGAN discriminator over windows of ``window`` frames.

    features (..., T, F) -> scores (..., T - window + 1): a temporal conv (kernel = window, VALID), then
    dense layers (leaky ReLU 0.2) to one linear score per window position.
    """

    window: int
    widths: tuple = (512, 256)

    @nn.compact
    def __call__(self, features):
        lead = features.shape[:-2]
        x = features.reshape((-1,) + features.shape[-2:])
        x = nn.Conv(self.widths[0], kernel_size=(self.window,), padding="VALID", name="temporal_conv")(x)
        x = nn.leaky_relu(x, 0.2)
        for i, width in enumerate(self.widths[1:]):
            x = nn.leaky_relu(nn.Dense(width, name=f"dense_{i}")(x), 0.2)
        x = nn.Dense(1, name="score")(x)[..., 0]
        return x.reshape(lead + x.shape[-1:])


# ---------------------------------------------------------------------------------------------------


def phase_dim(spec) -> int:
    """P = 2 phase features per contact channel (``spec``: a :class:`GeneratorSpec`)."""
    return 2 * spec.num_contacts


def disc_feature_dim(num_joints: int) -> int:
    """Per-frame discriminator features of J joints: positions relative to the root (J-1)*3 + root velocity 3."""
    return (num_joints - 1) * 3 + 3


@dataclasses.dataclass(frozen=True)
class DiscriminatorSpec:
    """The two LSGAN discriminators (:func:`discriminator_spec`): short_window, long_window (frames; paper /
    RMIB 2 and 10), widths of the temporal conv and dense layers, feature_dim (:func:`disc_feature_dim`)."""

    short_window: int
    long_window: int
    widths: tuple
    feature_dim: int


def discriminator_spec(model, num_joints: int) -> DiscriminatorSpec:
    """The :class:`DiscriminatorSpec` of a config's ``model`` section (``disc_*``) for J = ``num_joints``."""
    return DiscriminatorSpec(short_window=model.disc_short_window, long_window=model.disc_long_window,
                             widths=tuple(model.disc_widths), feature_dim=disc_feature_dim(num_joints))


@dataclasses.dataclass(frozen=True)
class ModelSpec:
    """Every network of a model: generator (:class:`GeneratorSpec`, both directions share it) and
    discriminators (:class:`DiscriminatorSpec`)."""

    generator: GeneratorSpec
    discriminators: DiscriminatorSpec


def model_spec(model, data) -> ModelSpec:
    """The :class:`ModelSpec` of a config's ``model`` and ``data`` sections (:func:`generator_spec`,
    :func:`discriminator_spec`): built once where training starts or a model is loaded."""
    return ModelSpec(generator=generator_spec(model, data), discriminators=discriminator_spec(model, data.num_joints))


def generator_input_dims(spec) -> dict:
    """Sizes of the generator's per-step inputs (one example); ``spec``: a :class:`GeneratorSpec`."""
    s = features.state_dim(spec.num_joints, spec.num_contacts)
    offset = spec.num_joints * 4 + 3 + 1  # the offsets and the time to the target
    return {"state": s, "target": s, "offset": offset, "phase": phase_dim(spec), "eps": spec.latent_dim}


def make_generator(spec) -> Generator:
    """The generator of a :class:`GeneratorSpec`, on its ``layers``. The plain layers compute in float32 only:
    ``matmul_dtype`` "bfloat16" needs accel's layers (``stitchjax.accel.matmul.with_layers``), which the train
    step and the model loader put in the spec; without them it is refused, never silently run in float32."""
    if spec.matmul_dtype != "float32" and not spec.layers:
        raise ValueError(f"model.matmul_dtype={spec.matmul_dtype!r} needs the layers of stitchjax.accel.matmul "
                         "(GeneratorSpec.layers; accel.matmul.with_layers(rollout_spec) sets them)")
    return Generator(spec, *spec.layers)


def make_discriminator(spec, which: str) -> Discriminator:
    """The "disc_short" or "disc_long" discriminator of a :class:`DiscriminatorSpec`."""
    window = spec.short_window if which == "disc_short" else spec.long_window
    return Discriminator(window=window, widths=tuple(spec.widths))


def initial_carry(spec, dtype=jnp.float32):
    """Zero LSTM carry (c, h) for one example; ``spec``: a :class:`GeneratorSpec`."""
    zeros = jnp.zeros((spec.lstm_size,), dtype)
    return (zeros, zeros)


def init_params(spec: ModelSpec, key) -> dict:
    """Fresh parameters {"forward", "backward", "disc_short", "disc_long"} (independent generators) of a
    :class:`ModelSpec` (:func:`model_spec`). Pure jax code: works under ``jax.jit`` and ``jax.eval_shape``.
    """
    g, d = spec.generator, spec.discriminators
    dims = generator_input_dims(g)
    generator = make_generator(dataclasses.replace(g, matmul_dtype="float32"))  # the same parameters at any dtype
    dummy = {name: jnp.zeros((size,), jnp.float32) for name, size in dims.items()}

    def init_generator(k):
        next_state = dummy["state"] if g.posterior != "none" else None
        return generator.init(k, initial_carry(g), dummy["state"], dummy["target"], dummy["offset"],
                              jnp.zeros((), jnp.float32), dummy["phase"], dummy["eps"], next_state)

    k_fwd, k_bwd, k_short, k_long = jax.random.split(key, 4)
    frames = max(d.long_window, d.short_window)
    disc_in = jnp.zeros((1, frames, d.feature_dim), jnp.float32)
    return {
        "forward": init_generator(k_fwd),
        "backward": init_generator(k_bwd),
        "disc_short": make_discriminator(d, "disc_short").init(k_short, disc_in),
        "disc_long": make_discriminator(d, "disc_long").init(k_long, disc_in),
    }
