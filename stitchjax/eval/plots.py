"""Figures for motions: stick figures, filmstrips, root trajectories, error over time; a training run's loss
curves; foot heights before and after foot locking. GIFs are :mod:`stitchjax.eval.animation`'s.

Everything takes FK *global* positions (file units, Y-up) and the skeleton's ``parents`` tuple, draws
on matplotlib's non-interactive Agg canvas (no pyplot, no display; :mod:`stitchjax.eval.drawing`), and returns
the ``matplotlib.figure.Figure``; pass ``path=`` to also write a PNG. Figure pixel size = ``figsize * dpi``
exactly (no tight bounding box), so callers and tests can rely on it. Views and colours: see
:mod:`stitchjax.eval.drawing`.
"""
from __future__ import annotations

import dataclasses
import math
import textwrap
from typing import Any, Mapping, Sequence

import matplotlib
import numpy as np
from matplotlib.figure import Figure

from stitchjax.eval.drawing import (CONTEXT_COLOR, DEFAULT_CMAP, KEYFRAME_COLOR, check_pose, draw_skeleton,
                                    draw_skeleton_from_above, finish_figure, frame_axes, frame_colors,
                                    horizontal_axis, new_figure, project, sample_color)

__all__ = ["stick_figure", "filmstrip", "FilmstripStyle", "FootLockFigureStyle",
           "body_width", "samples_overview", "root_trajectories", "error_over_time",
           "per_frame_error", "loss_curves", "time_to_quality", "foot_lock_before_after"]


# ----------------------------------------------------------------------------------------- poses


def stick_figure(positions, parents, *, view="auto", color="black", title: str | None = None,
                 figsize=(3.0, 4.0), dpi: int = 100, path=None) -> Figure:
    """One pose (J, 3) as a stick figure seen from the side. Returns the Figure (PNG at ``path``)."""
    p = check_pose(positions, parents)
    fig = new_figure(figsize, dpi)
    ax = fig.add_subplot(1, 1, 1)
    axis = horizontal_axis(p[None], view) if view != "auto" else np.array([1.0, 0.0])
    draw_skeleton(ax, p, parents, axis=axis, color=color, linewidth=2.0)
    screen = project(p, axis)
    frame_axes(ax, screen[:, 0].min(), screen[:, 0].max(), screen[:, 1].min(), screen[:, 1].max())
    if title:
        ax.set_title(title, fontsize=9)
    return finish_figure(fig, path)


# ------------------------------------------------------------------------------------- filmstrips


def _checked_motions(motions, parents, every: int) -> list:
    """The filmstrip's motions as a list of (T, J, 3) float64 arrays; ValueError naming a bad shape."""
    if isinstance(motions, np.ndarray) and motions.ndim == 3:
        motions = [motions]
    motions = [np.asarray(m, dtype=np.float64) for m in motions]
    if not motions:
        raise ValueError("filmstrip needs at least one motion")
    num_frames = motions[0].shape[0]
    for m in motions:
        if m.ndim != 3 or m.shape[0] != num_frames or m.shape[1:] != (len(parents), 3):
            raise ValueError(f"filmstrip motions must all be (T, J, 3) = ({num_frames}, {len(parents)}, 3) "
                             f"global positions, got {m.shape}")
    if every < 1:
        raise ValueError(f"every must be >= 1, got {every}")
    return motions


def body_width(poses, axis) -> float:
    """How wide a pose looks along the screen's horizontal ``axis``: the median over poses (..., J, 3) of
    each one's horizontal extent (data units)."""
    screen = project(np.asarray(poses, np.float64), axis)[..., 0]
    extent = screen.max(axis=-1) - screen.min(axis=-1)
    return float(np.median(extent))


def _placed_poses(poses, axis, spacing: float, travel: bool, min_step: float = 0.0) -> np.ndarray:
    """Screen coordinates (D, J, 2) of the drawn poses (D, J, 3), shifted into place: each centred on its
    root `spacing` apart, or (travel) keeping their displacement from the first one, except that each pose
    lies at least ``min_step`` further along the strip than the one before (a root that moves less, or
    back, would draw the poses on top of each other)."""
    screen = project(poses, axis)
    root = screen[:, :1, 0]
    if travel:
        steps = np.maximum(np.diff(root[:, 0]), float(min_step))
        place = np.concatenate([[0.0], np.cumsum(steps)])
        screen[..., 0] += place[:, None] - root
    else:
        screen[..., 0] += np.arange(len(poses))[:, None] * spacing - root
    return screen


def _filmstrip_layout(titles, title, row_height: float, data_w: float, data_h: float, rows: int, figsize) -> tuple:
    """(figsize, the title wrapped to the figure's width, the title's height, the row titles' width), in inches.

    data_w, data_h: the drawn poses' width and height (data units); each row is ``row_height`` inches tall; the
    width keeps their aspect (at least 4 inches) unless ``figsize`` is given."""
    # room for the row titles: about 0.065 inch per character at font size 8
    label_w = max(0.7, 0.15 + 0.065 * max(len(str(t)) for t in titles)) if titles else 0.1
    width = label_w + 0.1 + row_height * data_w / data_h  # inches: rows of row_height, the data's aspect
    if figsize is None:
        width = max(width, 4.0)
    else:
        width = float(figsize[0])
    # the title wrapped to the figure's width (about 0.07 inch per character at font size 9)
    lines = textwrap.wrap(title, max(20, int((width - 0.3) / 0.07))) if title else []
    title = "\n".join(lines)
    title_h = 0.1 + 0.17 * len(lines) if lines else 0.0
    if figsize is None:
        figsize = (width, row_height * rows + title_h)
    return figsize, title, title_h, label_w


def _draw_filmstrip_row(ax, motion, screen, drawn, keyframes, colors, parents, axis):
    """The poses of one filmstrip row: motion (T, J, 3), at the placed screen coordinates (D, J, 2) of its
    ``drawn`` frames (D,); keyframes drawn thicker and on top."""
    for k, t in enumerate(drawn):
        is_key = t in keyframes
        shift = screen[k, 0, 0] - project(motion[t, :1], axis)[0, 0]
        draw_skeleton(ax, motion[t], parents, axis=axis, shift=shift, color=colors[t],
                      linewidth=1.6 if is_key else 1.2, zorder=3 if is_key else 2)


@dataclasses.dataclass(frozen=True)
class FilmstripStyle:
    """How :func:`filmstrip` lays out and draws its rows (see there): the horizontal ``view``, the figures'
    ``spacing`` and ``travel``, the transition's colour map ``cmap``, ``row_height`` (inches), ``dpi`` and a
    fixed ``figsize`` (inches, or None)."""

    view: Any = "auto"
    spacing: float | None = None
    travel: bool = False
    cmap: str = DEFAULT_CMAP
    row_height: float = 1.6
    dpi: int = 100
    figsize: tuple | None = None


def filmstrip(motions, parents, *, every: int = 5, keyframes: Sequence[int] | None = None,
              transition: tuple | None = None, titles: Sequence[str] | None = None, title: str | None = None,
              path=None, style: FilmstripStyle | None = None, **style_overrides) -> Figure:
    """Several motions as filmstrips, one row per motion, a stick figure every ``every`` frames.

    style: a :class:`FilmstripStyle` (default ``FilmstripStyle()``); style_overrides: its fields as keywords on
    top of it (``travel=True``, ``dpi=80``, ...).

    motions: list of (T, J, 3) global positions (Y-up), or one (S, T, J, 3) array; all the same T.
    keyframes: frame indices drawn in black and always drawn (default: first and last frame).
    transition: (first, last) frames coloured with ``cmap`` (default: between the keyframes);
      frames outside it are light grey.
    view: see :mod:`stitchjax.eval.drawing`; one axis is chosen for all rows, so rows are comparable.
    spacing: horizontal distance between consecutive figures (file units; default 0.6 x body height);
      each figure is centred on its own root unless ``travel=True``: then each keeps its real horizontal
      displacement from the one drawn before, which shows speed, but at least a body width
      (1.2 x :func:`body_width`, at least a quarter of the body's height), so motion in place is spaced out
      instead of stacked.
    Figure size: ``figsize``, or ``row_height`` inches per row and the width that keeps the poses'
    aspect ratio (plus room for the titles).
    """
    style = dataclasses.replace(style or FilmstripStyle(), **style_overrides)
    view, spacing, travel, cmap = style.view, style.spacing, style.travel, style.cmap
    row_height, dpi, figsize = style.row_height, style.dpi, style.figsize
    motions = _checked_motions(motions, parents, every)
    num_frames = motions[0].shape[0]
    keyframes = (0, num_frames - 1) if keyframes is None else tuple(int(k) % num_frames for k in keyframes)
    if transition is None:
        transition = (min(keyframes), max(keyframes)) if len(keyframes) >= 2 else (0, num_frames - 1)
    drawn = sorted(set(range(0, num_frames, every)) | set(keyframes) | {num_frames - 1})
    colors = frame_colors(num_frames, keyframes, transition, cmap)
    axis = horizontal_axis(motions, view)
    ymin = min(float(m[..., 1].min()) for m in motions)
    ymax = max(float(m[..., 1].max()) for m in motions)
    height = max(ymax - ymin, 1e-3)
    spacing = 0.6 * height if spacing is None else float(spacing)
    # travel: a root that moves less than a body width between drawn frames is spaced by one (in-place motion)
    min_step = max(1.2 * body_width(np.stack([m[drawn] for m in motions]), axis), 0.25 * height) if travel else 0.0
    placed = [_placed_poses(m[drawn], axis, spacing, travel, min_step) for m in motions]
    xmin = min(float(p[..., 0].min()) for p in placed)
    xmax = max(float(p[..., 0].max()) for p in placed)
    pad = 0.05 * height
    data_w, data_h = xmax - xmin + 2 * pad, height + 2 * pad
    figsize, title, title_h, label_w = _filmstrip_layout(titles, title, row_height, data_w, data_h, len(motions),
                                                         figsize)
    fig = new_figure(figsize, dpi)
    fig_w, fig_h = fig.get_size_inches()
    row_h = (fig_h - title_h) / len(motions)
    for row, (m, screen) in enumerate(zip(motions, placed)):
        bottom = (fig_h - title_h - (row + 1) * row_h) / fig_h
        ax = fig.add_axes((label_w / fig_w, bottom, (fig_w - label_w - 0.1) / fig_w, row_h / fig_h))
        _draw_filmstrip_row(ax, m, screen, drawn, keyframes, colors, parents, axis)
        ax.axhline(ymin, color="0.8", linewidth=0.8, zorder=1, gid="ground")
        ax.set_xlim(xmin - pad, xmax + pad)
        ax.set_ylim(ymin - pad, ymax + pad)
        ax.set_aspect("equal", adjustable="box", anchor="W")
        ax.set_axis_off()
        if titles is not None and row < len(titles):
            ax.text(-0.01, 0.5, str(titles[row]), transform=ax.transAxes, fontsize=8, ha="right",
                    va="center")
    if title:
        fig.suptitle(title, fontsize=9, y=1 - 0.05 * title_h / fig_h)
    return finish_figure(fig, path)


# ------------------------------------------------------------------------------------ samples overview


def _along_the_way(positions, start, direction) -> np.ndarray:
    """Global positions (..., 3) Y-up turned and moved about the vertical so that ``start`` (x, z) is the origin
    and ``direction`` (x, z, unit) is +x; seen from above, +z stays a quarter turn from +x as before."""
    p = np.asarray(positions, np.float64)
    d = p[..., [0, 2]] - start
    along = d @ direction
    side = d @ np.array([-direction[1], direction[0]])
    return np.stack([along, p[..., 1], side], axis=-1)


def _overview_from_above(ax, motions, parents, keyframes, middle, reference):
    """The top panel of :func:`samples_overview`: root paths from above, turned so the way from the start
    keyframe's root to the target's runs left to right; the keyframe poses, dots at the middle frame."""
    a, b = keyframes
    start = motions[0][a, 0, [0, 2]]
    chord = motions[0][b, 0, [0, 2]] - start
    direction = chord / np.linalg.norm(chord) if np.linalg.norm(chord) > 1e-6 else np.array([1.0, 0.0])
    turned = [_along_the_way(m, start, direction) for m in motions]
    if reference is not None:
        r = _along_the_way(reference, start, direction)
        ax.plot(r[:, 0, 0], r[:, 0, 2], "--", color=KEYFRAME_COLOR, linewidth=0.9, zorder=4, label="input")
    for i, m in enumerate(turned):
        color = sample_color(i)
        ax.plot(m[:a + 1, 0, 0], m[:a + 1, 0, 2], color=CONTEXT_COLOR, linewidth=1.0, zorder=1)
        ax.plot(m[b:, 0, 0], m[b:, 0, 2], color=CONTEXT_COLOR, linewidth=1.0, zorder=1)
        ax.plot(m[a:b + 1, 0, 0], m[a:b + 1, 0, 2], color=color, linewidth=1.5, zorder=3)
        ax.plot(m[middle, 0, 0], m[middle, 0, 2], "o", color=color, markersize=6, markeredgecolor="white",
                markeredgewidth=0.7, zorder=5)
    for k in (a, b):
        draw_skeleton_from_above(ax, turned[0][k], parents, color=KEYFRAME_COLOR, linewidth=1.2, zorder=6)
    ax.set_aspect("equal", adjustable="datalim")
    ax.invert_yaxis()
    ax.tick_params(labelsize=7)
    ax.set_xlabel("along the way from the start keyframe's root to the target's (cm)", fontsize=8)
    ax.set_ylabel("to the side (cm)", fontsize=8)
    ax.grid(True, linewidth=0.4, alpha=0.5)
    ax.set_title("root paths from above, keyframes in black (dots: the middle frame)", fontsize=9)
    if reference is not None:
        ax.legend(fontsize=7, loc="upper right")


def _overview_middle_poses(ax, motions, parents, middle, reference, axis):
    """The bottom panel of :func:`samples_overview`: each sample's middle frame seen from the side, in a row."""
    poses = [m[middle] for m in motions]
    names = [f"sample {i}" for i in range(len(motions))]
    colors = [sample_color(i) for i in range(len(motions))]
    if reference is not None:
        poses.insert(0, reference[middle])
        names.insert(0, "input")
        colors.insert(0, CONTEXT_COLOR)
    stack = np.stack(poses)
    ymin, ymax = float(stack[..., 1].min()), float(stack[..., 1].max())
    height = max(ymax - ymin, 1e-3)
    step = max(1.3 * body_width(stack, axis), 0.45 * height)
    for k, (pose, name, color) in enumerate(zip(poses, names, colors)):
        root = project(pose[:1], axis)[0, 0]
        draw_skeleton(ax, pose, parents, axis=axis, shift=k * step - root, color=color, linewidth=1.8)
        ax.text(k * step, ymin - 0.06 * height, name, ha="center", va="top", fontsize=8, color="0.25")
    ax.axhline(ymin, color="0.8", linewidth=0.8, zorder=1)
    frame_axes(ax, -0.6 * step, (len(poses) - 0.4) * step, ymin - 0.15 * height, ymax, margin=0.02)
    ax.set_title("the middle frame of each sample, from the side", fontsize=9)


def samples_overview(motions, parents, *, keyframes: Sequence[int], middle: int | None = None, reference=None,
                     view="auto", figsize=(10.0, 6.0), dpi: int = 100, title: str | None = None,
                     path=None) -> Figure:
    """Samples told apart at a glance: their root paths seen from above (top; turned so the way from the
    start keyframe's root to the target's runs left to right, equal scales; the keyframe poses in black, each
    transition in its sample's colour, context grey, a dot at the middle frame) above each sample's middle
    frame seen from the side (bottom, same colours, in a row).

    motions: list of (T, J, 3) global positions (Y-up), the same keyframes (a, b) = ``keyframes`` in each;
    middle: the frame shown at the bottom (default: halfway between the keyframes); reference: an optional
    (T, J, 3) motion (e.g. the take's own frames) drawn dashed at the top and grey first at the bottom;
    view: the side view's direction (:mod:`stitchjax.eval.drawing`). Returns the Figure (PNG at ``path``).
    """
    motions = _checked_motions(motions, parents, 1)
    num_frames = motions[0].shape[0]
    a, b = sorted(int(k) % num_frames for k in keyframes)
    middle = (a + b) // 2 if middle is None else int(middle) % num_frames
    if reference is not None:
        reference = _checked_motions([reference], parents, 1)[0]
        if reference.shape[0] != num_frames:
            raise ValueError(f"the reference has {reference.shape[0]} frames, the motions {num_frames}")
    fig = new_figure(figsize, dpi)
    top = 0.9 if title else 0.95
    above = fig.add_axes((0.08, 0.53, 0.9, top - 0.53))
    side = fig.add_axes((0.02, 0.02, 0.96, 0.37))
    _overview_from_above(above, motions, parents, (a, b), middle, reference)
    axis = horizontal_axis([m[a:b + 1] for m in motions], view)
    _overview_middle_poses(side, motions, parents, middle, reference, axis)
    if title:
        fig.suptitle(title, fontsize=10, y=0.975)
    return finish_figure(fig, path)


# ----------------------------------------------------------------------------------- trajectories


def root_trajectories(trajectories, *, labels: Sequence[str] | None = None, keyframes: Sequence[int] | None = None,
                      reference=None, figsize=(4.5, 4.5), dpi: int = 100, title: str | None = None,
                      path=None) -> Figure:
    """Root trajectories seen from above (x-z plane, z pointing down the page as in a top view).

    trajectories: list of (T, 3) root positions or (T, J, 3) global positions (root = joint 0), or one
      (S, T, 3) / (S, T, J, 3) array (a single motion goes in a list). keyframes: frame indices marked with black dots (default first
      and last). reference: optional (T', 3) / (T', J, 3) trajectory drawn dashed in black (e.g. the
      ground truth).
    """
    def roots(x):
        x = np.asarray(x, dtype=np.float64)
        return x[:, 0] if x.ndim == 3 else x

    items = list(trajectories)  # an array iterates over its first axis: (S, T, 3) or (S, T, J, 3)
    paths = [roots(t) for t in items]
    fig = new_figure(figsize, dpi)
    ax = fig.add_subplot(1, 1, 1)
    colormap = matplotlib.colormaps["tab10"]
    for i, r in enumerate(paths):
        label = labels[i] if labels is not None and i < len(labels) else None
        ax.plot(r[:, 0], r[:, 2], color=colormap(i % 10), linewidth=1.2, label=label)
        keys = (0, len(r) - 1) if keyframes is None else keyframes
        key_idx = [int(k) % len(r) for k in keys]
        ax.plot(r[key_idx, 0], r[key_idx, 2], "o", color=KEYFRAME_COLOR, markersize=4, zorder=3)
    if reference is not None:
        r = roots(reference)
        ax.plot(r[:, 0], r[:, 2], "--", color=KEYFRAME_COLOR, linewidth=1.0, label="reference")
    ax.set_aspect("equal", adjustable="datalim")
    ax.invert_yaxis()
    ax.set_xlabel("x")
    ax.set_ylabel("z")
    ax.grid(True, linewidth=0.4, alpha=0.5)
    if labels is not None or reference is not None:
        ax.legend(fontsize=7, loc="best")
    if title:
        ax.set_title(title, fontsize=9)
    fig.tight_layout()
    return finish_figure(fig, path)


# ---------------------------------------------------------------------------------- error curves


def per_frame_error(samples, ground_truth, metres_per_unit: float = 0.01) -> np.ndarray:
    """Per-frame ADE: mean over joints (and over samples and windows) of the Euclidean distance.

    samples: (..., L, J, 3) global positions (any leading sample / window axes);
    ground_truth: broadcastable (..., L, J, 3). Returns (L,) in metres (file units x metres_per_unit).
    """
    s = np.asarray(samples, dtype=np.float64)
    g = np.asarray(ground_truth, dtype=np.float64)
    d = np.linalg.norm(s - g, axis=-1).mean(axis=-1)  # (..., L)
    return d.reshape(-1, d.shape[-1]).mean(axis=0) * metres_per_unit


def error_over_time(errors: Mapping[str, Sequence[float]], *, first_frame: int = 1,
                    ylabel: str = "ADE (m)", xlabel: str = "frame of the transition",
                    figsize=(5.0, 3.2), dpi: int = 100, title: str | None = None, path=None) -> Figure:
    """Per-frame error of several methods along the transition (as the paper's Fig. 4).

    errors: method name -> (L,) errors per generated frame; frames are numbered from ``first_frame``.
    """
    if not errors:
        raise ValueError("error_over_time needs at least one method")
    fig = new_figure(figsize, dpi)
    ax = fig.add_subplot(1, 1, 1)
    for name, values in errors.items():
        v = np.asarray(values, dtype=np.float64).ravel()
        ax.plot(np.arange(first_frame, first_frame + len(v)), v, marker="o", markersize=2.5,
                linewidth=1.2, label=str(name))
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_ylim(bottom=0)
    ax.grid(True, linewidth=0.4, alpha=0.5)
    ax.legend(fontsize=8)
    if title:
        ax.set_title(title, fontsize=9)
    fig.tight_layout()
    return finish_figure(fig, path)


# -------------------------------------------------------------------------------------- training


def loss_curves(records: Sequence[Mapping[str, float]], *, dpi: int = 90, path=None) -> Figure:
    """One panel per loss term against step, four panels a row (3.6 x 2.4 inches each).

    records: the metrics.jsonl records (dicts with "step" and the logged terms). Per-direction /
    per-discriminator parts ("fk_forward", "adv_d_short", ...) share their term's panel. Order: the total
    generator loss ("loss") first, the discriminator's second, the other terms as logged, then the
    validation figures (val_*), each beside interpolation's on the same windows where it was logged.
    """
    skip = {"step", "windows_per_s", "time_s", "epoch", "val_s"}
    suffixes = ("_forward", "_backward", "_short", "_long", "_interp")
    names = list(dict.fromkeys(n for r in records for n in r if n not in skip))  # validation records too
    panels = {n: [] for n in names if not n.endswith(suffixes) or n.rsplit("_", 1)[0] not in names}
    for n in names:
        if n not in panels:
            panels[n.rsplit("_", 1)[0]].append(n)
    first = [n for n in ("loss", "disc_loss") if n in panels]
    panels = {n: panels[n] for n in first + [n for n in panels if n not in first and not n.startswith("val_")]
              + [n for n in panels if n.startswith("val_")]}
    cols = 4
    rows = max(1, math.ceil(len(panels) / cols))
    fig = new_figure((3.6 * cols, 2.4 * rows), 100)  # laid out at 100 dpi (matplotlib's default), drawn at `dpi`
    axes = fig.subplots(rows, cols, squeeze=False)
    def curve(name):  # the records that have the term (validation records come every eval_every steps)
        points = [(r["step"], r[name]) for r in records if name in r]
        return [p[0] for p in points], [p[1] for p in points]

    for ax, (name, parts) in zip(axes.flat, panels.items()):
        ax.plot(*curve(name), lw=1.4, label=name, marker="." if name.startswith("val_") else None)
        for part in parts:
            label = "interpolation" if part.endswith("_interp") else part
            ax.plot(*curve(part), lw=0.8, alpha=0.7, label=label, ls="--" if part.endswith("_interp") else "-")
        if parts:
            ax.legend(fontsize=6)
        ax.set_title(name, fontsize=9)
        ax.set_xlabel("step", fontsize=8)
        ax.tick_params(labelsize=7)
    for ax in list(axes.flat)[len(panels):]:
        ax.axis("off")
    fig.tight_layout()
    fig.set_dpi(dpi)
    return finish_figure(fig, path)


def time_to_quality(curves: Mapping[str, Sequence[Mapping[str, float]]], *,
                    metrics: Sequence[str] = ("ade", "npss", "foot_slide", "penetration"),
                    lengths: Sequence[int] = (30, 50), reference: str | None = None, dpi: int = 90,
                    path=None) -> Figure:
    """Validation ratios to interpolation against hours of training loop, one panel per metric and length
    (rows: metrics, columns: lengths; 3.4 x 2.3 inches each), every run a line; 1 (interpolation) dashed.

    curves: {run label: its validation points (``reporting.validation_curve``: "time_s" and
    "<metric>_L<length>_ratio")}; a run without a metric leaves that panel without its line. reference: the
    label drawn thick and grey (the run the others are compared with).
    """
    rows, cols = len(metrics), len(lengths)
    fig = new_figure((3.4 * cols, 2.3 * rows), 100)
    axes = fig.subplots(rows, cols, squeeze=False)
    colors = matplotlib.colormaps["tab10"]
    for r, metric in enumerate(metrics):
        for c, length in enumerate(lengths):
            ax, key = axes[r, c], f"{metric}_L{length}_ratio"
            for index, (label, points) in enumerate(curves.items()):
                shown = [(p["time_s"] / 3600.0, p[key]) for p in points if key in p]
                if not shown:
                    continue
                style = (dict(color="0.55", lw=2.6, zorder=1) if label == reference
                         else dict(color=colors(index % 10), lw=1.3, zorder=2))
                ax.plot(*zip(*shown), marker=".", ms=4, label=label, **style)
            ax.axhline(1.0, color="black", lw=0.8, ls="--")
            ax.set_title(f"{metric.replace('_', ' ')}, L = {length}", fontsize=9)
            ax.set_ylabel("ratio to interpolation", fontsize=7)
            ax.set_xlabel("hours of training loop", fontsize=7)
            ax.tick_params(labelsize=7)
    handles, labels = axes[0, 0].get_legend_handles_labels()
    if handles:
        axes[0, -1].legend(handles, labels, fontsize=6, loc="upper right")
    fig.tight_layout()
    fig.set_dpi(dpi)
    return finish_figure(fig, path)


# ------------------------------------------------------------------------------------------ foot locking


def _shade_spans(ax, mask, color, alpha, label=None):
    """Shade the runs of True in ``mask`` (T,) as frame intervals [t - 0.5, t + 0.5]."""
    mask = np.asarray(mask, bool)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(int), [0]])))
    for k, (a, b) in enumerate(zip(edges[::2], edges[1::2])):
        ax.axvspan(a - 0.5, b - 0.5, color=color, alpha=alpha, linewidth=0, label=label if k == 0 else None)


@dataclasses.dataclass(frozen=True)
class FootLockFigureStyle:
    """How :func:`foot_lock_before_after` looks: the legs' names in order, the size (inches) and dpi."""

    leg_names: Sequence[str] = ("left", "right")
    figsize: tuple = (8.0, 4.6)
    dpi: int = 90


def foot_lock_before_after(before, after, planted, feet, *, let_go=None, ground: float = 0.0, up_axis: int = 1,
                           title: str | None = None, path=None, style: FootLockFigureStyle | None = None,
                           **style_overrides) -> Figure:
    """Foot heights and sliding along one transition without and with foot locking (``stitchjax.sample.footlock``).

    before, after: (T, J, 3) global positions (keyframes included); planted: (T, legs) bool frames held by a
    span (shaded); let_go: optional (T, legs) span frames let go out of reach (shaded red); feet: the
    contact joints (ankle, toe, ...) per leg in order; ground: the ground height (file units).
    Top row: each leg's lowest foot joint above the ground; bottom row: its ankle's horizontal displacement
    to the next frame (file units per frame), dashed without the pass, solid with it.
    style: a :class:`FootLockFigureStyle`; style_overrides: its fields as keywords on top of it.
    """
    style = dataclasses.replace(style or FootLockFigureStyle(), **style_overrides)
    leg_names, figsize, dpi = style.leg_names, style.figsize, style.dpi
    before, after = np.asarray(before, np.float64), np.asarray(after, np.float64)
    planted = np.asarray(planted, bool)
    legs = len(feet) // 2
    if before.shape != after.shape or planted.shape != (before.shape[0], legs):
        raise ValueError(f"foot_lock_before_after: positions {before.shape} and {after.shape} must match and "
                         f"planted must be (T, {legs}), got {planted.shape}")
    horizontal = [a for a in range(3) if a != up_axis]
    fig = new_figure(figsize, dpi)
    frames = np.arange(before.shape[0])
    for leg in range(legs):
        ankle, toe = feet[2 * leg], feet[2 * leg + 1]
        top = fig.add_subplot(2, legs, leg + 1)
        bottom = fig.add_subplot(2, legs, legs + leg + 1, sharex=top)
        for ax in (top, bottom):
            _shade_spans(ax, planted[:, leg], "tab:green", 0.15, "planted")
            if let_go is not None:
                _shade_spans(ax, np.asarray(let_go, bool)[:, leg], "tab:red", 0.2, "let go")
            ax.grid(True, linewidth=0.4, alpha=0.5)
        for x, style, name in ((before, "--", "without"), (after, "-", "with foot locking")):
            height = np.minimum(x[:, ankle, up_axis], x[:, toe, up_axis]) - ground
            top.plot(frames, height, style, color="C0", linewidth=1.2, label=name)
            step = np.linalg.norm(np.diff(x[:, ankle][:, horizontal], axis=0), axis=-1)
            bottom.plot(frames[:-1], step, style, color="C1", linewidth=1.2, label=name)
        top.set_title(f"{leg_names[leg] if leg < len(leg_names) else leg} foot", fontsize=9)
        top.set_ylabel("height above ground")
        bottom.set_ylabel("ankle slide per frame")
        bottom.set_xlabel("frame (0 and last: keyframes)")
        top.set_ylim(bottom=min(0.0, top.get_ylim()[0]))
        bottom.set_ylim(bottom=0)
        if leg == 0:
            top.legend(fontsize=7, loc="upper right")
    if title:
        fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    return finish_figure(fig, path)
