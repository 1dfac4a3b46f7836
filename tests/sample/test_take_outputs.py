"""Every output of bin/inbetween (the BVHs, the filmstrip, the GIF and the HTML page) for every take the loader
accepts: a root bone above Hips, 60 fps, metres, and a real LAFAN1 clip at 60 fps with a root bone (shared data).

The figures and the page are drawn on the model's skeleton, in cm and +Y up, whatever the take's joints, units and
frame rate; the BVHs keep the take's frame rate, frame count and units. All runs use the tiny model's 8 generated
frames and 2 samples, so the sampler compiles once."""
import json
import re

import numpy as np
import pytest
from PIL import Image

from stitchjax import rotations as R
from stitchjax.data import bundled, bvh, conform
from stitchjax.eval import animation, plots
from stitchjax.skeleton import Skeleton

from bin_scripts import load_cli

LENGTH, SAMPLES, CONTEXT = 8, 2, 10
SIX = ("Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation")


@pytest.fixture(scope="module")
def take():
    """60 frames (2 s at 30 fps) of the bundled test take, 22 joints in cm."""
    return bvh.load(bundled.sample_files(["subject5"])[0])[80:140]


def _under_a_root_bone(motion):
    """The take under an extra root bone "SimulationBone" above Hips (as LAFAN1's 60 fps clips have), both with
    position channels; every other joint's world motion unchanged."""
    sk = motion.skeleton
    lift = np.array([0.0, 5.0, 0.0])
    offsets = np.concatenate([np.zeros((1, 3)), sk.offsets])
    offsets[1] = lift
    rotations = np.concatenate([np.broadcast_to(R.quat_identity((1,)), (motion.num_frames, 1, 4)),
                                motion.rotations], 1)
    positions = np.concatenate([motion.positions[:, :1] - lift, motion.positions], 1)
    positions[:, 1] = lift
    channels = (SIX, SIX) + tuple(("Zrotation", "Yrotation", "Xrotation") for _ in sk.names[1:])
    return bvh.Motion(rotations, positions, Skeleton(("SimulationBone",) + sk.names, (-1,) + tuple(
        p + 1 for p in sk.parents), offsets), motion.fps, channels=channels)


def _variant(take, name):
    """(the take as ``name`` says, start keyframe, end keyframe, the --scale it needs, cm per unit of its file)."""
    if name == "root bone":
        return _under_a_root_bone(take), 20, 29, 1.0, 1.0
    if name == "60 fps":  # 17 frames between the keyframes at 60 fps: the model's 8 at its 30 fps
        return conform.resample(take, 60.0, 20)[0], 40, 58, 1.0, 1.0
    if name == "metres":
        return conform.rescale(take, 0.01), 20, 29, 100.0, 100.0
    raise ValueError(name)


def _run(capsys, monkeypatch, *args):
    """bin/inbetween's main() in this process, recording what the filmstrip and the GIF were given:
    (exit status, stderr, {"filmstrip": rows, "gif": motions})."""
    drawn = {}
    filmstrip, animate = plots.filmstrip, animation.animate

    def record_filmstrip(rows, *a, **k):
        drawn["filmstrip"] = [np.asarray(r) for r in rows]
        return filmstrip(rows, *a, **k)

    def record_animate(motions, *a, **k):
        drawn["gif"] = [np.asarray(m) for m in motions]
        return animate(motions, *a, **k)

    monkeypatch.setattr(plots, "filmstrip", record_filmstrip)
    monkeypatch.setattr(animation, "animate", record_animate)
    code = load_cli("inbetween").main([str(a) for a in args])
    return code, capsys.readouterr().err, drawn


def _page_data(path) -> dict:
    page = path.read_text()
    return json.loads(re.search(r'id="stitchjax-data">(.*?)</script>', page, re.S).group(1))


def _check_outputs(out, stem, source, a, b, units_in_cm, drawn, model_names):
    """The four outputs of one run, against the take ``source`` (as loaded from its file)."""
    first, last = max(a - CONTEXT, 0), min(b + CONTEXT, source.num_frames - 1)
    shown = last - first + 1
    picked = [source.skeleton.names.index(n) for n in model_names]
    source_cm = source.global_positions()[:, picked] * units_in_cm  # (T, 22, 3) cm
    # BVHs: the take's rate, frame count and units, on the model's skeleton, the keyframes where they were
    written = [bvh.load(out / f"{stem}_sample{k}.bvh") for k in range(SAMPLES)]
    for motion in written:
        assert motion.fps == source.fps and motion.num_frames == source.num_frames
        assert motion.skeleton.names == tuple(model_names)
        g = motion.global_positions() * units_in_cm
        np.testing.assert_allclose(g[[a, b]], source_cm[[a, b]], atol=1e-3)
        assert 60.0 < np.median(g[:, 0, 1]) < 130.0  # the hips' height, back in the take's units
    # the filmstrip: the input row and one per sample, 22 joints, cm
    png = out / f"{stem}_filmstrip.png"
    assert Image.open(png).size[1] > 3 * 100
    rows = drawn["filmstrip"]
    assert len(rows) == 1 + SAMPLES and all(r.shape[1:] == (22, 3) for r in rows)
    assert all(130.0 < np.ptp(r[..., 1]) < 220.0 for r in rows)  # a body's height in cm
    # the GIF: every sample, the shown frames at a rate browsers keep (at most 30 fps, delays of 20 ms or more)
    assert [m.shape for m in drawn["gif"]] == [(shown, 22, 3)] * SAMPLES
    frames, rate = animation.gif_frames(shown, source.fps, (a - first, b - first))
    gif = Image.open(out / f"{stem}.gif")
    assert gif.n_frames == len(frames) and rate <= animation.GIF_MAX_FPS
    assert gif.info["duration"] >= 20
    assert abs(gif.n_frames * gif.info["duration"] / 1000 - shown / source.fps) < 0.25 * shown / source.fps
    # the page: the same frames at the take's rate, the keyframes as the take has them, in cm
    data = _page_data(out / f"{stem}.html")
    assert data["fps"] == source.fps and data["num_frames"] == shown and len(data["parents"]) == 22
    assert data["keyframes"] == [a - first, b - first] and len(data["tracks"]) == 1 + SAMPLES
    for key, frame in zip(data["keyposes"], (a, b)):
        pose = np.asarray(key["positions"]).reshape(22, 3) / data["scale"]
        np.testing.assert_allclose(pose, source_cm[frame], atol=0.051)
    heights = [np.ptp(np.asarray(t["positions"]).reshape(shown, 22, 3)[..., 1]) / data["scale"]
               for t in data["tracks"]]
    assert all(130.0 < h < 220.0 for h in heights)
    assert all(len(t["contacts"]) == shown for t in data["tracks"])


@pytest.mark.parametrize("name", ["root bone", "60 fps", "metres"])
def test_every_output_for_a_take_with_a_root_bone_at_60_fps_or_in_metres(name, tiny_run, take, tmp_path, capsys,
                                                                         monkeypatch):
    variant, a, b, scale, cm_per_unit = _variant(take, name)
    source = tmp_path / "take.bvh"
    bvh.save(source, variant)
    code, err, drawn = _run(capsys, monkeypatch, "--checkpoint", tiny_run, "--bvh", source, "--start-frame", a,
                            "--end-frame", b, "--samples", SAMPLES, "--scale", scale, "--gif", "--html",
                            "--out", tmp_path / "out")
    assert code == 0, err
    _check_outputs(tmp_path / "out", "take", bvh.load(source), a, b, cm_per_unit, drawn, take.skeleton.names)


@pytest.mark.shared_data
def test_every_output_for_a_lafan1_clip_at_60_fps_with_a_root_bone(shared_data, tiny_run, take, tmp_path, capsys,
                                                                   monkeypatch):
    clip = sorted((shared_data / "lafan1_filtered60").glob("*.bvh"))[0]
    source = bvh.load(clip)
    assert source.fps == 60.0 and source.skeleton.names[1] == "Hips" and source.skeleton.num_joints == 23
    code, err, drawn = _run(capsys, monkeypatch, "--checkpoint", tiny_run, "--bvh", clip, "--start-frame", 100,
                            "--end-frame", 118, "--samples", SAMPLES, "--gif", "--html", "--out", tmp_path)
    assert code == 0, err
    _check_outputs(tmp_path, clip.name[:-4], source, 100, 118, 1.0, drawn, take.skeleton.names)
