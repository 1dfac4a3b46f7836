"""Time to quality: validation points from metrics.jsonl records, and bin/compare's table, figure and errors."""
import json

import pytest

from stitchjax.train import reporting

from bin_scripts import load_cli


def records():
    """Two processes of one run (the second resumed: its clock restarts), validation at steps 100, 200, 300."""
    return [
        {"step": 50, "loss": 3.0, "time_s": 40.0},
        {"step": 100, "val_ade_L30": 0.5, "val_ade_L30_interp": 0.25, "val_npss_L30": 0.3, "val_npss_L30_interp": 0.3,
         "val_apd_L30": 0.1, "val_apd_L30_interp": 0.0, "val_s": 5.0},
        {"step": 100, "loss": 2.0, "time_s": 80.0},
        {"step": 150, "loss": 1.5, "time_s": 20.0},  # resumed: 80 + 20
        {"step": 200, "val_ade_L30": 0.2, "val_ade_L30_interp": 0.25, "val_npss_L30": 0.15, "val_npss_L30_interp": 0.3},
        {"step": 200, "loss": 1.0, "time_s": 60.0},
        {"step": 300, "val_ade_L30": 0.1, "val_ade_L30_interp": 0.25, "val_npss_L30": 0.12, "val_npss_L30_interp": 0.3},
    ]


def test_loop_seconds_sum_the_processes_of_a_resumed_run():
    assert reporting.loop_seconds(records()) == [40.0, 40.0, 80.0, 100.0, 100.0, 140.0, 140.0]


def test_validation_curve_gives_ratios_to_interpolation_at_loop_seconds():
    points = reporting.validation_curve(records())
    assert [p["step"] for p in points] == [100, 200, 300]
    assert [p["time_s"] for p in points] == [40.0, 100.0, 140.0]
    assert points[0]["ade_L30_ratio"] == pytest.approx(2.0) and points[1]["npss_L30_ratio"] == pytest.approx(0.5)
    assert "apd_L30_ratio" not in points[0]  # interpolation's APD is 0: no ratio


def test_compare_prints_the_table_and_writes_the_figure_and_json(tmp_path, capsys):
    run = tmp_path / "fast"
    run.mkdir()
    (run / "metrics.jsonl").write_text("".join(json.dumps(r) + "\n" for r in records()))
    slow = [{"step": 100, "time_s": 90.0, "ade_L30_ratio": 0.9, "npss_L30_ratio": 0.9},
            {"step": 500, "time_s": 400.0, "ade_L30_ratio": 0.6, "npss_L30_ratio": 0.5}]
    (tmp_path / "ref.json").write_text(json.dumps({"curve": {"points": slow}}))
    compare = load_cli("compare")
    code = compare.main([f"ref={tmp_path / 'ref.json'}", str(run), "--lengths", "30", "--metrics", "ade,npss",
                         "--at", "120", "--out", str(tmp_path / "c.png"), "--json", str(tmp_path / "c.json")])
    assert code == 0 and (tmp_path / "c.png").stat().st_size > 0
    table = json.loads((tmp_path / "c.json").read_text())
    assert table["reference"] == "ref" and table["reference_final_quality"] == pytest.approx(0.55)
    fast = table["runs"]["fast"]
    assert fast["step"] == 200 and fast["quality"] == pytest.approx((0.8 + 0.5) / 2)  # the last point by 120 s
    assert fast["reached_reference_final_s"] == 140.0  # (0.4 + 0.4) / 2 <= 0.55 at step 300
    assert table["runs"]["ref"]["reached_reference_final_s"] == 400.0
    assert "fast | 200" in capsys.readouterr().out


def test_compare_refuses_a_run_without_validation_records(tmp_path, capsys):
    (tmp_path / "metrics.jsonl").write_text(json.dumps({"step": 1, "loss": 1.0, "time_s": 1.0}) + "\n")
    assert load_cli("compare").main([str(tmp_path)]) == 2
    assert "train.eval_every" in capsys.readouterr().err
