"""Checkpoints: round trip onto an abstract state, config beside the state, retention, atomic writes."""
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from stitchjax import checkpoints


def _state(seed=0):
    key = jax.random.PRNGKey(seed)
    return {
        "step": jnp.int32(7),
        "params": {"w": jax.random.normal(key, (3, 4)), "b": jnp.arange(4.0)},
        "key": jax.random.PRNGKey(seed + 1),
    }


def test_round_trip_with_config_and_extras(tmp_path):
    state = _state()
    manager = checkpoints.open_manager(tmp_path, max_to_keep=2)
    checkpoints.save(manager, 7, state, {"train": {"batch_size": 4, "widths": (8, 8)}}, {"stats": {"mean": [1.0]}})
    abstract = jax.eval_shape(lambda: _state(5))  # shapes only, different values
    restored, config_json, extras = checkpoints.restore(manager, abstract)
    checkpoints.close(manager)
    for a, b in zip(jax.tree.leaves(state), jax.tree.leaves(restored)):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    assert config_json == {"train": {"batch_size": 4, "widths": [8, 8]}}
    assert extras == {"stats": {"mean": [1.0]}}
    assert checkpoints.read_config_json(tmp_path)["train"]["batch_size"] == 4
    assert (checkpoints.checkpoint_dir(tmp_path) / "7" / "config").is_dir()  # config saved beside the state


def test_keeps_last_max_to_keep(tmp_path):
    manager = checkpoints.open_manager(tmp_path, max_to_keep=2)
    for step in (1, 2, 3):
        checkpoints.save(manager, step, _state(step), {})
    checkpoints.close(manager)
    assert sorted(int(p.name) for p in checkpoints.checkpoint_dir(tmp_path).iterdir()) == [2, 3]


def test_atomic_half_written_checkpoint_is_ignored_and_cleaned(tmp_path):
    manager = checkpoints.open_manager(tmp_path)
    checkpoints.save(manager, 3, _state(), {})
    checkpoints.close(manager)
    folder = checkpoints.checkpoint_dir(tmp_path)
    assert [p.name for p in folder.iterdir()] == ["3"]  # the temporary folder was renamed, nothing left over
    # A run killed while writing step 9 leaves only orbax's temporary folder behind.
    partial = folder / "9.orbax-checkpoint-tmp-123"
    (partial / "state").mkdir(parents=True)
    (partial / "state" / "junk").write_bytes(b"half written")
    manager = checkpoints.open_manager(tmp_path)
    assert manager.latest_step() == 3
    restored, _, _ = checkpoints.restore(manager, jax.eval_shape(_state))
    checkpoints.close(manager)
    assert int(restored["step"]) == 7
    assert not partial.exists()  # cleaned up when the manager opened


def test_missing_checkpoint_errors(tmp_path):
    with pytest.raises(checkpoints.CheckpointError, match="no checkpoints"):
        checkpoints.open_manager(tmp_path / "nothing", read_only=True)
    manager = checkpoints.open_manager(tmp_path)
    with pytest.raises(checkpoints.CheckpointError, match="no checkpoint found"):
        checkpoints.restore(manager, jax.eval_shape(_state))
    checkpoints.close(manager)
