"""Animated GIFs of motions playing side by side (Pillow writer), drawn with :mod:`stitchjax.eval.drawing`."""
from __future__ import annotations

import dataclasses
import os
import pathlib
from typing import Any, Sequence

import numpy as np

from stitchjax.eval.drawing import (DEFAULT_CMAP, draw_skeleton, frame_axes, frame_colors, horizontal_axis, new_figure,
                                    project)

__all__ = ["animate", "GifStyle", "gif_frames", "GIF_MAX_FPS"]

# A GIF stores frame delays in hundredths of a second and browsers show a delay under 0.02 s as 0.1 s: a
# motion above this rate is shown every k-th frame (its keyframes kept) so that it plays at its own speed.
GIF_MAX_FPS = 30.0


def gif_frames(num_frames: int, fps: float, keyframes: Sequence[int] = ()) -> tuple[list, float]:
    """(frame indices a GIF shows, its frame rate): every frame at ``fps`` <= :data:`GIF_MAX_FPS`, else every
    k-th frame (k = ceil(fps / GIF_MAX_FPS)) at fps / k, with the first, last and ``keyframes`` frames too."""
    if not fps > 0:
        raise ValueError(f"fps must be positive, got {fps}")
    step = max(1, int(np.ceil(float(fps) / GIF_MAX_FPS - 1e-9)))
    shown = set(range(0, num_frames, step)) | {num_frames - 1} | {int(k) for k in keyframes}
    return sorted(shown), float(fps) / step


def _panel(ax, motion, parents, axis, first_color, ymin: float, ymax: float, half: float):
    """Set up one panel of :func:`animate` and draw the motion's first frame on it.

    motion: (T, J, 3) global positions; half: half the visible width (file units). The camera follows a
    character that travels further than half its height; marks on the ground every quarter of the body's
    height scroll past. Returns (screen (T, J, 2) coordinates, the bones' Line2D, centres (T,) of the view)."""
    num_frames = motion.shape[0]
    body = max(ymax - ymin, 1e-6)
    screen = project(motion, axis)
    root = screen[:, 0, 0]
    follow = root.max() - root.min() > 0.5 * body
    centres = root if follow else np.full(num_frames, 0.5 * (screen[..., 0].min() + screen[..., 0].max()))
    frame_axes(ax, centres[0] - half, centres[0] + half, ymin, ymax)
    ax.set_xlim(centres[0] - half, centres[0] + half)
    ax.axhline(ymin, color="0.85", linewidth=0.8)
    step = 0.25 * body
    for x in np.arange(np.floor((root.min() - 2 * half) / step), np.ceil((root.max() + 2 * half) / step) + 1) * step:
        ax.plot([x, x], [ymin - 0.03 * body, ymin], color="0.7", linewidth=0.8)
    lines = draw_skeleton(ax, motion[0], parents, axis=axis, color=first_color, linewidth=1.8)
    return screen, lines, centres


@dataclasses.dataclass(frozen=True)
class GifStyle:
    """How :func:`animate` draws: the horizontal ``view`` (:mod:`stitchjax.eval.drawing`), the transition's
    colour map ``cmap``, each panel's ``height`` (inches) and ``dpi``."""

    view: Any = "auto"
    cmap: str = DEFAULT_CMAP
    height: float = 3.6
    dpi: int = 80


def animate(motions, parents, path, *, fps: float = 30.0, keyframes: Sequence[int] | None = None,
            transition: tuple | None = None, titles: Sequence[str] | None = None, style: GifStyle | None = None,
            **style_overrides):
    """Write an animated GIF (Pillow writer) of motions playing side by side, one panel each.

    motions: list of (T, J, 3) global positions, same T. The figure at a keyframe is black, during the
    transition it takes the frame's colour map colour, elsewhere grey. Each panel is square and shows the
    body at about 70 % of its height (``height`` inches at ``dpi``: 288 px, a figure ~210 px tall by
    default); a character that travels further than half its height is followed by the camera, and marks on
    the ground every quarter of the body's height scroll past, so root travel and foot sliding show. A motion
    faster than :data:`GIF_MAX_FPS` shows every k-th frame (:func:`gif_frames`), so it keeps its speed.
    style: a :class:`GifStyle`; style_overrides: its fields as keywords on top of it (``dpi=40``, ...).
    Returns the path written.
    """
    style = dataclasses.replace(style or GifStyle(), **style_overrides)
    view, cmap, height, dpi = style.view, style.cmap, style.height, style.dpi
    from matplotlib.animation import FuncAnimation, PillowWriter

    motions = [np.asarray(m, dtype=np.float64) for m in motions]
    num_frames = motions[0].shape[0]
    keyframes = (0, num_frames - 1) if keyframes is None else tuple(int(k) % num_frames for k in keyframes)
    if transition is None:
        transition = (min(keyframes), max(keyframes))
    colors = frame_colors(num_frames, keyframes, transition, cmap)
    axis = horizontal_axis(motions, view)
    fig = new_figure((height * 0.9 * len(motions), height), dpi)
    axes = fig.subplots(1, len(motions), squeeze=False)[0]
    ymin = min(float(m[..., 1].min()) for m in motions)
    ymax = max(float(m[..., 1].max()) for m in motions)
    half = 0.6 * max(ymax - ymin, 1e-6)  # half the visible width: a square view of the body with a margin
    artists = []
    for i, (ax, m) in enumerate(zip(axes, motions)):
        screen, lines, centres = _panel(ax, m, parents, axis, colors[0], ymin, ymax, half)
        if titles is not None and i < len(titles):
            ax.set_title(str(titles[i]), fontsize=8)
        artists.append((ax, screen, lines, centres))
    counter = fig.text(0.01, 0.01, "", fontsize=7)
    bones = [(p, j) for j, p in enumerate(parents) if p >= 0]
    fig.subplots_adjust(left=0.01, right=0.99, bottom=0.05, top=0.9, wspace=0.05)

    def update(t):
        changed = [counter]
        for ax, screen, lines, centres in artists:
            ax.set_xlim(centres[t] - half, centres[t] + half)
            for line, (p, j) in zip(lines, bones):
                line.set_data(screen[t, [p, j], 0], screen[t, [p, j], 1])
                line.set_color(colors[t])
                changed.append(line)
        counter.set_text(f"frame {t}")
        return changed

    shown, rate = gif_frames(num_frames, fps, keyframes)
    anim = FuncAnimation(fig, update, frames=shown, blit=False)
    path = pathlib.Path(os.fspath(path))
    path.parent.mkdir(parents=True, exist_ok=True)
    anim.save(str(path), writer=PillowWriter(fps=rate), dpi=dpi)
    return path
