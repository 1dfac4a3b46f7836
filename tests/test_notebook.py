"""notebooks/latent_space.ipynb runs top to bottom (nbclient, python3 kernel) on a tiny trained model."""
import pathlib

import numpy as np
import pytest

REPO = pathlib.Path(__file__).resolve().parent.parent
NOTEBOOK = REPO / "notebooks" / "latent_space.ipynb"

TINY = [
    "model.encoder_widths=16,16,16", "model.lstm_size=16", "model.latent_dim=4", "model.decoder_widths=16,16",
    "model.gating_widths=8,8", "model.disc_widths=16,16", "model.disc_long_window=4", "model.stitch_buffer=2",
    "phase.hidden_dim=8", "phase.num_layers=1", "phase.steps=10", "phase.batch_size=64",
    "train.batch_size=4", "train.max_length=8", "train.min_length=4", "train.log_every=1",
]


def _tiny_config():
    from stitchjax import config as config_lib

    config = config_lib.load_config("lafan1")
    for item in TINY:  # overrides of fields this version lacks are skipped
        try:
            config = config_lib.apply_overrides(config, [item])
        except config_lib.ConfigError:
            pass
    return config


@pytest.fixture(scope="module")
def tiny_trained_run(tmp_path_factory):
    """A tiny model trained for 1 step on 16 windows of the bundled sample, cut to 10 frames
    (the cost is compiling the train step; more steps would only make the figures less random)."""
    from stitchjax import train

    config = _tiny_config()
    data, stats = train.load_training_data(config, None)
    data = {k: (v[:16, :10] if v.shape[1] > 1 else v[:16]) for k, v in data.items()}
    workdir = tmp_path_factory.mktemp("notebook_run")
    train.train(config, workdir, max_steps=1, dataset=data, stats=stats, progress=False)
    return workdir


@pytest.mark.slow
def test_latent_space_notebook_runs(tiny_trained_run, monkeypatch):
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    monkeypatch.setenv("STITCHJAX_CHECKPOINT", str(tiny_trained_run))
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
