"""notebooks/latent_space.ipynb runs top to bottom (nbclient, python3 kernel) on an untrained tiny model."""
import pathlib

import numpy as np
import pytest

REPO = pathlib.Path(__file__).resolve().parent.parent
NOTEBOOK = REPO / "notebooks" / "latent_space.ipynb"


@pytest.mark.slow
def test_latent_space_notebook_runs(tiny_run, monkeypatch):
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    monkeypatch.setenv("STITCHJAX_CHECKPOINT", str(tiny_run))
    monkeypatch.setenv("STITCHJAX_NOTEBOOK_LENGTH", "8")
    monkeypatch.setenv("STITCHJAX_NOTEBOOK_LENGTHS", "8")  # one compile; the notebook default is 5,15,30,45
    monkeypatch.setenv("STITCHJAX_NOTEBOOK_WINDOWS", "4")
    notebook = nbformat.read(NOTEBOOK, as_version=4)
    client = nbclient.NotebookClient(notebook, timeout=300, kernel_name="python3",
                                     resources={"metadata": {"path": str(NOTEBOOK.parent)}})
    client.execute()
    outputs = [o for cell in notebook.cells if cell.cell_type == "code" for o in cell.get("outputs", [])]
    assert not [o for o in outputs if o.output_type == "error"]
    images = [o for o in outputs if "image/png" in o.get("data", {})]
    assert len(images) >= 4  # PCA, overlap gap, interpolation filmstrip, APD curve
    text = "".join(o.get("text", "") for o in outputs if o.output_type == "stream")
    assert "latent codes of size 4" in text and "L =  8: APD" in text
    # APD is a distance: finite and non-negative for the samples of an untrained-but-random model.
    apd = float(text.split("L =  8: APD")[1].split("m")[0])
    assert np.isfinite(apd) and apd > 0.0
