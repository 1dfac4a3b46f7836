"""Appendix D's switches in training: without discriminators there is no adversarial term and no discriminator
update; without the LSTM the generators train."""
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from stitchjax import config as config_lib, parallel, specs
from stitchjax.data import datasets
from stitchjax.model import objective
from stitchjax.train import loop as train

FRAMES = 10  # tiny windows: transitions of up to 8 frames


def tiny_config(*extra):
    return config_lib.apply_overrides(config_lib.load_config("tiny"), list(extra))


@pytest.fixture(scope="module")
def dataset():
    """The bundled sample's training windows cut to FRAMES frames (24 windows)."""
    data, _ = datasets.load_training_data(tiny_config().data, None)
    return {name: (x[:24, :FRAMES] if x.shape[1] > 1 else x[:24]) for name, x in data.items()}


def _train(config, data, steps: int = 2):
    """(initial state, state after `steps` train steps at L = 6, the metrics of the last step)."""
    mesh = parallel.make_mesh()
    state = train.create_train_state(specs.train_spec(config), jax.random.PRNGKey(0), None, mesh)
    before = jax.device_get(state)
    step = train.make_train_step(specs.train_spec(config), mesh)
    device_data = parallel.shard_dataset(data, mesh)
    for _ in range(steps):
        state, metrics = step(state, device_data, jnp.int32(6))
    return before, jax.device_get(state), jax.device_get(metrics)


def _equal(a, b) -> bool:
    return all(np.array_equal(x, y) for x, y in zip(jax.tree.leaves(a), jax.tree.leaves(b)))


def test_without_discriminators_no_adversarial_term_and_no_discriminator_update(dataset):
    config = tiny_config("model.discriminators=false")
    before, after, metrics = _train(config, dataset)
    assert int(after.step) == 2 and all(np.isfinite(v) for v in metrics.values())
    assert not any(name.startswith(("adv", "disc", "d_")) for name in metrics), sorted(metrics)
    for group in train.DISCRIMINATORS:  # never updated: parameters and optimiser state as initialised
        assert _equal(before.params[group], after.params[group]), group
    assert _equal(before.disc_opt_state, after.disc_opt_state)
    for group in train.GENERATORS:
        assert not _equal(before.params[group], after.params[group]), group
    with pytest.raises(ValueError, match="no discriminators"):
        objective.discriminator_loss(after.params, after.phase_params, {}, jax.random.PRNGKey(0),
                                     specs.train_spec(config), 6)


def test_the_discriminator_switch_removes_exactly_the_adversarial_term_from_the_generator_loss(dataset):
    """Same parameters, batch and key: the two totals differ by alpha5 L_G, and only the switched-off loss lacks
    the adversarial terms."""
    on, off = tiny_config(), tiny_config("model.discriminators=false")
    params = train.create_train_state(specs.train_spec(on), jax.random.PRNGKey(0)).params
    batch = {name: jnp.asarray(x[:4]) for name, x in dataset.items()}
    key = jax.random.PRNGKey(3)
    total_on, terms_on, _ = objective.generator_loss(params, None, batch, key, specs.train_spec(on), 6)
    total_off, terms_off, _ = objective.generator_loss(params, None, batch, key, specs.train_spec(off), 6)
    assert not any(name.startswith("adv") for name in terms_off) and float(terms_on["adv_g"]) > 0
    assert float(on.loss.gen_weight * terms_on["adv_g"]) > 1e-4
    np.testing.assert_allclose(float(total_on - total_off), float(on.loss.gen_weight * terms_on["adv_g"]),
                               rtol=1e-3, atol=1e-5 * abs(float(total_on)))  # float32 sums of the other terms
    for name in ("state", "kl", "fk", "stitch"):
        np.testing.assert_allclose(float(terms_on[name]), float(terms_off[name]), rtol=1e-6)


def test_without_the_lstm_the_generators_train(dataset):
    config = tiny_config("model.lstm=false")
    before, after, metrics = _train(config, dataset)
    assert all(np.isfinite(v) for v in metrics.values()) and "adv_g" in metrics
    for group in train.GENERATORS + train.DISCRIMINATORS:
        assert not _equal(before.params[group], after.params[group]), group
        assert "lstm" not in after.params[group]["params"]
