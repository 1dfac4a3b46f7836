"""The PyTorch twin used by benchmarks/run_all.py computes the same losses as stitchjax.

Skipped when PyTorch is not installed (it is only the optional `bench` extra).
"""
import pathlib
import sys

import numpy as np
import pytest

torch = pytest.importorskip("torch")

BENCH = pathlib.Path(__file__).resolve().parent.parent / "benchmarks"
if str(BENCH) not in sys.path:
    sys.path.insert(0, str(BENCH))

import jax  # noqa: E402

import run_all  # noqa: E402
import torch_twin  # noqa: E402
from stitchjax import config as config_lib  # noqa: E402
from stitchjax import features, networks, phase  # noqa: E402

TINY = ["model.encoder_widths=32,32,16", "model.lstm_size=32", "model.latent_dim=8", "model.decoder_widths=32,32",
        "model.gating_widths=16,16", "model.disc_widths=32,16", "phase.hidden_dim=16", "data.window=14",
        "train.max_length=12", "train.batch_size=3", *run_all.TWIN_MODEL]


@pytest.fixture(scope="module")
def tiny():
    """(config, params, phase_params, data): tiny full model (MoE decoder, phase gating), 3 windows of 14 frames."""
    config = config_lib.apply_overrides(config_lib.load_config("lafan1"), TINY)
    params = jax.jit(lambda key: networks.init_params(config, key))(jax.random.PRNGKey(0))
    phase_params = phase.init_phase_params(jax.random.PRNGKey(1), features.state_dim(config), config)
    data = run_all.synthetic_dataset(config, 3, 14)
    return config, params, phase_params, data


def test_twin_matches_stitchjax_losses(tiny):
    """Same weights, batch and latent noise: same generator loss, every term, and discriminator loss.
    Length 12 = the window's maximum (nothing masked), 7 = odd (the backward generator makes one frame more
    than the forward one) and shorter than the long discriminator's 10-frame window."""
    config, params, phase_params, data = tiny
    for length in (12, 7):
        result = torch_twin.check_equal_loss(config, params, phase_params, data, length, jax.random.PRNGKey(2))
        assert result["jax_loss"] > 0
        np.testing.assert_allclose(result["torch_loss"], result["jax_loss"], rtol=2e-5, err_msg=f"L={length}")
        np.testing.assert_allclose(result["torch_disc_loss"], result["jax_disc_loss"], rtol=2e-5)
        for name, value in result["torch_terms"].items():
            np.testing.assert_allclose(value, result["jax_terms"][name], rtol=1e-4, atol=1e-6,
                                       err_msg=f"{name}, L={length}")


def test_twin_noise_matters_and_train_step_updates(tiny):
    """Different noise gives a different loss (so the equality above is not vacuous); a train step
    changes the generator and discriminator weights and returns finite losses."""
    config, params, phase_params, data = tiny
    twin = torch_twin.Twin(config, threads=1)
    twin.load_flax(params, phase_params)
    batch = torch_twin.batch_to_torch(data, np.arange(3))
    eps = torch.from_numpy(np.array(torch_twin.jax_noise(jax.random.PRNGKey(2), 3, config, 12)))
    with torch.no_grad():
        a = float(twin.generator_loss(batch, 12, eps)[0])
        b = float(twin.generator_loss(batch, 12, eps + 1.0)[0])
    assert a != pytest.approx(b, rel=1e-4)
    before_g = twin.generators["forward"].lstm.weight_ih.detach().clone()
    before_d = twin.discriminators["disc_long"].conv.weight.detach().clone()
    losses = twin.train_step(batch, 12, eps=eps)
    assert np.isfinite(losses["loss"]) and np.isfinite(losses["disc_loss"])
    assert not torch.equal(before_g, twin.generators["forward"].lstm.weight_ih)
    assert not torch.equal(before_d, twin.discriminators["disc_long"].conv.weight)
