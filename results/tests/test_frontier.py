"""results/frontier.py: every model row at one length as a point, a setting counted once, sorted by spread."""
import json
import pathlib
import sys

import pytest

SCRIPT = pathlib.Path(__file__).resolve().parent.parent / "frontier.py"
sys.path.insert(0, str(SCRIPT.parent))
import frontier  # noqa: E402


def _row(spread, ade):
    return {"spread_mid": spread, "ade": ade, "slde": 0.03, "npss": 0.4, "foot_slide": 2.0}


def _write(path, entry, settings):
    path.write_text(json.dumps({"lengths": {"50": entry}, "settings": settings}))
    return str(path)


def test_points_merge_files_once_per_setting_sorted_by_spread_with_the_first_interpolation(tmp_path):
    a = _write(tmp_path / "a.json", {"model": _row(2.0, 0.21), "model_noise0": _row(0.0, 0.20),
                                     "interp": _row(0.0, 0.23)}, {"model": "x1", "model_noise0": "x0"})
    b = _write(tmp_path / "b.json", {"model": _row(2.1, 0.99), "model_noise4": _row(9.0, 0.25),
                                     "interp": _row(0.0, 0.5)}, {"model": "x1", "model_noise4": "x4"})
    rows, interp = frontier.points([a, b], "50")
    assert [setting for setting, _ in rows] == ["x0", "x1", "x4"]
    assert rows[1][1]["ade"] == 0.21  # x1 from the first file, not the second's
    assert interp["ade"] == 0.23


def test_widest_below_interpolation_needs_every_figure_below():
    interp = {**_row(0.0, 0.23), "slde": 0.035}
    rows = [("x0", _row(0.0, 0.20)), ("x2", _row(5.0, 0.22)), ("x4", _row(9.0, 0.24)), ("x3", _row(7.0, 0.225))]
    assert frontier.widest_below(rows, interp, ["ade"]) == ("x3", 7.0)
    rows[3][1]["slde"] = 0.04  # x3 now loses to interpolation on SLDE
    assert frontier.widest_below(rows, interp, ["ade", "slde"]) == ("x2", 5.0)
    assert frontier.widest_below(rows, _row(0.0, 0.1), ["ade"]) is None


def test_a_missing_length_is_refused_by_name(tmp_path):
    a = _write(tmp_path / "a.json", {"model": _row(2.0, 0.21)}, {})
    with pytest.raises(SystemExit, match="no results at L = 30"):
        frontier.points([a], "30")


def test_main_writes_the_figure(tmp_path, capsys):
    a = _write(tmp_path / "a.json", {"model": _row(2.0, 0.21), "interp": _row(0.0, 0.23)}, {"model": "x1"})
    out = tmp_path / "f.png"
    assert frontier.main([f"m={a}", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert out.stat().st_size > 10000 and "| m | x1 | 2.00 |" in printed
    assert "| m | 2.00 cm (x1) | none |" in printed  # below on ADE (0.21 < 0.23), not on SLDE (equal)
    with pytest.raises(SystemExit, match="LABEL=FILE"):
        frontier.main([a, "--out", str(out)])
