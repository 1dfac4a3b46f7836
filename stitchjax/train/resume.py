"""Which state a run starts from: its own newest checkpoint that restores, another run's (fine-tuning), or
a fresh one.

- Resume: the newest step folder in WORKDIR/checkpoints that restores; broken newer ones are named, set aside
  as `<step>.broken` (nothing is deleted) and metrics past the restored step are dropped. A saved run whose
  data / model / loss / phase config differs is refused (only train.* may change on resume).
- Fine-tune (`init_from`): a new run folder starts from another run's newest state (same data, model and phase
  config; loss.* and train.* may differ), its step, optimiser moments and key included; a ``train.seed`` other than the source run's re-seeds that key (:func:`reseeded_key`), so
  two fine-tunes that differ only in the seed draw different batches and noise.
"""
from __future__ import annotations

import os
import pathlib
import sys
from typing import Any, Callable

import jax
from jax.experimental import multihost_utils

from stitchjax import checkpoints
from stitchjax.train import reporting
from stitchjax import config as config_lib

__all__ = ["ResumeError", "restore_or_init", "reseeded_key", "state_from_run"]


class ResumeError(RuntimeError):
    """The run folder (or the run to start from) cannot give a state: the message says why and the fix."""


def _newest_readable_config(workdir) -> tuple[int, dict]:
    """(step, config JSON) of the newest checkpoint whose config file reads (for the resume check)."""
    steps = checkpoints.saved_steps(workdir)
    for step in reversed(steps):
        try:
            return step, checkpoints.read_config_json(workdir, step)
        except (OSError, ValueError):  # missing or truncated JSON: the restore will fall back too
            continue
    return (steps[-1] if steps else -1), {}


def _set_aside_newer_steps(manager, workdir, restored: int, report) -> None:
    """Rename the broken step folders newer than `restored` to `<step>.broken` (nothing is deleted), so
    the resumed run can save those steps again; process 0 renames, the others wait for it."""
    folder = checkpoints.checkpoint_dir(workdir)
    if jax.process_index() == 0:
        for step in checkpoints.saved_steps(workdir):
            if step > restored:
                target = folder / f"{step}.broken"
                n = 1
                while target.exists():
                    target, n = folder / f"{step}.broken{n}", n + 1
                (folder / str(step)).rename(target)
                if report is not None:
                    report(f"warning: moved the broken checkpoint {folder / str(step)} to {target}")
    if jax.process_count() > 1:
        multihost_utils.sync_global_devices("stitchjax-set-aside-broken-checkpoints")
    manager.reload()


def _saved_config(workdir) -> tuple[int, dict]:
    """(step, config JSON) of the newest readable checkpoint config of `workdir`, with the fields added
    since it was saved at their legacy / default value (as when loading it); ({} when none reads)."""
    step, saved = _newest_readable_config(workdir)
    try:
        saved = config_lib.to_dict(config_lib.from_dict(saved)) if saved else saved
    except config_lib.RetiredFieldError as error:  # made by an earlier version with a setting now removed
        raise ResumeError(f"{workdir}: {error}") from None
    except (config_lib.ConfigError, TypeError):
        pass
    return step, saved


def _differing_sections(saved: dict, config_json: dict, sections: tuple) -> list:
    """The config sections among `sections` whose saved and current values differ."""
    return [section for section in sections if (saved.get(section) or {}) != (config_json.get(section) or {})]


def _check_same_run(config_json: dict, workdir: pathlib.Path, manager) -> None:
    """Raise ResumeError when the run saved in `workdir` has other data / model / loss / phase settings."""
    try:
        saved_step, saved = _saved_config(workdir)
    except ResumeError:
        checkpoints.close(manager)
        raise
    changed = _differing_sections(saved, config_json, ("data", "model", "loss", "phase"))
    if changed:
        checkpoints.close(manager)
        raise ResumeError(
            f"{workdir} holds a run (step {saved_step}) whose {', '.join(changed)} config differs from this "
            "one; resume with the same config and overrides (only train.* may change), or use a new --workdir")


def reseeded_key(key, seed: int):
    """The carried uint32 (2,) PRNG key of a fine-tune whose ``train.seed`` is ``seed``: fold_in(key, seed),
    on the key's devices."""
    new = jax.random.fold_in(key, seed)
    sharding = getattr(key, "sharding", None)
    return jax.device_put(new, sharding) if sharding is not None else new


def state_from_run(config_json: dict, source: str | os.PathLike, abstract_state: Any) -> Any:
    """The newest restorable state of the run in `source`, to fine-tune under other loss / train settings.

    The source run must have the same data, model and phase config (the parameters must mean the same);
    its step, optimiser state and key carry over, so the length schedule and KL warm-up go on from there; when
    ``train.seed`` differs from the source run's, the key is re-seeded (:func:`reseeded_key`) and that is said.
    abstract_state: the run's state as `jax.eval_shape` gives it (shapes, dtypes, shardings).
    Raises ResumeError naming the sections that differ, or when nothing in `source` restores.
    """
    source = pathlib.Path(source).expanduser().resolve()
    _, saved = _saved_config(source)
    if not saved:
        raise ResumeError(f"--init-from {source}: no readable checkpoint (expected {source}/checkpoints/<step>)")
    changed = _differing_sections(saved, config_json, ("data", "model", "phase"))
    if changed:
        raise ResumeError(f"--init-from {source}: its {', '.join(changed)} config differs from this one; "
                          "only loss.* and train.* may change when fine-tuning")
    manager = checkpoints.open_manager(source, read_only=True)
    try:
        state, _, _, step = checkpoints.restore_newest_good(manager, abstract_state)
    except checkpoints.CheckpointError as error:
        raise ResumeError(f"--init-from {source}: {error}") from None
    finally:
        checkpoints.close(manager)
    seed, source_seed = config_json["train"]["seed"], (saved.get("train") or {}).get("seed")
    reseed = source_seed is not None and seed != source_seed
    if reseed:
        state = state.replace(key=reseeded_key(state.key, seed))
    if jax.process_index() == 0:
        print(f"starting from step {step} of {source}", file=sys.stderr)
        if reseed:
            print(f"train.seed={seed} (the source run's: {source_seed}): its key is re-seeded, so the batches and "
                  "noise differ from a continuation of that run", file=sys.stderr)
    return state


def restore_or_init(config_json: dict, workdir: pathlib.Path, manager, log: reporting.MetricsLog,
                    abstract_state: Any, fresh_state: Callable[[], Any],
                    init_from: str | os.PathLike | None = None) -> tuple[Any, int | None]:
    """(state, restored step or None): the newest checkpoint in `workdir` that restores, else the state of
    the run `init_from` (:func:`state_from_run`), else `fresh_state()`.

    abstract_state: the state's `jax.eval_shape` (what a checkpoint is restored onto).
    On resume, newer checkpoints that do not restore are set aside as `<step>.broken` and metrics past the
    restored step are dropped. Raises ResumeError when the saved run's config differs (`_check_same_run`)
    or no checkpoint restores.
    """
    latest = manager.latest_step()
    if latest is None:
        if init_from is not None:
            return state_from_run(config_json, init_from, abstract_state), None
        return fresh_state(), None
    _check_same_run(config_json, workdir, manager)
    is_main = jax.process_index() == 0
    report = (lambda message: print(message, file=sys.stderr)) if is_main else None
    try:
        state, _, _, restored = checkpoints.restore_newest_good(
            manager, abstract_state, report=report)
    except checkpoints.CheckpointError as error:
        checkpoints.close(manager)
        raise ResumeError(str(error)) from None
    if restored != latest:
        _set_aside_newer_steps(manager, workdir, restored, report)
    if is_main:
        print(f"resuming from step {restored} ({checkpoints.checkpoint_dir(workdir) / str(restored)})",
              file=sys.stderr)
    log.truncate_after(int(restored))
    return state, restored
