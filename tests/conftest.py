"""Test setup: CPU only, persistent compilation cache, shared data location."""
import os
import pathlib
import sys

os.environ.setdefault("JAX_PLATFORMS", "cpu")
os.environ.setdefault(
    "JAX_COMPILATION_CACHE_DIR",
    str(pathlib.Path(__file__).resolve().parent.parent / ".cache" / "jax"),
)
os.environ.setdefault("JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS", "0.5")
# Preprocessed datasets go to the repository's own cache folder, not the user's home.
os.environ.setdefault(
    "STITCHJAX_CACHE_DIR",
    str(pathlib.Path(__file__).resolve().parent.parent / ".cache" / "stitchjax"),
)

# Tests compile many tiny programs and run each briefly: skip LLVM's optimisation passes (about halves
# compile time on a CPU; the results are the same programs, only slower to run, which tiny models don't feel).
if "xla_backend_optimization_level" not in os.environ.get("XLA_FLAGS", ""):
    os.environ["XLA_FLAGS"] = (os.environ.get("XLA_FLAGS", "") + " --xla_backend_optimization_level=0").strip()

import pytest  # noqa: E402

REPO = pathlib.Path(__file__).resolve().parent.parent
SHARED_DATA = pathlib.Path(os.environ.get("STITCHJAX_SHARED_DATA", REPO.parent / "shared" / "data"))


@pytest.fixture(scope="session")
def shared_data() -> pathlib.Path:
    """../shared/data, or skip the test with the reason when it is absent."""
    if not (SHARED_DATA / "lafan1").is_dir():
        pytest.skip(f"shared motion data not found at {SHARED_DATA} (set STITCHJAX_SHARED_DATA)")
    return SHARED_DATA


def save_tiny_checkpoint(workdir, seed: int = 0) -> pathlib.Path:
    """A freshly initialised `tiny` model written as a training run writes it (checkpoints/0)."""
    import jax

    from stitchjax import checkpoints, specs
    from stitchjax.train import loop as train
    from stitchjax import config as config_lib

    config = config_lib.load_config("tiny")
    state = train.create_train_state(specs.train_spec(config), jax.random.PRNGKey(seed))
    manager = checkpoints.open_manager(workdir, async_save=False)
    checkpoints.save(manager, 0, state, config_lib.to_dict(config), {"config_name": "tiny"})
    checkpoints.close(manager)
    return pathlib.Path(workdir)


@pytest.fixture(scope="session")
def tiny_run(tmp_path_factory) -> pathlib.Path:
    """A run folder holding an untrained `tiny` model: enough to exercise loading and inference."""
    return save_tiny_checkpoint(tmp_path_factory.mktemp("tiny_run"))


@pytest.hookimpl(tryfirst=True)
def pytest_sessionfinish(session):
    """On a pytest-xdist worker, free JAX's compiled programs before the worker reports that it is done: the
    controller interrupts a worker still busy 5 s after that, which a late collection of thousands of
    executables can be."""
    if os.environ.get("PYTEST_XDIST_WORKER") and "jax" in sys.modules:
        import gc

        sys.modules["jax"].clear_caches()
        gc.collect()
