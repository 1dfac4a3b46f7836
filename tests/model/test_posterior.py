"""The conditional VAE: the posterior at training, the prior at inference, noise scale, KL(q || p),
the interpolation-weight schedule, legacy configs and the reversed phase pretraining data."""
import json

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from stitchjax import config as C
from stitchjax import parallel
from stitchjax.data import datasets
from stitchjax.eval import evaluate, metrics
from stitchjax.model import losses, objective
from stitchjax.train import loop as train
from stitchjax.sample import trained_model
from stitchjax.data import features as F
from stitchjax.model import networks as N
from stitchjax.model import batch as BT
from stitchjax.model import noise as NZ
from stitchjax.model import rollout as RO
from stitchjax import specs

from test_rollout import phase_params_for, synthetic_batch, tiny_config

LENGTH = 8


def _generator_loss(params, phase_params, batch, key, config, length):
    """``objective.generator_loss`` with the train step's specs of `config`."""
    return objective.generator_loss(params, phase_params, batch, key, specs.train_spec(config), length)


@pytest.fixture(scope="module")
def setup():
    config = tiny_config()
    params = N.init_params(N.model_spec(config.model, config.data), jax.random.PRNGKey(0))
    return config, params, phase_params_for(config), synthetic_batch()


def _changed_in_between(batch, seed=5):
    """The batch with every frame strictly between the keyframes 0 and LENGTH + 1 replaced by noise."""
    rng = np.random.default_rng(seed)
    out = dict(batch)
    for name in ("rotations", "root_positions", "contacts", "global_positions"):
        x = np.array(batch[name])
        x[:, 1:LENGTH + 1] = rng.normal(size=x[:, 1:LENGTH + 1].shape)
        out[name] = jnp.asarray(x, jnp.float32)
    return out


def test_posterior_params_exist_only_with_a_posterior(setup):
    config, params, _, _ = setup
    assert "posterior" in params["forward"]["params"] and "posterior" in params["backward"]["params"]
    legacy_config = tiny_config("model.posterior=none")
    legacy = N.init_params(N.model_spec(legacy_config.model, legacy_config.data), jax.random.PRNGKey(0))
    assert "posterior" not in legacy["forward"]["params"]


def test_training_rollout_reads_the_ground_truth_and_inference_does_not(setup):
    config, params, phase_params, batch = setup
    other = _changed_in_between(batch)
    key = jax.random.PRNGKey(1)

    def run(b, posterior):
        return BT.rollout_batch(params, phase_params, b, key, RO.rollout_spec(config), LENGTH, posterior=posterior)

    # training (posterior): the in-between ground truth decides z, so the motion changes with it
    assert float(jnp.abs(run(batch, True)["rotations"] - run(other, True)["rotations"]).max()) > 1e-4
    # prior: identical whatever the in-between ground truth holds
    np.testing.assert_array_equal(run(batch, False)["rotations"], run(other, False)["rotations"])
    q = run(batch, True)["forward"]
    assert float(jnp.abs(q["mu_posterior"] - q["mu_blend"]).max()) > 1e-4  # q is its own distribution
    p = run(batch, False)["forward"]
    np.testing.assert_array_equal(p["mu_posterior"], p["mu_blend"])  # no posterior at inference


def test_evaluation_method_ignores_the_ground_truth_and_noise_scale_zero_collapses(tiny_run):
    from stitchjax.data.windows import Windows
    from stitchjax.data import bundled, lafan1

    model = trained_model.load_model(tiny_run)
    windows = lafan1.load_windows(bundled.sample_dir(), ("subject5",), window=30, offset=40)[:2]
    rng = np.random.default_rng(0)
    changed_rot = np.array(windows.rotations)
    changed_rot[:, 10:10 + LENGTH] = rng.normal(size=changed_rot[:, 10:10 + LENGTH].shape)
    changed_rot /= np.linalg.norm(changed_rot, axis=-1, keepdims=True)
    changed = Windows(**{**{f: getattr(windows, f) for f in windows.__dataclass_fields__}, "rotations": changed_rot})
    method = evaluate.model_method(model)
    a = method(windows, 9, LENGTH, 4, 3)
    b = method(changed, 9, LENGTH, 4, 3)
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x, y)
    spread = metrics.joint_spread_per_window(a[1])
    assert np.all(spread > 0)
    still = evaluate.model_method(model, noise_scale=0.0)(windows, 9, LENGTH, 4, 3)
    for x in still:
        np.testing.assert_array_equal(x, np.broadcast_to(x[:1], x.shape))  # every sample identical
    assert np.all(metrics.apd_per_window(still[1]) == 0)
    half = evaluate.model_method(model, noise_scale=0.5)(windows, 9, LENGTH, 4, 3)
    assert 0 < metrics.joint_spread_per_window(half[1]).mean() < spread.mean()
    with pytest.raises(trained_model.InbetweenError, match="noise_scale"):
        evaluate.model_method(model, noise_scale=-1.0)(windows, 9, LENGTH, 4, 3)
    # one noise draw per transition: the samples still differ, and each moves off the paper's draw
    shared = evaluate.model_method(model, noise_correlation=1.0)(windows, 9, LENGTH, 4, 3)
    assert np.all(metrics.joint_spread_per_window(shared[1]) > 0)
    assert float(np.abs(shared[1] - a[1]).max()) > 1e-3
    with pytest.raises(trained_model.InbetweenError, match="noise_correlation"):
        evaluate.model_method(model, noise_correlation=-0.5)(windows, 9, LENGTH, 4, 3)
    ramped = evaluate.model_method(model, noise_ramp_steps=2)(windows, 9, LENGTH, 4, 3)
    assert np.all(metrics.joint_spread_per_window(ramped[1]) > 0)  # still diverse
    with pytest.raises(trained_model.InbetweenError, match="noise_ramp_steps"):
        evaluate.model_method(model, noise_ramp_steps=-1)(windows, 9, LENGTH, 4, 3)


def test_one_train_step_changes_the_posterior_and_the_kl_is_kl_q_p():
    config = tiny_config()
    data, _ = datasets.load_training_data(config.data, None)
    data = {k: (x[:8, :10] if x.shape[1] > 1 else x[:8]) for k, x in data.items()}
    mesh = parallel.make_mesh()
    spec = specs.train_spec(config)
    state = train.create_train_state(spec, jax.random.PRNGKey(0), None, mesh)
    before = jax.device_get(state.params)
    state, m = train.make_train_step(spec, mesh)(state, parallel.shard_dataset(data, mesh), jnp.int32(6))
    after = jax.device_get(state.params)
    for direction in ("forward", "backward"):
        pairs = zip(jax.tree.leaves(before[direction]["params"]["posterior"]),
                    jax.tree.leaves(after[direction]["params"]["posterior"]))
        assert all(not np.array_equal(a, b) for a, b in pairs), direction
    m = jax.device_get(m)
    assert float(m["kl"]) > 0 and np.isfinite(float(m["kl_prior"]))
    assert float(m["kl"]) != pytest.approx(float(m["kl_prior"]))  # KL(q || p), not KL(p || N(0, I))


def test_gaussian_kl_free_bits_and_warmup():
    mu_q, lv_q = jnp.array([[0.5, -1.0]]), jnp.array([[0.2, -0.3]])
    mu_p, lv_p = jnp.array([[0.1, 0.0]]), jnp.array([[-0.1, 0.4]])
    q = np.exp(np.array([0.2, -0.3])); p = np.exp(np.array([-0.1, 0.4]))
    expected = np.sum(0.5 * (np.log(p / q) + (q + (np.array([0.4, -1.0])) ** 2) / p - 1))
    np.testing.assert_allclose(losses.gaussian_kl(mu_q, lv_q, mu_p, lv_p), [expected], rtol=1e-5)
    assert float(losses.gaussian_kl(mu_q, lv_q, mu_q, lv_q)[0]) == pytest.approx(0.0, abs=1e-6)
    out = {"mu_posterior": mu_q, "logvar_posterior": lv_q, "mu_blend": mu_p, "logvar_blend": lv_p}
    raw, penalised = losses.posterior_kl_loss(out, jnp.array([True]), free_bits=10.0)
    assert float(raw) == pytest.approx(expected, rel=1e-5) and float(penalised) == pytest.approx(10.0)
    assert [float(objective.kl_warmup(s, 100)) for s in (0, 50, 100, 500)] == [0.0, 0.5, 1.0, 1.0]
    assert float(objective.kl_warmup(0, 0)) == 1.0


def test_interpolation_weight_runs_from_zero_to_one_in_each_direction():
    config = tiny_config()
    h, k, n_fwd, n_bwd = (int(x) for x in RO.schedule(RO.rollout_spec(config), 48))
    last_fwd = float(RO.interpolation_weight(n_fwd, n_fwd))
    last_bwd = float(RO.interpolation_weight(n_bwd, n_bwd))
    assert last_fwd == pytest.approx(1.0) and last_bwd == pytest.approx(1.0)
    assert float(RO.interpolation_weight(1, n_fwd)) == pytest.approx(1 / n_fwd)
    assert float(RO.interpolation_weight(3, 0)) == 1.0  # clipped: never above 1


def test_configs_saved_before_the_posterior_are_refused_naming_the_fields_to_add():
    saved = C.to_dict(C.load_config("tiny"))
    del saved["model"]["posterior"], saved["model"]["latent_dim"]
    saved["train"]["length_counts_keyframes"] = False  # a field read nowhere: dropped
    # removed fields at the values the code now always uses: dropped
    saved["model"].update(z_every_layer=True, decoder_uses_lstm=False, gamma_schedule="direction")
    with pytest.raises(C.ConfigError, match="lacks model.latent_dim, model.posterior"):  # field order
        C.from_dict(json.loads(json.dumps(saved)))
    saved["model"].update(posterior="none", latent_dim=4)
    old = C.from_dict(json.loads(json.dumps(saved)))
    assert (old.model.posterior, old.model.latent_dim) == ("none", 4)
    saved["model"]["decoder_uses_lstm"] = True  # a model the code can no longer build: refused, naming the field
    with pytest.raises(C.RetiredFieldError, match="model.decoder_uses_lstm=True"):
        C.from_dict(json.loads(json.dumps(saved)))
    with pytest.raises(C.ConfigError, match="posterior must be one of"):
        C.apply_overrides(C.load_config("tiny"), ["model.posterior=nope"])


def test_reverse_time_and_phase_pretraining_on_reversed_windows():
    data = {"rotations": np.arange(2 * 3 * 1 * 4.0).reshape(2, 3, 1, 4),
            "root_positions": np.arange(18.0).reshape(2, 3, 3), "contacts": np.arange(6.0).reshape(2, 3, 1)}
    rev = F.reverse_time(data)
    np.testing.assert_array_equal(rev["root_positions"][:, 0], data["root_positions"][:, -1])
    np.testing.assert_array_equal(rev["contacts"][:, ::-1], data["contacts"])


def test_joint_spread_is_the_mean_pairwise_joint_distance():
    a = np.zeros((1, 1, 2, 3, 3))
    b = a.copy()
    b[..., 0] = 3.0  # every joint 3 units away in x
    samples = np.concatenate([a, b, a])  # pairs: (a, b) 3, (a, a) 0, (b, a) 3 -> mean 2
    np.testing.assert_allclose(metrics.joint_spread_per_window(samples), [2.0])
    c = a.copy()
    c[:, :, 1] = 4.0
    np.testing.assert_allclose(metrics.joint_spread_per_window(np.concatenate([a, c]), frame=0), [0.0])
    assert metrics.joint_spread_per_window(a)[0] == 0.0


def test_prior_sample_fraction_rolls_windows_out_from_the_prior(setup):
    """loss.prior_sample_fraction: a window drawn for the prior moves exactly as at inference (same noise),
    the others exactly as with the posterior; q is still computed for every window (the KL term)."""
    config, params, phase_params, batch = setup
    key = jax.random.PRNGKey(3)
    mixed_config = C.apply_overrides(config, ["loss.prior_sample_fraction=0.5"])
    flags = np.asarray(BT.prior_sample_flags(key, batch["rotations"].shape[0], 0.5))
    assert flags.any() and not flags.all(), "the test batch must hold both kinds of window"
    mixed = BT.rollout_batch(params, phase_params, batch, key, RO.rollout_spec(mixed_config), LENGTH)
    posterior = BT.rollout_batch(params, phase_params, batch, key, RO.rollout_spec(config), LENGTH)
    prior = BT.rollout_batch(params, phase_params, batch, key, RO.rollout_spec(config), LENGTH, posterior=False)
    np.testing.assert_array_equal(mixed["rotations"][flags], prior["rotations"][flags])
    np.testing.assert_array_equal(mixed["rotations"][~flags], posterior["rotations"][~flags])
    assert float(jnp.abs(prior["rotations"] - posterior["rotations"]).max()) > 1e-4
    q = mixed["forward"]
    assert float(jnp.abs(q["mu_posterior"][flags] - q["mu_blend"][flags]).max()) > 1e-4  # q still computed


def test_prior_sample_fraction_trains_and_keeps_the_paper_path_at_zero(setup):
    config, params, phase_params, batch = setup
    key = jax.random.PRNGKey(4)
    base = _generator_loss(params, phase_params, batch, key, config, LENGTH)[0]
    zero = _generator_loss(params, phase_params, batch, key,
                           C.apply_overrides(config, ["loss.prior_sample_fraction=0"]), LENGTH)[0]
    assert float(base) == float(zero)
    mixed_config = C.apply_overrides(config, ["loss.prior_sample_fraction=1"])
    grads = jax.grad(lambda p: _generator_loss(p, phase_params, batch, key, mixed_config, LENGTH)[0])(params)
    # with every window from the prior, the posterior is trained by the KL term alone, and still trained
    post = grads["forward"]["params"]["posterior"]
    assert max(float(jnp.abs(x).max()) for x in jax.tree.leaves(post)) > 0
    with pytest.raises(ValueError, match="prior_sample_fraction"):
        BT.prior_sample_flags(key, 4, 1.5)
    with pytest.raises(ValueError, match="prior_sample_fraction"):  # a negative fraction is refused, not ignored
        BT.rollout_batch(params, phase_params, batch, key,
                         RO.rollout_spec(C.apply_overrides(config, ["loss.prior_sample_fraction=-0.1"])), LENGTH)


@pytest.mark.parametrize("rho", [0.5, 0.9])
def test_correlated_noise_keeps_unit_variance_and_has_the_asked_correlation(rho):
    eps = jax.random.normal(jax.random.PRNGKey(0), (12, 40000))
    e = np.asarray(NZ.correlated_noise(eps, rho))
    np.testing.assert_allclose(e.std(axis=1), 1.0, atol=0.02)
    lag1 = np.mean(e[1:] * e[:-1], axis=1)
    np.testing.assert_allclose(lag1, rho, atol=0.02)
    np.testing.assert_allclose(np.mean(e[3:] * e[:-3], axis=1), rho ** 3, atol=0.02)


def test_correlated_noise_ends():
    eps = jax.random.normal(jax.random.PRNGKey(1), (6, 2, 3))
    assert NZ.correlated_noise(eps, 0.0) is eps  # the paper's independent noise, untouched
    one = np.asarray(NZ.correlated_noise(eps, 1.0))
    np.testing.assert_allclose(one, np.broadcast_to(np.asarray(eps)[:1], one.shape), rtol=1e-6)
    with pytest.raises(ValueError, match="noise_correlation"):
        NZ.correlated_noise(eps, 1.2)


def test_noise_ramp_factors():
    np.testing.assert_array_equal(NZ.noise_ramp(5, 0), np.ones(5))  # the paper's sampling: no ramp
    np.testing.assert_allclose(NZ.noise_ramp(6, 4), [0.0, 0.25, 0.5, 0.75, 1.0, 1.0])
    with pytest.raises(ValueError, match="noise_ramp_steps"):
        NZ.noise_ramp(5, -1)
    with pytest.raises(ValueError, match="noise_ramp_steps"):
        NZ.noise_ramp(5, 2.5)


def test_noise_ramp_puts_the_frames_next_to_the_keyframes_on_the_mean_path():
    config = tiny_config()
    params = N.init_params(N.model_spec(config.model, config.data), jax.random.PRNGKey(0))
    batch = synthetic_batch()
    length = 10
    start, target, offsets = jax.tree.map(lambda x: x[0], BT.keyframes_from_batch(batch, length))

    spec = RO.rollout_spec(config)

    def run(key, ramp):
        return RO.rollout(params, phase_params_for(config), (start, target, offsets), key, spec, length, length,
                          NZ.NoiseSpec(ramp_steps=ramp))

    keys = jax.random.split(jax.random.PRNGKey(3), 2)
    ramped = [run(k, 4) for k in keys]
    still = run(keys[0], 4)  # same key, same result
    mean = RO.rollout(params, phase_params_for(config), (start, target, offsets), keys[0], spec, length, length,
                      NZ.NoiseSpec(scale=0.0))
    for direction in ("forward", "backward"):
        first = [np.asarray(r[direction]["global_positions"][0]) for r in ramped]
        # step 0 of each direction (frame 1, frame L) draws no noise: every sample is on the mean path there
        np.testing.assert_allclose(first[0], first[1], atol=1e-5)
        np.testing.assert_allclose(first[0], np.asarray(mean[direction]["global_positions"][0]), atol=1e-5)
        # from step 1 on the samples part
        second = [np.asarray(r[direction]["global_positions"][1]) for r in ramped]
        assert np.abs(second[0] - second[1]).max() > 1e-4
    np.testing.assert_array_equal(still["global_positions"], ramped[0]["global_positions"])
    plain = [run(k, 0) for k in keys]  # without the ramp the first step already differs
    assert np.abs(np.asarray(plain[0]["forward"]["global_positions"][0])
                  - np.asarray(plain[1]["forward"]["global_positions"][0])).max() > 1e-4


def test_the_noise_spec_correlates_the_rollouts_noise_and_the_latent_noise_may_be_given(setup):
    """A NoiseSpec's correlation moves the rollout, 0 (the default) is the paper's independent noise, and noise
    given in ``latent`` is used as the noise the key would have drawn."""
    config, params, phase_params, batch = setup
    keyframes = jax.tree.map(lambda x: x[0], BT.keyframes_from_batch(batch, LENGTH))
    key, spec = jax.random.PRNGKey(2), RO.rollout_spec(config)

    def run(noise=NZ.NoiseSpec(), latent=None):
        return np.asarray(RO.rollout(params, phase_params, keyframes, key, spec, LENGTH, LENGTH, noise,
                                     latent)["global_positions"])

    np.testing.assert_array_equal(run(NZ.NoiseSpec(correlation=0.0)), run())
    correlated = run(NZ.NoiseSpec(correlation=0.9))
    assert np.abs(correlated - run()).max() > 1e-4
    eps = jax.random.normal(key, (RO.num_steps(spec, LENGTH), 2, config.model.latent_dim))
    given = run(NZ.NoiseSpec(correlation=0.9), {"noise": eps})
    np.testing.assert_array_equal(given, correlated)
    assert np.abs(run(latent={"noise": -eps}) - run()).max() > 1e-4


def test_next_frame_states_are_the_states_of_the_frames_each_step_makes(setup):
    """The posterior's inputs: forward step j (making frame j) shows q frame j, the backward step j (making
    frame L + 1 - j) frame L + 1 - j, each with the root's velocity in that direction's time."""
    config, _, _, batch = setup
    steps, length = 7, LENGTH
    scale = F.VELOCITY_SCALE
    got = BT.next_frame_states(batch, length, steps, scale)
    root = np.asarray(batch["root_positions"])
    for name in ("forward", "backward"):
        rows = []
        for j in range(1, steps + 1):
            frame, before = (length + 1 - j, length + 2 - j) if name == "backward" else (j, j - 1)
            velocity = (root[:, frame] - root[:, before]) / scale
            rows.append(F.state_vector(batch["rotations"][:, frame], jnp.asarray(velocity),
                                       batch["contacts"][:, frame]))
        np.testing.assert_allclose(got[name], jnp.stack(rows, axis=1), rtol=1e-6, atol=1e-6, err_msg=name)
