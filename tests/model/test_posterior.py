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
    params = N.init_params(N.model_spec(config), jax.random.PRNGKey(0))
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
    legacy = N.init_params(N.model_spec(tiny_config("model.posterior=none")), jax.random.PRNGKey(0))
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
    data, _ = datasets.load_training_data(config, None)
    data = {k: (x[:8, :10] if x.shape[1] > 1 else x[:8]) for k, x in data.items()}
    mesh = parallel.make_mesh()
    state = train.create_train_state(config, jax.random.PRNGKey(0), None, mesh)
    before = jax.device_get(state.params)
    state, m = train.make_train_step(config, mesh)(state, parallel.shard_dataset(data, mesh), jnp.int32(6))
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
    last_fwd = float(RO.interpolation_weight(RO.rollout_spec(config), n_fwd, n_fwd, 48))
    last_bwd = float(RO.interpolation_weight(RO.rollout_spec(config), n_bwd, n_bwd, 48))
    assert last_fwd == pytest.approx(1.0) and last_bwd == pytest.approx(1.0)
    assert float(RO.interpolation_weight(RO.rollout_spec(config), 1, n_fwd, 48)) == pytest.approx(1 / n_fwd)
    legacy = tiny_config("model.gamma_schedule=transition")
    legacy_last = float(RO.interpolation_weight(RO.rollout_spec(legacy), n_fwd, n_fwd, 48))
    assert legacy_last == pytest.approx(n_fwd / 49) and legacy_last < 0.6


def test_configs_saved_before_the_posterior_are_refused_naming_the_fields_to_add():
    saved = C.to_dict(C.load_config("tiny"))
    for name in ("posterior", "z_every_layer", "decoder_uses_lstm", "gamma_schedule"):
        del saved["model"][name]
    del saved["phase"]["include_reversed"]
    saved["train"]["length_counts_keyframes"] = False  # a removed field
    with pytest.raises(C.ConfigError, match="lacks model.gamma_schedule, model.posterior, model.z_every_layer, "
                                            "model.decoder_uses_lstm, phase.include_reversed"):  # field order
        C.from_dict(json.loads(json.dumps(saved)))
    saved["model"].update(posterior="none", z_every_layer=False, decoder_uses_lstm=True, gamma_schedule="transition")
    saved["phase"]["include_reversed"] = False
    old = C.from_dict(json.loads(json.dumps(saved)))
    assert (old.model.posterior, old.model.z_every_layer, old.model.decoder_uses_lstm,
            old.model.gamma_schedule, old.phase.include_reversed) == ("none", False, True, "transition", False)
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


def test_prior_sample_reconstruction_weight_only_reweighs_the_prior_windows_state_and_fk(setup):
    """loss.prior_sample_reconstruction_weight: at 0 the state and FK terms no longer read the ground truth of
    the windows drawn from the prior (only the posterior windows are scored); at 1 nothing changes."""
    config, params, phase_params, batch = setup
    key = jax.random.PRNGKey(1)
    mixed = C.apply_overrides(config, ["loss.prior_sample_fraction=0.5"])
    posterior_key = jax.random.split(key)[0]  # the key generator_rollouts gives the rollout
    flags = np.asarray(BT.prior_sample_flags(posterior_key, batch["rotations"].shape[0], 0.5))
    assert flags.any() and not flags.all(), "the test batch must hold both kinds of window"
    out = BT.rollout_batch(params, phase_params, batch, posterior_key, RO.rollout_spec(mixed), LENGTH)
    np.testing.assert_array_equal(np.asarray(out["prior_sampled"]), flags)

    changed = _changed_in_between(batch)  # the prior windows' in-between ground truth replaced by noise
    changed = {k: (jnp.where(jnp.asarray(flags).reshape((-1,) + (1,) * (v.ndim - 1)), changed[k], v)
                   if k in ("rotations", "root_positions", "contacts", "global_positions") else v)
               for k, v in batch.items()}

    def terms(cfg, b):
        return _generator_loss(params, phase_params, b, key, cfg, LENGTH)[1]

    weight0 = C.apply_overrides(mixed, ["loss.prior_sample_reconstruction_weight=0"])
    a, b = terms(weight0, batch), terms(weight0, changed)
    for name in ("state", "fk", "rotation", "velocity"):
        np.testing.assert_allclose(float(a[name]), float(b[name]), rtol=1e-6, err_msg=name)
    full_a, full_b = terms(mixed, batch), terms(mixed, changed)  # weight 1: the prior windows are scored
    assert abs(float(full_a["fk"]) - float(full_b["fk"])) > 1e-3
    weight1 = C.apply_overrides(mixed, ["loss.prior_sample_reconstruction_weight=1"])
    assert float(terms(weight1, batch)["state"]) == float(full_a["state"])
    assert abs(float(a["state"]) - float(full_a["state"])) > 1e-4
    with pytest.raises(ValueError, match="prior_sample_reconstruction_weight"):
        terms(C.apply_overrides(mixed, ["loss.prior_sample_reconstruction_weight=-1"]), batch)
    with pytest.raises(ValueError, match="prior_sample_fraction > 0"):  # no prior window: refused, not ignored
        terms(C.apply_overrides(config, ["loss.prior_sample_reconstruction_weight=0.25"]), batch)


def test_near_keyframe_weight_reweighs_only_the_frames_next_to_the_keyframes(setup):
    """loss.near_keyframe_weight: at 0 the state and FK terms no longer read the ground truth of each
    direction's first generated frame (frames 1 and L); at 1 nothing changes; above 1 the terms change."""
    _, params, phase_params, batch = setup
    config = tiny_config("model.posterior=none")  # the rollout then reads no in-between ground truth
    params = N.init_params(N.model_spec(config), jax.random.PRNGKey(0))
    key = jax.random.PRNGKey(1)
    rng = np.random.default_rng(3)
    changed = dict(batch)
    for name in ("rotations", "contacts", "global_positions"):  # not the root: velocities span two frames
        x = np.array(batch[name])
        for frame in (1, LENGTH):
            x[:, frame] = rng.normal(size=x[:, frame].shape)
        changed[name] = jnp.asarray(x, jnp.float32)

    def terms(overrides, b):
        return _generator_loss(params, phase_params, b, key, C.apply_overrides(config, overrides), LENGTH)[1]

    off = ["loss.near_keyframe_weight=0", "loss.near_keyframe_frames=1"]
    a, b = terms(off, batch), terms(off, changed)
    for name in ("state", "fk", "rotation", "contact"):
        np.testing.assert_allclose(float(a[name]), float(b[name]), rtol=1e-6, err_msg=name)
    default = terms([], batch)
    assert abs(float(default["fk"]) - float(terms([], changed)["fk"])) > 1e-3  # by default they are scored
    assert float(terms(["loss.near_keyframe_weight=1", "loss.near_keyframe_frames=3"], batch)["state"]) == \
        float(default["state"])
    assert abs(float(terms(["loss.near_keyframe_weight=8"], batch)["fk"]) - float(default["fk"])) > 1e-4
    np.testing.assert_array_equal(objective.near_keyframe_weights(5, 4.0, 2), [4, 4, 1, 1, 1])
    with pytest.raises(ValueError, match="near_keyframe_weight"):
        terms(["loss.near_keyframe_weight=-1"], batch)
    with pytest.raises(ValueError, match="near_keyframe_frames"):  # a weight on no frame is refused, not ignored
        terms(["loss.near_keyframe_weight=8", "loss.near_keyframe_frames=0"], batch)


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
    params = N.init_params(N.model_spec(config), jax.random.PRNGKey(0))
    batch = synthetic_batch()
    length = 10
    start, target, offsets = jax.tree.map(lambda x: x[0], BT.keyframes_from_batch(batch, length))

    spec = RO.rollout_spec(config)

    def run(key, ramp):
        return RO.rollout(params, phase_params_for(config), start, target, offsets, key, spec, length, length,
                          noise_ramp_steps=ramp)

    keys = jax.random.split(jax.random.PRNGKey(3), 2)
    ramped = [run(k, 4) for k in keys]
    still = run(keys[0], 4)  # same key, same result
    mean = RO.rollout(params, phase_params_for(config), start, target, offsets, keys[0], spec, length, length,
                      noise_scale=0.0)
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


def test_prior_best_of_scores_only_the_copy_closest_to_the_ground_truth(setup):
    """loss.prior_best_of = K: the last round(f B) windows are rolled out K times from the prior; the state and
    FK terms score the posterior windows and, of each prior window, only its copy nearest the ground truth;
    the discriminator sees the batch's own B windows; K = 1 is the random draw of prior_sample_fraction."""
    config, params, phase_params, batch = setup
    key = jax.random.PRNGKey(1)
    size = batch["rotations"].shape[0]
    best3 = C.apply_overrides(config, ["loss.prior_sample_fraction=0.5", "loss.prior_best_of=3"])
    copies, flags, num_prior = objective.prior_copies(batch, specs.loss_spec(best3))
    assert num_prior == round(0.5 * size) and copies["rotations"].shape[0] == size + 2 * num_prior
    np.testing.assert_array_equal(np.asarray(flags), np.arange(size + 2 * num_prior) >= size - num_prior)
    for block in (1, 2):  # the repeated blocks are the batch's last num_prior windows
        rows = slice(size + (block - 1) * num_prior, size + block * num_prior)
        np.testing.assert_array_equal(copies["global_positions"][rows], batch["global_positions"][-num_prior:])

    errors = jnp.asarray([9.0, 5.0, 1.0, 2.0, 0.5, 3.0, 3.0, 0.1])  # 2 posterior rows, then K = 3 blocks of 2
    np.testing.assert_array_equal(objective.best_of_weights(errors, 2, 3), [1, 1, 0, 0, 1, 0, 0, 1])
    positions = jnp.zeros((2, 3, 4, 3)).at[1, :, :, 0].set(3.0)
    np.testing.assert_allclose(objective.window_position_errors(positions, jnp.zeros_like(positions),
                                                             jnp.ones((2, 3), bool)), [0.0, 3.0])

    total, terms, generated = _generator_loss(params, phase_params, batch, key, best3, LENGTH)
    assert np.isfinite(float(total)) and generated["features"].shape[0] == size
    # the best copy is at least as close as the copies' mean, and the copies differ (independent noise)
    assert float(terms["prior_error_best"]) < float(terms["prior_error_mean"])
    # the prior copies' ground truth enters the state and FK terms: replacing it changes them
    changed = _changed_in_between(batch)
    changed = {k: (v.at[-num_prior:].set(changed[k][-num_prior:]) if k in ("rotations", "contacts") else v)
               for k, v in batch.items()}
    assert abs(float(_generator_loss(params, phase_params, changed, key, best3, LENGTH)[1]["state"])
               - float(terms["state"])) > 1e-4
    grads = jax.grad(lambda p: _generator_loss(p, phase_params, batch, key, best3, LENGTH)[0])(params)
    assert all(np.isfinite(np.asarray(g)).all() for g in jax.tree.leaves(grads))
    with pytest.raises(ValueError, match="prior_best_of"):  # no prior window to repeat: refused, not ignored
        _generator_loss(params, phase_params, batch, key, C.apply_overrides(config, ["loss.prior_best_of=2"]), LENGTH)
    with pytest.raises(ValueError, match="prior_best_of"):
        objective.prior_copies(batch, specs.loss_spec(C.apply_overrides(config, ["loss.prior_best_of=0"])))


def test_model_noise_correlation_is_the_rollouts_default_at_training_and_inference(setup):
    """model.noise_correlation: a rollout without an explicit correlation uses the model's (training and the
    samplers), an explicit one overrides it, and 0 keeps the paper's independent noise."""
    config, params, phase_params, batch = setup
    correlated = C.apply_overrides(config, ["model.noise_correlation=0.9"])
    start, target, offsets = jax.tree.map(lambda x: x[0], BT.keyframes_from_batch(batch, LENGTH))
    key = jax.random.PRNGKey(2)

    def run(cfg, **kw):
        return np.asarray(RO.rollout(params, phase_params, start, target, offsets, key, RO.rollout_spec(cfg), LENGTH,
                                     LENGTH, **kw)["global_positions"])

    np.testing.assert_array_equal(run(correlated), run(config, noise_correlation=0.9))
    np.testing.assert_array_equal(run(correlated, noise_correlation=0.0), run(config))
    assert np.abs(run(correlated) - run(config)).max() > 1e-4
    # the training rollout reads it too: the prior windows move as the correlated sampler moves them
    prior = BT.rollout_batch(params, phase_params, batch, key, RO.rollout_spec(correlated), LENGTH, posterior=False)
    plain = BT.rollout_batch(params, phase_params, batch, key, RO.rollout_spec(config), LENGTH, posterior=False)
    assert float(jnp.abs(prior["global_positions"] - plain["global_positions"]).max()) > 1e-4


@pytest.mark.parametrize("ahead", [1, 4])
def test_posterior_horizon_shows_the_frame_k_ahead_with_the_roots_mean_velocity(setup, ahead):
    """model.posterior_horizon = k: forward step j (making frame j) shows q frame min(j + k - 1, L + 1), the
    backward step j (making frame L + 1 - j) frame max(L + 2 - j - k, 0), each with the root's mean velocity
    in that direction's time since the frame the step starts from; k = 1 is the next frame itself."""
    _, _, _, batch = setup
    config = tiny_config(f"model.posterior_horizon={ahead}")
    steps, length = 7, LENGTH
    got = BT.next_frame_states(batch, length, steps, RO.rollout_spec(config))
    root, scale = np.asarray(batch["root_positions"]), config.data.velocity_scale
    for name in ("forward", "backward"):
        rows = []
        for j in range(1, steps + 1):
            step = max(j, min(j + ahead - 1, length + 1))
            frame, before = (length + 1 - step, length + 2 - j) if name == "backward" else (step, j - 1)
            velocity = (root[:, frame] - root[:, before]) / (step - j + 1) / scale
            state = F.state_vector(batch["rotations"][:, frame], jnp.asarray(velocity), batch["contacts"][:, frame])
            rows.append(state)
        np.testing.assert_allclose(got[name], jnp.stack(rows, axis=1), rtol=1e-6, atol=1e-6, err_msg=name)
    if ahead > 1:  # the frames it shows differ from the next frame's
        nearest = BT.next_frame_states(batch, length, steps, RO.rollout_spec(tiny_config()))
        assert float(jnp.abs(got["forward"] - nearest["forward"]).max()) > 1e-3
    with pytest.raises(ValueError, match="posterior_horizon"):
        BT.next_frame_states(batch, length, steps, RO.rollout_spec(tiny_config("model.posterior_horizon=0")))
