"""A self-contained HTML page that plays motions as 3D skeletons: orbit, zoom, play, scrub, one toggle per motion.

    page = viewer_html([sample0, sample1], parents, fps=30, keyframes=(10, 40), contacts=ContactMarks(model.feet))
    pathlib.Path("out.html").write_text(page)          # opens in any browser, no network
    show([sample0, sample1], parents, fps=30, keyframes=(10, 40))   # a notebook cell shows it inline

Motions are FK *global* positions (T, J, 3) in cm, +Y up (:func:`stitchjax.sample.takes.to_model_frame` brings a
take there), all with the same T and skeleton ``parents``. The page holds the motions as JSON (positions rounded
to 0.1 cm), the renderer (``viewer.js`` beside this module: a canvas with its own perspective camera, no
library) and its style; it loads nothing.

Foot contacts are drawn as dots on the contact joints (:class:`ContactMarks`): the ones given (e.g. the model's
predicted contacts), else measured from the motion as the training labels are (:func:`foot_contacts_at_rate`).
"""
from __future__ import annotations

import dataclasses
import html
import importlib.resources
import json
import os
import pathlib
from typing import Sequence

import numpy as np
from matplotlib.colors import to_hex

from stitchjax.data.windows import CONTACT_THRESHOLD, foot_contacts
from stitchjax.eval.drawing import sample_color

__all__ = ["viewer_html", "viewer_data", "show", "Viewer", "ContactMarks", "foot_contacts_at_rate", "PAGE_HEIGHT_PX"]

KEYFRAME_COLOR = "#111111"
REFERENCE_COLOR = "#9a9a9a"
CONTACT_COLOR = "#ff2d55"
POSITION_STEPS_PER_CM = 10  # positions are stored as whole tenths of a centimetre
PAGE_HEIGHT_PX = 640  # the inline frame's height in a notebook

_STYLE = """
body { margin: 0; font: 13px system-ui, sans-serif; color: #222; background: #fff; }
#stitchjax-viewer { max-width: 1100px; margin: 0 auto; padding: 6px; }
.sjv-title { font-weight: 600; margin: 2px 0 6px; }
.sjv-canvas { display: block; width: 100%; height: 460px; border: 1px solid #dde; border-radius: 4px;
  cursor: grab; touch-action: none; }
.sjv-bar { display: flex; align-items: center; gap: 8px; margin-top: 6px; }
.sjv-slider { flex: 1; }
.sjv-label { font-variant-numeric: tabular-nums; min-width: 17em; }
.sjv-toggles { display: flex; flex-wrap: wrap; gap: 4px 14px; margin-top: 6px; }
.sjv-toggle { display: inline-flex; align-items: center; gap: 4px; cursor: pointer; }
.sjv-swatch, .sjv-dot { display: inline-block; width: 14px; height: 4px; border-radius: 2px; }
.sjv-dot { width: 9px; height: 9px; border-radius: 50%; }
.sjv-legend { display: inline-flex; align-items: center; gap: 4px; color: #555; }
.sjv-error { color: #b00020; white-space: pre-wrap; }
.sjv-help { color: #666; margin-top: 4px; }
"""

_HELP = ("drag: orbit · shift-drag: pan · wheel: zoom · space: play / pause · arrows: step a frame · "
         "keyframes in black")


def foot_contacts_at_rate(positions, feet, fps: float, reference_fps: float = 30.0,
                          threshold: float = CONTACT_THRESHOLD) -> np.ndarray:
    """Foot contacts (T, C) bool of a motion (T, J, 3) cm at ``fps``, measured as the training labels are
    (:func:`stitchjax.data.windows.foot_contacts`: a contact joint moves less than ``sqrt(threshold)`` cm per
    frame at ``reference_fps``, the data's frame rate): at another rate the limit per frame scales with the
    frame time, so the same speed counts."""
    p = np.asarray(positions, np.float64)
    if p.ndim != 3 or p.shape[0] < 2:
        return np.zeros((p.shape[0] if p.ndim else 0, len(feet)), bool)
    per_frame = float(threshold) * (float(reference_fps) / float(fps)) ** 2
    return foot_contacts(p, tuple(int(f) for f in feet), per_frame) > 0.5


def _checked(motions, parents) -> list:
    """The motions as (T, J, 3) float64 arrays; ValueError naming a bad shape."""
    if isinstance(motions, np.ndarray) and motions.ndim == 3:
        motions = [motions]
    motions = [np.asarray(m, np.float64) for m in motions]
    if not motions:
        raise ValueError("the viewer needs at least one motion")
    t = motions[0].shape[0]
    for m in motions:
        if m.ndim != 3 or m.shape != (t, len(parents), 3) or t < 1:
            raise ValueError(f"viewer motions must all be (T, J, 3) = ({t}, {len(parents)}, 3) global positions, "
                             f"got {m.shape}")
        if not np.all(np.isfinite(m)):
            raise ValueError("viewer motions hold non-finite positions")
    return motions


def _packed(positions) -> list:
    """Positions (..., 3) cm as a flat list of whole tenths of a centimetre."""
    return np.rint(np.asarray(positions) * POSITION_STEPS_PER_CM).astype(np.int64).ravel().tolist()


def _contact_bits(contacts) -> list:
    """(T, C) bool -> T ints, bit k set where contact joint k touches."""
    c = np.asarray(contacts, bool)
    return (c * (1 << np.arange(c.shape[1]))).sum(axis=1).astype(int).tolist()


@dataclasses.dataclass(frozen=True)
class ContactMarks:
    """Which foot contacts the page marks: the contact joints ``feet`` (joint indices), and per motion either
    ``given`` (one (T, len(feet)) array per motion, > 0.5 is a contact, e.g. the model's predicted contacts;
    ``source`` names them in the legend) or, when None, contacts measured from the motions as the training
    labels are (:func:`foot_contacts_at_rate` at ``reference_fps``, the training data's frame rate)."""

    feet: tuple
    given: tuple | None = None
    source: str = ""
    reference_fps: float = 30.0

    def __post_init__(self):
        object.__setattr__(self, "feet", tuple(int(f) for f in self.feet))
        if self.given is not None:
            object.__setattr__(self, "given", tuple(np.asarray(c) for c in self.given))
        if not self.source:
            object.__setattr__(self, "source", "given" if self.given is not None else "foot speed")

    def of(self, index: int, motion, fps: float, name: str):
        """(T, C) bool contacts of ``motion`` (T, J, 3) at ``fps``: the given ones of motion ``index``, or measured
        (none given, or ``index`` None); None without feet. ValueError naming a bad shape."""
        marks = self.given[index] if self.given is not None and index is not None else None
        if marks is None:
            return foot_contacts_at_rate(motion, self.feet, fps, self.reference_fps) if self.feet else None
        if np.shape(marks) != (motion.shape[0], len(self.feet)):
            raise ValueError(f"contacts of {name!r} must be (T, C) = ({motion.shape[0]}, {len(self.feet)}), got "
                             f"{np.shape(marks)}")
        return marks > 0.5


def viewer_data(motions, parents, *, fps: float = 30.0, keyframes: Sequence[int] | None = None,
                titles: Sequence[str] | None = None, contacts: ContactMarks | None = None, reference=None,
                title: str = "") -> dict:
    """The page's motion data (the JSON :func:`viewer_html` embeds; see it for the arguments).

    Fields: ``parents``, ``feet``, ``fps``, ``num_frames``, ``scale`` (steps per cm of the integer
    positions), ``ground`` (cm), ``keyframes`` and ``transition`` (frame indices), ``tracks`` (name, colour,
    flat positions (T * J * 3), per-frame contact bits or None, visible), ``keyposes`` (the keyframe poses),
    colours and ``contact_source``."""
    motions = _checked(motions, parents)
    num_frames = motions[0].shape[0]
    keyframes = (0, num_frames - 1) if keyframes is None else tuple(int(k) % num_frames for k in keyframes)
    contacts = ContactMarks(()) if contacts is None else contacts
    if contacts.given is not None and len(contacts.given) != len(motions):
        raise ValueError(f"contacts: give one (T, C) array per motion ({len(motions)}), got {len(contacts.given)}")
    names = [str(titles[i]) if titles is not None and i < len(titles) else f"sample {i}" for i in range(len(motions))]
    shown = [(i, m, names[i], to_hex(sample_color(i)), True) for i, m in enumerate(motions)]
    if reference is not None:  # the take's own frames: contacts always measured, hidden until ticked
        reference = _checked([reference], parents)[0]
        if reference.shape[0] != num_frames:
            raise ValueError(f"the reference has {reference.shape[0]} frames, the motions {num_frames}")
        shown.insert(0, (None, reference, "input", REFERENCE_COLOR, False))
    tracks = []
    for index, m, name, color, visible in shown:
        marks = contacts.of(index, m, fps, name)
        tracks.append({"name": name, "color": color, "positions": _packed(m), "visible": visible,
                       "contacts": None if marks is None else _contact_bits(marks)})
    lowest = np.stack(motions)[..., 1].min(axis=-1)  # (S, T): the lowest joint of each pose
    return {
        "title": str(title), "fps": float(fps), "num_frames": int(num_frames), "parents": [int(p) for p in parents],
        "feet": list(contacts.feet), "scale": POSITION_STEPS_PER_CM, "units": "cm",
        # most frames have a foot down: the 5th percentile of the lowest joint, robust to a sunken foot or a jump
        "ground": round(float(np.percentile(lowest, 5)), 1),
        "keyframes": list(keyframes), "transition": [min(keyframes), max(keyframes)], "tracks": tracks,
        "keyposes": [{"frame": k, "positions": _packed(motions[0][k])} for k in dict.fromkeys(keyframes)],
        "keyframe_color": KEYFRAME_COLOR, "contact_color": CONTACT_COLOR, "contact_source": contacts.source,
    }


def _script() -> str:
    """The renderer, viewer.js, to inline in a script element (which "</" inside it would close)."""
    script = importlib.resources.files("stitchjax.eval").joinpath("viewer.js").read_text(encoding="utf-8")
    return script.replace("</", "<\\/")


def viewer_html(motions, parents, *, fps: float = 30.0, keyframes: Sequence[int] | None = None,
                titles: Sequence[str] | None = None, contacts: ContactMarks | None = None, reference=None,
                title: str = "") -> str:
    """One self-contained HTML page (str) that plays ``motions`` as 3D skeletons on a ground grid.

    motions: list of (T, J, 3) global positions (cm, +Y up), or one (T, J, 3); parents: (J,) parent indices.
    fps: the motions' frame rate (playback speed). keyframes: frame indices drawn as black skeletons all the
    time (default: first and last); the frames between the first and last are called "transition".
    titles: one name per motion (default "sample k"). contacts: the foot contacts to mark (:class:`ContactMarks`;
    None: none). reference: an optional (T, J, 3) motion (e.g. the take's own frames), called "input", hidden
    until ticked, its contacts measured. Positions are rounded to 0.1 cm.
    """
    data = viewer_data(motions, parents, fps=fps, keyframes=keyframes, titles=titles, contacts=contacts,
                       reference=reference, title=title)
    # "<" escaped: the JSON cannot close its <script> element
    payload = json.dumps(data, separators=(",", ":")).replace("<", "\\u003c")
    heading = html.escape(title or "stitchjax viewer")
    return (f'<!DOCTYPE html>\n<html lang="en">\n<head>\n<meta charset="utf-8">\n<title>{heading}</title>\n'
            f'<meta name="viewport" content="width=device-width, initial-scale=1">\n<style>{_STYLE}</style>\n</head>\n'
            f'<body>\n<div class="sjv-title" style="max-width:1100px;margin:6px auto 0;padding:0 6px">{heading}</div>\n'
            f'<div id="stitchjax-viewer"></div>\n<div class="sjv-help" style="max-width:1100px;margin:0 auto;'
            f'padding:0 6px">{html.escape(_HELP)}</div>\n'
            f'<script type="application/json" id="stitchjax-data">{payload}</script>\n'
            f'<script>\n{_script()}\n</script>\n</body>\n</html>\n')


class Viewer:
    """A viewer page that a notebook shows inline (``_repr_html_``: the page in an inline frame, so its script
    runs on its own) and that can be written to a file."""

    def __init__(self, page: str, height: int = PAGE_HEIGHT_PX):
        self.html = page
        self.height = int(height)

    def _repr_html_(self) -> str:
        return (f'<iframe srcdoc="{html.escape(self.html, quote=True)}" style="width:100%;height:{self.height}px;'
                f'border:0" title="stitchjax viewer" data-stitchjax-viewer="1"></iframe>')

    def save(self, path) -> pathlib.Path:
        """Write the page to ``path`` (an .html file); returns the path."""
        path = pathlib.Path(os.fspath(path))
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(self.html, encoding="utf-8")
        return path


def show(motions, parents, **kwargs) -> Viewer:
    """The viewer of ``motions`` for a notebook: the last expression of a cell displays it inline.
    Arguments: as :func:`viewer_html`."""
    return Viewer(viewer_html(motions, parents, **kwargs))
