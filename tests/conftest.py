"""Test setup: CPU only, persistent compilation cache, shared data location."""
import os
import pathlib

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

import pytest  # noqa: E402

REPO = pathlib.Path(__file__).resolve().parent.parent
SHARED_DATA = pathlib.Path(os.environ.get("STITCHJAX_SHARED_DATA", REPO.parent / "shared" / "data"))


@pytest.fixture(scope="session")
def shared_data() -> pathlib.Path:
    """../shared/data, or skip the test with the reason when it is absent."""
    if not (SHARED_DATA / "lafan1").is_dir():
        pytest.skip(f"shared motion data not found at {SHARED_DATA} (set STITCHJAX_SHARED_DATA)")
    return SHARED_DATA
