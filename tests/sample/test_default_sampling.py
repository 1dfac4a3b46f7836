"""A model's default sampling (model.json "sampling", written by bin/export --sampling): the API and
bin/inbetween use it when a call gives no noise settings, --paper-sampling and explicit flags override it, a
training run samples as the paper does, and a malformed setting is refused with the fix."""
import json

import numpy as np
import pytest

from stitchjax.data import bvh, bundled
from stitchjax.sample import inbetween, trained_model
from stitchjax.sample.sampling import Sampling

from bin_scripts import load_cli

WIDE = {"noise_scale": 2.0, "noise_correlation": 0.9, "noise_ramp_steps": 3}


@pytest.fixture(scope="module")
def take():
    return bvh.load(bundled.sample_files(["subject5"])[0])


@pytest.fixture(scope="module")
def exported(tiny_run, tmp_path_factory):
    out = tmp_path_factory.mktemp("wide") / "model"
    assert load_cli("export").main(["--run", str(tiny_run), "--out", str(out), "--sampling", "2,0.9,3",
                                    "--sampling-note", "a test"]) == 0
    return out


def _positions(model, take, **noise):
    samples = inbetween.inbetween(model, take[99:101], take[107:109], 6, num_samples=2, seed=5, **noise)
    return np.stack([s.global_positions() for s in samples])


def test_a_training_run_samples_as_the_paper(tiny_run):
    model = trained_model.load_model(tiny_run)
    assert model.default_sampling is None
    assert model.sampling.noise == model.paper_sampling.noise == {"noise_scale": 1.0, "noise_correlation": 0.0,
                                                                  "noise_ramp_steps": 0}
    assert model.sampling == Sampling.paper(foot_lock=True)  # the API's default locks the feet
    assert model.paper_sampling == Sampling() and model.paper_sampling.foot_lock is False


def test_export_stores_the_sampling_and_the_api_uses_it(exported, tiny_run, take):
    description = json.loads((exported / "model.json").read_text())
    assert description["sampling"] == WIDE and description["notes"]["sampling"] == "a test"
    model = trained_model.load_model(exported)
    assert model.sampling.noise == WIDE and model.sampling == Sampling.from_json(WIDE, foot_lock=True)
    default = _positions(model, take)
    np.testing.assert_array_equal(default, _positions(model, take, **WIDE))
    np.testing.assert_array_equal(default, _positions(model, take, sampling=model.sampling))
    paper = _positions(model, take, **model.paper_sampling.noise)
    np.testing.assert_array_equal(paper, _positions(model, take, sampling=model.paper_sampling.replace(foot_lock=True)))
    assert np.abs(default - paper).max() > 1e-3  # the default is not the paper's sampling
    # one setting given, the others from the default
    np.testing.assert_array_equal(_positions(model, take, noise_scale=1.0),
                                  _positions(model, take, noise_scale=1.0, noise_correlation=0.9, noise_ramp_steps=3))


def test_inbetween_cli_default_paper_sampling_and_flags(exported, tmp_path):
    cli = load_cli("inbetween")
    source = str(bundled.sample_files(["subject5"])[0])
    runs = {}
    for name, extra in {"default": [], "explicit": ["--noise-scale", "2", "--noise-correlation", "0.9",
                                                    "--noise-ramp", "3"],
                        "paper": ["--paper-sampling"],
                        "paper_explicit": ["--noise-scale", "1", "--noise-correlation", "0", "--noise-ramp", "0"]
                        }.items():
        out = tmp_path / name
        assert cli.main(["--checkpoint", str(exported), "--bvh", source, "--start-frame", "100", "--end-frame",
                         "107", "--samples", "2", "--output", "transition", "--out", str(out)]
                        + extra) == 0
        runs[name] = np.stack([bvh.load(p).global_positions() for p in sorted(out.glob("*.bvh"))])
    np.testing.assert_allclose(runs["default"], runs["explicit"], atol=1e-6)
    np.testing.assert_allclose(runs["paper"], runs["paper_explicit"], atol=1e-6)
    assert np.abs(runs["default"] - runs["paper"]).max() > 1e-3


def test_malformed_sampling_is_refused(tiny_run, tmp_path, capsys):
    cli = load_cli("export")
    for bad in ("2,0.9", "2,1.5,3", "2,0.9,2.5", "-1,0,0", "a,b,c"):
        assert cli.main(["--run", str(tiny_run), "--out", str(tmp_path / "x"), f"--sampling={bad}"]) == 2
        assert "--sampling" in capsys.readouterr().err
    with pytest.raises(trained_model.InbetweenError, match="unknown noise_speed"):
        trained_model.check_sampling({"noise_speed": 1.0})
