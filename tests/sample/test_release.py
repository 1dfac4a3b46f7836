"""The release model shipped in the package (stitchjax/pretrained/, made by bin/export): it loads, samples and keeps
both keyframes exact; loading restores no optimiser or train state; its default sampling spreads the samples wider
than the paper's; bin/inbetween without --checkpoint uses it."""
import fnmatch
import json
import os
import pathlib
import subprocess
import sys
import tomllib

import jax
import numpy as np
import pytest

import stitchjax
from stitchjax import checkpoints
from stitchjax.data import bvh, bundled
from stitchjax.sample import inbetween, takes, trained_model

from bin_scripts import load_cli

REPO = pathlib.Path(__file__).resolve().parents[2]
RELEASE = REPO / "stitchjax" / "pretrained" / trained_model.RELEASE_MODEL
TOL_CM = 1e-4  # keyframes: float64 FK of the same local transforms


@pytest.fixture(scope="module")
def release():
    return stitchjax.pretrained()


@pytest.fixture(scope="module")
def take():
    return bvh.load(bundled.sample_files(["subject5"])[0])


def test_release_model_loads_samples_and_keeps_both_keyframes_exact(release, take):
    assert release.config.name == "lafan1_cpu_release" and release.num_joints == 22
    assert release.feet_names == ("LeftFoot", "LeftToe", "RightFoot", "RightToe")
    assert all(x.dtype == np.float32 for x in jax.tree.leaves(release.params))  # stored float16, computed float32
    assert release.stats["mean"].shape == (66,) and release.stats["offsets"].shape == (22, 3)
    samples = inbetween.inbetween(None, take[99:101], take[130:132], 29, num_samples=3, seed=0)  # None: release
    ends = take[100].global_positions()[0], take[130].global_positions()[0]
    generated = []
    for s in samples:
        g = s.global_positions()
        assert g.shape == (31, 22, 3) and np.all(np.isfinite(g))
        assert np.abs(g[0] - ends[0]).max() < TOL_CM and np.abs(g[-1] - ends[1]).max() < TOL_CM
        generated.append(g[1:-1])
    assert np.abs(generated[0] - generated[1]).max() > 1.0  # cm: the samples differ
    clip = takes.inbetween_clip(None, take, 100, 130, num_samples=1, seed=0)[0]  # the take-level API too
    assert clip.num_frames == take.num_frames
    assert np.abs(clip.global_positions()[130] - ends[1]).max() < TOL_CM


def test_release_model_is_what_the_release_config_trains(release):
    """One recipe: the shipped model's config is configs/lafan1_cpu_release field for field (bin/export
    --config-name renames the run's own config, which must then equal the named one)."""
    from stitchjax import config as config_lib

    assert release.config == config_lib.load_config("lafan1_cpu_release")


def test_release_folder_holds_only_what_sampling_needs():
    assert sorted(p.name for p in RELEASE.iterdir()) == ["length_model.json", "model.json", "params.msgpack"]
    assert sum(p.stat().st_size for p in RELEASE.iterdir()) < 10 * 2**20
    description = json.loads((RELEASE / "model.json").read_text())
    from flax import serialization

    tree = serialization.msgpack_restore((RELEASE / "params.msgpack").read_bytes())
    assert set(tree) == {"generators", "phase"} and set(tree["generators"]) == {"forward", "backward"}
    assert {np.asarray(x).dtype for x in jax.tree.leaves(tree)} == {np.dtype(description["param_dtype"])}
    assert description["param_dtype"] == "float16"
    check = description["notes"]["precision_check"]  # what bin/export --check-data measured before keeping it
    assert max(check["relative_change"].values()) <= check["tolerance"]
    # every config field is written out, so a later change of a default cannot change the model; a field
    # added since the export can only be an extension, which loads at its paper value (off), or a switch of
    # a part of the paper's model (Appendix D), which loads with the part on
    from stitchjax import config as config_lib

    saved = description["config"]
    loaded = config_lib.to_dict(config_lib.from_dict(saved))
    added = set()
    for section, fields in loaded.items():
        if not isinstance(fields, dict):
            assert fields == saved[section]
            continue
        for name, value in fields.items():
            if name in saved[section]:
                assert value == saved[section][name], (section, name)
            else:
                added.add(f"{section}.{name}")
    assert added <= set(config_lib.EXTENSIONS) | set(config_lib.ABLATION_SWITCHES)
    assert not set(config_lib.extensions_on(config_lib.from_dict(saved))) & added
    assert all(loaded[name.split(".")[0]][name.split(".")[1]] is True
               for name in added & set(config_lib.ABLATION_SWITCHES))


def test_loading_restores_only_the_sampling_parameters(tiny_run, monkeypatch):
    asked = []
    restore = checkpoints.restore

    def recording_restore(manager, abstract, step=None, partial=False):
        asked.append((abstract, partial))
        return restore(manager, abstract, step, partial)

    monkeypatch.setattr(checkpoints, "restore", recording_restore)
    model = trained_model.load_model(tiny_run)
    (abstract, partial), = asked
    assert partial and set(abstract) <= {"params", "phase_params"} and set(abstract["params"]) == {"forward",
                                                                                                   "backward"}
    assert set(model.params) == {"forward", "backward"}
    # a fresh process: loading either kind of model imports neither the training code nor builds an optimiser
    code = ("import sys; from stitchjax.sample import trained_model as t; t.load_model(sys.argv[1]); t.pretrained(); "
            "print(sorted(m for m in sys.modules if m.startswith('stitchjax.train')))")
    result = subprocess.run([sys.executable, "-c", code, str(tiny_run)], capture_output=True, text=True,
                            env=dict(os.environ, PYTHONPATH=str(REPO)), timeout=300)
    assert result.returncode == 0, result.stderr[-2000:]
    assert result.stdout.strip() == "[]"


def test_export_round_trip_and_clear_errors(tiny_run, tmp_path, capsys):
    cli = load_cli("export")
    out = tmp_path / "exported"
    assert cli.main(["--run", str(tiny_run), "--out", str(out)]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["model.json", "params.msgpack"]
    source, exported = trained_model.load_model(tiny_run), trained_model.load_model(out)
    assert exported.config == source.config and exported.joint_names == source.joint_names
    for a, b in zip(jax.tree.leaves(source.params), jax.tree.leaves(exported.params)):
        np.testing.assert_array_equal(np.asarray(b), np.asarray(a).astype(np.float16).astype(np.float32))
    with pytest.raises(trained_model.InbetweenError, match="without a step"):
        trained_model.load_model(out, step=3)
    capsys.readouterr()
    assert cli.main(["--run", str(tmp_path / "missing"), "--out", str(tmp_path / "x")]) == 2
    assert "export: error: --run" in capsys.readouterr().err
    (tmp_path / "a_file").write_text("")
    assert cli.main(["--run", str(tiny_run), "--out", str(tmp_path / "a_file")]) == 2
    assert "is a file, not a folder" in capsys.readouterr().err
    # --config-name: a config of configs/ only when the run's config equals it (tiny's does; the release
    # recipe's does not, and nothing is written), any other name as a free label
    assert cli.main(["--run", str(tiny_run), "--out", str(tmp_path / "named"), "--config-name", "tiny"]) == 0
    assert trained_model.load_model(tmp_path / "named").config == source.config
    capsys.readouterr()
    assert cli.main(["--run", str(tiny_run), "--out", str(tmp_path / "mislabelled"),
                     "--config-name", "lafan1_cpu_release"]) == 2
    assert "not trained by configs/lafan1_cpu_release.py" in capsys.readouterr().err
    assert not (tmp_path / "mislabelled").exists()
    assert cli.main(["--run", str(tiny_run), "--out", str(tmp_path / "label"), "--config-name", "my_label"]) == 0
    assert trained_model.load_model(tmp_path / "label").config.name == "my_label"
    (out / "model.json").write_text(json.dumps({"format": "something else"}))
    with pytest.raises(trained_model.InbetweenError, match="export the model again"):
        trained_model.load_model(out)


def test_release_default_sampling_spreads_the_samples_wider_than_the_papers(release, take):
    """The default sampling (model.json "sampling", chosen on the validation split) is not the paper's, and its
    samples of a 40-frame transition of the bundled take are further apart at mid-transition."""
    assert release.sampling != release.paper_sampling
    assert release.default_sampling["noise_scale"] >= 1.0

    def spread(**noise):
        samples = inbetween.inbetween(release, take[199:201], take[240:242], 39, num_samples=4, seed=0, **noise)
        mid = np.stack([s.global_positions()[20] for s in samples])  # (S, J, 3) cm
        pairs = [np.linalg.norm(mid[a] - mid[b], axis=-1).mean() for a in range(4) for b in range(a + 1, 4)]
        return float(np.mean(pairs))

    assert spread() > 1.5 * spread(**release.paper_sampling.noise)


def test_inbetween_cli_without_checkpoint_uses_the_release_model(tmp_path):
    source = bundled.sample_files(["subject5"])[0]
    result = subprocess.run([sys.executable, str(REPO / "bin" / "inbetween"), "--bvh", str(source), "--start-frame",
                             "100", "--end-frame", "111", "--samples", "2", "--out", str(tmp_path)],
                            capture_output=True, text=True, env=dict(os.environ, PYTHONPATH=str(REPO)), timeout=300)
    assert result.returncode == 0, result.stderr[-2000:]
    written = sorted(tmp_path.glob("*.bvh"))
    assert [p.name for p in written] == [f"{source.name[:-len('.bvh.gz')]}_sample{k}.bvh" for k in range(2)]
    original = bvh.load(source)
    for path in written:
        clip = bvh.load(path)
        assert clip.num_frames == original.num_frames
    assert trained_model.RELEASE_MODEL in result.stderr  # the summary line names the model used


def test_package_data_ships_the_release_model():
    pyproject = tomllib.loads((REPO / "pyproject.toml").read_text())
    globs = pyproject["tool"]["setuptools"]["package-data"]["stitchjax"]
    for path in RELEASE.iterdir():
        relative = str(path.relative_to(REPO / "stitchjax"))
        assert any(fnmatch.fnmatch(relative, g) for g in globs), relative
