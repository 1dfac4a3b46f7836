"""The ground-penetration term and the foot-skate term on predicted contacts: hand computations on tiny batches."""
import jax
import jax.numpy as jnp
import numpy as np

from stitchjax import config as C
from stitchjax import skeleton as S
from stitchjax import specs as SP
from stitchjax.model import losses as LS
from stitchjax.model import objective as OB

from tests.model.test_losses import setup  # noqa: F401  (the tiny model and batch fixture)

J = 22
FEET = S.LAFAN1_FEET


def test_ground_penetration_equals_a_hand_computation():
    truth = jnp.zeros((1, 3, J, 3)).at[0, :, :, 1].set(5.0)  # every joint 5 cm up: the window's ground is 5 cm
    mask = jnp.ones((1, 3), bool)
    assert float(LS.ground_penetration_loss(truth, truth, mask, FEET, 100.0)) == 0.0
    # LeftFoot 2 cm below the ground in frame 1, RightToe 3 cm below in frame 2, a hand 40 cm below (not a foot)
    sunk = truth.at[0, 1, FEET[0], 1].set(3.0).at[0, 2, FEET[3], 1].set(2.0).at[0, 1, 17, 1].set(-35.0)
    expected = (0.0 + 0.02 + 0.03) / 3  # metres summed over the feet per frame, mean over the 3 frames
    np.testing.assert_allclose(LS.ground_penetration_loss(sunk, truth, mask, FEET, 100.0), expected, rtol=1e-6)
    # a frame outside the mask neither counts nor sets the ground
    masked = mask.at[0, 2].set(False)
    np.testing.assert_allclose(LS.ground_penetration_loss(sunk, truth, masked, FEET, 100.0), 0.02 / 2, rtol=1e-6)
    # a foot above the ground costs nothing, and the gradient pushes a sunk foot up
    lifted = sunk.at[0, 0, FEET[0], 1].set(9.0)
    grad = jax.grad(lambda p: LS.ground_penetration_loss(p, truth, mask, FEET, 100.0))(lifted)
    assert float(grad[0, 1, FEET[0], 1]) < 0 and float(grad[0, 0, FEET[0], 1]) == 0.0


def test_window_ground_is_the_lowest_true_foot_joint():
    truth = jnp.zeros((2, 3, J, 3)).at[:, :, :, 1].set(10.0).at[0, 2, FEET[1], 1].set(4.0).at[1, 0, 0, 1].set(-9.0)
    np.testing.assert_allclose(LS.window_ground(truth, jnp.ones((2, 3), bool), FEET), [4.0, 10.0])


def test_ground_penetration_weight_adds_its_term_to_the_generator_objective(setup):  # noqa: F811
    config, params, phase_params, batch = setup
    on = C.apply_overrides(config, ["loss.ground_penetration_weight=4.0"])
    total, terms, _ = OB.generator_loss(params, phase_params, batch, jax.random.PRNGKey(1), SP.train_spec(on),
                                        jnp.int32(8))
    base, base_terms, _ = OB.generator_loss(params, phase_params, batch, jax.random.PRNGKey(1),
                                            SP.train_spec(config), jnp.int32(8))
    assert "ground_penetration" not in base_terms and float(terms["ground_penetration"]) >= 0
    np.testing.assert_allclose(total - base, 4.0 * terms["ground_penetration"], rtol=1e-4, atol=1e-6)


def test_foot_skate_on_predicted_contacts_equals_a_hand_computation(setup):  # noqa: F811
    config, params, phase_params, batch = setup
    on = C.apply_overrides(config, ["loss.foot_skate_weight=2.0", "loss.foot_skate_contacts=predicted"])
    spec = SP.train_spec(on)
    length = 8
    out = OB.generator_rollouts(params, phase_params, batch, jax.random.PRNGKey(1), spec, jnp.int32(length))
    _, terms, _ = OB.generator_loss(params, phase_params, batch, jax.random.PRNGKey(1), spec, jnp.int32(length))
    positions = np.asarray(out["global_positions"], np.float64)[..., list(FEET), :]
    contacts = np.asarray(out["contacts"], np.float64)
    mask = np.asarray(out["mask"])
    step = np.diff(positions, axis=1) / 100.0
    step[..., 1] = 0.0  # horizontal movement only
    per_frame = np.sum(np.abs(step * contacts[:, 1:, :, None]), axis=(-2, -1))
    valid = mask[:, 1:] & mask[:, :-1]
    expected = np.sum(per_frame * valid) / np.sum(valid)
    np.testing.assert_allclose(terms["foot_skate"], expected, rtol=1e-4)
