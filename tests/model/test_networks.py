"""Networks: shapes, the expert blend, latent interpolation, ablation structure."""
import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from stitchjax import config as C
from stitchjax.model import layers
from stitchjax.model import networks as N
from stitchjax.accel import matmul as accel_matmul
from stitchjax.accel import probes
from stitchjax.accel import tape




def tiny_config(*extra):
    return C.apply_overrides(C.load_config("tiny"), list(extra))


def _model_spec(config):
    return N.model_spec(config.model, config.data)


def test_init_params_and_generator_shapes():
    config = tiny_config()
    params = N.init_params(N.model_spec(config.model, config.data), jax.random.PRNGKey(0))
    assert set(params) == {"forward", "backward", "disc_short", "disc_long"}
    kernel = params["forward"]["params"]["current_head"]["kernel"]
    assert not np.allclose(kernel, params["backward"]["params"]["current_head"]["kernel"])  # independent
    dims = N.generator_input_dims(N.model_spec(config.model, config.data).generator)
    assert dims["state"] == 22 * 4 + 7 and dims["offset"] == 22 * 4 + 3 + 1 and dims["phase"] == 8
    b = 3
    inputs = [jnp.ones((b, dims[k])) for k in ("state", "target", "offset")]
    carry = jax.tree.map(lambda x: jnp.zeros((b,) + x.shape), N.initial_carry(N.model_spec(config.model, config.data).generator))
    generator = N.make_generator(N.model_spec(config.model, config.data).generator)
    apply = jax.jit(jax.vmap(generator.apply, in_axes=(None, 0, 0, 0, 0, 0, 0, 0)))
    new_carry, out = apply(params["forward"], carry, *inputs, jnp.full((b,), 0.5), jnp.ones((b, 8)), jnp.ones((b, 4)))
    assert new_carry[0].shape == (b, 16) and new_carry[1].shape == (b, 16)
    assert out["velocity"].shape == (b, 3) and out["rotation_update"].shape == (b, 88)
    assert out["contact_logits"].shape == (b, 4)
    for key in ("mu", "logvar", "mu_target", "logvar_target", "mu_blend", "logvar_blend"):
        assert out[key].shape == (b, 4)
    # eval_shape-friendly init gives the same structure
    abstract = jax.eval_shape(lambda k: N.init_params(N.model_spec(config.model, config.data), k), jax.random.PRNGKey(0))
    assert jax.tree.structure(abstract) == jax.tree.structure(params)


def test_discriminator_scores_one_per_window_position():
    config = tiny_config("model.disc_long_window=10")  # the paper's 2- and 10-frame windows
    params = N.init_params(N.model_spec(config.model, config.data), jax.random.PRNGKey(0))
    feats = jnp.ones((2, 12, N.disc_feature_dim(config.data.num_joints)))
    short = N.make_discriminator(N.model_spec(config.model, config.data).discriminators, "disc_short").apply(params["disc_short"], feats)
    long = N.make_discriminator(N.model_spec(config.model, config.data).discriminators, "disc_long").apply(params["disc_long"], feats)
    assert short.shape == (2, 11) and long.shape == (2, 3)


def test_moe_einsum_equals_blended_weights():
    layer = layers.MoEDense(features=5, num_experts=4)
    x = jax.random.normal(jax.random.PRNGKey(1), (3, 6))
    coefficients = jax.nn.softmax(jax.random.normal(jax.random.PRNGKey(2), (3, 4)))
    params = jax.jit(layer.init)(jax.random.PRNGKey(0), x, coefficients)
    params = jax.tree.map(lambda p: p + 0.1 * jax.random.normal(jax.random.PRNGKey(3), p.shape), params)
    got = jax.jit(layer.apply)(params, x, coefficients)
    kernel, bias = params["params"]["kernel"], params["params"]["bias"]
    explicit = []
    for i in range(3):
        w = sum(coefficients[i, e] * kernel[:, e] for e in range(4))
        bb = sum(coefficients[i, e] * bias[e] for e in range(4))
        explicit.append(x[i] @ w + bb)
    np.testing.assert_allclose(got, np.stack(explicit), rtol=1e-5, atol=1e-5)


def test_blend_gaussians_endpoints_and_midpoint():
    mu, logvar = jnp.array([1.0, -2.0]), jnp.log(jnp.array([4.0, 0.25]))
    mu_t, logvar_t = jnp.array([3.0, 0.0]), jnp.log(jnp.array([1.0, 1.0]))
    m0, v0 = N.blend_gaussians(mu, logvar, mu_t, logvar_t, 0.0)
    m1, v1 = N.blend_gaussians(mu, logvar, mu_t, logvar_t, 1.0)
    np.testing.assert_allclose(m0, mu, rtol=1e-6)
    np.testing.assert_allclose(v0, logvar, rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(m1, mu_t, rtol=1e-6)
    np.testing.assert_allclose(v1, logvar_t, rtol=1e-5, atol=1e-6)
    m, v = N.blend_gaussians(mu, logvar, mu_t, logvar_t, 0.5)
    np.testing.assert_allclose(m, [2.0, -1.0], rtol=1e-6)
    np.testing.assert_allclose(jnp.exp(0.5 * v), [1.5, 0.75], rtol=1e-5)  # the standard deviations blend


def test_plain_decoder_without_phase_modulation():
    with_phase = N.init_params(_model_spec(tiny_config()), jax.random.PRNGKey(0))["forward"]["params"]
    plain_spec = _model_spec(tiny_config("model.phase_modulation=false"))
    plain = N.init_params(plain_spec, jax.random.PRNGKey(0))["forward"]["params"]
    assert "gating" in with_phase and "expert_0" in with_phase and "decoder" not in with_phase
    assert "gating" not in plain and "expert_0" not in plain and "decoder" in plain


def test_lstm_cell_matches_the_lstm_equations():
    cell = layers.LSTMCell(features=3)
    x = jax.random.normal(jax.random.PRNGKey(1), (2, 5))
    carry = (jax.random.normal(jax.random.PRNGKey(2), (2, 3)), jax.random.normal(jax.random.PRNGKey(3), (2, 3)))
    params = cell.init(jax.random.PRNGKey(0), carry, x)
    p = jax.tree.map(lambda a: a + 0.1, params["params"])  # non-zero bias too
    (c, h), out = cell.apply({"params": p}, carry, x)

    def sigmoid(v):
        return 1.0 / (1.0 + np.exp(-v))

    gates = np.asarray(x) @ p["input_kernel"] + np.asarray(carry[1]) @ p["hidden_kernel"] + p["bias"]
    i, f, g, o = np.split(np.asarray(gates), 4, axis=-1)  # gate order i, f, g, o (as torch.nn.LSTMCell)
    c_ref = sigmoid(f) * np.asarray(carry[0]) + sigmoid(i) * np.tanh(g)
    np.testing.assert_allclose(c, c_ref, rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(h, sigmoid(o) * np.tanh(c_ref), rtol=1e-5, atol=1e-6)
    np.testing.assert_array_equal(out, h)
    hidden = np.asarray(params["params"]["hidden_kernel"])  # each gate's block starts orthogonal
    for block in np.split(hidden, 4, axis=1):
        np.testing.assert_allclose(block.T @ block, np.eye(3), atol=1e-5)


def test_kernel_matmul_probe_gradient_is_the_output_gradient():
    layer = probes.ProbedDense(features=4)
    x = jax.random.normal(jax.random.PRNGKey(1), (6, 3))
    params = layer.init(jax.random.PRNGKey(0), x)

    def loss(params, probe):
        y, recorded = layer.apply({**params, "probes": {"kernel": probe}}, x, mutable=["inputs"])
        return jnp.sum(jnp.sin(y)), recorded["inputs"]["kernel"]

    (value, inputs), (g_params, g_probe) = jax.value_and_grad(loss, argnums=(0, 1), has_aux=True)(
        params, jnp.zeros((6, 4)))
    plain, g_plain = jax.value_and_grad(lambda p: jnp.sum(jnp.sin(layer.apply(p, x))))(params)
    np.testing.assert_allclose(value, plain, rtol=1e-6)
    np.testing.assert_array_equal(inputs, x)
    assert not np.any(g_params["params"]["kernel"])  # held constant under probing
    np.testing.assert_allclose(g_params["params"]["bias"], g_plain["params"]["bias"], rtol=1e-5)
    np.testing.assert_allclose(np.asarray(x).T @ np.asarray(g_probe), g_plain["params"]["kernel"], rtol=1e-5,
                               atol=1e-6)


def test_tape_point_records_then_replays_with_the_derivative_and_the_output_gradient():
    """A Dense layer's output tape point: recording stores elu(x W + b); replaying returns the taped value
    (whatever x is), differentiates as elu would at the recorded point, and hands the pre-activation's
    gradient back as the tape's cotangent (the kernel's output gradient dy)."""
    layer = probes.ProbedDense(features=4, activation="elu")
    x = jax.random.normal(jax.random.PRNGKey(1), (6, 3))
    params = layer.init(jax.random.PRNGKey(0), x)
    assert set(params) == {"params"}  # initialising records nothing
    y, records = layer.apply(params, x, mutable=["inputs", "tape", "output_tape"])
    np.testing.assert_array_equal(records["output_tape"]["output"], y)
    np.testing.assert_array_equal(records["inputs"]["kernel"], x)
    taped = records["output_tape"]["output"]

    def replayed(x, t):
        return jnp.sum(jnp.sin(layer.apply({**params, "output_tape": {"output": t}}, x)))

    def plain(x, params):
        return jnp.sum(jnp.sin(layer.apply(params, x)))

    other = x + 1.0  # replaying ignores x's value: the taped y comes back
    np.testing.assert_allclose(replayed(other, taped), plain(x, params), rtol=1e-6)
    dx, d_tape = jax.grad(replayed, argnums=(0, 1))(x, taped)
    dx_plain, d_params = jax.grad(plain, argnums=(0, 1))(x, params)
    np.testing.assert_allclose(dx, dx_plain, rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(np.asarray(x).T @ np.asarray(d_tape), d_params["params"]["kernel"], rtol=1e-5,
                               atol=1e-6)
    np.testing.assert_allclose(np.sum(np.asarray(d_tape), axis=0), d_params["params"]["bias"], rtol=1e-5,
                               atol=1e-6)


@pytest.mark.parametrize("kind", ["elu", "identity", "sigmoid", "tanh", "softmax"])
def test_tape_derivatives_match_autodiff(kind):
    fns = {"elu": accel_matmul.elu, "identity": lambda v: v, "sigmoid": jax.nn.sigmoid, "tanh": jnp.tanh,
           "softmax": lambda v: jax.nn.softmax(v, axis=-1)}
    assert set(fns) == set(tape.DERIVATIVES)
    x = jax.random.normal(jax.random.PRNGKey(2), (5, 7)) * 2.0
    dy = jax.random.normal(jax.random.PRNGKey(3), (5, 7))
    y, vjp = jax.vjp(fns[kind], x)
    np.testing.assert_allclose(tape.DERIVATIVES[kind](y, dy), vjp(dy)[0], rtol=1e-5, atol=1e-6)


def test_bfloat16_matmul_rounds_only_the_operands_forward_and_backward():
    x = jax.random.normal(jax.random.PRNGKey(1), (2, 5, 48))
    kernel = jax.random.normal(jax.random.PRNGKey(2), (48, 24))
    as_bf16 = lambda a: np.asarray(jnp.asarray(a).astype(jnp.bfloat16).astype(jnp.float32), np.float64)  # noqa: E731
    y = accel_matmul.matmul(x, kernel, "bfloat16")
    assert y.dtype == jnp.float32
    np.testing.assert_allclose(y, as_bf16(x) @ as_bf16(kernel), rtol=1e-5, atol=1e-4)
    assert np.abs(np.asarray(y) - np.asarray(accel_matmul.matmul(x, kernel))).max() > 1e-3  # really rounded

    def loss(x, kernel, dtype):
        return jnp.sum(jnp.sin(accel_matmul.matmul(x, kernel, dtype)))

    dx, dkernel = jax.grad(loss, argnums=(0, 1))(x, kernel, "bfloat16")
    assert dx.dtype == jnp.float32 and dkernel.dtype == jnp.float32
    dy = as_bf16(np.cos(np.asarray(y)))
    # tolerance: an output gradient an ulp away from a bfloat16 rounding boundary may round the other way
    expected_dx, expected_dkernel = dy @ as_bf16(kernel).T, np.einsum("bti,bto->io", as_bf16(x), dy)
    np.testing.assert_allclose(dx, expected_dx, atol=0.01 * np.abs(expected_dx).max())
    np.testing.assert_allclose(dkernel, expected_dkernel, atol=0.01 * np.abs(expected_dkernel).max())
    dx32, dkernel32 = jax.grad(loss, argnums=(0, 1))(x, kernel, "float32")
    np.testing.assert_allclose(dkernel, dkernel32, atol=0.05 * float(np.abs(dkernel32).max()))
    with pytest.raises(ValueError, match="matmul_dtype='float16'"):
        accel_matmul.matmul(x, kernel, "float16")


def test_generator_matmul_dtype_keeps_parameters_and_changes_outputs_slightly():
    config = tiny_config()
    low = tiny_config("model.matmul_dtype=bfloat16")
    params = N.init_params(N.model_spec(config.model, config.data), jax.random.PRNGKey(0))
    low_params = N.init_params(N.model_spec(low.model, low.data), jax.random.PRNGKey(0))
    assert jax.tree.structure(params) == jax.tree.structure(low_params)
    for a, b in zip(jax.tree.leaves(params), jax.tree.leaves(low_params)):
        assert a.dtype == b.dtype == jnp.float32
        np.testing.assert_array_equal(a, b)
    dims = N.generator_input_dims(N.model_spec(config.model, config.data).generator)
    rng = np.random.default_rng(0)
    inputs = [jnp.asarray(rng.normal(size=(3, dims[k])), jnp.float32) for k in ("state", "target", "offset")]
    carry = jax.tree.map(lambda z: jnp.zeros((3,) + z.shape), N.initial_carry(N.model_spec(config.model, config.data).generator))
    args = (carry, *inputs, jnp.full((3,), 0.5), jnp.asarray(rng.normal(size=(3, dims["phase"])), jnp.float32),
            jnp.asarray(rng.normal(size=(3, dims["eps"])), jnp.float32))
    def generator(c):  # on accel's layers, which honour model.matmul_dtype
        return N.make_generator(dataclasses.replace(N.model_spec(c.model, c.data).generator, layers=accel_matmul.LAYERS))

    _, out = jax.vmap(lambda *a: generator(config).apply(params["forward"], *a))(*args)
    _, out_low = jax.vmap(lambda *a: generator(low).apply(params["forward"], *a))(*args)
    for key in ("rotation_update", "mu"):
        assert out_low[key].dtype == jnp.float32
        difference = np.abs(np.asarray(out_low[key]) - np.asarray(out[key]))
        assert 0 < difference.max() < 0.05 * np.abs(np.asarray(out[key])).max() + 1e-3


def test_elu_has_flax_values_and_gradients_formed_from_its_output():
    import flax.linen as nn

    x = jnp.concatenate([jnp.linspace(-8.0, 8.0, 101), jnp.zeros(1)])
    np.testing.assert_array_equal(layers.elu(x), nn.elu(x))  # the model's plain ELU
    np.testing.assert_array_equal(accel_matmul.elu(x), nn.elu(x))
    ours = jax.grad(lambda v: jnp.sum(jnp.sin(accel_matmul.elu(v))))(x)
    flax_ = jax.grad(lambda v: jnp.sum(jnp.sin(nn.elu(v))))(x)
    np.testing.assert_allclose(ours, flax_, rtol=1e-6, atol=1e-7)
    slopes = jax.vmap(jax.grad(accel_matmul.elu))(x)  # 1 for x >= 0 here (x = 0 included, as nn.elu), exp(x) below
    np.testing.assert_allclose(slopes, np.where(np.asarray(x) > 0, 1.0, np.exp(np.asarray(x))), rtol=1e-6,
                               atol=1e-7)  # y + 1 for y near -1: absolute rounding of float32
    np.testing.assert_allclose(jax.jvp(accel_matmul.elu, (x,), (jnp.ones_like(x),))[1], slopes, rtol=1e-6)  # forward mode


@pytest.mark.parametrize("extra", [(), ("model.phase_modulation=false",), ("model.matmul_dtype=bfloat16",)])
def test_probed_generator_has_the_plain_generators_parameters_and_values(extra):
    """The training step's probed layers (stitchjax.accel.probes) change nothing a reader of the model sees:
    the same parameter tree from the same key, and bit-identical outputs without probes or tape."""
    spec = _model_spec(tiny_config(*extra)).generator
    dims = N.generator_input_dims(spec)
    args = (N.initial_carry(spec),) + tuple(
        jax.random.normal(jax.random.PRNGKey(i), (dims[k],)) for i, k in enumerate(("state", "target", "offset")))
    args += (jnp.float32(0.3), jnp.ones((dims["phase"],)), jnp.ones((dims["eps"],)), args[1] * 0.5)
    plain = N.make_generator(dataclasses.replace(spec, layers=accel_matmul.LAYERS))
    probed = probes.probed_generator(spec)
    params = plain.init(jax.random.PRNGKey(0), *args)
    probed_params = probed.init(jax.random.PRNGKey(0), *args)
    assert jax.tree.structure(params) == jax.tree.structure(probed_params)
    for a, b in zip(jax.tree.leaves(params), jax.tree.leaves(probed_params)):
        np.testing.assert_array_equal(a, b)
    for a, b in zip(jax.tree.leaves(jax.jit(plain.apply)(params, *args)),
                    jax.tree.leaves(jax.jit(probed.apply)(params, *args))):
        np.testing.assert_array_equal(a, b)


def test_bfloat16_generator_needs_accel_layers_and_init_does_not():
    config = C.apply_overrides(C.load_config("tiny"), ["model.matmul_dtype=bfloat16"])
    spec = N.model_spec(config.model, config.data).generator
    with pytest.raises(ValueError, match="accel.matmul"):
        N.make_generator(spec)  # the plain layers would silently compute in float32
    assert isinstance(N.make_generator(dataclasses.replace(spec, layers=accel_matmul.LAYERS)), N.Generator)
    fresh = N.init_params(N.model_spec(config.model, config.data), jax.random.PRNGKey(0))
    plain = N.init_params(_model_spec(C.load_config("tiny")), jax.random.PRNGKey(0))
    assert jax.tree.all(jax.tree.map(lambda a, b: bool(jnp.array_equal(a, b)), fresh, plain))
