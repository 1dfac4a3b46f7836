"""The 3D viewer page (stitchjax.eval.viewer): self-contained, holds the motions rounded to 0.1 cm, marks foot
contacts given or measured at the motion's frame rate, shows inline in a notebook, and draws in a real headless
browser (Debian's chromium; skipped where none is installed)."""
import html
import json
import re
import shutil
import subprocess

import numpy as np
import pytest

from stitchjax.eval import viewer
from stitchjax.skeleton import LAFAN1_PARENTS, forward_kinematics

J = len(LAFAN1_PARENTS)
FEET = (3, 4, 7, 8)
CHROMIUM_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                  "--disable-background-networking", "--disable-component-update", "--disable-sync",
                  "--hide-scrollbars"]


def _motion(num_frames=40, seed=0, speed=3.0):
    """(T, J, 3) global positions (cm, Y-up) of a made-up LAFAN1-like figure about 170 cm tall, its root moving
    ``speed`` cm per frame along x."""
    rng = np.random.default_rng(seed)
    offsets = rng.normal(size=(J, 3)) * 2.0
    offsets[1:, 1] -= 12.0  # bones hanging down
    rot = np.zeros((num_frames, J, 4))
    rot[..., 0] = 1.0
    rot[..., 1:] = rng.normal(size=(num_frames, J, 3)) * 0.05
    rot /= np.linalg.norm(rot, axis=-1, keepdims=True)
    pos = np.broadcast_to(offsets, (num_frames, J, 3)).copy()
    pos[:, 0] = np.stack([speed * np.arange(num_frames), np.full(num_frames, 95.0), np.zeros(num_frames)], -1)
    return forward_kinematics(rot, pos, LAFAN1_PARENTS)[1]


def _data(page: str) -> dict:
    found = re.search(r'<script type="application/json" id="stitchjax-data">(.*?)</script>', page, re.S)
    assert found, "the page holds no motion data"
    return json.loads(found.group(1))


def test_page_is_self_contained_and_holds_the_motions_to_a_tenth_of_a_cm():
    motions = [_motion(seed=s) for s in range(3)]
    page = viewer.viewer_html(motions, LAFAN1_PARENTS, fps=30, keyframes=(5, 30), contacts=viewer.ContactMarks(FEET),
                              reference=motions[0], title="walk </script><b>x</b>")
    assert page.startswith("<!DOCTYPE html>") and page.count("<script") == 2
    assert not re.search(r"(src|href)\s*=|https?://|import\s*\(|fetch\(", page)  # loads nothing
    assert "<b>x</b>" not in page and "&lt;/script&gt;" in page  # the title is text, not markup
    data = _data(page)
    assert data["num_frames"] == 40 and data["parents"] == list(LAFAN1_PARENTS) and data["fps"] == 30
    assert data["keyframes"] == [5, 30] and [k["frame"] for k in data["keyposes"]] == [5, 30]
    assert [t["name"] for t in data["tracks"]] == ["input", "sample 0", "sample 1", "sample 2"]
    assert [t["visible"] for t in data["tracks"]] == [False, True, True, True]  # the input until ticked
    assert data["title"] == "walk </script><b>x</b>"  # "<" escaped inside the JSON, intact once parsed
    for track, motion in zip(data["tracks"][1:], motions):
        stored = np.asarray(track["positions"]).reshape(40, J, 3) / data["scale"]
        assert np.abs(stored - motion).max() <= 0.05 + 1e-9  # rounded to 0.1 cm
        assert len(track["contacts"]) == 40
    assert len({t["color"] for t in data["tracks"]}) == 4
    lowest = np.stack(motions)[..., 1].min(axis=-1)
    assert lowest.min() - 0.05 <= data["ground"] <= np.median(lowest) + 0.05


def _feet_moving(speeds_cm_per_s, fps, seconds=1.0):
    """(T, F, 3): foot joints moving along x at the given speeds (one per joint)."""
    t = np.arange(int(round(seconds * fps)) + 1) / fps
    p = np.zeros((len(t), len(speeds_cm_per_s), 3))
    p[..., 0] = t[:, None] * np.asarray(speeds_cm_per_s, float)
    return p


def test_contacts_measured_as_the_training_labels_at_the_motions_rate():
    """The data code's rule (0.02 cm² per frame at 30 fps: under 4.2 cm/s) holds at any frame rate."""
    for fps in (30, 60, 120):
        contacts = viewer.foot_contacts_at_rate(_feet_moving([0.0, 3.0, 6.0, 60.0], fps), range(4), fps=fps)
        assert contacts[:, :2].all() and not contacts[:, 2:].any(), fps


def test_contacts_given_win_and_are_stored_as_bits_per_frame():
    motion = np.zeros((30, J, 3))
    motion[:, :, 1] = np.linspace(0, 170, J)
    motion[15:, FEET[0], 0] = 2.0 * np.arange(1, 16)  # the left ankle slides from frame 14 on
    measured = viewer.viewer_data([motion], LAFAN1_PARENTS, contacts=viewer.ContactMarks(FEET))
    assert measured["tracks"][0]["contacts"] == [15] * 14 + [14] * 16
    assert measured["contact_source"] == "foot speed"
    given = np.zeros((30, 4))
    given[:, 2] = 1.0
    data = viewer.viewer_data([motion], LAFAN1_PARENTS, contacts=viewer.ContactMarks(FEET, given=[given],
                                                                                     source="predicted"))
    assert data["tracks"][0]["contacts"] == [4] * 30 and data["contact_source"] == "predicted"
    assert viewer.viewer_data([motion], LAFAN1_PARENTS)["tracks"][0]["contacts"] is None  # no feet, no marks


def test_bad_motions_are_refused_naming_the_shape():
    with pytest.raises(ValueError, match=r"\(T, J, 3\) = \(40, 22, 3\).*\(40, 23, 3\)"):
        viewer.viewer_html([_motion(), np.zeros((40, 23, 3))], LAFAN1_PARENTS)
    with pytest.raises(ValueError, match="contacts of 'sample 0' must be"):
        viewer.viewer_html([_motion()], LAFAN1_PARENTS, contacts=viewer.ContactMarks(FEET, given=[np.zeros((40, 2))]))


def test_notebook_helper_shows_the_same_page_inline(tmp_path):
    motions = [_motion(seed=s) for s in range(2)]
    shown = viewer.show(motions, LAFAN1_PARENTS, fps=30, contacts=viewer.ContactMarks(FEET))
    inline = shown._repr_html_()
    assert inline.startswith("<iframe") and 'data-stitchjax-viewer="1"' in inline
    srcdoc = re.search(r'srcdoc="([^"]*)"', inline).group(1)
    assert html.unescape(srcdoc) == shown.html == viewer.viewer_html(motions, LAFAN1_PARENTS, fps=30,
                                                                     contacts=viewer.ContactMarks(FEET))
    path = shown.save(tmp_path / "page.html")
    assert path.read_text() == shown.html


# --------------------------------------------------------------------------------------- in a real browser


def _chromium() -> str:
    browser = shutil.which("chromium") or shutil.which("chromium-browser")
    if browser is None:
        pytest.skip("no chromium on this machine (Debian: apt-get install chromium): the page is not opened in a "
                    "browser here")
    return browser


def _open(browser, page_path, tmp_path, *extra):
    """Run headless chromium on the page: (its stderr, stdout)."""
    profile = tmp_path / f"profile{len(list(tmp_path.glob('profile*')))}"
    proc = subprocess.run([browser, *CHROMIUM_FLAGS, f"--user-data-dir={profile}", "--enable-logging=stderr",
                           "--v=0", "--virtual-time-budget=1500", *extra, page_path.as_uri()],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return proc.stderr, proc.stdout


def _console(stderr: str) -> list:
    """The page's console messages (chromium logs them as CONSOLE lines)."""
    return [line for line in stderr.splitlines() if ":CONSOLE" in line]


@pytest.mark.slow
def test_page_draws_in_headless_chromium_without_console_errors(tmp_path):
    from PIL import Image

    browser = _chromium()
    motions = [_motion(seed=s, speed=2.0 * s) for s in range(3)]
    page = tmp_path / "page.html"
    page.write_text(viewer.viewer_html(motions, LAFAN1_PARENTS, fps=30, keyframes=(0, 39),
                                       contacts=viewer.ContactMarks(FEET)))
    stderr, dom = _open(browser, page, tmp_path, "--dump-dom")
    assert _console(stderr) == []
    element = re.search(r'<div id="stitchjax-viewer"[^>]*>', dom).group(0)
    assert "data-error" not in element
    drawn = re.search(r'data-frames-drawn="(\d+)"', element)
    assert drawn and int(drawn.group(1)) >= 1
    assert dom.count('type="checkbox"') == 3 + 2  # one per sample, the keyframes, the root paths
    shot = tmp_path / "shot.png"
    _open(browser, page, tmp_path, "--window-size=900,640", f"--screenshot={shot}")
    pixels = np.asarray(Image.open(shot).convert("RGB")).astype(int)
    canvas = pixels[40:480]  # the canvas, above the controls
    background = np.array([0xF7, 0xF8, 0xFA])
    drawn_pixels = np.abs(canvas - background).sum(axis=-1) > 40
    assert drawn_pixels.mean() > 0.005  # the grid and the skeletons
    for color in ("#1f77b4", "#ff7f0e", "#2ca02c", "#111111"):  # every sample's colour and the keyframes'
        rgb = np.array([int(color[i:i + 2], 16) for i in (1, 3, 5)])
        assert (np.abs(canvas - rgb).sum(axis=-1) < 30).sum() > 20, color


@pytest.mark.slow
def test_headless_check_sees_a_page_that_fails(tmp_path):
    """The browser check above would catch a broken page: motion data of the wrong size is reported in the page
    (data-error) and on the console."""
    browser = _chromium()
    page_text = viewer.viewer_html([_motion()], LAFAN1_PARENTS)
    data = _data(page_text)
    data["tracks"][0]["positions"] = data["tracks"][0]["positions"][:-3]
    broken = page_text.replace(re.search(r'id="stitchjax-data">(.*?)</script>', page_text, re.S).group(1),
                               json.dumps(data))
    page = tmp_path / "broken.html"
    page.write_text(broken)
    stderr, dom = _open(browser, page, tmp_path, "--dump-dom")
    assert 'data-error="motion \'sample 0\' holds' in dom
    assert any("Uncaught" in line for line in _console(stderr))
