"""Local motion phases: automatic labels from foot contacts and the phase-identification network.

Labels follow Starke et al. 2020 ("Local Motion Phases for Learning Multi-Contact Character
Movements"): each foot-contact channel is smoothed, and in a window of +-:data:`WINDOW_SECONDS`
around every frame a sinusoid ``A sin(2 pi (F t - S)) + B`` is fitted. For every frequency F of a
grid (:data:`MIN_FREQUENCY`..:data:`MAX_FREQUENCY` Hz) the model is linear in (a, b, B) with
``a sin(2 pi F t) + b cos(2 pi F t) + B``, so each fit is a small (ridge) least-squares problem
solved for all frames and frequencies at once with matrix products; the frequency with the lowest
residual wins. With t measured from the centre frame, the phase there is phi = (-S) mod 1 and the
label ``A (sin 2 pi phi, cos 2 pi phi)`` equals ``(b, a)``.

Windows near the ends of a clip are truncated (frames outside the clip do not count). Labelling a
whole clip and slicing it gives better labels near window borders than labelling 50-frame windows.

The phase network (``PhaseNetwork``) maps the per-frame character state (``features.state_vector``,
size J*4 + 7) to the P = 2*C phase features; ``pretrain_phase`` fits it to the labels with Adam.

The labels' fit uses the named constants below (the paper gives none of them). The network's size and its
pretraining are the ``phase`` section of the config (``stitchjax.config.PhaseConfig``): functions take that
section as ``settings`` (None = the defaults), and keyword arguments override single fields.
"""
from __future__ import annotations

import dataclasses
import functools
import math
from typing import Any, NamedTuple, Sequence

import flax.linen as nn
import jax
import jax.numpy as jnp
import numpy as np
import optax

from stitchjax.config import PhaseConfig


class PhaseError(ValueError):
    """Bad input to a phase function (shape, fps or settings)."""


# --------------------------------------------------------------------------------------------------
# settings

# The labels' fit (Starke et al. 2020; docs/design.md §5.1):
WINDOW_SECONDS = 1.0  # the +-1 s fit window holds >= 1 period for F >= 0.5 Hz
MIN_FREQUENCY = 0.25  # Hz: the lowest of the sinusoid fit's frequency grid
MAX_FREQUENCY = 4.0  # Hz: the highest of the grid
NUM_FREQUENCIES = 31  # a 0.125 Hz grid, finer than a 2 s window resolves
SMOOTHING_SECONDS = 0.05  # removes 1-2 frame contact flicker
RIDGE = 1.0  # keeps near-degenerate low-frequency fits finite
# The phase network and its pretraining:
LEARNING_RATE = 1e-3  # Adam's default scale for a small MLP

_FIELDS = tuple(f.name for f in dataclasses.fields(PhaseConfig))


def phase_settings(settings: PhaseConfig | None = None, **overrides: Any) -> PhaseConfig:
    """Settings from a ``PhaseConfig`` (``config.phase``) or None (the defaults), plus keyword overrides."""
    unknown = set(overrides) - set(_FIELDS)
    if unknown:
        raise PhaseError(f"unknown phase setting(s) {sorted(unknown)}; known: {list(_FIELDS)}")
    return dataclasses.replace(PhaseConfig() if settings is None else settings, **overrides)


def frequency_grid() -> np.ndarray:
    """The candidate frequencies in Hz, (NUM_FREQUENCIES,)."""
    return np.linspace(MIN_FREQUENCY, MAX_FREQUENCY, NUM_FREQUENCIES)


# --------------------------------------------------------------------------------------------------
# labels


class LocalPhase(NamedTuple):
    """Per frame and channel fit results, each (..., T, C)."""

    phase: np.ndarray  # phi in [0, 1)
    amplitude: np.ndarray  # A >= 0 (in contact units, 0..1 scale)
    frequency: np.ndarray  # F in Hz
    offset: np.ndarray  # B

    def features(self) -> np.ndarray:
        """A (sin 2 pi phi, cos 2 pi phi), (..., T, C, 2)."""
        angle = 2 * np.pi * self.phase
        return np.stack([np.sin(angle), np.cos(angle)], axis=-1) * self.amplitude[..., None]


def _smooth(y: np.ndarray, sigma_frames: float) -> np.ndarray:
    """Gaussian smoothing of (R, T) along T; near the ends the kernel is renormalised."""
    if sigma_frames <= 0:
        return y
    radius = max(1, int(math.ceil(3 * sigma_frames)))
    offsets = np.arange(-radius, radius + 1)
    kernel = np.exp(-0.5 * (offsets / sigma_frames) ** 2).astype(np.float32)
    num_rows, num_frames = y.shape
    padded = np.zeros((num_rows, num_frames + 2 * radius), np.float32)
    padded[:, radius:radius + num_frames] = y
    ones = np.zeros(num_frames + 2 * radius, np.float32)
    ones[radius:radius + num_frames] = 1
    windows = np.lib.stride_tricks.sliding_window_view(padded, 2 * radius + 1, axis=1)
    weight = np.lib.stride_tricks.sliding_window_view(ones, 2 * radius + 1) @ kernel
    return (windows @ kernel) / weight


@functools.lru_cache(maxsize=16)
def _fit_operators(num_frames: int, fps: float, half: int, freqs: tuple, ridge: float):
    """Matrices of the per-frame fits for clips of ``num_frames`` frames.

    Returns (basis (K, F*3), solve (G, K, F*3), group (T,) int) with K = 2*half + 1: ``window @ basis``
    gives X^T y per frequency, ``window @ solve[group[t]]`` the ridge solution (a, b, B) for centre t.
    Centres whose window lies inside the clip share one group; truncated ones get their own.
    """
    freqs = np.asarray(freqs, np.float64)
    k = np.arange(2 * half + 1)
    tau = (k - half) / fps  # seconds from the centre frame
    angle = 2 * np.pi * tau[:, None] * freqs[None, :]  # (K, F)
    basis = np.stack([np.sin(angle), np.cos(angle), np.ones_like(angle)], axis=-1)  # (K, F, 3)

    centres = np.arange(num_frames)
    source = centres[:, None] + k[None, :] - half  # frame index of each window sample
    inside = (source >= 0) & (source < num_frames)  # (T, K)
    # one group per distinct mask: interior centres share the all-true mask
    _, first, group = np.unique(inside, axis=0, return_index=True, return_inverse=True)
    masks = inside[first].astype(np.float64)  # (G, K)
    gram = np.einsum("gk,kfi,kfj->gfij", masks, basis, basis)
    gram[..., 0, 0] += ridge
    gram[..., 1, 1] += ridge
    gram += 1e-9 * np.eye(3)
    solve = np.einsum("gfij,kfj->gkfi", np.linalg.inv(gram), basis)  # (G, K, F, 3)
    num_freqs = len(freqs)
    return (
        basis.reshape(len(k), num_freqs * 3).astype(np.float32),
        solve.reshape(len(first), len(k), num_freqs * 3).astype(np.float32),
        group.reshape(-1),
    )


def _smoothing_matrix(num_frames: int, sigma_frames: float) -> np.ndarray:
    """(T, T) matrix S with smoothed = y @ S, the same smoothing as ``_smooth``."""
    if sigma_frames <= 0:
        return np.eye(num_frames)
    radius = max(1, int(math.ceil(3 * sigma_frames)))
    gap = np.arange(num_frames)[:, None] - np.arange(num_frames)[None, :]
    kernel = np.where(np.abs(gap) <= radius, np.exp(-0.5 * (gap / sigma_frames) ** 2), 0.0)
    return kernel / kernel.sum(axis=0, keepdims=True)  # column t: weights of the frames around t


@functools.lru_cache(maxsize=16)
def _dense_operators(num_frames: int, fps: float, half: int, freqs: tuple, ridge: float, sigma: float):
    """For short clips: (T, T*F*3) matrices taking raw contacts (R, T) to X^T y and to the solution.

    Smoothing is folded in; all centres are fitted with one matrix product each.
    """
    freqs = np.asarray(freqs, np.float64)
    frames = np.arange(num_frames)
    gap = frames[:, None] - frames[None, :]  # (source k, centre t): k - t
    inside = (np.abs(gap) <= half).astype(np.float64)
    angle = 2 * np.pi * (gap / fps)[..., None] * freqs  # (K=T, T, F)
    basis = np.stack([np.sin(angle), np.cos(angle), np.ones_like(angle)], axis=-1) * inside[..., None, None]
    gram = np.einsum("ktfi,ktfj->tfij", basis, basis)
    gram[..., 0, 0] += ridge
    gram[..., 1, 1] += ridge
    gram += 1e-9 * np.eye(3)
    solve = np.einsum("tfij,ktfj->ktfi", np.linalg.inv(gram), basis)
    smooth = _smoothing_matrix(num_frames, sigma)  # (T_raw, T_smoothed)
    columns = num_frames * len(freqs) * 3
    to_xty = (smooth @ basis.reshape(num_frames, columns)).astype(np.float32)
    to_coef = (smooth @ solve.reshape(num_frames, columns)).astype(np.float32)
    return to_xty, to_coef


def _fit_rows(y: np.ndarray, fps: float, freqs: np.ndarray):
    """Fit every frame of (R, T) raw contact rows; returns (a, b, B, F) each (R, T)."""
    num_rows, num_frames = y.shape
    half = max(1, int(round(WINDOW_SECONDS * fps)))
    width = 2 * half + 1
    num_freqs = len(freqs)
    sigma = float(SMOOTHING_SECONDS * fps)
    if num_frames <= 2 * width:  # short clips (training windows): one dense product per quantity
        to_xty, to_coef = _dense_operators(num_frames, float(fps), half, tuple(freqs), float(RIDGE), sigma)
        xty = (y @ to_xty).reshape(num_rows, num_frames, num_freqs, 3)
        coef = (y @ to_coef).reshape(num_rows, num_frames, num_freqs, 3)
    else:  # long clips: sliding windows, one solve matrix per distinct (truncated) window
        y = _smooth(y, sigma)
        basis, solve, group = _fit_operators(num_frames, float(fps), half, tuple(freqs), float(RIDGE))
        padded = np.zeros((num_rows, num_frames + 2 * half), np.float32)
        padded[:, half:half + num_frames] = y
        windows = np.lib.stride_tricks.sliding_window_view(padded, width, axis=1)  # (R, T, K) view
        xty = (windows.reshape(-1, width) @ basis).reshape(num_rows, num_frames, num_freqs, 3)
        coef = np.empty_like(xty)
        for g in range(solve.shape[0]):
            centres = np.flatnonzero(group == g)
            if centres[-1] - centres[0] + 1 == len(centres):  # contiguous range: a slice avoids a copy
                centres = slice(centres[0], centres[-1] + 1)
            block = windows[:, centres].reshape(-1, width) @ solve[g]
            coef[:, centres] = block.reshape(num_rows, -1, num_freqs, 3)
    # ridge objective at the optimum: y.y - coef.xty, so the best frequency maximises coef.xty
    explained = coef[..., 0] * xty[..., 0] + coef[..., 1] * xty[..., 1] + coef[..., 2] * xty[..., 2]
    best = np.argmax(explained, axis=-1)  # (R, T)
    chosen = np.take_along_axis(coef, best[..., None, None], axis=2)[:, :, 0]  # (R, T, 3)
    return chosen[..., 0], chosen[..., 1], chosen[..., 2], freqs[best]


def fit_local_phase(contacts: Any, fps: float) -> LocalPhase:
    """Local phase fit of every frame and contact channel.

    contacts: (..., T, C) contact signals (0/1 floats), any leading axes (clips or windows); each
    (..., :, c) series is fitted on its own. fps: frames per second (LAFAN1: 30).
    Returns ``LocalPhase`` with fields of shape (..., T, C), float32.
    """
    contacts = np.asarray(contacts, np.float32)
    if contacts.ndim < 2 or contacts.shape[-2] == 0:
        raise PhaseError(f"contacts must be (..., T, C) with T >= 1 frames, got shape {contacts.shape}")
    if not np.all(np.isfinite(contacts)):
        raise PhaseError("contacts contain NaN or inf; pass 0/1 contact floats")
    if not fps > 0:
        raise PhaseError(f"fps must be positive, got {fps}")
    freqs = frequency_grid()
    *lead, num_frames, num_channels = contacts.shape
    rows = np.moveaxis(contacts, -1, -2).reshape(-1, num_frames)  # (R, T), R = prod(lead) * C
    outputs = [np.empty(rows.shape, np.float32) for _ in range(4)]
    half = max(1, int(round(WINDOW_SECONDS * fps)))
    # chunk rows so each (rows, T, F, 3) work array stays near 8M floats (32 MB)
    chunk = max(1, (8 << 20) // max(1, num_frames * len(freqs) * 3 + num_frames * (2 * half + 1)))
    for start in range(0, rows.shape[0], chunk):
        for out, value in zip(outputs, _fit_rows(rows[start:start + chunk], fps, freqs)):
            out[start:start + chunk] = value
    a, b, offset, freq = (np.moveaxis(o.reshape(*lead, num_channels, num_frames), -1, -2) for o in outputs)
    amplitude = np.hypot(a, b)
    phase = np.mod(np.arctan2(b, a) / (2 * np.pi), 1.0).astype(np.float32)
    phase[phase >= 1.0] = 0.0  # float32 rounding of values just below 1
    return LocalPhase(phase=phase, amplitude=amplitude.astype(np.float32),
                      frequency=freq.astype(np.float32), offset=offset.astype(np.float32))


def phase_labels(contacts: Any, fps: float) -> np.ndarray:
    """Phase labels A (sin 2 pi phi, cos 2 pi phi): (..., T, C) contacts -> (..., T, C, 2) float32.

    Works on one clip (T, C) or on batches of windows (N, T, C); flatten the last two axes for the
    network target: ``labels.reshape(*labels.shape[:-2], -1)`` -> (..., T, 2*C).
    """
    return fit_local_phase(contacts, fps).features().astype(np.float32)


# --------------------------------------------------------------------------------------------------
# network


class PhaseNetwork(nn.Module):
    """MLP: character state (..., S) -> phase features (..., P). ELU hidden layers, linear output."""

    hidden_dims: Sequence[int] = (128, 128)
    num_outputs: int = 8

    @nn.compact
    def __call__(self, state: jax.Array) -> jax.Array:
        x = state
        for i, width in enumerate(self.hidden_dims):
            x = nn.elu(nn.Dense(width, name=f"hidden_{i}")(x))
        return nn.Dense(self.num_outputs, name="output")(x)


def _network_from_params(phase_params: Any) -> PhaseNetwork:
    """Rebuild the module that made ``phase_params`` from its kernel shapes."""
    inner = phase_params.get("params", phase_params)
    try:
        hidden = []
        while f"hidden_{len(hidden)}" in inner:
            hidden.append(int(inner[f"hidden_{len(hidden)}"]["kernel"].shape[-1]))
        outputs = int(inner["output"]["kernel"].shape[-1])
    except (KeyError, TypeError, AttributeError) as err:
        raise PhaseError("phase_params are not PhaseNetwork parameters (from init_phase_params)") from err
    return PhaseNetwork(hidden_dims=tuple(hidden), num_outputs=outputs)


def init_phase_params(key: jax.Array, state_dim: int, settings: PhaseConfig | None = None, num_outputs: int = 8,
                      **overrides: Any) -> dict:
    """Fresh PhaseNetwork parameters for states of size ``state_dim`` (J*4 + 7)."""
    settings = phase_settings(settings, **overrides)
    network = PhaseNetwork(hidden_dims=(settings.hidden_dim,) * settings.num_layers, num_outputs=num_outputs)
    return network.init(key, jnp.zeros((1, state_dim), jnp.float32))


def phase_features(phase_params: Any, state: jax.Array) -> jax.Array:
    """Phase features (..., P) of character states (..., S); pure, jit/vmap friendly."""
    return _network_from_params(phase_params).apply(phase_params, state)


def phase_loss(phase_params: Any, states: jax.Array, labels: jax.Array) -> jax.Array:
    """Mean squared error between predicted phase features and labels (N, P)."""
    return jnp.mean((phase_features(phase_params, states) - labels) ** 2)


@functools.partial(jax.jit, static_argnames=("steps", "batch_size"))
def _train(params, states, labels, key, learning_rate, steps: int, batch_size: int):
    optimizer = optax.adam(learning_rate)

    def step_fn(carry, step):
        params, opt_state = carry
        idx = jax.random.randint(jax.random.fold_in(key, step), (batch_size,), 0, states.shape[0])
        loss, grads = jax.value_and_grad(phase_loss)(params, states[idx], labels[idx])
        updates, opt_state = optimizer.update(grads, opt_state, params)
        return (optax.apply_updates(params, updates), opt_state), loss

    (params, _), losses = jax.lax.scan(step_fn, (params, optimizer.init(params)), jnp.arange(steps))
    return params, losses


def pretrain_phase(key: jax.Array, states: Any, labels: Any, settings: PhaseConfig | None = None,
                   **overrides: Any) -> tuple[dict, jax.Array]:
    """Fit a fresh PhaseNetwork to phase labels with Adam (one jitted ``lax.scan`` over steps, learning rate
    :data:`LEARNING_RATE`).

    states: (N, S) character states; labels: (N, P) flattened phase labels. Minibatches of
    ``batch_size`` frames are drawn with replacement using ``fold_in(key, step)``.
    Returns (params, final_loss): final_loss is the mean minibatch MSE over the last 5% of steps.
    """
    settings = phase_settings(settings, **overrides)
    states = jnp.asarray(states, jnp.float32)
    labels = jnp.asarray(labels, jnp.float32)
    if states.ndim != 2 or labels.ndim != 2 or states.shape[0] != labels.shape[0] or states.shape[0] == 0:
        raise PhaseError(
            f"need states (N, S) and labels (N, P) with the same N > 0, got {states.shape} and {labels.shape}; "
            "flatten frames first, e.g. states.reshape(-1, S)"
        )
    if settings.steps < 1 or settings.batch_size < 1:
        raise PhaseError("steps and batch_size must be >= 1")
    init_key, train_key = jax.random.split(key)
    params = init_phase_params(init_key, states.shape[-1], settings, num_outputs=labels.shape[-1])
    params, losses = _train(params, states, labels, train_key, jnp.float32(LEARNING_RATE),
                            steps=int(settings.steps), batch_size=int(settings.batch_size))
    tail = max(1, settings.steps // 20)
    return params, jnp.mean(losses[-tail:])
