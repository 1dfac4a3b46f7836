"""LAFAN1: file listing, training / test windows and normalisation statistics (float64).

Reproduces the official benchmark's data preparation (ubisoft-laforge-animation-dataset,
``lafan1/extract.py``; docs/design.md §4): for every file of the chosen subjects, windows of ``window``
frames every ``offset`` frames over the file's whole frame range (``start + window < T``), contacts
on the raw windows, then centring and facing alignment at frame 9. Training: subjects 1-4, 50/20.
Benchmark test set: subject5, 65/40 (2232 windows on the full release).

Works on a folder holding any subset of the 77 release files, ``.bvh`` or ``.bvh.gz`` (names as in
the release: ``<action>_<subject>.bvh``); other files in the folder are ignored. Results are cached
on disk (see :mod:`stitchjax.data.cache`), keyed by the files' contents.
"""
from __future__ import annotations

import dataclasses
import multiprocessing
import os
import pathlib
import re
import sys
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from stitchjax.data import bvh, cache
from stitchjax.skeleton import LAFAN1_FEET, Skeleton
from stitchjax.data.windows import (FACING_FRAME, Stats, Windows, clip_moments, clip_windows, clips_statistics,
                               concatenate_clips)

__all__ = [
    "LAFAN1NotFoundError", "Stats", "TRAIN_SUBJECTS", "TEST_SUBJECTS", "list_files", "load_windows",
    "load_file_windows",
    "train_statistics", "test_windows",
]

TRAIN_SUBJECTS = ("subject1", "subject2", "subject3", "subject4")
TEST_SUBJECTS = ("subject5",)
TRAIN_WINDOW, TRAIN_OFFSET = 50, 20
TEST_WINDOW, TEST_OFFSET = 65, 40
_NAME = re.compile(r"^(?P<action>[A-Za-z0-9]+)_(?P<subject>subject\d+)\.bvh(?P<gz>\.gz)?$")
# Modules whose source is part of the cache key: editing any of them rebuilds the cached arrays.
_CODE = ("stitchjax.rotations", "stitchjax.skeleton", "stitchjax.data.bvh", "stitchjax.data.windows",
         "stitchjax.data.lafan1")
_DOWNLOAD = ("get the release (lafan1.zip) from https://github.com/ubisoft/ubisoft-laforge-"
             "animation-dataset and unpack it into a folder, then pass that folder")


class LAFAN1NotFoundError(FileNotFoundError):
    """The LAFAN1 folder, or the files of the subjects a step needs, are missing."""


def list_files(data_dir) -> dict:
    """LAFAN1 files in ``data_dir`` by subject: ``{"subject1": [Path, ...], ...}`` (sorted by name).

    Accepts ``.bvh`` and ``.bvh.gz``; when both exist for one take, the ``.bvh`` is used. Raises
    :class:`LAFAN1NotFoundError` when the folder does not exist.
    """
    folder = pathlib.Path(os.fspath(data_dir)).expanduser()
    if not folder.is_dir():
        what = "is a file, not a folder" if folder.exists() else "does not exist"
        raise LAFAN1NotFoundError(f"LAFAN1 folder {folder} {what}: {_DOWNLOAD} (e.g. --data PATH).")
    takes = {}
    for path in folder.iterdir():
        match = _NAME.match(path.name)
        if match is None or not path.is_file():
            continue
        stem = f"{match['action']}_{match['subject']}"
        if stem not in takes or not match["gz"]:  # prefer the uncompressed file
            takes[stem] = (match["subject"], path)
    by_subject = {}
    for stem in sorted(takes):
        subject, path = takes[stem]
        by_subject.setdefault(subject, []).append(path)
    return dict(sorted(by_subject.items(), key=lambda kv: _subject_number(kv[0])))


def _subject_number(subject: str) -> int:
    return int(subject[len("subject"):])


def _files_for(data_dir, subjects, purpose: str) -> list:
    """Sorted files of ``subjects``; a clear error when none of them is present."""
    subjects = (subjects,) if isinstance(subjects, str) else tuple(subjects)
    found = list_files(data_dir)
    files = sorted((p for s in subjects for p in found.get(s, [])), key=lambda p: p.name)
    if not files:
        folder = pathlib.Path(os.fspath(data_dir)).expanduser()
        if found:
            have = ", ".join(f"{s} ({len(v)} files)" for s, v in found.items())
            have = f"it holds files of {have}"
        else:
            have = "it holds no LAFAN1 files (expected names like walk1_subject1.bvh or .bvh.gz)"
        raise LAFAN1NotFoundError(
            f"no LAFAN1 files of {', '.join(subjects)} in {folder}: {have}. {purpose} needs at least "
            f"one file of {' or '.join(subjects)}; {_DOWNLOAD}.")
    return files


def _file_windows(path, window, offset, feet, frame, what):
    """One file's :func:`~stitchjax.data.windows.clip_windows` (``what="windows"``) or
    :func:`~stitchjax.data.windows.clip_moments` (``what="moments"``), with its skeleton's names, parents,
    offsets, fps and file name."""
    motion = bvh.load(path)
    sk = motion.skeleton
    out = {"names": sk.names, "parents": sk.parents, "offsets": sk.offsets, "fps": motion.fps,
           "name": pathlib.Path(path).name}
    if what == "moments":
        return {**out, **clip_moments(motion.rotations, motion.positions, sk.parents, window, offset, frame)}
    return {**out, **clip_windows(motion.rotations, motion.positions, sk.parents, window, offset, feet, frame)}


def _jax_backend_started() -> bool:
    """True when JAX may be running threads (forking then is unsafe); False when it cannot be."""
    if "jax" not in sys.modules:
        return False
    try:
        from jax._src import xla_bridge
        return bool(xla_bridge._backends)
    except Exception:  # private API moved: assume the worst
        return True


def _map_files(files, *args, workers=None):
    """``_file_windows(f, *args)`` for every file, in order; in forked worker processes when there
    are several files and cores and JAX has not started (BVH parsing dominates a cold build)."""
    if workers is None:
        workers = min(len(files), os.cpu_count() or 1)
    if workers > 1 and not _jax_backend_started():
        try:
            context = multiprocessing.get_context("fork")
        except ValueError:
            context = None
        if context is not None:
            with ProcessPoolExecutor(workers, mp_context=context) as pool:
                return list(pool.map(_file_windows, files, *[[a] * len(files) for a in args]))
    return [_file_windows(f, *args) for f in files]


def _check_same_skeleton(results, files):
    first = results[0]
    for r, path in zip(results, files):
        if (r["names"], r["parents"]) != (first["names"], first["parents"]):
            raise ValueError(f"{path} has a different joint hierarchy from {files[0]}; all files of "
                             f"a set must share one skeleton")


def build_windows(files, window: int, offset: int, feet=LAFAN1_FEET, frame: int = FACING_FRAME,
                  workers=None) -> Windows:
    """Windows of the given BVH files (no caching): see the module docstring for the steps.

    Files in the given order, windows in start order; the skeleton (and its offsets) is the first
    file's. Raises ValueError when the files do not share one joint hierarchy.
    """
    files = list(files)
    if not files:
        raise ValueError("no files given")
    results = _map_files(files, window, offset, tuple(feet), frame, "windows", workers=workers)
    _check_same_skeleton(results, files)
    first = results[0]
    skeleton = Skeleton(first["names"], first["parents"], first["offsets"])
    arrays = concatenate_clips(results)
    sources = [f"{r['name']}:{s}" for r in results for s in r["starts"]]
    return Windows(arrays["rotations"], arrays["positions"], arrays["contacts"], skeleton, first["fps"], sources)


def build_statistics(files, window: int = TRAIN_WINDOW, offset: int = TRAIN_OFFSET,
                     frame: int = FACING_FRAME, workers=None) -> Stats:
    """:class:`Stats` of the windows of the given files (no caching), without materialising them."""
    files = list(files)
    if not files:
        raise ValueError("no files given")
    results = _map_files(files, window, offset, LAFAN1_FEET, frame, "moments", workers=workers)
    _check_same_skeleton(results, files)
    if not any(len(r["starts"]) for r in results):
        raise ValueError(f"no file is longer than {window} frames: no training windows")
    return clips_statistics(results)


def _windows_to_arrays(w: Windows) -> dict:
    return {"rotations": w.rotations, "positions": w.positions, "contacts": w.contacts,
            "sources": np.array(w.sources, dtype=str), "fps": np.float64(w.fps),
            "names": np.array(w.skeleton.names, dtype=str),
            "parents": np.array(w.skeleton.parents, dtype=np.int64), "offsets": w.skeleton.offsets}


def _arrays_to_windows(a: dict) -> Windows:
    skeleton = Skeleton(tuple(a["names"].tolist()), tuple(a["parents"].tolist()), a["offsets"])
    return Windows(a["rotations"], a["positions"], a["contacts"], skeleton, float(a["fps"]),
                  a["sources"].tolist())


def load_windows(data_dir, subjects, window: int, offset: int, cache_dir=None) -> Windows:
    """Centred, facing-aligned windows with contacts, float64, of all files of ``subjects``.

    Args:
      data_dir: a folder with LAFAN1 files (any subset of the release; .bvh or .bvh.gz).
      subjects: e.g. ``("subject1", ..., "subject4")`` or ``"subject5"``.
      window, offset: window length and stride in frames (training 50/20, test 65/40).
      cache_dir: see :func:`stitchjax.data.cache.resolve_cache_dir` (False disables the cache).
    Returns:
      :class:`Windows` (N, window, 22, ...), files in name order, windows in start order.
    Raises :class:`LAFAN1NotFoundError` when the folder or every file of ``subjects`` is missing.
    """
    subjects = (subjects,) if isinstance(subjects, str) else tuple(subjects)
    files = _files_for(data_dir, subjects, f"Loading windows of {', '.join(subjects)}")
    params = {"window": int(window), "offset": int(offset), "frame": FACING_FRAME,
              "feet": list(LAFAN1_FEET)}
    arrays = cache.cached("lafan1-windows", files, params,
                          lambda: _windows_to_arrays(build_windows(files, window, offset)), cache_dir,
                          _CODE)
    return _arrays_to_windows(arrays)


def load_file_windows(files, window: int, offset: int, cache_dir=None) -> Windows:
    """:func:`load_windows` of the given LAFAN1 files (e.g. the validation takes), cached the same way."""
    files = sorted((pathlib.Path(f) for f in files), key=lambda p: p.name)
    if not files:
        raise LAFAN1NotFoundError("no LAFAN1 files given")
    params = {"window": int(window), "offset": int(offset), "frame": FACING_FRAME, "feet": list(LAFAN1_FEET)}
    arrays = cache.cached("lafan1-windows", files, params,
                          lambda: _windows_to_arrays(build_windows(files, window, offset)), cache_dir, _CODE)
    return _arrays_to_windows(arrays)


def train_statistics(data_dir, subjects=TRAIN_SUBJECTS, window: int = TRAIN_WINDOW,
                     offset: int = TRAIN_OFFSET, cache_dir=None) -> Stats:
    """Normalisation statistics of the training windows (official ``get_train_stats``).

    Global positions (FK, centred + faced) of all training windows -> per-coordinate mean and
    population std, (J*3,) = (66,) in joint-major order (joint j, axis a at 3*j + a), cm.
    ``offsets`` (J, 3): the local positions in the first frame of the first training window (files
    in name order); row 0 (the root) is zero, since the root's local position is its trajectory.
    (The official code takes the first window in ``os.listdir`` order; LAFAN1's offsets agree
    across files to ~1e-5 cm, so the choice does not matter.)
    """
    subjects = (subjects,) if isinstance(subjects, str) else tuple(subjects)
    files = _files_for(data_dir, subjects, f"The training statistics ({', '.join(subjects)})")
    params = {"window": int(window), "offset": int(offset), "frame": FACING_FRAME}

    def compute():
        return dataclasses.asdict(build_statistics(files, window, offset))

    arrays = cache.cached("lafan1-stats", files, params, compute, cache_dir, _CODE)
    return Stats(**arrays)


def test_windows(data_dir, cache_dir=None) -> Windows:
    """The official benchmark test set: subject5, windows of 65 frames every 40 (2232 windows on
    the full release). Raises :class:`LAFAN1NotFoundError` when the folder has no subject5 file."""
    _files_for(data_dir, TEST_SUBJECTS, "The benchmark test set")
    return load_windows(data_dir, TEST_SUBJECTS, TEST_WINDOW, TEST_OFFSET, cache_dir)


test_windows.__test__ = False  # a data loader, not a pytest test
