"""pyproject.toml: the accelerator extras install JAX's builds of the version the package needs, the README gives
their install lines, and the viewer's script ships as package data."""
import importlib.resources
import pathlib

import pytest

REPO = pathlib.Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def project():
    tomllib = pytest.importorskip("tomllib")  # Python 3.11+
    return tomllib.loads((REPO / "pyproject.toml").read_text())


def test_accelerator_extras_install_jax_builds_of_the_package_version(project):
    jax = [d for d in project["project"]["dependencies"] if d.replace(" ", "").startswith("jax>=")]
    assert len(jax) == 1
    version = jax[0].split(">=")[1]
    extras = project["project"]["optional-dependencies"]
    for extra in ("cuda12", "cuda13", "tpu"):
        assert extras[extra] == [f"jax[{extra}]>={version}"], extra
    readme = (REPO / "README.md").read_text()
    assert 'python -m pip install -e ".[dev,cuda12]"' in readme
    assert 'python -m pip install -e ".[dev,tpu]"' in readme


def test_the_viewer_script_ships_with_the_package(project):
    assert "eval/viewer.js" in project["tool"]["setuptools"]["package-data"]["stitchjax"]
    script = importlib.resources.files("stitchjax.eval").joinpath("viewer.js").read_text()
    assert "stitchjax-data" in script and "data-frames-drawn" in script
