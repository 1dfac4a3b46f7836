"""results/placed_target.py end to end on an untrained tiny model and the bundled LAFAN1 excerpt (issue 12)."""
import json
import pathlib
import subprocess
import sys

import numpy as np
import pytest

from stitchjax.data import bvh, bundled

REPO = pathlib.Path(__file__).resolve().parent.parent.parent
SCRIPT = REPO / "results" / "placed_target.py"
sys.path.insert(0, str(SCRIPT.parent))
import placed_target  # noqa: E402


def test_speed_jumps_and_mid_frames():
    roots = np.array([[0, 0, 0], [1, 0, 0], [3, 0, 0], [6, 0, 0], [6, 0, 4]], np.float64)  # cm
    np.testing.assert_allclose(placed_target.root_speed(roots), [1, 2, 3, 4])
    np.testing.assert_allclose(placed_target.speed_jumps(roots), [1, 1, 1])
    assert list(placed_target.mid_frames(6)) == [2, 3, 4, 5] and list(placed_target.mid_frames(1)) == [1]


@pytest.mark.slow
def test_placed_target_script_on_a_tiny_model(tiny_run, tmp_path):
    data = bundled.sample_dir()
    out = tmp_path / "out"
    proc = subprocess.run([sys.executable, str(SCRIPT), "--checkpoint", str(tiny_run), "--data", str(data),
                           "--start-bvh", "walk4_subject1.bvh.gz", "--start-frame", "100",
                           "--target-bvh", "obstacles1_subject5.bvh.gz", "--target-frame", "50", "--length", "6",
                           "--samples", "2", "--allow-fast", "--out", str(out)],  # 300 cm in 7 frames: fast
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode in (0, 1), proc.stderr[-2000:]  # 1: measured, not smooth (an untrained model)
    lines = proc.stdout.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(("PASS: ", "FAIL: ")) and "exactly" in lines[0]
    summary = json.loads((out / "placed_target.json").read_text())
    assert (out / "filmstrip.png").stat().st_size > 0 and (out / "root_speed.png").is_file()
    measured = summary["transition"]
    assert measured["end_error_cm"] < 1e-3 and measured["start_error_cm"] < 1e-3  # BVH text: 6 decimals
    # the figures are those of the written BVH files, recomputed here
    first = bvh.load(out / "inbetween" / "walk4_subject1_sample0.bvh")
    assert first.num_frames == 8
    # --offset-from start (the default): the placed target's root is 300 cm along x from the start's root
    np.testing.assert_allclose((first.positions[-1, 0] - first.positions[0, 0])[[0, 2]], [300.0, 0.0], atol=1e-3)
    assert summary["target"]["offset_from"] == "start"
    speed = np.linalg.norm(np.diff(first.positions[:, 0], axis=0), axis=-1)
    np.testing.assert_allclose(measured["per_sample"][0]["root_speed_cm_per_frame"], speed, atol=1e-4)
    assert measured["per_sample"][0]["max_jump"] == pytest.approx(np.abs(np.diff(speed)).max())
    # the ground truth covers every file of --data; its largest jump is at least that of each take
    truth = summary["ground_truth"]
    assert truth["files"] == len(list(data.glob("*.bvh.gz")))
    walk = bvh.load(data / "walk4_subject1.bvh.gz").positions[:, 0]
    assert truth["max_jump"] >= np.abs(np.diff(np.linalg.norm(np.diff(walk, axis=0), axis=-1))).max() - 1e-12
    assert summary["pass"] == lines[0].startswith("PASS")


def test_placed_target_script_names_a_missing_take(tmp_path):
    proc = subprocess.run([sys.executable, str(SCRIPT), "--checkpoint", str(tmp_path), "--data", str(tmp_path),
                           "--start-bvh", "nothing.bvh", "--out", str(tmp_path / "o")], capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 2 and proc.stderr.strip().count("\n") == 0
    assert proc.stderr.startswith("placed_target: error: --start-bvh nothing.bvh: no such file")
