"""Validation during training (``train.eval_every``): the evaluation protocol on a few fixed windows.

Every ``train.eval_every`` steps the current generators sample ``train.eval_samples`` transitions of each of
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
from stitchjax.sample import trained_model

__all__ = ["METRICS", "validation_windows", "make_validator"]

METRICS = ("ade", "slde", "npss", "foot_slide", "penetration", "apd")


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


def make_validator(config, data_dir, stats_json: dict, facts: dict | None) -> Callable[..., dict] | None:
    """`validate(state) -> record` for ``train.eval_every`` > 0 (None when it is 0).

    data_dir: the training data folder (the test windows come from the same dataset entry); stats_json /
    facts: the normalisation statistics and skeleton facts saved in the run's checkpoints. The test windows
    are loaded and interpolation is scored here, once. Raises FileNotFoundError (no test windows there).
    """
    tc = config.train
    if tc.eval_every <= 0:
        return None
    entry = datasets.get(config.data.dataset)
    try:
        if config.data.validation_files:
            windows, stats = datasets.validation_windows(entry.data_dir(data_dir), config.data)
        else:
            windows, stats = entry.test_windows(entry.data_dir(data_dir), config.data)
    except FileNotFoundError as error:
        raise FileNotFoundError(f"train.eval_every={tc.eval_every} validates on the dataset's test windows, "
                                f"which cannot be loaded ({error}); add them to --data or set "
                                "train.eval_every=0") from None
    windows = validation_windows(windows, tc.eval_windows)
    lengths = tuple(int(n) for n in tc.eval_lengths)
    feet = tuple(facts["feet"]) if facts else tuple(entry.feet)
    options = dict(lengths=lengths, samples=tc.eval_samples, feet=feet, metres_per_unit=0.01, up_axis=1,
                   progress=False, seed=0)
    baseline = evaluate.evaluate_protocol({"interp": evaluate.interpolation_method}, windows, stats, **options)
    interp = _records(baseline, lengths, "_interp", ("interp",))

    def validate(state) -> dict:
        t0 = time.perf_counter()
        model = trained_model.model_from_state(config, state, stats_json, facts, f"step {int(state.step)}")
        results = evaluate.evaluate_protocol({"model": evaluate.model_method(model)}, windows, stats, **options)
        return {**_records(results, lengths, ""), **interp, "val_s": time.perf_counter() - t0}

    return validate
