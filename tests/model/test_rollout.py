"""Rollout: keyframes exact, masks for several lengths with one compiled function, ablations, FK."""
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from stitchjax import config as C
from stitchjax.data import features as F
from stitchjax.accel import fast_rollout
from stitchjax.model import batch as BT
from stitchjax.model import networks as N
from stitchjax.model import rollout as RO
from stitchjax import skeleton as S


B, T, J = 2, 12, 22


def tiny_config(*extra):
    return C.apply_overrides(C.load_config("tiny"), list(extra))


def synthetic_batch(seed=0, batch=B, frames=T):
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(batch, frames, J, 4))
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    root = np.cumsum(rng.normal(size=(batch, frames, 3)) * 3.0, axis=1)
    offsets = rng.normal(size=(batch, 1, J, 3)) * 10.0
    offsets[:, :, 0] = 0
    _, gpos = S.forward_kinematics(q, F.local_positions(offsets, root), S.LAFAN1_PARENTS)
    arrays = {"rotations": q, "root_positions": root, "contacts": rng.integers(0, 2, (batch, frames, 4)),
              "offsets": offsets, "global_positions": gpos, "phase": rng.normal(size=(batch, frames, 8))}
    return {k: jnp.asarray(v, jnp.float32) for k, v in arrays.items()}


def phase_params_for(config):
    from stitchjax.data import phase

    return phase.init_phase_params(jax.random.PRNGKey(7), F.state_dim(config.data.num_joints),
                                   config.phase)


@pytest.fixture(scope="module")
def setup():
    config = tiny_config()
    params = N.init_params(N.model_spec(config.model, config.data), jax.random.PRNGKey(0))
    phase_params = phase_params_for(config)
    # z from the prior, as at inference (the posterior path is tested in test_posterior.py)
    spec = RO.rollout_spec(config)
    fn = jax.jit(lambda p, pp, b, k, length: BT.rollout_batch(p, pp, b, k, spec, length, posterior=False))
    return config, params, phase_params, synthetic_batch(), fn


def test_keyframes_exact_and_masks_for_several_lengths_one_compile(setup):
    config, params, phase_params, batch, fn = setup
    K = config.model.stitch_buffer
    for length in (1, 2, 5, 7, 10):
        out = fn(params, phase_params, batch, jax.random.PRNGKey(1), jnp.int32(length))
        assert out["rotations"].shape == (B, T, J, 4) and out["global_positions"].shape == (B, T, J, 3)
        np.testing.assert_array_equal(out["rotations"][:, 0], batch["rotations"][:, 0])
        np.testing.assert_array_equal(out["rotations"][:, length + 1], batch["rotations"][:, length + 1])
        np.testing.assert_array_equal(out["root_positions"][:, 0], batch["root_positions"][:, 0])
        np.testing.assert_array_equal(out["root_positions"][:, length + 1], batch["root_positions"][:, length + 1])
        np.testing.assert_array_equal(out["contacts"][:, length + 1], batch["contacts"][:, length + 1])
        h = length // 2
        k = min(K, h)
        np.testing.assert_array_equal(out["mask"].sum(1), length + 2)
        assert bool(out["mask"][:, length + 1].all()) and not bool(out["mask"][:, length + 2:].any())
        np.testing.assert_array_equal(out["forward"]["mask"].sum(1), h + k)
        np.testing.assert_array_equal(out["backward"]["mask"].sum(1), length - h + k)
        np.testing.assert_array_equal(out["overlap"]["mask"].sum(1), 2 * k)
        # generated frames are unit quaternions and differ from the keyframes
        norms = jnp.linalg.norm(out["rotations"], axis=-1)
        np.testing.assert_allclose(norms, 1.0, atol=1e-5)
        assert bool(jnp.isfinite(out["global_positions"]).all())
    assert fn._cache_size() == 1


def test_stitched_frames_come_from_the_right_direction(setup):
    config, params, phase_params, batch, fn = setup
    length = 10
    out = fn(params, phase_params, batch, jax.random.PRNGKey(1), jnp.int32(length))
    # frame 1 is the forward generator's first frame, frame L the backward generator's first frame
    np.testing.assert_allclose(out["rotations"][:, 1], out["forward"]["rotations"][:, 0], atol=1e-6)
    np.testing.assert_allclose(out["rotations"][:, length], out["backward"]["rotations"][:, 0], atol=1e-6)
    np.testing.assert_allclose(out["root_positions"][:, 1], out["forward"]["root_positions"][:, 0], atol=1e-4)
    # FK of the forward sequence matches its reported global positions
    _, gpos = S.forward_kinematics(np.asarray(out["forward"]["rotations"], np.float64),
                                   F.local_positions(np.asarray(batch["offsets"], np.float64),
                                                     np.asarray(out["forward"]["root_positions"], np.float64)),
                                   S.LAFAN1_PARENTS)
    np.testing.assert_allclose(out["forward"]["global_positions"], gpos, atol=1e-3)


def test_noise_gives_diverse_transitions(setup):
    config, params, phase_params, batch, fn = setup
    a = fn(params, phase_params, batch, jax.random.PRNGKey(1), jnp.int32(8))
    b = fn(params, phase_params, batch, jax.random.PRNGKey(2), jnp.int32(8))
    assert float(jnp.abs(a["rotations"][:, 1:9] - b["rotations"][:, 1:9]).max()) > 1e-4
    np.testing.assert_array_equal(a["rotations"][:, 9], b["rotations"][:, 9])


@pytest.mark.parametrize("switch", [
    "model.bidirectional=false", "model.latent_interpolation=false", "model.bidirectional_aligning=false",
    "model.phase_modulation=false"])
def test_each_ablation_runs_and_changes_the_output(setup, switch):
    config, params, phase_params, batch, fn = setup
    ablated = tiny_config(switch)
    if switch.startswith("model.phase_modulation"):
        params = N.init_params(N.model_spec(ablated.model, ablated.data), jax.random.PRNGKey(0))
    length = jnp.int32(8)
    full = fn(params if "phase" not in switch else N.init_params(N.model_spec(config.model, config.data), jax.random.PRNGKey(0)),
              phase_params, batch, jax.random.PRNGKey(1), length)
    out = jax.jit(lambda p, pp, b, k, n: BT.rollout_batch(p, pp, b, k, RO.rollout_spec(ablated), n))(
        params, phase_params, batch, jax.random.PRNGKey(1), length)
    np.testing.assert_array_equal(out["rotations"][:, 9], batch["rotations"][:, 9])
    np.testing.assert_array_equal(out["rotations"][:, 0], batch["rotations"][:, 0])
    assert float(jnp.abs(out["rotations"] - full["rotations"]).max()) > 1e-5
    if switch == "model.bidirectional=false":
        assert "backward" not in out and int(out["forward"]["mask"].sum(1)[0]) == 8
        assert not bool(out["overlap"]["mask"].any())


def test_keyframes_are_fed_as_poses_with_zero_root_velocity(setup):
    _, _, _, batch, _ = setup
    start = {"rotations": batch["rotations"][0, 0], "root_position": batch["root_positions"][0, 0],
             "contacts": batch["contacts"][0, 0]}
    target = {"rotations": batch["rotations"][0, 9], "root_position": batch["root_positions"][0, 9],
              "contacts": batch["contacts"][0, 9]}
    first, last = RO.keyframe_states(start, target)
    assert not np.any(np.asarray(first["velocity"])) and not np.any(np.asarray(last["velocity"]))
    np.testing.assert_array_equal(first["root"], start["root_position"])
    np.testing.assert_array_equal(last["rotations"], target["rotations"])


def test_phase_network_modulates_the_decoder(setup):
    config, params, phase_params, batch, fn = setup
    with_phase = fn(params, phase_params, batch, jax.random.PRNGKey(1), jnp.int32(6))
    zero = jax.tree.map(jnp.zeros_like, phase_params)  # zero phase features, same compiled function
    without = fn(params, zero, batch, jax.random.PRNGKey(1), jnp.int32(6))
    assert float(jnp.abs(with_phase["rotations"] - without["rotations"]).max()) > 1e-6


@pytest.mark.parametrize("extra", [(), ("model.bidirectional=false",), ("model.matmul_dtype=bfloat16",)])
def test_weight_gradients_after_scan_equal_per_step_gradients(setup, extra):
    _, params, phase_params, batch, _ = setup
    from stitchjax import specs
    from stitchjax.model import objective

    def gradients(flag):
        config = tiny_config(f"train.weight_gradients_after_scan={flag}", *extra)
        spec, rollout_batch = specs.train_spec(config), fast_rollout.training_rollout_batch(config.train)

        def loss(gen, pp, b):
            return objective.generator_loss({**params, **gen}, pp, b, jax.random.PRNGKey(3), spec, 7,
                                            rollout_batch=rollout_batch)[0]

        generators = {k: params[k] for k in ("forward", "backward")}
        return jax.jit(jax.value_and_grad(loss, argnums=(0, 1, 2)))(generators, phase_params, batch)

    (loss_a, grads_a), (loss_b, grads_b) = gradients(False), gradients(True)
    np.testing.assert_allclose(loss_a, loss_b, rtol=1e-6)
    lstm = grads_b[0]["forward"]["params"]["lstm"]["input_kernel"]
    assert np.any(np.asarray(lstm) != 0)  # kernel gradients are formed, not left at zero
    # bfloat16: both paths round the same output gradients, but an f32 ulp apart may round differently
    atol = 1e-3 if "model.matmul_dtype=bfloat16" in extra else 2e-5
    for a, b in zip(jax.tree.leaves(grads_a), jax.tree.leaves(grads_b)):
        scale = max(float(np.max(np.abs(a))), 1e-6)
        np.testing.assert_allclose(np.asarray(b) / scale, np.asarray(a) / scale, atol=atol)
    if "model.bidirectional=false" in extra:  # the unused backward generator gets zero gradients either way
        assert not any(np.any(np.asarray(g)) for g in jax.tree.leaves(grads_b[0]["backward"]))


@pytest.mark.parametrize("extra", [(), ("model.bidirectional=false", "model.phase_modulation=false"),
                                   ("model.posterior=none", "model.matmul_dtype=bfloat16")])
def test_taped_scan_gives_the_gradients_of_plain_autodiff(extra):
    """train.scan_remat=taped (record, then replay the tape) changes what the scan stacks, never the loss or
    any gradient (parameters, phase network, batch), against autodiff without after-scan kernel gradients."""
    from stitchjax import specs
    from stitchjax.model import objective

    batch = synthetic_batch()

    def gradients(*flags):
        config = tiny_config(*extra, *flags)
        spec, rollout_batch = specs.train_spec(config), fast_rollout.training_rollout_batch(config.train)
        params = N.init_params(N.model_spec(config.model, config.data), jax.random.PRNGKey(0))
        generators = {k: params[k] for k in ("forward", "backward")}

        def loss(gen, pp, b):
            return objective.generator_loss({**params, **gen}, pp, b, jax.random.PRNGKey(3), spec, 7,
                                            rollout_batch=rollout_batch)[0]

        return jax.jit(jax.value_and_grad(loss, argnums=(0, 1, 2)))(generators, phase_params_for(config), batch)

    (loss_a, grads_a), (loss_b, grads_b) = (gradients("train.weight_gradients_after_scan=false"),
                                            gradients("train.scan_remat=taped"))
    np.testing.assert_allclose(loss_b, loss_a, rtol=1e-6)
    assert np.any(np.asarray(grads_b[0]["forward"]["params"]["lstm"]["hidden_kernel"]) != 0)
    atol = 1e-3 if "model.matmul_dtype=bfloat16" in extra else 2e-5
    for a, b in zip(jax.tree.leaves(grads_a), jax.tree.leaves(grads_b)):
        scale = max(float(np.max(np.abs(a))), 1e-6)
        np.testing.assert_allclose(np.asarray(b) / scale, np.asarray(a) / scale, atol=atol)


def test_taped_scan_refuses_to_run_without_the_after_scan_gradients():
    config = tiny_config("train.scan_remat=taped", "train.weight_gradients_after_scan=false")
    params = N.init_params(N.model_spec(config.model, config.data), jax.random.PRNGKey(0))
    with pytest.raises(ValueError, match="scan_remat=taped needs train.weight_gradients_after_scan=true"):
        fast_rollout.training_rollout_batch(config.train)(params, phase_params_for(config), synthetic_batch(),
                                                          jax.random.PRNGKey(1), RO.rollout_spec(config), 7)


def test_recorded_values_are_stacked_once():
    """Recording, an activation that is also the next layer's matmul input comes out of the scan as one
    array, and the LSTM input's parts are the encoders' taped outputs themselves."""
    config = tiny_config()
    params = N.init_params(N.model_spec(config.model, config.data), jax.random.PRNGKey(0))
    batch = synthetic_batch()
    start, target, offsets = BT.keyframes_from_batch(batch, 7)
    one = jax.tree.map(lambda x: x[0], (start, target, offsets))
    from stitchjax.accel import probes

    _, records = RO.rollout(params, phase_params_for(config), one, jax.random.PRNGKey(1), RO.rollout_spec(config), 7,
                            10, hook=probes.RecordingHook(tape="record"))
    forward_inputs, forward_outputs = records["inputs"]["forward"], records["output_tape"]["forward"]
    assert forward_inputs["state_encoder"]["dense_1"]["kernel"] is forward_outputs["state_encoder"]["dense_0"]["output"]
    parts = forward_inputs["lstm"]["input_kernel"]
    assert isinstance(parts, tuple) and len(parts) == 3
    assert parts[1] is forward_outputs["offset_encoder"]["dense_2"]["output"]
    n = RO.num_steps(RO.rollout_spec(config), 10)
    assert parts[0].shape == (n, config.model.encoder_widths[-1])
    assert set(records["tape"]["forward"]["lstm"]) == {"cell_tanh"}


def test_scan_remat_keeps_the_loss_and_gradients(setup):
    """train.scan_remat changes only what the scan saves for the backward pass, never the gradients."""
    _, params, phase_params, batch, _ = setup
    from stitchjax import specs
    from stitchjax.model import objective

    assert set(fast_rollout.SCAN_REMAT) == set(C.CHOICES[("train", "scan_remat")])

    def gradients(remat):
        config = tiny_config(f"train.scan_remat={remat}")
        spec, rollout_batch = specs.train_spec(config), fast_rollout.training_rollout_batch(config.train)

        def loss(gen, b):
            return objective.generator_loss({**params, **gen}, phase_params, b, jax.random.PRNGKey(3), spec, 7,
                                            rollout_batch=rollout_batch)[0]

        generators = {k: params[k] for k in ("forward", "backward")}
        return jax.jit(jax.value_and_grad(loss, argnums=(0, 1)))(generators, batch)

    loss_a, grads_a = gradients("none")  # computed once, compared with each policy
    for policy in ("dots", "nothing"):
        loss_b, grads_b = gradients(policy)
        np.testing.assert_allclose(loss_b, loss_a, rtol=1e-6, err_msg=policy)
        for a, b in zip(jax.tree.leaves(grads_a), jax.tree.leaves(grads_b)):
            scale = max(float(np.max(np.abs(a))), 1e-6)
            np.testing.assert_allclose(np.asarray(b) / scale, np.asarray(a) / scale, atol=2e-5, err_msg=policy)
