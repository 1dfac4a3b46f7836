"""Training: the train state, one jitted train step, and a run set up around them.

Size (~440 lines): one job, the train state and the step that updates it; the loop that runs it is runner.py.

The loop that runs the steps (``runner.py``), the schedule (``schedule.py``), which state a run starts from
(``resume.py``), devices (``parallel.py``), records (``reporting.py``) and validation (``validation.py``) live
elsewhere.

Pieces (pure functions over explicit pytrees; `bin/train` is a thin CLI over `train`):

- `TrainState`: step, params {"forward", "backward", "disc_short", "disc_long"}, phase_params (frozen after
  pretraining), gen_opt_state, disc_opt_state, key (a raw uint32 PRNG key).
- `create_train_state(spec, key, phase_params, mesh)`: initialisation inside `jax.jit`; the same function
  under `jax.eval_shape` gives the abstract state a checkpoint is restored onto.
- `make_train_step(spec, mesh)` -> `train_step(state, dataset, length) -> (state, metrics)`, jitted with the
  state donated. The whole training set lives on the device(s) as arrays with a leading window axis; each
  step draws its batch indices on device from `fold_in(state.key, state.step)`, gathers the windows, runs ONE
  rollout per generator (inside `objective.generator_loss`), and updates both generators and both
  discriminators with separate AdamW optimisers. `length` (the transition length) is a traced int32, so
  the progressive schedule never recompiles. The train step alone chooses the fast paths of `config.train`
  (`stitchjax.accel.fast_rollout`) and, through `specs.train_spec`, accel's generator layers
  (`stitchjax.accel.matmul`); the model's rollout runs the plain model.
- Every function below `train` reads the run's `specs.TrainSpec` (`spec`), built once by `train` from the
  `Config`; none reads the whole `Config`.
- `schedule.transition_length(step, steps_per_epoch, train_config)`: the progressive length (stitchjax.train.schedule).
- `train(config, workdir, ...)`, the entry point: `resume.restore_or_init` (resume from the newest good checkpoint, start from
  another run with `init_from`, or pretrain the phase network and initialise), `runner.run_loop` (progress bar,
  metrics JSON lines, periodic checkpoints, NaN guard, Ctrl-C / SIGTERM save), then `runner.finish` (report.md
  and loss_curves.png).

Devices, sharding and multi-host start-up: `stitchjax.parallel` (the same code runs on 1 CPU, 1 GPU, several
GPUs or a TPU slice). With several processes, process 0 alone writes metrics, the report and the progress
bar; orbax coordinates the checkpoint writes of all processes.
"""

from __future__ import annotations

import functools
import os
import pathlib
import time
from typing import Any, Callable

import flax.struct
import jax
import jax.numpy as jnp
import optax
from jax.sharding import Mesh
from tqdm.auto import tqdm

from stitchjax import checkpoints
from stitchjax.data import datasets
from stitchjax.train import resume, runner, schedule
from stitchjax import config as config_lib
from stitchjax import parallel, specs
from stitchjax.data import features, phase
from stitchjax.accel import fast_rollout
from stitchjax.model import networks, objective
from stitchjax.train import reporting
from stitchjax.train.runner import NonFiniteLossError, TrainingError
from stitchjax.data import windows as windows_lib

GENERATORS = ("forward", "backward")
DISCRIMINATORS = ("disc_short", "disc_long")


class TrainState(flax.struct.PyTreeNode):
    """Everything a training run needs to continue, as one pytree (what a checkpoint holds).

    step: int32 scalar, number of updates done. params: {"forward", "backward", "disc_short", "disc_long"}.
    phase_params: pretrained phase network (not updated by train_step; None-free pytree, may be {}).
    gen_opt_state / disc_opt_state: AdamW states over {"forward","backward"} / {"disc_short","disc_long"}.
    key: uint32 (2,) PRNG key; step n uses fold_in(key, n), so resuming replays the same randomness.
    """

    step: jax.Array
    params: dict
    phase_params: Any
    gen_opt_state: Any
    disc_opt_state: Any
    key: jax.Array


# ------------------------------------------------------------------------------------------ optimisers


def make_optimizer(train_config) -> optax.GradientTransformation:
    """AdamW with the paper's settings (lr 1e-4, b1 0.5, b2 0.9, weight decay 1e-5 by default)."""
    return optax.adamw(
        learning_rate=train_config.learning_rate,
        b1=train_config.adam_b1,
        b2=train_config.adam_b2,
        weight_decay=train_config.weight_decay,
    )


def split_params(params: dict) -> tuple[dict, dict]:
    """{"forward","backward","disc_short","disc_long"} -> (generators, discriminators)."""
    return {k: params[k] for k in GENERATORS}, {k: params[k] for k in DISCRIMINATORS}


def create_train_state(spec, key: jax.Array, phase_params: Any = None, mesh: Mesh | None = None) -> TrainState:
    """Fresh state (step 0) of a `specs.TrainSpec`: networks initialised from `key`, optimiser states zero,
    replicated on `mesh`.

    phase_params: pretrained phase network params, or None to initialise it randomly (phase.init_phase_params)
    — the value when phase modulation is off, and the structure used for restoring.
    """
    mesh = parallel.make_mesh() if mesh is None else mesh
    init_key, phase_key, state_key = jax.random.split(key, 3)
    return _state_initializer(spec, mesh)(init_key, phase_key, state_key, phase_params)


@functools.lru_cache(maxsize=8)
def _state_initializer(spec, mesh: Mesh) -> Callable:
    """The jitted initialiser of `create_train_state`, kept per process like `_train_step_of`."""
    optimizer = make_optimizer(spec.train)

    def init(init_key, phase_key, state_key, phase_params):
        params = networks.init_params(spec.model, init_key)
        if phase_params is None:
            phase_params = init_phase_params(spec, phase_key)
        generators, discriminators = split_params(params)
        return TrainState(
            step=jnp.zeros((), jnp.int32),
            params=params,
            phase_params=phase_params,
            gen_opt_state=optimizer.init(generators),
            disc_opt_state=optimizer.init(discriminators),
            key=state_key,
        )

    return jax.jit(init, out_shardings=parallel.replicated(mesh))


def init_phase_params(spec, key: jax.Array) -> Any:
    """Randomly initialised phase network params of a `specs.TrainSpec`."""
    return phase.init_phase_params(key, state_dim(spec), spec.phase)


def state_dim(spec) -> int:
    """Per-frame character state size J*4 + 3 + C (local quats, root velocity, contacts) of a `specs.TrainSpec`."""
    generator = spec.model.generator
    return features.state_dim(generator.num_joints, generator.num_contacts)


def abstract_train_state(spec, mesh: Mesh | None = None) -> TrainState:
    """ShapeDtypeStructs (with replicated shardings) of the train state of a `specs.TrainSpec`: the target for
    `restore`."""
    mesh = parallel.make_mesh() if mesh is None else mesh
    shapes = jax.eval_shape(lambda key: create_train_state(spec, key, None, mesh), jax.random.PRNGKey(0))
    sharding = parallel.replicated(mesh)
    return jax.tree.map(lambda x: jax.ShapeDtypeStruct(x.shape, x.dtype, sharding=sharding), shapes)


# ---------------------------------------------------------------------------------------- train step


def make_sampler(spec, mesh: Mesh | None = None, window: int | None = None):
    """Jitted `sample(dataset, key, step) -> batch`: the batch of step `step`, drawn on device
    (`spec`: the `specs.TrainSpec`).

    Uses fold_in(key, step) split in 3 (batch, generator noise, discriminator noise), as the update does.
    """
    mesh = parallel.make_mesh() if mesh is None else mesh
    batch_size = spec.train.batch_size

    draw = None
    if spec.random_starts:  # any frame starts a window: cut from the carried windows (features.py)
        def draw(data, key, n):
            return features.random_start_batch(data, key, n, spec.window, windows_lib.FACING_FRAME)

    def sample(dataset, key, step):
        batch_key = jax.random.split(jax.random.fold_in(key, step), 3)[0]
        return parallel.sample_batch(dataset, batch_key, batch_size, mesh, window, draw)

    return jax.jit(sample)


def make_update_step(spec, mesh: Mesh | None = None,
                     generator_loss: Callable | None = None, discriminator_loss: Callable | None = None):
    """Jitted `update(state, batch, length) -> (state, metrics)`: one update of all four networks (of the two
    generators alone with `model.discriminators=false`: `discriminator_loss` is then never called).

    batch: dict of (B, T, ...) arrays (batch axis sharded over the mesh). ONE rollout per generator
    (inside `generator_loss`, whose third output, when present, is handed to `discriminator_loss`). Both
    losses take the run's `specs.TrainSpec` `spec`. The default generator loss also takes the KL warm-up
    factor and the training step's rollout, the one place that chooses the fast paths of `config.train`
    (`accel.fast_rollout.training_rollout_batch`).
    The state is donated: do not use the old state after the call.
    """
    loss_options = _loss_options(spec) if generator_loss is None else (lambda step: {})
    generator_loss = generator_loss or objective.generator_loss
    discriminator_loss = discriminator_loss or objective.discriminator_loss
    mesh = parallel.make_mesh() if mesh is None else mesh
    optimizer = make_optimizer(spec.train)
    tc = spec.train  # the update reads no other setting (but _loss_options' KL warm-up)
    adversarial = spec.loss.discriminators is not None  # model.discriminators=false: no discriminator update

    def update(state: TrainState, batch: dict, length: jax.Array):
        key = jax.random.fold_in(state.key, state.step)
        _, gen_key, disc_key = jax.random.split(key, 3)
        generators, discriminators = split_params(state.params)
        extra = loss_options(state.step)
        (gen_loss, (gen_terms, aux)), gen_grads = _generator_gradients(
            generator_loss, generators, discriminators, state.phase_params, batch, gen_key, spec, length, extra)
        loss_values = {"loss": gen_loss, "gen_terms": gen_terms}
        disc_grads = None
        if adversarial:
            (disc_loss, disc_terms), disc_grads = _discriminator_gradients(
                discriminator_loss, generators, discriminators, state.phase_params, batch, disc_key, spec, length,
                aux)
            loss_values.update(disc_loss=disc_loss, disc_terms=disc_terms)
        new_state, lr_factor = _apply_gradients(optimizer, tc, state, gen_grads, disc_grads)
        return new_state, _step_metrics(loss_values, gen_grads, disc_grads, length, tc, lr_factor)

    rep = parallel.replicated(mesh)
    return jax.jit(update, donate_argnums=(0,), out_shardings=(rep, rep))


def _loss_options(spec) -> Callable:
    """`step -> options` of the default generator loss: the KL warm-up factor at that step and the training
    step's rollout (`accel.fast_rollout`: same values as `batch.rollout_batch`, faster gradients)."""
    rollout_batch = fast_rollout.training_rollout_batch(spec.train)
    kl_warmup_steps = spec.loss.loss.kl_warmup_steps
    return lambda step: {"kl_scale": objective.kl_warmup(step, kl_warmup_steps), "rollout_batch": rollout_batch}


def _generator_gradients(generator_loss, generators, discriminators, phase_params, batch, key, spec, length,
                         extra: dict):
    """((loss, (terms, aux)), gradients) of `generator_loss` in the generators; aux: its third output, or None."""
    def gen_objective(gen_params):
        out = generator_loss({**gen_params, **discriminators}, phase_params, batch, key, spec, length, **extra)
        loss, terms = out[0], out[1]
        aux = out[2] if len(out) > 2 else None
        return loss, (terms, aux)

    return jax.value_and_grad(gen_objective, has_aux=True)(generators)


def _discriminator_gradients(discriminator_loss, generators, discriminators, phase_params, batch, key, spec,
                             length, aux):
    """((loss, terms), gradients) of `discriminator_loss` in the discriminators, given the generator loss's
    aux (stop-gradient) when it has one."""
    def disc_objective(disc_params):
        params = {**jax.lax.stop_gradient(generators), **disc_params}
        extra = () if aux is None else (jax.lax.stop_gradient(aux),)
        out = discriminator_loss(params, phase_params, batch, key, spec, length, *extra)
        return out[0], out[1]

    return jax.value_and_grad(disc_objective, has_aux=True)(discriminators)


def _apply_gradients(optimizer, tc, state: TrainState, gen_grads: dict, disc_grads: dict | None):
    """(the state after one AdamW step of the generators and one of the discriminators, the learning-rate
    factor of `train.lr_decay_to` or None when the rate is constant). disc_grads None (a model without
    discriminators): the discriminators' parameters and optimiser state stay as they are."""
    generators, discriminators = split_params(state.params)
    lr_factor = None if tc.lr_decay_to == 1.0 else schedule.learning_rate_factor(state.step, tc)

    def step(grads, opt_state, params):
        updates, opt_state = optimizer.update(grads, opt_state, params)
        if lr_factor is not None:  # AdamW's update is linear in the learning rate: scale it
            updates = jax.tree.map(lambda u: u * lr_factor, updates)
        return optax.apply_updates(params, updates), opt_state

    generators, gen_opt_state = step(gen_grads, state.gen_opt_state, generators)
    disc_opt_state = state.disc_opt_state
    if disc_grads is not None:
        discriminators, disc_opt_state = step(disc_grads, disc_opt_state, discriminators)
    new_state = state.replace(step=state.step + 1, params={**generators, **discriminators},
                              gen_opt_state=gen_opt_state, disc_opt_state=disc_opt_state)
    return new_state, lr_factor


def _step_metrics(loss_values: dict, gen_grads: dict, disc_grads: dict | None, length, tc, lr_factor) -> dict:
    """The update's metrics: "loss", "disc_loss", every term of both losses (a discriminator term named like a
    generator one gets "disc_"), the gradient norms, "length" and, with a decaying rate, "lr". Without
    discriminators (disc_grads None) there is no "disc_loss", discriminator term or "disc_grad_norm"."""
    metrics = {"loss": loss_values["loss"]}
    if disc_grads is not None:
        metrics["disc_loss"] = loss_values["disc_loss"]
    metrics.update({name: value for name, value in loss_values["gen_terms"].items() if name not in metrics})
    metrics.update({(name if name not in metrics else f"disc_{name}"): value
                    for name, value in loss_values.get("disc_terms", {}).items()})
    metrics["gen_grad_norm"] = optax.tree.norm(gen_grads)
    if disc_grads is not None:
        metrics["disc_grad_norm"] = optax.tree.norm(disc_grads)
    metrics = {name: jnp.asarray(value, jnp.float32) for name, value in metrics.items()}
    metrics["length"] = jnp.asarray(length, jnp.int32)
    if lr_factor is not None:
        metrics["lr"] = tc.learning_rate * lr_factor
    return metrics


def make_train_step(spec, mesh: Mesh | None = None, window: int | None = None,
                    generator_loss: Callable | None = None, discriminator_loss: Callable | None = None):
    """`train_step(state, dataset, length) -> (state, metrics)` of a `specs.TrainSpec`: draw the step's batch
    on device, update.

    dataset: dict of (N, T, ...) arrays from `parallel.shard_dataset`. length: int32 transition length (traced).
    window: frames per training window the losses see (static; None = the dataset's T). Metrics: the
    generator "loss", "disc_loss", every term of both, "length", gradient norms; float32 scalars.
    Two jitted calls (sampler, then update): the gather stays out of the update's program, which keeps that
    program smaller and quicker to compile. The state is donated.
    """
    mesh = parallel.make_mesh() if mesh is None else mesh
    sample = make_sampler(spec, mesh, window)
    update = make_update_step(spec, mesh, generator_loss, discriminator_loss)

    def train_step(state: TrainState, dataset: dict, length):
        return update(state, sample(dataset, state.key, state.step), length)

    train_step.sample, train_step.update = sample, update
    return train_step


# ---------------------------------------------------------------------------------------------- data


def pretrain_phase_params(spec, dataset: dict, key: jax.Array):
    """Pretrain the phase network of a `specs.TrainSpec` on every frame of the training windows and of the
    same windows played backwards; (params, final_loss)."""
    states, labels = features.phase_training_arrays(dataset, spec.skeleton.velocity_scale, spec.rollout.fps)
    return phase.pretrain_phase(key, states, labels, spec.phase)


# ------------------------------------------------------------------------------------------------ loop


def _fresh_state(spec, dataset: dict, mesh: Mesh) -> TrainState:
    """Step 0 from train.seed, with the phase network pretrained on `dataset` when the model uses one."""
    key = jax.random.PRNGKey(spec.train.seed)
    phase_params = None
    if spec.model.generator.phase_modulation:
        phase_params, phase_loss = pretrain_phase_params(spec, dataset, jax.random.fold_in(key, 1))
        if jax.process_index() == 0:
            print(f"phase network pretrained: final loss {float(phase_loss):.4g}")
    return create_train_state(spec, key, phase_params, mesh)


@functools.lru_cache(maxsize=8)
def _train_step_of(spec, mesh: Mesh, window: int | None):
    """`make_train_step(spec, mesh, window)`, kept per process: a second run of an equal `specs.TrainSpec` in the
    same process (a notebook, the tests) reuses the traced and compiled programs instead of tracing them again."""
    return make_train_step(spec, mesh, window)


def _step_for_length(spec, mesh: Mesh) -> Callable:
    """`step_for(length)`: the train step for transition length `length` (one compiled step per window)."""

    def step_for(length: int):
        return _train_step_of(spec, mesh, schedule.bucket_window(length, spec.train))

    return step_for


def train(config, workdir: str | os.PathLike, *, data_dir: str | os.PathLike | None = None,
          max_steps: int | None = None, config_name: str = "", progress: bool = True, prepared: tuple | None = None,
          train_step: Callable | None = None, init_from: str | os.PathLike | None = None,
          make_validator: Callable | None = None) -> dict:
    """Train (or resume) a run of `config` in `workdir` until step `max_steps` (default: `total_steps`). The
    entry point: it builds the run's `specs.TrainSpec` once; what it calls reads that.

    init_from: a run folder to start a new `workdir` from (fine-tuning with other loss / train settings;
    ignored once `workdir` has checkpoints of its own). make_validator: with ``train.eval_every`` > 0,
    ``make_validator(config.data, config.train, data_dir, stats_json, skeleton_facts) -> validate(state) ->
    record`` (``stitchjax.eval.validation.make_validator`` with its model builder bound; bin/train passes it).

    prepared: (dataset, stats), prepared arrays to skip loading (tests, notebooks); otherwise they are loaded
    from `data_dir` (None = the bundled LAFAN1 sample). train_step: a replacement step function (tests).
    Returns a summary dict (step, losses, wall time, stop_reason). Raises NonFiniteLossError on NaN/inf.
    """
    t_begin = time.perf_counter()
    workdir = pathlib.Path(workdir).expanduser().resolve()
    workdir.mkdir(parents=True, exist_ok=True)
    mesh = parallel.make_mesh()
    spec = specs.train_spec(config)
    dataset, stats, device_data = _training_data(config.data, data_dir, prepared, mesh)
    num_windows = int(next(iter(dataset.values())).shape[0])
    plan = schedule.plan_run(num_windows, spec.train, max_steps)

    manager = checkpoints.open_manager(workdir)
    log = reporting.MetricsLog(workdir / "metrics.jsonl", enabled=jax.process_index() == 0)
    config_json = config_lib.to_dict(config)
    try:
        state, latest = resume.restore_or_init(config_json, workdir, manager, log, abstract_train_state(spec, mesh),
                                               lambda: _fresh_state(spec, dataset, mesh), init_from)
    except resume.ResumeError as error:
        raise TrainingError(str(error)) from None
    extras = _checkpoint_extras(config.data, config_name, data_dir, dataset, stats)
    saver = runner.Saver(manager, config_json, extras, latest)
    validate = (make_validator(config.data, config.train, data_dir, extras["stats"], extras["skeleton"])
                if make_validator is not None and spec.train.eval_every > 0 else None)
    step_for = (lambda length: train_step) if train_step is not None else _step_for_length(spec, mesh)
    bar = (tqdm(total=plan.max_steps, initial=int(state.step), unit="step", dynamic_ncols=True)
           if progress and jax.process_index() == 0 else None)
    t_start = time.perf_counter()
    state, outcome = _closing_on_error(
        lambda: runner.run_loop(state, device_data, step_for, plan, spec.train, log, saver, bar, t_start, validate),
        workdir, manager, bar, saver)
    if bar is not None:
        bar.close()
    if saver.last != outcome["step"]:
        saver(outcome["step"], state)
    checkpoints.close(manager)
    return runner.finish(workdir, config_name, outcome, num_windows, spec.train, t_begin, t_start)


def _training_data(data, data_dir, prepared: tuple | None, mesh: Mesh) -> tuple:
    """(dataset, stats, device_data): the training windows of the config's ``data`` section (loaded from
    `data_dir` unless `prepared` gives them) and this process's share of them sharded over `mesh`.
    TrainingError when there is no window."""
    dataset, stats = datasets.load_training_data(data, data_dir) if prepared is None else prepared
    num_windows = int(next(iter(dataset.values())).shape[0])
    if num_windows == 0:
        raise TrainingError("no training windows: check --data and config.data (window length, subjects)")
    local = parallel.local_windows_slice(num_windows)
    device_data = parallel.shard_dataset({k: v[local] for k, v in dataset.items()}, mesh)
    return dataset, stats, device_data


def _checkpoint_extras(data, config_name: str, data_dir, dataset: dict, stats) -> dict:
    """What every checkpoint of the run holds beside the state: the data statistics, the config's name and the
    skeleton's facts (``data``: the config's data section)."""
    extras = {"stats": datasets.stats_to_json(stats), "config_name": config_name,
              "skeleton": datasets.skeleton_facts(data_dir, data)}
    # the training windows' 99th percentile of horizontal root speed (cm/s): the fastest transition a
    # placed target may ask for (stitchjax.sample.takes)
    extras["stats"]["root_speed_p99"] = features.root_speed_percentiles(dataset["root_positions"],
                                                                        data.fps)["p99"]
    return extras


def _closing_on_error(run: Callable, workdir: pathlib.Path, manager, bar, saver: runner.Saver) -> tuple:
    """``run()`` (the run's loop); on a non-finite loss or a second Ctrl-C the progress bar and the checkpoint
    manager are closed first, and the NonFiniteLossError names the checkpoint kept."""
    try:
        return run()
    except NonFiniteLossError as error:
        runner.close(bar, manager)
        raise NonFiniteLossError(
            f"{error} (checkpoint kept: {'none' if saver.last is None else f'step {saver.last}'} in "
            f"{checkpoints.checkpoint_dir(workdir)})") from None
    except KeyboardInterrupt:  # a second Ctrl-C: the state may be mid-update, so do not save it
        runner.close(bar, manager)
        raise
