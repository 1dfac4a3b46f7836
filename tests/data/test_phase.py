"""Local-phase labels from foot contacts and the phase network (stitchjax.data.phase)."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from stitchjax.config import PhaseConfig
from stitchjax.data import phase

FPS = 30.0


def square_wave(num_frames, frequency, shift=0.0, duty=0.5):
    """0/1 contact signal with period 1/frequency seconds, (T,)."""
    t = np.arange(num_frames) / FPS
    return (np.mod(frequency * t + shift, 1.0) < duty).astype(np.float32)


def wrapped(d):
    """Phase difference mapped to [-0.5, 0.5)."""
    return np.mod(d + 0.5, 1.0) - 0.5


def test_square_wave_frequency_and_phase_advance():
    frequency = 1.2
    contacts = np.stack([square_wave(300, frequency), square_wave(300, frequency, shift=0.5)], axis=-1)
    fit = phase.fit_local_phase(contacts, FPS)
    inner = slice(30, 270)  # frames whose +-1 s window lies inside the clip
    # grid step is 0.125 Hz, so the nearest grid frequency is within 0.0625 Hz of 1.2
    assert np.all(np.abs(fit.frequency[inner] - frequency) <= 0.1)
    step = wrapped(np.diff(fit.phase[inner], axis=0))
    assert np.all(np.abs(step - frequency / FPS) < 0.01)
    assert abs(step.mean() - frequency / FPS) < 0.002
    # the second channel is half a period later: phases differ by 0.5
    assert np.all(np.abs(wrapped(fit.phase[inner, 1] - fit.phase[inner, 0] - 0.5)) < 0.02)
    # a 0/1 square wave's fundamental has amplitude 2/pi ~ 0.64 (slightly shrunk by smoothing/ridge)
    assert np.all((fit.amplitude[inner] > 0.45) & (fit.amplitude[inner] < 0.7))
    labels = phase.phase_labels(contacts, FPS)
    angle = 2 * np.pi * fit.phase
    expected = fit.amplitude[..., None] * np.stack([np.sin(angle), np.cos(angle)], -1)
    np.testing.assert_allclose(labels, expected, atol=1e-5)


def test_constant_channels_have_no_amplitude():
    contacts = np.stack([np.ones(80), np.zeros(80), square_wave(80, 2.0)], axis=-1)
    labels = phase.phase_labels(contacts, FPS)
    assert np.abs(labels[:, :2]).max() < 1e-4
    assert np.linalg.norm(labels[:, 2], axis=-1).mean() > 0.3


def test_leading_axes_and_batching_match_single_clips():
    rng = np.random.default_rng(0)
    contacts = (rng.random((2, 3, 50, 4)) < 0.5).astype(np.float32)
    labels = phase.phase_labels(contacts, FPS)
    assert labels.shape == (2, 3, 50, 4, 2) and labels.dtype == np.float32
    np.testing.assert_allclose(labels[1, 2], phase.phase_labels(contacts[1, 2], FPS), atol=1e-5)


def test_short_and_long_clip_paths_agree():
    # T=100 uses the dense short-clip path, T=300 the sliding-window path; frame 50 sees the same
    # frames (20..80, +-5 for smoothing) in both, so its fit must be the same.
    rng = np.random.default_rng(1)
    signal = (rng.random((300, 2)) < 0.5).astype(np.float32)
    short = phase.fit_local_phase(signal[:100], FPS)
    long = phase.fit_local_phase(signal, FPS)
    np.testing.assert_allclose(short.frequency[50], long.frequency[50])
    np.testing.assert_allclose(short.features()[50], long.features()[50], atol=1e-4)


def test_bad_input_raises():
    with pytest.raises(ValueError, match="contacts"):
        phase.phase_labels(np.zeros(10), FPS)
    with pytest.raises(ValueError, match="fps"):
        phase.phase_labels(np.zeros((10, 4)), 0.0)
    with pytest.raises(ValueError, match="unknown"):
        phase.init_phase_params(jax.random.key(0), 95, None, hidden_dims=16)


def test_settings_come_from_the_configs_phase_section():
    params = phase.init_phase_params(jax.random.key(0), 95, PhaseConfig(hidden_dim=16, num_layers=1))
    assert params["params"]["hidden_0"]["kernel"].shape == (95, 16)
    assert "hidden_1" not in params["params"]


def test_phase_features_shape():
    params = phase.init_phase_params(jax.random.key(0), 95, None, hidden_dim=32)
    out = phase.phase_features(params, jnp.ones((2, 5, 95)))
    assert out.shape == (2, 5, 8)
    jitted = jax.jit(phase.phase_features)(params, jnp.ones((3, 95)))
    assert jitted.shape == (3, 8) and bool(jnp.all(jnp.isfinite(jitted)))


def test_pretrain_reduces_loss_on_learnable_mapping():
    key = jax.random.key(0)
    states = jax.random.normal(jax.random.key(1), (512, 20))
    weights = jax.random.normal(jax.random.key(2), (20, 8)) / np.sqrt(20)
    labels = jnp.tanh(states @ weights)
    settings = dict(hidden_dim=32, num_layers=2, steps=300, batch_size=64)
    start = phase.phase_loss(phase.init_phase_params(key, 20, None, **settings), states, labels)
    params, final_loss = phase.pretrain_phase(key, states, labels, None, **settings)
    assert float(final_loss) < 0.3 * float(start)
    assert float(phase.phase_loss(params, states, labels)) < 0.3 * float(start)
    with pytest.raises(ValueError, match="same N"):
        phase.pretrain_phase(key, states, labels[:10], None, **settings)
