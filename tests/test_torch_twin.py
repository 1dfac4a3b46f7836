"""The PyTorch twin used by benchmarks/run_all.py computes the same losses and gradients as stitchjax.

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
import jax.numpy as jnp  # noqa: E402

import run_all  # noqa: E402
import torch_twin  # noqa: E402
from stitchjax import config as config_lib  # noqa: E402
from stitchjax.data import features, phase  # noqa: E402
from stitchjax.model import batch as batch_lib
from stitchjax.model import networks

TINY = ["model.encoder_widths=32,32,16", "model.lstm_size=32", "model.latent_dim=8", "model.decoder_widths=32,32",
        "model.gating_widths=16,16", "model.disc_widths=32,16", "phase.hidden_dim=16", "data.window=14",
        "train.max_length=12", "train.batch_size=3"]

# (config name, overrides, train step for the KL warm-up): the defaults (config.py) and the lafan1_cpu
# reproduction config as its runs were trained (contact gradient on, KL weight 0.1, free bits, KL warm-up at
# step 100 of 500, the foot-skate term; prior samples off, which the twin does not mirror), each with the
# posterior and without it; then the branches neither of them takes.
CPU_TWIN = ["model.contact_input_gradient=true", "loss.kl_weight=0.1", "loss.free_bits=1.0", "loss.kl_warmup_steps=500",
            "loss.foot_skate_weight=8.0", "loss.prior_sample_fraction=0"]
CASES = {
    "lafan1": ("lafan1", [], 0),
    "lafan1_posterior_none": ("lafan1", ["model.posterior=none"], 0),
    "lafan1_cpu": ("lafan1_cpu", CPU_TWIN, 100),
    "lafan1_cpu_posterior_none": ("lafan1_cpu", CPU_TWIN + ["model.posterior=none"], 100),
    "plain_decoder_foot_skate": ("lafan1", ["model.phase_modulation=false", "loss.foot_skate_weight=0.5",
                                            "loss.free_bits=0.5"], 0),
    "no_aligning": ("lafan1", ["model.bidirectional_aligning=false"], 0),
}
RTOL = 5e-6  # measured: at most 4.4e-7 relative on any term of any case


def make_case(name, extra=()):
    """(config, params, phase_params, data): a tiny model of CASES[name], 3 windows of 14 frames."""
    base, overrides, step = CASES[name]
    config = config_lib.apply_overrides(config_lib.load_config(base), TINY + overrides + list(extra))
    params = jax.jit(lambda key: networks.init_params(networks.model_spec(config.model, config.data), key))(jax.random.PRNGKey(0))
    phase_params = phase.init_phase_params(jax.random.PRNGKey(1),
                                           features.state_dim(config.data.num_joints),
                                           config.phase)
    data = run_all.synthetic_dataset(config, 3, 14)
    return config, params, phase_params, data


@pytest.fixture(scope="module")
def tiny():
    return make_case("lafan1")


@pytest.mark.parametrize("name", list(CASES))
def test_twin_matches_stitchjax_losses(name):
    """Same weights, batch, latent noise and warm-up step: same generator loss, every term, and
    discriminator loss. Length 12 = the window's maximum (nothing masked), 7 = odd (the backward generator
    makes one frame more than the forward one) and shorter than the long discriminator's 10-frame window."""
    config, params, phase_params, data = make_case(name)
    step = CASES[name][2]
    for length in (12, 7):
        result = torch_twin.check_equal_loss(config, params, phase_params, data, length, jax.random.PRNGKey(2),
                                             step=step)
        assert result["jax_loss"] > 0
        assert set(result["torch_terms"]) == set(result["jax_terms"])
        np.testing.assert_allclose(result["torch_loss"], result["jax_loss"], rtol=RTOL, err_msg=f"L={length}")
        np.testing.assert_allclose(result["torch_disc_loss"], result["jax_disc_loss"], rtol=RTOL)
        for term, value in result["torch_disc_terms"].items():
            np.testing.assert_allclose(value, result["jax_disc_terms"][term], rtol=RTOL, err_msg=term)
        for term, value in result["torch_terms"].items():
            np.testing.assert_allclose(value, result["jax_terms"][term], rtol=RTOL, atol=1e-7,
                                       err_msg=f"{term}, L={length}")
    if config.model.posterior != "none":  # the posterior is really in use: KL(q || p) is not 0
        assert result["jax_terms"]["kl"] > 1e-3
    if name == "lafan1_cpu":
        assert result["kl_scale"] == pytest.approx(0.2)
    if config.loss.foot_skate_weight:
        assert result["jax_terms"]["foot_skate"] > 0


def test_twin_matches_stitchjax_gradients():
    """The generators' kernel gradients agree, with and without model.contact_input_gradient (the
    stop-gradient on contacts fed back changes them: the two settings' gradients differ by far more than
    the twin differs from stitchjax)."""
    results = {}
    for setting in (False, True):
        config, params, phase_params, data = make_case(
            "lafan1", [f"model.contact_input_gradient={str(setting).lower()}"])
        results[setting] = torch_twin.check_equal_gradients(config, params, phase_params, data, 12,
                                                            jax.random.PRNGKey(2))
        assert "forward/posterior/hidden/kernel" in results[setting]
        for name, (jax_grad, torch_grad) in results[setting].items():
            scale = np.abs(jax_grad).max()
            assert scale > 0, name
            np.testing.assert_allclose(torch_grad, jax_grad, rtol=1e-3, atol=1e-4 * scale,
                                       err_msg=f"{name}, contact_input_gradient={setting}")
    changed = max(np.abs(results[True][n][0] - results[False][n][0]).max() / np.abs(results[False][n][0]).max()
                  for n in results[False])
    assert changed > 1e-2


def test_twin_next_frame_states_match_stitchjax(tiny):
    """The posterior's ground-truth inputs are the states of batch.next_frame_states, step by step."""
    config, _, _, data = tiny
    twin = torch_twin.Twin(config)
    batch = torch_twin.batch_to_torch(data, np.arange(3))
    n = torch_twin.num_steps(config, 12)
    for length in (12, 7, 1):
        expected = batch_lib.next_frame_states({k: jnp.asarray(v) for k, v in data.items()}, length, n,
                                               features.VELOCITY_SCALE)
        got = twin.next_frame_states(batch, length)
        steps = max(torch_twin.schedule(config, length)[2:])
        for name in ("forward", "backward"):
            assert got[name].shape == (3, steps, features.state_dim(config.data.num_joints))
            np.testing.assert_allclose(got[name].numpy(), np.asarray(expected[name])[:, :steps], rtol=1e-6,
                                       atol=1e-6, err_msg=f"{name}, L={length}")


@pytest.mark.parametrize("override", ["model.matmul_dtype=bfloat16", "loss.prior_sample_fraction=0.25",
                                      "train.lr_decay_to=0.5", "loss.foot_skate_contacts=height"])
def test_twin_refuses_what_it_does_not_mirror(override):
    config = config_lib.apply_overrides(config_lib.load_config("lafan1"), TINY + [override])
    with pytest.raises(torch_twin.UnsupportedConfig, match=override.split("=")[0]):
        torch_twin.Twin(config)


def test_twin_noise_matters_and_train_step_updates(tiny):
    """Different noise gives a different loss (so the equality above is not vacuous); a train step
    changes the generator, posterior and discriminator weights, returns finite losses and counts steps."""
    config, params, phase_params, data = tiny
    twin = torch_twin.Twin(config, threads=1)
    twin.load_flax(params, phase_params)
    batch = torch_twin.batch_to_torch(data, np.arange(3))
    eps = torch.from_numpy(np.array(torch_twin.generator_noise(jax.random.PRNGKey(2), 3, config, 12)))
    with torch.no_grad():
        a = float(twin.generator_loss(batch, 12, eps)[0])
        b = float(twin.generator_loss(batch, 12, eps + 1.0)[0])
    assert a != pytest.approx(b, rel=1e-4)
    g = twin.generators["forward"]
    before = [p.detach().clone() for p in (g.lstm.weight_ih, g.posterior.head.weight,
                                           twin.discriminators["disc_long"].conv.weight)]
    losses = twin.train_step(batch, 12, eps=eps)
    assert np.isfinite(losses["loss"]) and np.isfinite(losses["disc_loss"])
    after = (g.lstm.weight_ih, g.posterior.head.weight, twin.discriminators["disc_long"].conv.weight)
    for old, new in zip(before, after):
        assert not torch.equal(old, new)
    assert twin.step == 1


def test_matmul_hand_count_counts_the_posterior_and_z_every_layer(tiny):
    """The hand count grows by the posterior network and by z at every decoder layer."""
    config = tiny[0]
    full = torch_twin.matmul_flops(config, 32, 12)
    assert "posterior" in full["per_step_macs_per_example"]
    plain = torch_twin.matmul_flops(config_lib.apply_overrides(
        config, ["model.posterior=none", "model.z_every_layer=false"]), 32, 12)
    m = config.model
    extra_per_step = (full["per_step_macs_per_example"]["posterior"]
                      + m.num_experts * m.latent_dim * (sum(m.decoder_widths[1:]) + 3 + 22 * 4 + 4))
    assert "posterior" not in plain["per_step_macs_per_example"]
    assert full["generator_forward"] - plain["generator_forward"] == pytest.approx(
        2.0 * 32 * full["scan_steps"] * 2 * extra_per_step)
