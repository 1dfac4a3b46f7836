"""Validation during training (``train.eval_every``): the evaluation protocol on a few fixed windows.

Every ``train.eval_every`` steps the current generators sample :data:`VALIDATION_SAMPLES` transitions of each of
``train.eval_windows`` windows of the validation split (``data.validation_files``: whole training takes held
out, cut as the test windows; without a split, the dataset's benchmark test windows), evenly spaced, the same
windows every time, at each length of ``train.eval_lengths``, with z from the prior as at inference, and
``stitchjax.eval.evaluate.evaluate_protocol`` scores them. One validation record goes to metrics.jsonl:

    {"step": 500, "val_ade_L30": ..., "val_slde_L30": ..., "val_npss_L30": ..., "val_foot_slide_L30": ...,
     "val_apd_L30": ...,
     "val_ade_L30_interp": ..., ..., "val_s": seconds it took}

``*_interp`` is the interpolation baseline on the same windows (computed once), so ``loss_curves.png`` shows
in one panel per metric when the model starts to beat it. Units: ADE, SLDE and APD in metres, foot slide in
cm/frame, NPSS unitless (``evaluate.metric_units``).
"""
from __future__ import annotations

import time
from typing import Callable

import numpy as np

from stitchjax.data import datasets
from stitchjax.eval import evaluate

__all__ = ["METRICS", "VALIDATION_SAMPLES", "validation_windows", "make_validator"]

METRICS = ("ade", "slde", "npss", "foot_slide", "penetration", "apd")
VALIDATION_SAMPLES = 4  # transitions sampled per window and length: enough for APD and a steady mean ADE


def validation_windows(windows, count: int):
    """`count` windows evenly spaced over `windows` (all of them when there are fewer)."""
    total = int(windows.rotations.shape[0])
    if count >= total:
        return windows
    return windows[np.unique(np.linspace(0, total - 1, count).round().astype(int))]


def _records(results: dict, lengths, suffix: str, names=("model",)) -> dict:
    out = {}
    for length in lengths:
        entry = results["lengths"][str(length)]
        for name in names:
            for metric in METRICS:
                out[f"val_{metric}_L{length}{suffix}"] = float(entry[name][metric])
    return out


def make_validator(data, train, data_dir, stats_json: dict, facts: dict | None, *, model_of_state: Callable,
                   samples: int = VALIDATION_SAMPLES) -> Callable[..., dict] | None:
    """`validate(state) -> record` for ``train.eval_every`` > 0 (None when it is 0).

    data, train: the run config's ``data`` section (the dataset and its validation split) and ``train``
    section (``eval_every``, ``eval_windows``, ``eval_lengths``); data_dir: the training data folder (the
    windows come from the same dataset entry); stats_json / facts: the normalisation statistics and skeleton
    facts saved in the run's checkpoints; model_of_state: ``(state, stats_json, facts, source) -> Model``
    (``trained_model.model_from_state`` of the run's config, bound by the entry point); samples: transitions
    per window and length. The windows are loaded and interpolation is scored here, once. Raises
    FileNotFoundError (no validation or test windows there).
    """
    if train.eval_every <= 0:
        return None
    entry = datasets.get(data.dataset)
    try:
        if data.validation_files:
            windows, stats = datasets.validation_windows(entry.data_dir(data_dir), data)
        else:
            windows, stats = entry.test_windows(entry.data_dir(data_dir), data)
    except FileNotFoundError as error:
        raise FileNotFoundError(f"train.eval_every={train.eval_every} validates on the dataset's test windows, "
                                f"which cannot be loaded ({error}); add them to --data or set "
                                "train.eval_every=0") from None
    windows = validation_windows(windows, train.eval_windows)
    lengths = tuple(int(n) for n in train.eval_lengths)
    feet = tuple(facts["feet"]) if facts else tuple(entry.feet)
    options = dict(lengths=lengths, samples=samples, feet=feet, metres_per_unit=0.01, up_axis=1,
                   progress=False, seed=0)
    baseline = evaluate.evaluate_protocol({"interp": evaluate.interpolation_method}, windows, stats, **options)
    interp = _records(baseline, lengths, "_interp", ("interp",))

    def validate(state) -> dict:
        t0 = time.perf_counter()
        model = model_of_state(state, stats_json, facts, f"step {int(state.step)}")
        results = evaluate.evaluate_protocol({"model": evaluate.model_method(model)}, windows, stats, **options)
        return {**_records(results, lengths, ""), **interp, "val_s": time.perf_counter() - t0}

    return validate
