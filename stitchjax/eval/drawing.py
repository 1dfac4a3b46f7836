"""Drawing primitives of the figures (:mod:`stitchjax.eval.plots`, :mod:`stitchjax.eval.animation`): the
screen projection, frame colours, a pose as a stick figure, and figures on an Agg canvas.

Poses are FK *global* positions (file units, Y-up) with the skeleton's ``parents`` tuple, drawn in a
vertical plane seen from the side. Views: ``view="side"`` looks along -Z (the x-y plane),
``view="front"`` along +X (the z-y plane), a number is an azimuth in degrees (the horizontal screen axis is
``cos(a) x + sin(a) z``), and ``view="auto"`` (default) picks the azimuth of the main direction of root
travel, so a walking character is seen in profile.

Colours: keyframes are drawn in black, transition frames with a colour map running from the start to
the target keyframe, other frames (context kept from the file) in light grey.

Figures are ``matplotlib.figure.Figure`` on matplotlib's non-interactive Agg canvas (no pyplot, no display);
:func:`finish_figure` writes one at its own size (``figsize * dpi`` pixels exactly, no tight bounding box).
"""
from __future__ import annotations

import os
import pathlib
from typing import Sequence

import matplotlib
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

__all__ = ["KEYFRAME_COLOR", "CONTEXT_COLOR", "DEFAULT_CMAP", "SAMPLE_CMAP", "horizontal_axis", "project",
           "frame_colors", "sample_color", "check_pose", "draw_skeleton", "draw_skeleton_from_above", "new_figure",
           "finish_figure", "frame_axes"]

KEYFRAME_COLOR = "black"
CONTEXT_COLOR = "0.75"
DEFAULT_CMAP = "viridis"
SAMPLE_CMAP = "tab10"  # one colour per sample where samples are told apart (and in stitchjax.eval.viewer)


# --------------------------------------------------------------------------------------- geometry


def horizontal_axis(positions, view="auto") -> np.ndarray:
    """Unit horizontal direction (x, z) used as the screen's horizontal axis.

    positions: (..., T, J, 3) or a list of such arrays (global, Y-up); only used by ``view="auto"``,
    which takes the principal direction of the root's x-z displacement over all frames (or +X when
    the root hardly moves).
    """
    if isinstance(view, str):
        if view == "side":
            return np.array([1.0, 0.0])
        if view == "front":
            return np.array([0.0, 1.0])
        if view != "auto":
            raise ValueError(f"view must be 'auto', 'side', 'front' or an azimuth in degrees, got {view!r}")
        arrays = positions if isinstance(positions, (list, tuple)) else [positions]
        roots = [np.asarray(p, dtype=np.float64)[..., 0, :].reshape(-1, 3)[:, [0, 2]] for p in arrays]
        xz = np.concatenate([r - r.mean(axis=0) for r in roots], axis=0)
        if xz.shape[0] < 2 or np.abs(xz).max() < 1e-6:
            return np.array([1.0, 0.0])
        _, s, vt = np.linalg.svd(xz, full_matrices=False)
        direction = vt[0]
        if s[0] < 1e-6:
            return np.array([1.0, 0.0])
        # Point the axis along the travel from the first to the last root position of the first motion.
        first = roots[0]
        if np.dot(first[-1] - first[0], direction) < 0:
            direction = -direction
        return direction / np.linalg.norm(direction)
    angle = np.deg2rad(float(view))
    return np.array([np.cos(angle), np.sin(angle)])


def project(positions, axis) -> np.ndarray:
    """(..., 3) global positions -> (..., 2) screen coordinates (horizontal along ``axis``, height y)."""
    p = np.asarray(positions, dtype=np.float64)
    h = p[..., 0] * axis[0] + p[..., 2] * axis[1]
    return np.stack([h, p[..., 1]], axis=-1)


def frame_colors(num_frames: int, keyframes: Sequence[int] = (), transition: tuple | None = None,
                 cmap: str = DEFAULT_CMAP) -> list:
    """One matplotlib colour per frame: black at ``keyframes``, the colour map over the
    ``transition`` frames (first, last) inclusive, light grey elsewhere.

    ``transition=None`` colours every non-keyframe with the colour map.
    """
    colormap = matplotlib.colormaps[cmap]
    first, last = (0, num_frames - 1) if transition is None else transition
    span = max(last - first, 1)
    colors = []
    for t in range(num_frames):
        if t in keyframes:
            colors.append(KEYFRAME_COLOR)
        elif first <= t <= last:
            colors.append(colormap(0.1 + 0.8 * (t - first) / span))
        else:
            colors.append(CONTEXT_COLOR)
    return colors


def sample_color(index: int):
    """The colour of sample ``index`` where samples are told apart by colour (matplotlib's tab10, cycling)."""
    return matplotlib.colormaps[SAMPLE_CMAP](int(index) % 10)


def check_pose(positions, parents):
    """(J, 3) float64 global positions of one pose; ValueError naming a bad shape."""
    p = np.asarray(positions, dtype=np.float64)
    if p.ndim != 2 or p.shape[-1] != 3 or p.shape[0] != len(parents):
        raise ValueError(f"a pose must be global positions (J, 3) with J = {len(parents)} joints, got "
                         f"shape {p.shape}")
    return p


# ----------------------------------------------------------------------------------------- poses


def draw_skeleton(ax, positions, parents, *, axis=(1.0, 0.0), shift: float = 0.0, color="C0",
                  linewidth: float = 1.5, alpha: float = 1.0, zorder: int = 2, shade_far: bool = True) -> list:
    """Draw one pose as a stick figure on ``ax``: one line per bone (J - 1 lines).

    positions: (J, 3) global positions (Y-up); parents: (J,) parent indices (-1 for the root).
    axis: horizontal screen direction (x, z) (see :func:`horizontal_axis`); shift: added to the
    horizontal screen coordinate (to lay figures side by side). shade_far: bones farther from the
    viewer than the root are drawn fainter and thinner, so left and right limbs can be told apart.
    Returns the list of Line2D bones.
    """
    p = check_pose(positions, parents)
    axis = np.asarray(axis, dtype=np.float64)
    screen = project(p, axis)
    screen[:, 0] += shift
    # Towards the viewer: (axis_x, 0, axis_z) x (0, 1, 0) = (-axis_z, 0, axis_x).
    nearness = -axis[1] * p[:, 0] + axis[0] * p[:, 2]
    lines = []
    for j, parent in enumerate(parents):
        if parent < 0:
            continue
        far = shade_far and 0.5 * (nearness[j] + nearness[parent]) < nearness[0] - 1e-9
        (line,) = ax.plot(screen[[parent, j], 0], screen[[parent, j], 1], color=color,
                          linewidth=linewidth * (0.75 if far else 1.0), alpha=alpha * (0.45 if far else 1.0),
                          solid_capstyle="round", zorder=zorder - (0.5 if far else 0.0))
        lines.append(line)
    return lines


def draw_skeleton_from_above(ax, positions, parents, *, color="black", linewidth: float = 1.2,
                             alpha: float = 1.0, zorder: int = 2) -> list:
    """Draw one pose (J, 3) (Y-up) seen from above on ``ax``: each bone's x (right) against z (the axes'
    vertical; invert it for z pointing down the page). Returns the bones' Line2D (J - 1)."""
    p = check_pose(positions, parents)
    lines = []
    for j, parent in enumerate(parents):
        if parent >= 0:
            (line,) = ax.plot(p[[parent, j], 0], p[[parent, j], 2], color=color, linewidth=linewidth, alpha=alpha,
                              solid_capstyle="round", zorder=zorder)
            lines.append(line)
    return lines


# --------------------------------------------------------------------------------------- figures


def finish_figure(fig: Figure, path) -> Figure:
    """``fig``, written as an image at ``path`` (PNG by its suffix) at its own dpi unless ``path`` is None."""
    if path is not None:
        path = pathlib.Path(os.fspath(path))
        path.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(path, dpi=fig.dpi)
    return fig


def new_figure(figsize, dpi) -> Figure:
    """An empty Figure of ``figsize`` inches at ``dpi`` on an Agg canvas."""
    # Figure() on an Agg canvas, not pyplot: no display needed, whatever backend the host uses, and
    # figures are not kept alive by pyplot's registry (they still display inline in notebooks).
    fig = Figure(figsize=figsize, dpi=dpi)
    FigureCanvasAgg(fig)
    return fig


def frame_axes(ax, xmin, xmax, ymin, ymax, margin: float = 0.08):
    """Equal aspect, a small margin, the ground line at y = ymin, no ticks."""
    w, h = max(xmax - xmin, 1e-6), max(ymax - ymin, 1e-6)
    pad = margin * max(w, h)
    ax.set_xlim(xmin - pad, xmax + pad)
    ax.set_ylim(ymin - pad, ymax + pad)
    ax.set_aspect("equal", adjustable="box")
    ax.set_xticks([])
    ax.set_yticks([])
    for side in ("top", "right", "left", "bottom"):
        ax.spines[side].set_visible(False)
