"""The ablation switches of the model (paper section 5.3, Appendix D) on a tiny random model: w/o BS generates
forward only and leaves its last frame where it lands, w/o PM reads no phase, w/o LSTM has no recurrence."""
import jax
import jax.numpy as jnp
import numpy as np

from stitchjax import config as C
from stitchjax.data import phase as phase_lib
from stitchjax.data import features as F
from stitchjax.model import networks as N
from stitchjax.model import rollout as RO

J, CONTACTS = 22, 4


def tiny_config(*extra):
    return C.apply_overrides(C.load_config("tiny"), list(extra))


def keyframes(seed=0):
    """A start and a target keyframe 150 cm apart (random poses) and bone offsets, as rollout.rollout takes them."""
    rng = np.random.default_rng(seed)

    def pose(root):
        q = rng.normal(size=(J, 4))
        return {"rotations": jnp.asarray(q / np.linalg.norm(q, axis=-1, keepdims=True), jnp.float32),
                "root_position": jnp.asarray(root, jnp.float32),
                "contacts": jnp.asarray(rng.integers(0, 2, CONTACTS), jnp.float32)}

    offsets = rng.normal(size=(J, 3)) * 10.0
    return pose([0.0, 90.0, 0.0]), pose([150.0, 90.0, 0.0]), jnp.asarray(offsets, jnp.float32)


def rollout_of(config, length, seed=0):
    """(result, spec) of one transition of ``length`` frames by a random model of ``config`` (z from the prior)."""
    spec = RO.rollout_spec(config)
    key = jax.random.PRNGKey(seed)
    params = N.init_params(N.model_spec(config.model, config.data), key)
    phase_params = phase_lib.init_phase_params(jax.random.fold_in(key, 1),
                                               F.state_dim(config.data.num_joints), config.phase)
    start, target, offsets = keyframes(seed)
    result = RO.rollout(params, phase_params, (start, target, offsets), jax.random.PRNGKey(5), spec, length, length)
    return result, spec


def mean_joint_distance(a, b):
    return float(np.mean(np.linalg.norm(np.asarray(a) - np.asarray(b), axis=-1)))


def test_without_the_bidirectional_scheme_the_forward_generator_makes_every_frame_and_lands_its_last_anywhere():
    length = 6
    forward_only, _ = rollout_of(tiny_config("model.bidirectional=false"), length)
    assert "backward" not in forward_only and not bool(forward_only["overlap"]["mask"].any())
    assert int(forward_only["forward"]["mask"].sum()) == length  # frames 1..L, all forward
    # the transition's frames 1..L are the forward generator's own frames, unblended ...
    np.testing.assert_allclose(forward_only["global_positions"][1:length + 1],
                               forward_only["forward"]["global_positions"][:length], atol=1e-3)
    # ... frame L + 1 is the target keyframe, pinned, while the forward generator's last frame (frame L) is
    # wherever the L steps from the start put it: nothing moves it onto the target
    target_positions = forward_only["global_positions"][length + 1]
    last = forward_only["forward"]["global_positions"][length - 1]
    assert mean_joint_distance(last, target_positions) > 1.0  # cm, a random model far from the target
    # the bidirectional model makes frame L from the target keyframe: the backward generator's first frame
    both, _ = rollout_of(tiny_config(), length)
    np.testing.assert_allclose(both["global_positions"][length], both["backward"]["global_positions"][0], atol=1e-3)
    np.testing.assert_array_equal(both["global_positions"][length + 1], target_positions)


def _step(config, params, phase, carry=None, seed=3):
    """One generator step (prior, no ground truth) with the given phase features and carry."""
    spec = N.model_spec(config.model, config.data).generator
    dims = N.generator_input_dims(spec)
    rng = np.random.default_rng(seed)
    x = {name: jnp.asarray(rng.normal(size=(size,)), jnp.float32) for name, size in dims.items()}
    carry = N.initial_carry(spec) if carry is None else carry
    return N.make_generator(spec).apply(params, carry, x["state"], x["target"], x["offset"], jnp.float32(0.5),
                                        jnp.asarray(phase, jnp.float32), x["eps"])


def test_without_phase_modulation_the_decoder_is_an_mlp_and_reads_no_phase():
    phases = np.random.default_rng(0).normal(size=(2, 2 * CONTACTS))
    for switch, reads_phase in (("model.phase_modulation=true", True), ("model.phase_modulation=false", False)):
        config = tiny_config(switch)
        params = N.init_params(N.model_spec(config.model, config.data), jax.random.PRNGKey(0))["forward"]
        names = set(params["params"])
        if reads_phase:
            assert {"gating", "expert_0"} <= names and "decoder" not in names
        else:  # no gating network, no experts: one plain MLP
            assert "decoder" in names and not any(n == "gating" or n.startswith("expert_") for n in names)
        (_, first), (_, second) = (_step(config, params, phase) for phase in phases)
        moved = max(float(jnp.abs(first[k] - second[k]).max()) for k in ("velocity", "rotation_update"))
        assert (moved > 1e-6) == reads_phase, (switch, moved)
    # a whole transition does not depend on the phase network either: two different ones, the same motion
    config = tiny_config("model.phase_modulation=false")
    spec, params = RO.rollout_spec(config), N.init_params(N.model_spec(config.model, config.data), jax.random.PRNGKey(0))
    start, target, offsets = keyframes(0)
    state_dim = F.state_dim(config.data.num_joints)
    motions = [RO.rollout(params, phase_lib.init_phase_params(jax.random.PRNGKey(seed), state_dim, config.phase),
                          (start, target, offsets), jax.random.PRNGKey(5), spec, 6, 6)["global_positions"]
               for seed in (1, 2)]
    np.testing.assert_array_equal(motions[0], motions[1])


def test_without_the_lstm_the_embeddings_feed_the_heads_and_nothing_recurs():
    config = tiny_config("model.lstm=false")
    params = N.init_params(N.model_spec(config.model, config.data), jax.random.PRNGKey(0))["forward"]
    names = set(params["params"])
    assert "lstm" not in names and {"state_encoder", "offset_encoder", "target_encoder", "current_head"} <= names
    width = config.model.encoder_widths[-1]
    assert params["params"]["current_head"]["kernel"].shape[0] == 3 * width  # the three embeddings, concatenated
    spec = N.model_spec(config.model, config.data).generator
    other = jax.tree.map(lambda z: z + 1.0, N.initial_carry(spec))
    (carry_a, out_a), (carry_b, out_b) = _step(config, params, np.zeros(8)), _step(config, params, np.zeros(8), other)
    for name in ("velocity", "rotation_update", "mu", "logvar"):
        np.testing.assert_array_equal(out_a[name], out_b[name])  # the carry is not read ...
    for a, b in zip(carry_b, other):
        np.testing.assert_array_equal(a, b)  # ... and passes through unchanged
    with_lstm = tiny_config()
    lstm_params = N.init_params(N.model_spec(with_lstm.model, with_lstm.data), jax.random.PRNGKey(0))["forward"]
    (_, out_c), (_, out_d) = _step(with_lstm, lstm_params, np.zeros(8)), _step(with_lstm, lstm_params, np.zeros(8),
                                                                             other)
    assert float(jnp.abs(out_c["mu"] - out_d["mu"]).max()) > 1e-6  # with the LSTM the carry matters
    # a whole transition still ends exactly on both keyframes
    result, _ = rollout_of(config, 6)
    start, target, _ = keyframes(0)
    np.testing.assert_array_equal(result["rotations"][0], start["rotations"])
    np.testing.assert_array_equal(result["rotations"][7], target["rotations"])
