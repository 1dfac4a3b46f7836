"""time_to_quality.py: loop time summed across resumes and runs, and the first validation row that
beats interpolation on both NPSS and foot slide."""
import json
import pathlib
import sys

import pytest

SCRIPT = pathlib.Path(__file__).resolve().parent / "time_to_quality.py"
sys.path.insert(0, str(SCRIPT.parent))
import time_to_quality  # noqa: E402


def _write(path, rows):
    path.write_text("".join(json.dumps(r) + "\n" for r in rows))
    return path


def _val(step, time_s, npss, foot_slide):
    return {"step": step, "time_s": time_s, "val_npss_L30": npss, "val_npss_L30_interp": 0.12,
            "val_foot_slide_L30": foot_slide, "val_foot_slide_L30_interp": 1.4}


def test_lineage_sums_resumed_processes_and_finds_the_first_row_that_beats_both(tmp_path):
    first = _write(tmp_path / "a.jsonl", [
        {"step": 10, "time_s": 5.0}, _val(20, 10.0, 0.13, 1.0),
        {"step": 30, "time_s": 3.0},  # resumed: the clock restarted
        _val(40, 6.0, 0.11, 2.0),  # NPSS only
        {"step": 50, "time_s": 9.0}])  # after the next run's start: not counted
    second = _write(tmp_path / "b.jsonl", [
        {"step": 50, "time_s": 4.0}, _val(60, 8.0, 0.11, 1.3), _val(70, 12.0, 0.10, 1.0)])
    out = time_to_quality.lineage([first, second], length=30)
    assert [s["loop_s"] for s in out["segments"]] == [16.0, 12.0]  # 10 + 6 (step 50 excluded), then 12
    assert out["segments"][1]["cumulative_s"] == 28.0
    assert out["first_below_interp_npss"]["step"] == 40 and out["first_below_interp_npss"]["wall_s"] == 16.0
    both = out["first_below_interp_npss_and_foot_slide"]
    assert both["step"] == 60 and both["wall_s"] == 24.0 and both["val_foot_slide_L30"] == 1.3


def test_missing_file_is_refused_by_name(tmp_path):
    with pytest.raises(SystemExit, match="no such file"):
        time_to_quality.main([str(tmp_path / "nope.jsonl")])
