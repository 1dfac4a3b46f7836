"""Training: the jitted step, overfitting, resume, data parallelism, NaN guard, signals, the CLI."""
import dataclasses
import functools
import json
import os
import pathlib
import signal
import subprocess
import sys

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from stitchjax import checkpoints, config as config_lib, parallel, specs
from stitchjax.data import datasets
from stitchjax.train import resume, schedule, loop as train

from bin_scripts import load_cli

REPO = pathlib.Path(__file__).resolve().parents[2]
FRAMES = 10  # tiny windows: transitions of up to 8 frames

def tiny_config(*extra):
    return config_lib.apply_overrides(config_lib.load_config("tiny"), list(extra))


@pytest.fixture(scope="module")
def dataset():
    """The bundled sample's training windows cut to FRAMES frames (a few dozen windows)."""
    data, stats = datasets.load_training_data(tiny_config().data, None)
    return {name: (x[:24, :FRAMES] if x.shape[1] > 1 else x[:24]) for name, x in data.items()}, stats


def _device_data(data, mesh):
    return parallel.shard_dataset(data, mesh)


def test_schedule_and_buckets():
    tc = tiny_config("train.min_length=5", "train.max_length=48", "train.epochs_per_length=2").train
    assert [schedule.transition_length(s, 10, tc) for s in (0, 19, 20, 39, 40, 10_000)] == [5, 5, 6, 6, 7, 48]
    assert schedule.steps_per_epoch(100, 32) == 3
    assert schedule.bucket_window(7, tc) is None
    tb = tiny_config("train.length_buckets=10,30,48").train
    assert [schedule.bucket_window(n, tb) for n in (5, 10, 11, 48)] == [12, 12, 32, 50]


def test_uniform_lengths_after_schedule():
    tc = tiny_config("train.min_length=5", "train.max_length=48", "train.epochs_per_length=2",
                     "train.length_after_schedule=uniform").train
    # the progressive part is unchanged; after it, each step draws its own length, the same on every call
    assert [schedule.transition_length(s, 10, tc) for s in (0, 19, 20, 39, 40)] == [5, 5, 6, 6, 7]
    drawn = [schedule.transition_length(s, 10, tc) for s in range(860, 3860)]
    assert drawn == [schedule.transition_length(s, 10, tc) for s in range(860, 3860)]
    assert min(drawn) == 5 and max(drawn) == 48 and len(set(drawn)) == 44
    assert abs(sum(drawn) / len(drawn) - (5 + 48) / 2) < 1.0
    reseeded = dataclasses.replace(tc, seed=1)
    assert drawn != [schedule.transition_length(s, 10, reseeded) for s in range(860, 3860)]
    with pytest.raises(ValueError, match="length_after_schedule"):
        tiny_config("train.length_after_schedule=random")


@pytest.mark.parametrize("extra", [(), ("model.matmul_dtype=bfloat16",)])
def test_one_step_changes_every_parameter_group(dataset, extra):
    data, _ = dataset
    config = tiny_config(*extra)
    mesh = parallel.make_mesh()
    state = train.create_train_state(specs.train_spec(config), jax.random.PRNGKey(0), None, mesh)
    before = jax.device_get(state.params)
    phase_before = jax.device_get(state.phase_params)
    step = train.make_train_step(specs.train_spec(config), mesh)
    state, metrics = step(state, _device_data(data, mesh), jnp.int32(6))
    metrics = jax.device_get(metrics)
    assert int(state.step) == 1
    assert {"loss", "disc_loss", "length"} <= set(metrics) and len(metrics) > 5
    assert all(np.isfinite(v) for v in metrics.values()), metrics
    assert int(metrics["length"]) == 6
    after = jax.device_get(state.params)
    for group in train.GENERATORS + train.DISCRIMINATORS:
        changed = [not np.array_equal(a, b) for a, b in zip(jax.tree.leaves(before[group]), jax.tree.leaves(after[group]))]
        assert any(changed), f"no parameter of {group} changed"
        assert all(a.dtype == np.float32 for a in jax.tree.leaves(after[group]))  # any matmul_dtype
    for a, b in zip(jax.tree.leaves(phase_before), jax.tree.leaves(jax.device_get(state.phase_params))):
        np.testing.assert_array_equal(a, b)  # the phase network stays frozen


def test_tiny_model_overfits_one_batch(dataset):
    data, _ = dataset
    config = tiny_config()  # the same compiled program as the other tests
    one_batch = {name: x[:4] for name, x in data.items()}
    mesh = parallel.make_mesh()
    state = train.create_train_state(specs.train_spec(config), jax.random.PRNGKey(1), None, mesh)
    step = train.make_train_step(specs.train_spec(config), mesh)
    device_data = _device_data(one_batch, mesh)
    losses = []
    for _ in range(300):
        state, metrics = step(state, device_data, jnp.int32(8))
        losses.append(float(metrics["loss"]))
    first, last = np.mean(losses[:5]), np.mean(losses[-20:])  # the adversarial terms keep the end noisy
    assert np.isfinite(last) and last < first / 4, (first, last)


def _params(workdir):
    config = tiny_config()
    manager = checkpoints.open_manager(workdir)
    state, _, extras = checkpoints.restore(manager, train.abstract_train_state(specs.train_spec(config)))
    checkpoints.close(manager)
    return jax.device_get(state), extras


def test_resume_equals_one_run_and_writes_report(dataset, tmp_path):
    data, stats = dataset
    config = tiny_config()
    kwargs = dict(prepared=(data, stats), progress=False)
    train.train(config, tmp_path / "split", max_steps=3, **kwargs)
    summary = train.train(config, tmp_path / "split", max_steps=6, **kwargs)
    assert summary["start_step"] == 3 and summary["step"] == 6
    train.train(config, tmp_path / "whole", max_steps=6, **kwargs)
    split, extras = _params(tmp_path / "split")
    whole, _ = _params(tmp_path / "whole")
    assert int(split.step) == int(whole.step) == 6
    for a, b in zip(jax.tree.leaves(split), jax.tree.leaves(whole)):
        np.testing.assert_allclose(a, b, rtol=1e-5, atol=1e-6)
    assert len(extras["stats"]["mean"]) == 66
    records = [json.loads(line) for line in (tmp_path / "split" / "metrics.jsonl").read_text().splitlines()]
    assert [r["step"] for r in records] == [1, 2, 3, 4, 5, 6]
    assert {"loss", "length", "windows_per_s"} <= set(records[-1])
    assert (tmp_path / "split" / "report.md").read_text().startswith("# Training report")
    assert (tmp_path / "split" / "loss_curves.png").stat().st_size > 1000


def test_resume_refuses_a_different_model_config(dataset, tmp_path):
    data, stats = dataset
    manager = checkpoints.open_manager(tmp_path)
    checkpoints.save(manager, 5, {"step": jnp.int32(5)}, config_lib.to_dict(tiny_config()))
    checkpoints.close(manager)
    with pytest.raises(train.TrainingError, match="model config differs"):
        train.train(tiny_config("model.latent_dim=8"), tmp_path, max_steps=6, prepared=(data, stats),
                    progress=False)



def test_init_from_starts_a_new_run_from_another_runs_state(dataset, tmp_path):
    data, stats = dataset
    kwargs = dict(prepared=(data, stats), progress=False)
    train.train(tiny_config(), tmp_path / "base", max_steps=3, **kwargs)
    base, _ = _params(tmp_path / "base")
    with pytest.raises(train.TrainingError, match="model config differs"):
        train.train(tiny_config("model.latent_dim=8"), tmp_path / "bad", max_steps=4,
                    init_from=tmp_path / "base", **kwargs)
    copy = train.train(tiny_config(), tmp_path / "copy", max_steps=4, init_from=tmp_path / "base", **kwargs)
    train.train(tiny_config(), tmp_path / "base", max_steps=4, **kwargs)  # the base run resumed to step 4
    assert copy["start_step"] == 3
    for a, b in zip(jax.tree.leaves(_params(tmp_path / "copy")[0]), jax.tree.leaves(_params(tmp_path / "base")[0])):
        np.testing.assert_allclose(a, b, rtol=1e-5, atol=1e-6)  # the same state, key and optimiser moments
    tuned_config = tiny_config("loss.kl_weight=0.5")  # a loss change: allowed when fine-tuning
    summary = train.train(tuned_config, tmp_path / "tuned", max_steps=4, init_from=tmp_path / "base", **kwargs)
    assert summary["start_step"] == 4 and summary["step"] == 4
    manager = checkpoints.open_manager(tmp_path / "tuned")
    _, saved_config, _ = checkpoints.restore(manager, train.abstract_train_state(specs.train_spec(tuned_config)))
    checkpoints.close(manager)
    assert saved_config["loss"]["kl_weight"] == 0.5
    assert train.train(tuned_config, tmp_path / "tuned", max_steps=5, **kwargs)["start_step"] == 4  # resumes
    abstract = train.abstract_train_state(specs.train_spec(tiny_config()))
    same = resume.state_from_run(config_lib.to_dict(tiny_config()), tmp_path / "base", abstract)
    other = resume.state_from_run(config_lib.to_dict(tiny_config("train.seed=1")), tmp_path / "base", abstract)
    assert int(other.step) == int(same.step) == 4  # a new seed: the same state but the key
    np.testing.assert_array_equal(other.key, jax.random.fold_in(same.key, 1))
    assert not np.array_equal(other.key, same.key)


def test_dataset_registry_has_every_allowed_name_and_its_facts():
    assert datasets.names() == config_lib.CHOICES[("data", "dataset")]
    lafan = datasets.skeleton_facts(None, tiny_config().data)
    assert lafan["feet_names"] == ["LeftFoot", "LeftToe", "RightFoot", "RightToe"]
    h36m = datasets.get("h36m")
    assert [h36m.joint_names[j] for j in h36m.feet] == ["LeftFoot", "LeftToeBase", "RightFoot", "RightToeBase"]
    assert datasets.skeleton_facts(None, config_lib.DataConfig(dataset="bvh_folder")) is None  # read from files
    with pytest.raises(FileNotFoundError, match="needs --data"):
        datasets.get("h36m").data_dir(None)
    with pytest.raises(ValueError, match="expected one of lafan1, h36m, bvh_folder"):
        datasets.get("cmu")

def test_nan_guard_names_the_term_and_keeps_last_good_checkpoint(dataset, tmp_path):
    data, stats = dataset
    config = tiny_config("train.checkpoint_every_steps=1")
    real_step = train.make_train_step(specs.train_spec(config))

    def poisoned_step(state, device_data, length):
        state, metrics = real_step(state, device_data, length)
        if int(state.step) == 3:
            metrics = {**metrics, "kl": jnp.float32(np.nan)}
        return state, metrics

    with pytest.raises(train.NonFiniteLossError, match=r"'kl' is nan at step 3.*step 2"):
        train.train(config, tmp_path, max_steps=5, prepared=(data, stats), progress=False,
                    train_step=poisoned_step)
    assert sorted(int(p.name) for p in checkpoints.checkpoint_dir(tmp_path).iterdir()) == [1, 2]


def test_sigterm_saves_current_step_and_stops(dataset, tmp_path):
    data, stats = dataset
    config = tiny_config()
    real_step = train.make_train_step(specs.train_spec(config))

    def step_then_sigterm(state, device_data, length):
        state, metrics = real_step(state, device_data, length)
        if int(state.step) == 2:
            os.kill(os.getpid(), signal.SIGTERM)
        return state, metrics

    summary = train.train(config, tmp_path, max_steps=50, prepared=(data, stats), progress=False,
                          train_step=step_then_sigterm)
    assert summary["stop_reason"] == "SIGTERM received" and summary["step"] == 2
    assert [p.name for p in checkpoints.checkpoint_dir(tmp_path).iterdir()] == ["2"]


DATA_PARALLEL_SCRIPT = """
import jax, jax.numpy as jnp, numpy as np, sys
sys.path.insert(0, {repo!r})
from stitchjax import config as config_lib, parallel
from stitchjax import specs
from stitchjax.train import loop as train
assert jax.device_count() == 4, jax.devices()
config = config_lib.load_config("tiny")
data = dict(np.load({data!r}))
mesh = parallel.make_mesh()
initial = np.load({initial!r})  # the main process's initial state (saves compiling the init again)
abstract = train.abstract_train_state(specs.train_spec(config), mesh)
leaves, treedef = jax.tree.flatten(abstract)
state = jax.tree.unflatten(treedef, [jax.device_put(initial[f"arr_{{i}}"], x.sharding) for i, x in enumerate(leaves)])
step = train.make_train_step(specs.train_spec(config), mesh)
device_data = parallel.shard_dataset(data, mesh)
for _ in range(2):
    state, metrics = step(state, device_data, jnp.int32(6))
batch = step.sample(device_data, state.key, state.step)
assert [s.data.shape[0] for s in batch["rotations"].addressable_shards] == [1, 1, 1, 1]  # batch split 4 ways
leaves = jax.device_get(jax.tree.leaves(state.params))
np.savez({out!r}, loss=np.asarray(metrics["loss"]), *leaves)
"""


def test_data_parallel_step_matches_single_device(dataset, tmp_path):
    data, _ = dataset
    np.savez(tmp_path / "data.npz", **data)
    config = tiny_config()
    mesh = parallel.make_mesh()
    state = train.create_train_state(specs.train_spec(config), jax.random.PRNGKey(0), None, mesh)
    np.savez(tmp_path / "initial.npz", *jax.device_get(jax.tree.leaves(state)))
    step = train.make_train_step(specs.train_spec(config), mesh)
    device_data = parallel.shard_dataset(data, mesh)
    for _ in range(2):
        state, metrics = step(state, device_data, jnp.int32(6))
    env = {**os.environ, "XLA_FLAGS": "--xla_force_host_platform_device_count=4", "JAX_PLATFORMS": "cpu"}
    script = DATA_PARALLEL_SCRIPT.format(repo=str(REPO), data=str(tmp_path / "data.npz"),
                                         initial=str(tmp_path / "initial.npz"), out=str(tmp_path / "out.npz"))
    result = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stderr[-3000:]
    out = np.load(tmp_path / "out.npz")
    np.testing.assert_allclose(out["loss"], metrics["loss"], rtol=1e-4)
    leaves = jax.device_get(jax.tree.leaves(state.params))
    for i, leaf in enumerate(leaves):  # 4 devices sum gradients in another order: float32 round-off only
        np.testing.assert_allclose(out[f"arr_{i}"], leaf, rtol=2e-4, atol=2e-5)


def test_cli_help_and_bad_arguments(tmp_path, capsys):
    cli = [sys.executable, str(REPO / "bin" / "train")]
    help_run = subprocess.run(cli + ["--help"], capture_output=True, text=True, timeout=60)
    assert help_run.returncode == 0 and "--workdir" in help_run.stdout and "--max-steps" in help_run.stdout
    main = load_cli("train").main  # the argument checks in this process: no interpreter or jax start-up

    def bad(*args):
        with pytest.raises(SystemExit) as exit_:
            main(["--workdir", str(tmp_path), *args])
        return exit_.value.code, capsys.readouterr().err

    code, err = bad("--config", "no_such_config")
    assert code == 2 and "no config named 'no_such_config'" in err
    code, err = bad("--config", "quickstart", "model.nope=1")
    assert code == 2 and "no field 'nope'" in err


def test_validation_during_training_logs_model_and_interpolation_rows(dataset, tmp_path):
    from stitchjax.train import reporting
    from stitchjax.eval import validation
    from stitchjax.sample import trained_model

    data, stats = dataset
    config = tiny_config("train.eval_every=2", "train.eval_windows=3", "train.eval_lengths=5")
    model_of_state = functools.partial(trained_model.model_from_state, config)
    summary = train.train(config, tmp_path, max_steps=4, prepared=(data, stats), progress=False,
                          make_validator=functools.partial(validation.make_validator, model_of_state=model_of_state,
                                                           samples=2))
    records = reporting.read_metrics(tmp_path / "metrics.jsonl")
    rows = [r for r in records if "val_ade_L5" in r]
    assert [r["step"] for r in rows] == [2, 4]
    for row in rows:
        for metric in validation.METRICS:
            assert np.isfinite(row[f"val_{metric}_L5"]) and np.isfinite(row[f"val_{metric}_L5_interp"])
        assert row["val_ade_L5"] > 0 and row["val_apd_L5"] > 0  # sampled from the prior: samples differ
        assert row["val_apd_L5_interp"] == 0.0 and row["val_s"] > 0
    assert rows[0]["val_ade_L5"] != rows[1]["val_ade_L5"]  # the current parameters, not the first ones
    assert rows[0]["val_ade_L5_interp"] == rows[1]["val_ade_L5_interp"]  # the same fixed windows
    assert "loss" in summary["final"]  # the last training record, not the validation one
    assert "| val_npss_L5 |" in (tmp_path / "report.md").read_text()
    with pytest.raises(FileNotFoundError, match="train.eval_every=2 validates on the dataset's test windows"):
        validation.make_validator(config.data, config.train, tmp_path / "no_such_folder", {}, None,
                                  model_of_state=model_of_state)


def test_learning_rate_decay_scales_the_update_like_a_smaller_learning_rate(dataset):
    tc = tiny_config("train.lr_decay_to=0.1", "train.lr_decay_from_step=10", "train.lr_decay_until_step=20").train
    assert [round(float(schedule.learning_rate_factor(s, tc)), 6) for s in (0, 10, 15, 20, 99)] == [1, 1, 0.55, 0.1, 0.1]
    backwards = tiny_config("train.lr_decay_to=0.1", "train.lr_decay_from_step=20", "train.lr_decay_until_step=10")
    with pytest.raises(schedule.ScheduleError, match="lr_decay_until_step=10 must be after"):
        schedule.plan_run(100, backwards.train)  # refused when the run is planned, before any work
    data, _ = dataset
    mesh = parallel.make_mesh()
    halved = tiny_config("train.learning_rate=2e-4", "train.lr_decay_to=0.5", "train.lr_decay_from_step=-2",
                         "train.lr_decay_until_step=-1")  # past the decay at step 0: 2e-4 x 0.5
    after = {}
    for name, config in (("decayed", halved), ("plain", tiny_config("train.learning_rate=1e-4"))):
        state = train.create_train_state(specs.train_spec(config), jax.random.PRNGKey(0), None, mesh)
        state, metrics = train.make_train_step(specs.train_spec(config), mesh)(state, _device_data(data, mesh), jnp.int32(6))
        after[name] = jax.device_get(state.params)
    assert float(metrics["loss"]) > 0 and "lr" not in metrics
    for a, b in zip(jax.tree.leaves(after["decayed"]), jax.tree.leaves(after["plain"])):
        np.testing.assert_allclose(a, b, rtol=1e-5, atol=1e-7)


def test_a_second_run_of_an_equal_config_reuses_the_compiled_step(dataset, tmp_path, monkeypatch):
    data, stats = dataset
    built = []
    make = train.make_train_step
    monkeypatch.setattr(train, "make_train_step", lambda *args: built.append(args) or make(*args))
    config = tiny_config("train.seed=11")  # a spec no other test trains: the first run must build its step
    kwargs = dict(prepared=(data, stats), progress=False, max_steps=2)
    train.train(config, tmp_path / "first", **kwargs)
    assert len(built) == 1
    train.train(tiny_config("train.seed=11"), tmp_path / "second", **kwargs)  # an equal config, built anew
    assert len(built) == 1  # the same traced and compiled step
    first, second = _params(tmp_path / "first")[0], _params(tmp_path / "second")[0]
    for a, b in zip(jax.tree.leaves(first), jax.tree.leaves(second)):
        np.testing.assert_array_equal(a, b)
    train.train(tiny_config("train.seed=12"), tmp_path / "third", **kwargs)
    assert len(built) == 2  # another spec: its own step
