"""Devices and hosts: the device mesh, replicated and sharded placement, multi-host start-up, batches.

The same code runs on 1 CPU, 1 GPU, several GPUs or a TPU slice:
  A `Mesh` over all devices with axes ("hosts", "devices"): the batch is sharded over both axes (data
  parallelism), params and optimiser states are replicated, and XLA inserts the gradient all-reduce. The
  training set is sharded over "hosts" and replicated over the devices of a host; inside `shard_map` each
  device gathers its own slice of the batch from its host's windows, so no window crosses hosts.
  Within one process the batch indices are drawn from one key and sliced per device, so the data order
  (and the result, up to float summation order) does not depend on the number of devices.
Multi-process (several hosts, e.g. a TPU pod slice or a multi-node GPU job):
  Run the same command on every host. `bin/train --distributed` (or any of the environment variables
  JAX_COORDINATOR_ADDRESS / JAX_NUM_PROCESSES / JAX_PROCESS_ID, or a cluster jax detects itself such as
  SLURM or Cloud TPU) calls `maybe_initialize_distributed` before anything else touches jax. Each process
  then keeps windows i with i % process_count == process_index (`local_windows_slice`, truncated to the
  same count on every host) and draws its share of every batch from them.
"""

from __future__ import annotations

import os

import jax
import numpy as np
from jax.sharding import Mesh, NamedSharding
from jax.sharding import PartitionSpec as P

BATCH_AXES = ("hosts", "devices")
_DISTRIBUTED_ENV = (("JAX_COORDINATOR_ADDRESS", "coordinator_address"), ("JAX_NUM_PROCESSES", "num_processes"),
                    ("JAX_PROCESS_ID", "process_id"))


class ParallelError(ValueError):
    """The devices, the processes or the batch cannot be set up as asked (the message says which)."""


def make_mesh(devices=None) -> Mesh:
    """A ("hosts", "devices") mesh over all visible devices (hosts = process count)."""
    devices = list(jax.devices() if devices is None else devices)
    num_hosts = len({d.process_index for d in devices})
    devices = sorted(devices, key=lambda d: (d.process_index, d.id))
    grid = np.array(devices, dtype=object).reshape(num_hosts, len(devices) // num_hosts)
    return Mesh(grid, BATCH_AXES)


def replicated(mesh: Mesh) -> NamedSharding:
    """The same full array on every device of `mesh`."""
    return NamedSharding(mesh, P())


def maybe_initialize_distributed(force: bool = False) -> bool:
    """Call `jax.distributed.initialize()` when asked or when the standard env vars say so.

    Must run before any other jax call. Returns True when distributed mode was initialised.
    """
    if not force and not any(os.environ.get(name) for name, _ in _DISTRIBUTED_ENV):
        return False
    kwargs = {}
    for name, key in _DISTRIBUTED_ENV:
        text = os.environ.get(name, "").strip()
        if not text:
            continue
        if key != "coordinator_address":
            try:
                kwargs[key] = int(text)
            except ValueError:
                raise ParallelError(f"{name}={text!r} must be a whole number") from None
        else:
            kwargs[key] = text
    if "num_processes" in kwargs and "process_id" in kwargs \
            and not 0 <= kwargs["process_id"] < kwargs["num_processes"]:
        raise ParallelError(f"JAX_PROCESS_ID={kwargs['process_id']} must be in 0..JAX_NUM_PROCESSES-1 "
                            f"({kwargs['num_processes'] - 1})")
    jax.distributed.initialize(**kwargs)
    return True


def shard_dataset(dataset: dict, mesh: Mesh) -> dict:
    """Put this process's windows on its devices: leading axis split over hosts, replicated on devices.

    dataset: dict of numpy arrays with the same leading window count N_local (this process's windows);
    float64 arrays become float32. Every process must pass the same N_local (see `local_windows_slice`).
    """
    sharding = NamedSharding(mesh, P("hosts"))
    num_hosts = mesh.shape["hosts"]

    def put(x):
        x = np.asarray(x)
        if x.dtype == np.float64:
            x = x.astype(np.float32)
        if num_hosts == 1:
            return jax.device_put(x, sharding)
        global_shape = (x.shape[0] * num_hosts,) + x.shape[1:]
        return jax.make_array_from_process_local_data(sharding, x, global_shape)

    return {name: put(x) for name, x in dataset.items()}


def local_windows_slice(num_windows: int) -> slice:
    """The windows this process trains on: every process_count-th, same count on every process."""
    count, index = jax.process_count(), jax.process_index()
    per_process = num_windows // count
    if per_process == 0:
        raise ParallelError(f"{num_windows} training windows cannot be split over {count} processes")
    return slice(index, index + per_process * count, count)


def sample_batch(dataset: dict, key: jax.Array, batch_size: int, mesh: Mesh, window: int | None = None,
                 draw=None) -> dict:
    """Draw `batch_size` windows uniformly (with replacement) on device; batch sharded over the mesh.

    dataset: dict of (N, T, ...) arrays sharded as by `shard_dataset`. window: keep frames [0, window)
    (static; None = all). Within one process the indices come from one key and each device takes its
    slice, so the batch does not depend on the device count. Returns (batch_size, T or window, ...) arrays.
    draw: `draw(data, key, n) -> batch` replaces the uniform draw of whole windows (random window starts:
    features.random_start_batch); the window cut applies to its batch.
    """
    num_hosts, per_host_devices = mesh.shape["hosts"], mesh.shape["devices"]
    if batch_size % (num_hosts * per_host_devices):
        raise ParallelError(
            f"train.batch_size={batch_size} is not divisible by the {num_hosts * per_host_devices} devices; "
            "pick a multiple of the device count")
    host_batch = batch_size // num_hosts
    device_batch = host_batch // per_host_devices

    def local(key, data):
        host = jax.lax.axis_index("hosts")
        device = jax.lax.axis_index("devices")
        if draw is not None:
            batch = draw(data, jax.random.fold_in(key, host), host_batch)
            batch = jax.tree.map(lambda x: jax.lax.dynamic_slice_in_dim(x, device * device_batch, device_batch), batch)
            return jax.tree.map(lambda x: (x if window is None else x[:, :window]), batch)
        num_local = jax.tree.leaves(data)[0].shape[0]
        indices = jax.random.randint(jax.random.fold_in(key, host), (host_batch,), 0, num_local)
        indices = jax.lax.dynamic_slice_in_dim(indices, device * device_batch, device_batch)
        return jax.tree.map(lambda x: (x[indices] if window is None else x[indices, :window]), data)

    return jax.shard_map(
        local, mesh=mesh, in_specs=(P(), P("hosts")), out_specs=P(BATCH_AXES), check_vma=False,
    )(key, dataset)
