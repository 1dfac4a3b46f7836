"""Losses: elementary terms, the generator / discriminator objectives and their gradients."""
import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from stitchjax import config as C
from stitchjax.data import datasets
from stitchjax.data import features as F
from stitchjax.model import losses as LS
from stitchjax.model import objective as OB
from stitchjax.model import networks as N
from stitchjax import skeleton as S
from stitchjax import specs as SP


B, T, J = 2, 12, 22


def synthetic_batch(seed=0):
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(B, T, J, 4))
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    root = np.cumsum(rng.normal(size=(B, T, 3)) * 3.0, axis=1)
    offsets = rng.normal(size=(B, 1, J, 3)) * 10.0
    _, gpos = S.forward_kinematics(q, F.local_positions(offsets, root), S.LAFAN1_PARENTS)
    arrays = {"rotations": q, "root_positions": root, "contacts": rng.integers(0, 2, (B, T, 4)),
              "offsets": offsets, "global_positions": gpos, "phase": rng.normal(size=(B, T, 8))}
    return {k: jnp.asarray(v, jnp.float32) for k, v in arrays.items()}


def test_stitching_loss_zero_for_identical_positive_otherwise():
    pos = jax.random.normal(jax.random.PRNGKey(0), (3, 4, J, 3))
    mask = jnp.ones((3, 4), bool)
    assert float(LS.stitching_loss(pos, pos, mask)) == 0.0
    other = pos.at[:, 1].add(0.5)
    assert float(LS.stitching_loss(pos, other, mask)) > 0
    # only masked-in frames count: per frame sum |.| = J*3*0.5, averaged over 4 frames
    np.testing.assert_allclose(LS.stitching_loss(pos, other, mask), J * 3 * 0.5 / 4, rtol=1e-5)
    assert float(LS.stitching_loss(pos, other, mask.at[:, 1].set(False))) == 0.0
    assert float(LS.stitching_loss(pos, other, jnp.zeros((3, 4), bool))) == 0.0


def test_stitching_loss_per_motion_is_each_motions_own_loss():
    """The latent-pair search ranks rollouts by the same function training minimises, one value each."""
    pos = jax.random.normal(jax.random.PRNGKey(1), (3, 4, J, 3))
    other = jax.random.normal(jax.random.PRNGKey(2), (3, 4, J, 3))
    mask = jnp.array([[True] * 4, [True, True, False, False], [False] * 4])
    per_motion = LS.stitching_loss(pos, other, mask, reduction="mean", per_motion=True)
    assert per_motion.shape == (3,) and float(per_motion[2]) == 0.0
    for i in range(3):
        np.testing.assert_allclose(per_motion[i], LS.stitching_loss(pos[i], other[i], mask[i], reduction="mean"),
                                   rtol=1e-6)


def test_elementary_terms():
    x = {"rotations": jnp.ones((2, 5, J, 4)), "velocities": jnp.ones((2, 5, 3)), "contacts": jnp.ones((2, 5, 4))}
    mask = jnp.ones((2, 5), bool)
    total, parts = LS.state_loss(x, x, mask, C.LossConfig())
    assert float(total) == 0.0
    y = {**x, "contacts": jnp.zeros((2, 5, 4))}
    total, parts = LS.state_loss(y, x, mask, C.LossConfig())
    np.testing.assert_allclose(total, 0.1 * 4)  # beta3 * sum over 4 contact channels
    assert float(LS.kl_loss(jnp.zeros((2, 4)), jnp.zeros((2, 4)), jnp.ones(2, bool))) == 0.0
    assert float(LS.kl_loss(jnp.ones((2, 4)), jnp.zeros((2, 4)), jnp.ones(2, bool))) == pytest.approx(2.0)
    assert float(LS.lsgan_generator_loss(jnp.ones((2, 3)), jnp.ones((2, 3), bool))) == 0.0
    assert float(LS.lsgan_discriminator_loss(jnp.ones((2, 3)), jnp.zeros((2, 3)), jnp.ones((2, 3), bool))) == 0.0
    assert float(LS.masked_mean(jnp.array([1.0, 3.0, 100.0]), jnp.array([True, True, False]))) == 2.0


@pytest.fixture(scope="module")
def setup():
    from stitchjax.data import phase

    config = C.load_config("tiny")
    params = N.init_params(N.model_spec(config.model, config.data), jax.random.PRNGKey(0))
    phase_params = phase.init_phase_params(jax.random.PRNGKey(7), F.state_dim(config.data.num_joints),
                                        config.phase)
    return config, params, phase_params, synthetic_batch()


def _train_step(config):
    """Both objectives and their gradients, the way the train step uses them (one rollout)."""

    def step(params, phase_params, batch, key, length):
        gens = {k: params[k] for k in ("forward", "backward")}
        discs = {k: params[k] for k in ("disc_short", "disc_long")}

        def gen_objective(g):
            total, terms, generated = OB.generator_loss({**g, **discs}, phase_params, batch, key, SP.train_spec(config), length)
            return total, (terms, generated)

        (g_total, (terms, generated)), g_grads = jax.value_and_grad(gen_objective, has_aux=True)(gens)

        def disc_objective(d):
            return OB.discriminator_loss({**gens, **d}, phase_params, batch, key, SP.train_spec(config), length, generated)

        (d_total, d_terms), d_grads = jax.value_and_grad(disc_objective, has_aux=True)(discs)
        return g_total, terms, g_grads, d_total, d_terms, d_grads

    return jax.jit(step)


def test_generator_and_discriminator_losses_finite_gradients(setup):
    config, params, phase_params, batch = setup
    step = _train_step(config)
    for length in (3, 10):
        g_total, terms, g_grads, d_total, d_terms, d_grads = step(params, phase_params, batch,
                                                                  jax.random.PRNGKey(1), jnp.int32(length))
        for name in ("state", "kl", "fk", "stitch", "adv_g", "adv_g_short", "adv_g_long", "rotation",
                     "velocity", "contact", "state_forward", "state_backward"):
            assert name in terms and bool(jnp.isfinite(terms[name])), name
        lc = config.loss
        want = (terms["state"] + lc.kl_weight * terms["kl"] + lc.stitch_weight * terms["stitch"]
                + lc.fk_weight * terms["fk"] + lc.gen_weight * terms["adv_g"])
        np.testing.assert_allclose(g_total, want, rtol=1e-5)
        assert float(terms["stitch"]) > 0
        np.testing.assert_allclose(d_total, lc.disc_weight * d_terms["adv_d"], rtol=1e-6)
        leaves = jax.tree.leaves((g_grads, d_grads))
        assert all(bool(jnp.isfinite(x).all()) for x in leaves)
        assert any(float(jnp.abs(x).max()) > 0 for x in jax.tree.leaves(g_grads["backward"]))
        assert any(float(jnp.abs(x).max()) > 0 for x in jax.tree.leaves(d_grads["disc_short"]))
    # length 10: the 12-frame motion holds 10-frame windows, so the long discriminator learns too
    assert float(terms["adv_g_long"]) > 0
    assert any(float(jnp.abs(x).max()) > 0 for x in jax.tree.leaves(d_grads["disc_long"]))


def test_prepare_dataset_on_synthetic_windows():
    from stitchjax.data.windows import Windows

    config = C.Config()
    rng = np.random.default_rng(0)
    n, t = 2, 40
    q = rng.normal(size=(n, t, J, 4))
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    offsets = rng.normal(size=(J, 3)) * 10
    positions = np.broadcast_to(offsets, (n, t, J, 3)).copy()
    positions[:, :, 0] = rng.normal(size=(n, t, 3)) * 50
    contacts = (rng.random((n, t, 4)) > 0.5).astype(np.float64)
    skeleton = S.lafan1_skeleton(offsets)
    windows = Windows(q, positions, contacts, skeleton, 30.0, [f"clip:{i}" for i in range(n)])
    data = F.prepare_dataset(windows, None, config.data)
    assert data["rotations"].shape == (n, t, J, 4) and data["root_positions"].shape == (n, t, 3)
    assert data["contacts"].shape == (n, t, 4) and data["phase"].shape == (n, t, 8)
    assert data["offsets"].shape == (n, 1, J, 3) and data["global_positions"].shape == (n, t, J, 3)
    assert all(v.dtype == np.float32 for v in data.values())
    _, gpos = S.forward_kinematics(q, positions, S.LAFAN1_PARENTS)
    np.testing.assert_allclose(data["global_positions"], gpos, rtol=1e-4, atol=1e-3)
    states = F.dataset_states(data, F.VELOCITY_SCALE)
    assert states.shape == (n, t, F.state_dim(config.data.num_joints))
    bad = C.apply_overrides(config, ["data.parents=-1,0,1"])
    with pytest.raises(F.DatasetError, match="parents"):
        F.prepare_dataset(windows, None, bad.data)


def test_foot_skate_loss_counts_only_feet_that_move_while_in_contact():
    feet = S.LAFAN1_FEET
    pos = jnp.zeros((1, 4, J, 3))
    contacts = jnp.array([[[1.0, 0, 0, 0]] * 4])
    mask = jnp.ones((1, 4), bool)
    assert float(LS.foot_skate_loss(pos, contacts, mask, feet, 100.0)) == 0.0  # nothing moves
    slide = pos.at[0, 2:, feet[0], 0].set(10.0)  # LeftFoot moves 10 cm from frame 1 to frame 2
    np.testing.assert_allclose(LS.foot_skate_loss(slide, contacts, mask, feet, 100.0), 0.1 / 3, rtol=1e-6)
    assert float(LS.foot_skate_loss(slide, contacts.at[0, 2, 0].set(0.0), mask, feet, 100.0)) == 0.0  # airborne
    assert float(LS.foot_skate_loss(slide.at[0, 2:, 0, 0].set(10.0), contacts * 0, mask, feet, 100.0)) == 0.0
    assert float(LS.foot_skate_loss(slide, contacts, mask.at[0, 2].set(False), feet, 100.0)) == 0.0  # masked


def test_foot_height_contacts_weigh_feet_as_the_foot_slide_metric_does_one_frame_later():
    feet = S.LAFAN1_FEET
    truth = jnp.zeros((1, 4, J, 3)).at[..., 1].set(5.0).at[0, :, feet[1], 1].set(3.0)  # ground: 3 cm
    heights = jnp.array([0.0, 1.25, 2.5, 10.0])  # above the ground, one per frame, every foot
    pos = truth.at[0, :, list(feet), 1].set(3.0 + heights[None, :])
    mask = jnp.ones((1, 4), bool)
    w = LS.foot_height_contacts(pos, truth, mask, feet, up_axis=1)
    assert w.shape == (1, 4, len(feet))
    expected = np.clip(2.0 - 2.0 ** (np.asarray(heights) / 2.5), 0.0, 1.0)  # metrics.foot_slide_parts' weight
    np.testing.assert_allclose(w[0, 1:, 0], expected[:-1], rtol=1e-6)  # frame t carries frame t - 1's weight
    assert float(w[0, 0].sum()) == 0.0
    # the ground comes from valid frames only: a masked frame lower than the rest is ignored
    low = truth.at[0, 3, feet[0], 1].set(-50.0)
    np.testing.assert_allclose(LS.foot_height_contacts(pos, low, mask.at[0, 3].set(False), feet), w, rtol=1e-6)
    assert float(LS.foot_height_contacts(pos, low, mask, feet)[0, 1:].max()) == 0.0  # 53 cm above: no contact


def test_foot_skate_on_height_contacts_counts_horizontal_sliding_only():
    feet = S.LAFAN1_FEET
    truth = jnp.zeros((1, 4, J, 3))
    mask = jnp.ones((1, 4), bool)
    lift = truth.at[0, 2:, feet[0], 1].set(10.0)  # LeftFoot lifts 10 cm from frame 1 to 2: no slide
    contacts = LS.foot_height_contacts(lift, truth, mask, feet)
    assert float(LS.foot_skate_loss(lift, contacts, mask, feet, 100.0, up_axis=1)) == 0.0
    assert float(LS.foot_skate_loss(lift, contacts, mask, feet, 100.0)) > 0  # all components count it
    slide = truth.at[0, 2:, feet[0], 0].set(10.0)  # on the ground, 10 cm forward: a slide
    contacts = LS.foot_height_contacts(slide, truth, mask, feet)
    np.testing.assert_allclose(LS.foot_skate_loss(slide, contacts, mask, feet, 100.0, up_axis=1), 0.1 / 3, rtol=1e-6)
    # no gradient lifts a foot out of the term: the weights carry none, the vertical component is left out
    grad = jax.grad(lambda p: LS.foot_skate_loss(p, LS.foot_height_contacts(p, truth, mask, feet), mask, feet,
                                                 100.0, up_axis=1))(slide)
    assert float(jnp.abs(grad[..., 1]).max()) == 0.0 and float(jnp.abs(grad[..., 0]).max()) > 0


def test_foot_skate_on_height_contacts_refuses_windows_whose_up_axis_points_down(setup, monkeypatch):
    config, params, phase_params, batch = setup
    config = C.apply_overrides(config, ["loss.foot_skate_weight=2.0", "loss.foot_skate_contacts=height"])
    upside_down = dataclasses.replace(datasets.get(config.data.dataset), up_axis="-y")
    monkeypatch.setattr(datasets, "get", lambda name: upside_down)
    with pytest.raises(ValueError, match="positive up axis"):
        OB.generator_loss(params, phase_params, batch, jax.random.PRNGKey(1), SP.train_spec(config), jnp.int32(8))


@pytest.mark.parametrize("contacts", ["truth", "height", "height_either"])
def test_foot_skate_weight_adds_its_term_to_the_generator_objective(setup, contacts):
    config, params, phase_params, batch = setup
    config = C.apply_overrides(config, ["loss.foot_skate_weight=2.0", f"loss.foot_skate_contacts={contacts}"])
    total, terms, _ = OB.generator_loss(params, phase_params, batch, jax.random.PRNGKey(1), SP.train_spec(config), jnp.int32(8))
    lc = config.loss
    assert float(terms["foot_skate"]) > 0  # a random rollout: some feet in contact move
    base, base_terms, _ = OB.generator_loss(params, phase_params, batch, jax.random.PRNGKey(1),
                                            SP.train_spec(C.apply_overrides(config, ["loss.foot_skate_weight=0"])),
                                            jnp.int32(8))
    assert "foot_skate" not in base_terms
    np.testing.assert_allclose(total - base, lc.foot_skate_weight * terms["foot_skate"], rtol=1e-4)


def test_foot_velocity_loss_counts_feet_that_move_unlike_the_ground_truth_in_the_air_too():
    feet = S.LAFAN1_FEET
    truth = jnp.zeros((1, 4, J, 3)).at[0, :, feet[0], 0].set(jnp.arange(4.0) * 2.0)  # LeftFoot walks 2 cm/frame
    mask = jnp.ones((1, 4), bool)
    assert float(LS.foot_velocity_loss(truth, truth, mask, feet, 100.0)) == 0.0
    shifted = truth.at[..., 2].add(50.0)  # the same movement elsewhere: the term reads movement, not position
    assert float(LS.foot_velocity_loss(shifted, truth, mask, feet, 100.0)) == 0.0
    jump = truth.at[0, 1:, feet[1], 1].add(30.0)  # LeftToe jumps 30 cm up into frame 1, in the air after
    np.testing.assert_allclose(LS.foot_velocity_loss(jump, truth, mask, feet, 100.0), 0.3 / 3, rtol=1e-6)
    assert float(LS.foot_velocity_loss(jump, truth, mask.at[0, 1].set(False), feet, 100.0)) == 0.0  # masked


def test_foot_velocity_weight_adds_its_term_to_the_generator_objective(setup):
    config, params, phase_params, batch = setup
    config = C.apply_overrides(config, ["loss.foot_velocity_weight=2.0"])
    total, terms, _ = OB.generator_loss(params, phase_params, batch, jax.random.PRNGKey(1), SP.train_spec(config), jnp.int32(8))
    assert float(terms["foot_velocity"]) > 0  # a random rollout does not move its feet as the ground truth does
    base, base_terms, _ = OB.generator_loss(params, phase_params, batch, jax.random.PRNGKey(1),
                                            SP.train_spec(C.apply_overrides(config, ["loss.foot_velocity_weight=0"])),
                                            jnp.int32(8))
    assert "foot_velocity" not in base_terms
    np.testing.assert_allclose(total - base, 2.0 * terms["foot_velocity"], rtol=1e-4)


def test_height_either_contacts_hold_a_foot_that_lands_from_the_air():
    feet = S.LAFAN1_FEET
    truth = jnp.zeros((1, 4, J, 3))
    mask = jnp.ones((1, 4), bool)
    # LeftFoot 20 cm up in frames 0-1 (no contact), then on the ground 30 cm further on from frame 2
    landing = truth.at[0, :2, feet[0], 1].set(20.0).at[0, 2:, feet[0], 0].set(30.0)
    start_only = LS.foot_height_contacts(landing, truth, mask, feet, up_axis=1)
    either = LS.foot_height_contacts(landing, truth, mask, feet, up_axis=1, either_end=True)
    assert float(start_only[0, 2, 0]) == 0.0 and float(either[0, 2, 0]) == 1.0  # the jump into frame 2
    assert float(either[0, 0].sum()) == 0.0  # no movement into frame 0
    np.testing.assert_array_equal(np.asarray(either) >= np.asarray(start_only), True)
    assert float(LS.foot_skate_loss(landing, start_only, mask, feet, 100.0, up_axis=1)) == 0.0
    assert float(LS.foot_skate_loss(landing, either, mask, feet, 100.0, up_axis=1)) > 0


def _hand_l1_mean(diff, mask, axes):
    """sum |diff| over `axes`, then the mean over the frames where mask (float64 numpy) is set."""
    per_frame = np.sum(np.abs(diff), axis=axes)
    return float(np.sum(per_frame * mask) / max(np.sum(mask), 1.0))


@pytest.mark.parametrize("posterior", ["next_frame", "none"])
def test_with_every_extension_off_the_objective_is_eq9_term_for_term(setup, posterior):
    """L = L_state + 1.0 L_kl + 0.5 L_stitch + 0.5 L_fk + 0.1 L_G (Eq. 9 without L_D, which only the
    discriminators minimise), each term recomputed here by hand in float64 numpy from one rollout of the
    tiny model: Eq. 4 (beta 1, 1, 0.1), Eq. 5 (KL to the prior p with the posterior, KL(p || N(0, I)) without),
    Eq. 3, Eq. 6, Eq. 7, the forward and backward terms averaged."""
    config, params, phase_params, batch = setup
    config = C.apply_overrides(config, [f"model.posterior={posterior}"])
    assert C.extensions_on(config) == ()
    lc = config.loss
    assert ((lc.beta_rotation, lc.beta_velocity, lc.beta_contact), lc.kl_weight, lc.stitch_weight, lc.fk_weight,
            lc.gen_weight) == ((1.0, 1.0, 0.1), 1.0, 0.5, 0.5, 0.1)
    length = 7
    spec = SP.train_spec(config)
    out = OB.generator_rollouts(params, phase_params, batch, jax.random.PRNGKey(3), spec, jnp.int32(length))
    total, terms, _ = OB.generator_objective(params, out, batch, jnp.int32(length), spec.loss, spec.skeleton)
    assert not {"foot_skate", "foot_velocity"} & set(terms)

    f64 = lambda x: np.asarray(x, np.float64)  # noqa: E731
    truth = {k: f64(v) for k, v in batch.items()}
    state, kl, fk = [], [], []
    for name in ("forward", "backward"):
        o = {k: f64(v) for k, v in out[name].items()}
        mask = o["mask"].astype(np.float64)
        n = mask.shape[1]
        i = np.arange(n)
        last = batch["rotations"].shape[1] - 1
        frames = np.clip(length - i, 0, None) if name == "backward" else np.minimum(i + 1, last)
        before = (length + 1 - i) if name == "backward" else i  # the frame each step starts from
        rotations, contacts = truth["rotations"][:, frames], truth["contacts"][:, frames]
        velocities = (truth["root_positions"][:, frames] - truth["root_positions"][:, before]) / F.VELOCITY_SCALE
        state.append(_hand_l1_mean(o["rotations"] - rotations, mask, (-2, -1))
                     + _hand_l1_mean(o["velocities"] - velocities, mask, -1)
                     + 0.1 * _hand_l1_mean(o["contacts"] - contacts, mask, -1))
        fk.append(_hand_l1_mean((o["global_positions"] - truth["global_positions"][:, frames]) / F.POSITION_SCALE,
                                mask, (-2, -1)))
        mu_p, logvar_p = o["mu_blend"], o["logvar_blend"]
        if posterior == "none":  # KL(p || N(0, I))
            per_frame = 0.5 * np.sum(mu_p ** 2 + np.exp(logvar_p) - 1.0 - logvar_p, axis=-1)
        else:  # KL(q || p), q the posterior
            mu_q, logvar_q = o["mu_posterior"], o["logvar_posterior"]
            per_frame = 0.5 * np.sum(logvar_p - logvar_q + (np.exp(logvar_q) + (mu_q - mu_p) ** 2) / np.exp(logvar_p)
                                     - 1.0, axis=-1)
        kl.append(float(np.sum(per_frame * mask) / mask.sum()))
    overlap = {k: f64(v) for k, v in out["overlap"].items()}
    stitch = _hand_l1_mean((overlap["forward_positions"] - overlap["backward_positions"]) / F.POSITION_SCALE,
                           overlap["mask"].astype(np.float64), (-2, -1))
    # Eq. 7 on the stitched motion's discriminator features: positions relative to the root, root velocity
    positions, root, motion_mask = f64(out["global_positions"]), f64(out["root_positions"]), f64(out["mask"])
    rel = ((positions[:, :, 1:] - positions[:, :, :1]) / F.POSITION_SCALE).reshape(positions.shape[:2] + (-1,))
    velocity = np.concatenate([np.zeros_like(root[:, :1]), np.diff(root, axis=1)], axis=1) / F.VELOCITY_SCALE
    features = jnp.asarray(np.concatenate([rel, velocity], axis=-1), jnp.float32)
    adv = 0.0
    for which in ("disc_short", "disc_long"):
        scores = f64(N.make_discriminator(N.model_spec(config.model, config.data).discriminators, which).apply(params[which], features))
        window = config.model.disc_short_window if which == "disc_short" else config.model.disc_long_window
        valid = (np.arange(scores.shape[1])[None, :] + window <= motion_mask.sum(1, keepdims=True)).astype(np.float64)
        adv += 0.5 * float(np.sum((scores - 1.0) ** 2 * valid) / valid.sum())
    hand = {"state": np.mean(state), "kl": np.mean(kl), "stitch": stitch, "fk": np.mean(fk), "adv_g": adv}
    for name, value in hand.items():
        np.testing.assert_allclose(float(terms[name]), value, rtol=2e-5, atol=1e-7, err_msg=name)
    eq9 = hand["state"] + 1.0 * hand["kl"] + 0.5 * hand["stitch"] + 0.5 * hand["fk"] + 0.1 * hand["adv_g"]
    np.testing.assert_allclose(float(total), eq9, rtol=2e-5)
    assert hand["kl"] > 0 and hand["stitch"] > 0 and hand["adv_g"] > 0
