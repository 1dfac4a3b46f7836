"""Interpolation-anchored updates (model.update_anchor="interpolation"): a zero update interpolates the keyframes."""
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from stitchjax import rotations as R
from stitchjax.eval import baselines
from stitchjax.model import batch as BT
from stitchjax.model import networks as N
from stitchjax.model import rollout as RO

from tests.model.test_rollout import phase_params_for, synthetic_batch, tiny_config

LENGTHS = (1, 2, 5, 7, 10)


def zero_output_rollout(*overrides):
    """The rollout of a tiny model whose generators output zero (every parameter 0) on a synthetic batch."""
    config = tiny_config(*overrides)
    params = N.init_params(N.model_spec(config.model, config.data), jax.random.PRNGKey(0))
    params = {**params, "forward": jax.tree.map(jnp.zeros_like, params["forward"]),
              "backward": jax.tree.map(jnp.zeros_like, params["backward"])}
    spec = RO.rollout_spec(config)
    fn = jax.jit(lambda b, length: BT.rollout_batch(params, phase_params_for(config), b, jax.random.PRNGKey(1),
                                                    spec, length, posterior=False))
    return fn, synthetic_batch()


def interpolation_of(batch, length):
    """Slerp of every local rotation (the short way) and a linear root, frames 0..L+1, float64."""
    q = np.asarray(batch["rotations"], np.float64)
    root = np.asarray(batch["root_positions"], np.float64)
    weights = np.linspace(0.0, 1.0, length + 2)
    rotations = np.moveaxis(baselines.slerp_to_hemisphere(q[:, 0], q[:, length + 1], weights, 0.0), 0, 1)
    roots = root[:, :1] + weights[None, :, None] * (root[:, length + 1:length + 2] - root[:, :1])
    return rotations, roots


@pytest.mark.parametrize("overrides", [(), ("model.bidirectional=false",), ("model.bidirectional_aligning=false",)],
                         ids=["bidirectional", "forward_only", "no_aligning"])
def test_zero_update_reproduces_interpolation_every_frame(overrides):
    fn, batch = zero_output_rollout("model.update_anchor=interpolation", *overrides)
    for length in LENGTHS:
        out = fn(batch, jnp.int32(length))
        rotations, roots = interpolation_of(batch, length)
        got = np.asarray(out["rotations"][:, :length + 2], np.float64)
        same = np.abs(np.sum(got * rotations, axis=-1))  # q and -q are one rotation
        np.testing.assert_allclose(same, 1.0, atol=2e-5)
        np.testing.assert_allclose(out["root_positions"][:, :length + 2], roots, atol=1e-3)  # cm
        # both keyframes exactly
        for frame in (0, length + 1):
            np.testing.assert_array_equal(out["rotations"][:, frame], batch["rotations"][:, frame])
            np.testing.assert_array_equal(out["root_positions"][:, frame], batch["root_positions"][:, frame])


def test_zero_update_relative_to_the_current_frame_does_not_interpolate():
    fn, batch = zero_output_rollout()  # the paper's update: a zero update holds each generator's keyframe
    out = fn(batch, jnp.int32(10))
    rotations, roots = interpolation_of(batch, 10)
    assert np.abs(np.asarray(out["root_positions"][:, 1:11]) - roots[:, 1:11]).max() > 1.0


def test_anchor_heads_for_the_keyframe_past_the_meeting_point():
    current = {"rotations": jnp.asarray([[1.0, 0.0, 0.0, 0.0]]), "root": jnp.asarray([0.0, 0.0, 0.0])}
    half_turn = R.quat_normalize(jnp.asarray([[0.0, 0.0, 1.0, 0.0]]))
    target = {"rotations": -half_turn, "root": jnp.asarray([10.0, 0.0, 0.0])}  # the long way round as given
    keyframe = {"rotations": half_turn, "root": jnp.asarray([40.0, 0.0, 0.0])}
    ahead = RO.interpolation_anchor(current, target, jnp.int32(5), keyframe, jnp.int32(8))
    np.testing.assert_allclose(ahead["root"], [2.0, 0.0, 0.0], atol=1e-6)
    past = RO.interpolation_anchor(current, target, jnp.int32(0), keyframe, jnp.int32(8))
    np.testing.assert_allclose(past["root"], [5.0, 0.0, 0.0], atol=1e-6)
    # a fifth of the way round (180 deg about y): 36 deg, the short way
    angle = float(np.degrees(2 * np.arccos(np.clip(abs(float(ahead["rotations"][0, 0])), 0, 1))))
    assert abs(angle - 36.0) < 1e-3
