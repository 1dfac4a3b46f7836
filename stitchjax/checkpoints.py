"""Checkpoints of the training state: a thin layer over `orbax.checkpoint.CheckpointManager`.

One checkpoint = one folder `WORKDIR/checkpoints/<step>/` holding
  - `state/`:  the whole `TrainState` pytree (params of the four networks, frozen phase params, both
               optimiser states, step, PRNG key), written by orbax's StandardSave;
  - `config/`: the experiment `Config` as JSON (so a checkpoint says how it was made);
  - `extras/`: small JSON-able values saved beside the state (the normalisation statistics).

Atomicity: orbax writes a step into a temporary folder (`<step>.orbax-checkpoint-tmp-<n>`) and renames it
to `<step>` only once every file is written (tests/train/test_checkpoints.py checks this), so a run killed while
saving leaves the previous checkpoint intact and `latest_step` never returns a half-written one.
Restoring goes onto an abstract state (`jax.eval_shape` of the initial state), which gives orbax the
shapes, dtypes and shardings without allocating a second copy.
"""

from __future__ import annotations

import json
import logging
import os
import pathlib
import sys
import threading
from typing import Any, Callable

import jax
import numpy as np
import orbax.checkpoint as ocp

CHECKPOINT_SUBDIR = "checkpoints"


class CheckpointError(FileNotFoundError):
    """A checkpoint folder is missing or unreadable."""


def checkpoint_dir(workdir: str | os.PathLike) -> pathlib.Path:
    """The absolute folder holding the step folders of a run: WORKDIR/checkpoints."""
    return pathlib.Path(workdir).expanduser().resolve() / CHECKPOINT_SUBDIR


def open_manager(
    workdir: str | os.PathLike,
    max_to_keep: int = 3,
    async_save: bool = True,
    read_only: bool = False,
) -> ocp.CheckpointManager:
    """A CheckpointManager on WORKDIR/checkpoints keeping the last `max_to_keep` steps.

    `async_save`: the device-to-host copy happens inside `save`, the file writing in a background thread;
    call `manager.wait_until_finished()` (or `close(manager)`) before the process exits.
    """
    directory = checkpoint_dir(workdir)
    if read_only and not directory.is_dir():
        raise CheckpointError(f"no checkpoints in {directory}: train first (bin/train --workdir {workdir})")
    options = ocp.CheckpointManagerOptions(
        max_to_keep=None if read_only else max_to_keep,
        save_interval_steps=0 if read_only else 1,
        create=not read_only,
        read_only=read_only,
        enable_async_checkpointing=async_save,
        cleanup_tmp_directories=not read_only,
    )
    return ocp.CheckpointManager(directory, options=options, item_names=("state", "config", "extras"))


def _json_ready(value) -> dict:
    """A dict as JSON reads it back (tuples as lists, numpy values as Python ones)."""
    return json.loads(json.dumps(value, default=_json_default))


def _json_default(value):
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, (np.floating, np.integer, np.bool_)):
        return value.item()
    if isinstance(value, pathlib.PurePath):
        return str(value)
    raise TypeError(f"cannot store {type(value).__name__} in a checkpoint's JSON")


def save(manager: ocp.CheckpointManager, step: int, state: Any, config_json: dict, extras: dict | None = None,
         force: bool = True) -> bool:
    """Save `state` as checkpoint `step`, with the config and `extras` (JSON-able dict) beside it as JSON.

    config_json: the run's config as a JSON-able dict (`stitchjax.config.to_dict`).

    Returns True when a checkpoint was written (False when orbax's policy skipped the step).
    """
    return manager.save(
        int(step),
        args=ocp.args.Composite(
            state=ocp.args.StandardSave(state),
            config=ocp.args.JsonSave(_json_ready(config_json)),
            extras=ocp.args.JsonSave(_json_ready(extras or {})),
        ),
        force=force,
    )


def restore(manager: ocp.CheckpointManager, abstract_state: Any, step: int | None = None, partial: bool = False):
    """Restore checkpoint `step` (default: the latest) onto `abstract_state`.

    abstract_state: a pytree of jax.ShapeDtypeStruct (with .sharding) like `jax.eval_shape(init)`.
    partial: `abstract_state` is a dict holding some of the saved state's fields (e.g. {"params": {"forward":
    ..., "backward": ...}}); only those arrays are read (the rest, optimiser states included, stay on disk).
    Returns (state, config_json: dict, extras: dict).
    """
    if step is None:
        step = manager.latest_step()
    if step is None:
        raise CheckpointError(f"no checkpoint found in {manager.directory}")
    if partial:
        state_args = ocp.args.PyTreeRestore(item=abstract_state, partial_restore=True,
                                            restore_args=ocp.checkpoint_utils.construct_restore_args(abstract_state))
    else:
        state_args = ocp.args.StandardRestore(abstract_state)
    restored = manager.restore(
        int(step),
        args=ocp.args.Composite(
            state=state_args,
            config=ocp.args.JsonRestore(),
            extras=ocp.args.JsonRestore(),
        ),
    )
    return restored["state"], restored["config"], restored["extras"] or {}


def short_error(error: BaseException) -> str:
    """The first line of an orbax / TensorStore error, cut to a readable length."""
    text = str(error).strip().splitlines()[0] if str(error).strip() else type(error).__name__
    text = text.split(" See full TensorStore details")[0].rstrip(" .")
    return text if len(text) <= 200 else text[:197] + "..."


def _report_to_stderr(message: str) -> None:
    print(message, file=sys.stderr)


def _ignore_closed_loop_errors(kind, error, traceback) -> None:
    """sys.excepthook that drops "RuntimeError: Event loop is closed" and hands everything else on.

    When orbax fails to restore a broken folder, the reads still in flight end later on TensorStore's
    threads, whose callbacks find their asyncio loop gone and print that error with a traceback through
    sys.excepthook; it says nothing about the checkpoint and would bury the one-line warning.
    """
    if kind is RuntimeError and "Event loop is closed" in str(error):
        return
    _previous_excepthook(kind, error, traceback)


_previous_excepthook = sys.excepthook
_previous_unraisablehook = sys.unraisablehook
_previous_threading_excepthook = threading.excepthook


def _is_closed_loop_error(error) -> bool:
    return isinstance(error, RuntimeError) and "Event loop is closed" in str(error)


def _ignore_closed_loop_unraisable(unraisable) -> None:
    """sys.unraisablehook that drops the same error when it surfaces as "Exception ignored in: ..." (asyncio's
    call_soon_threadsafe from a TensorStore thread) and hands everything else on."""
    if _is_closed_loop_error(unraisable.exc_value):
        return
    _previous_unraisablehook(unraisable)


def _ignore_closed_loop_thread_errors(args) -> None:
    """threading.excepthook that drops the same error raised in a worker thread."""
    if _is_closed_loop_error(args.exc_value):
        return
    _previous_threading_excepthook(args)


def _drop_closed_loop_tracebacks() -> None:
    global _previous_excepthook, _previous_unraisablehook, _previous_threading_excepthook
    if sys.excepthook is not _ignore_closed_loop_errors:
        _previous_excepthook = sys.excepthook
        sys.excepthook = _ignore_closed_loop_errors
    if sys.unraisablehook is not _ignore_closed_loop_unraisable:
        _previous_unraisablehook = sys.unraisablehook
        sys.unraisablehook = _ignore_closed_loop_unraisable
    if threading.excepthook is not _ignore_closed_loop_thread_errors:
        _previous_threading_excepthook = threading.excepthook
        threading.excepthook = _ignore_closed_loop_thread_errors


_BACKGROUND_LOGGERS = ("asyncio", "concurrent.futures")


def _silence_pending_read_errors() -> dict:
    """When a restore fails, the broken folder's other reads still fail in the background and asyncio /
    concurrent.futures log each one with a traceback ("Task exception was never retrieved"), some of them
    before the failure reaches the caller; the one-line warning already says the folder is broken. So those
    two loggers keep only critical records from before the first attempt. Returns their previous levels."""
    previous = {name: logging.getLogger(name).level for name in _BACKGROUND_LOGGERS}
    for name in _BACKGROUND_LOGGERS:
        logging.getLogger(name).setLevel(logging.CRITICAL)
    return previous


def restore_newest_good(manager: ocp.CheckpointManager, abstract_state: Any,
                        report: Callable[[str], None] | None = _report_to_stderr,
                        steps: list[int] | None = None, partial: bool = False):
    """Restore the newest checkpoint that restores, falling back over broken ones (newest first).

    Each step folder that fails (a truncated or missing file, ...) is named through `report` with the
    first line of its error, and the next older one is tried. steps: candidates (default: all saved).
    partial: restore only the fields of `abstract_state` (see :func:`restore`).
    Returns (state, config_json, extras, step). Raises CheckpointError naming every folder tried when
    none restores (or there is none).
    """
    directory = pathlib.Path(str(manager.directory))
    steps = sorted(manager.all_steps() if steps is None else steps, reverse=True)
    if not steps:
        raise CheckpointError(f"no checkpoint found in {directory}")
    _drop_closed_loop_tracebacks()
    levels = _silence_pending_read_errors()
    failures = []
    for i, step in enumerate(steps):
        try:
            state, config_json, extras = restore(manager, abstract_state, step, partial)
        except Exception as error:  # orbax / TensorStore raise many types for a broken folder
            failures.append(f"{directory / str(step)}: {short_error(error)}")
            if report is not None:
                older = steps[i + 1] if i + 1 < len(steps) else None
                report(f"warning: checkpoint {directory / str(step)} cannot be restored ({short_error(error)}); "
                       + (f"falling back to step {older}" if older is not None else "no older checkpoint left"))
            continue
        if not failures:  # nothing is left reading in the background: the loggers as they were
            for name, level in levels.items():
                logging.getLogger(name).setLevel(level)
        return state, config_json, extras, int(step)
    raise CheckpointError(f"no checkpoint in {directory} can be restored: " + "; ".join(failures)
                          + ". Delete the broken step folders, or train again in a new --workdir")


def saved_steps(workdir: str | os.PathLike) -> list[int]:
    """Steps of the complete checkpoints of a run, ascending (orbax's temporary folders excluded)."""
    directory = checkpoint_dir(workdir)
    if not directory.is_dir():
        return []
    return sorted(int(p.name) for p in directory.iterdir() if p.is_dir() and p.name.isdigit())


def read_config_json(workdir: str | os.PathLike, step: int | None = None) -> dict:
    """The config JSON saved with checkpoint `step` (default latest) of a run, without restoring arrays."""
    steps = saved_steps(workdir)
    if not steps:
        raise CheckpointError(f"no checkpoint found in {checkpoint_dir(workdir)}")
    step = steps[-1] if step is None else int(step)
    path = checkpoint_dir(workdir) / str(step) / "config" / "metadata"
    if not path.is_file():
        raise CheckpointError(f"{path} is missing: checkpoint {step} has no config (steps saved: {steps})")
    return json.loads(path.read_text())


def abstract_like(tree: Any) -> Any:
    """ShapeDtypeStructs (keeping shardings) for a pytree of arrays: what `restore` wants."""
    def to_struct(x):
        sharding = getattr(x, "sharding", None)
        return jax.ShapeDtypeStruct(np.shape(x), x.dtype, sharding=sharding)

    return jax.tree.map(to_struct, tree)


def close(manager: ocp.CheckpointManager) -> None:
    """Wait for pending background writes, then release the manager."""
    manager.wait_until_finished()
    manager.close()
