"""notebooks/latent_space.ipynb runs top to bottom (jupyter nbconvert, python3 kernel) on an untrained tiny model."""
import os
import pathlib
import subprocess
import sys

import numpy as np
import pytest

REPO = pathlib.Path(__file__).resolve().parent.parent
NOTEBOOK = REPO / "notebooks" / "latent_space.ipynb"


def _pythonpath() -> str:
    """This checkout's package first in the kernel (not another install of stitchjax)."""
    return os.pathsep.join([str(REPO)] + [p for p in [os.environ.get("PYTHONPATH")] if p])


@pytest.mark.slow
def test_latent_space_notebook_runs(tiny_run, tmp_path):
    """The README's command: jupyter nbconvert --execute (dev extra), env pointing at a tiny checkpoint."""
    nbformat = pytest.importorskip("nbformat")
    pytest.importorskip("nbconvert")
    env = {**os.environ, "PYTHONPATH": _pythonpath(), "STITCHJAX_CHECKPOINT": str(tiny_run),
           "STITCHJAX_NOTEBOOK_LENGTH": "8",
           "STITCHJAX_NOTEBOOK_LENGTHS": "8",  # one compile; the notebook default is 5,15,30,45
           "STITCHJAX_NOTEBOOK_WINDOWS": "4"}
    out = tmp_path / "executed.ipynb"
    proc = subprocess.run([sys.executable, "-m", "jupyter", "nbconvert", "--to", "notebook", "--execute",
                           str(NOTEBOOK), "--output", str(out)], env=env, capture_output=True, text=True,
                          timeout=300, cwd=str(REPO))
    assert proc.returncode == 0, proc.stderr[-3000:]
    notebook = nbformat.read(out, as_version=4)
    outputs = [o for cell in notebook.cells if cell.cell_type == "code" for o in cell.get("outputs", [])]
    assert not [o for o in outputs if o.output_type == "error"]
    images = [o for o in outputs if "image/png" in o.get("data", {})]
    assert len(images) >= 4  # PCA, overlap gap, interpolation filmstrip, APD curve
    pages = ["".join(o["data"]["text/html"]) for o in outputs if "text/html" in o.get("data", {})]
    viewers = [p for p in pages if 'data-stitchjax-viewer="1"' in p]  # the 3D viewer of the interpolation, inline
    assert len(viewers) == 1 and "predicted by the model" in viewers[0]
    text = "".join(o.get("text", "") for o in outputs if o.output_type == "stream")
    assert "latent codes of size 4" in text and "L =  8: APD" in text
    # APD is a distance: finite and non-negative for the samples of an untrained-but-random model.
    apd = float(text.split("L =  8: APD")[1].split("m")[0])
    assert np.isfinite(apd) and apd > 0.0


def test_checkpoint_from_env_resolves_against_the_command_directory(tmp_path):
    from stitchjax.sample import latent

    run = tmp_path / "runs" / "quickstart"
    (run / "checkpoints").mkdir(parents=True)
    assert latent.checkpoint_from_env({"STITCHJAX_CHECKPOINT": "runs/quickstart",
                                       "STITCHJAX_CWD": str(tmp_path), "PWD": "/nowhere"}) == run
    assert latent.checkpoint_from_env({"STITCHJAX_CHECKPOINT": "runs/quickstart", "PWD": str(tmp_path)}) == run
    assert latent.checkpoint_from_env({"STITCHJAX_CHECKPOINT": str(run), "PWD": "/nowhere"}) == run
    assert latent.checkpoint_from_env({"STITCHJAX_CHECKPOINT": "demo"}) == latent.DEMO
    with pytest.raises(FileNotFoundError, match="STITCHJAX_CHECKPOINT is not set"):
        latent.checkpoint_from_env({"PWD": str(tmp_path)})
    with pytest.raises(FileNotFoundError) as info:
        latent.checkpoint_from_env({"STITCHJAX_CHECKPOINT": "runs/other", "STITCHJAX_CWD": str(tmp_path)})
    assert str(tmp_path / "runs" / "other") in str(info.value) and "does not exist" in str(info.value)


@pytest.mark.slow
def test_notebook_refuses_a_missing_checkpoint(tmp_path):
    """A relative STITCHJAX_CHECKPOINT that names nothing: nbconvert exits non-zero naming the resolved path
    (no model is trained or sampled in its place)."""
    pytest.importorskip("nbconvert")
    env = {**os.environ, "PYTHONPATH": _pythonpath(), "STITCHJAX_CHECKPOINT": "runs/quickstart",
           "STITCHJAX_CWD": str(tmp_path)}
    proc = subprocess.run([sys.executable, "-m", "jupyter", "nbconvert", "--to", "notebook", "--execute",
                           str(NOTEBOOK), "--output", str(tmp_path / "executed.ipynb")], env=env,
                          capture_output=True, text=True, timeout=300, cwd=str(REPO))
    assert proc.returncode != 0
    assert str(tmp_path / "runs" / "quickstart") in proc.stderr and "does not exist" in proc.stderr
    assert "training a tiny model" not in proc.stderr + proc.stdout
