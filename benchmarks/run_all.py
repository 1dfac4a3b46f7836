"""All benchmarks in one command: stitchjax vs an eager and a compiled PyTorch twin, FLOPs and peak fraction,
scaling.

    python benchmarks/run_all.py                      # full run (~30+ min on a 2-core CPU)
    python benchmarks/run_all.py --quick              # train + infer, fewer repetitions (< 3 min, see README)
    python benchmarks/run_all.py --quick --json out.json
    python benchmarks/run_all.py --only train,infer   # a subset of: train, infer, scale_batch,
                                                      #   scale_length, data_parallel
    python benchmarks/run_all.py --only train --train-batch 4 --train-length 6 --train-reps 1   # a smoke test

Measured side by side in one process (jax and torch share the CPU; each timing = warm-up, then several
repetitions, median reported; jax and torch repetitions are interleaved so load from other processes hits
both alike):

- train: one full training step (both generators' bidirectional aligned rollout, all losses, backward pass,
  AdamW on the generators, the discriminator update) of the `lafan1` config (the current default model:
  posterior q(z | h, next frame), z at every decoder layer, ...), batch 32, transition length 48 (= the
  config's train.max_length: a 50-frame window holds 48 in-betweens + 2 keyframes), windows/s.
  stitchjax: `train.make_train_step` (jitted, compiled ahead of time). Twin: `benchmarks/torch_twin.py`
  (eager PyTorch, Python loop over frames, torch.optim.AdamW), same sizes, same batch, at torch's default
  threads and at 1 thread (--quick: the faster of the two in a one-call probe). Compiled twin: the same
  twin with its per-frame generator step through torch.compile (inductor), at the faster thread setting;
  its first step (compilation + one step) is reported apart from the steady-state throughput.
- FLOPs per train step: matmul FLOPs of the optimised HLO with loop trip counts (benchmarks/flops.py),
  cross-checked against a hand count of the network's matmuls; XLA's cost_analysis() is also reported
  (it counts a scan body once). peak_flops_fraction = matmul FLOPs per step / median step time /
  THEORETICAL float32 peak (cores x nominal GHz x FLOP/cycle, see flops.py); the measured GEMM peak of
  numpy/XLA on this machine is reported beside it.
- infer: one transition of 50 generated frames, 64 samples (one vmapped rollout), ms per call; the twins
  under torch.inference_mode().
- bfloat16: train and infer also with model.matmul_dtype=bfloat16 (bfloat16 matmul operands, float32
  accumulation), against the twin in float32 and under torch.autocast(bfloat16), where the CPU has bfloat16
  units (/proc/cpuinfo flags amx_bf16 / avx512_bf16, aarch64 bf16; --bf16 on|off overrides); otherwise
  skipped, and the JSON says why.
- scale_batch: train windows/s vs batch size; scale_length: vs transition length (window = L + 2 frames of
  synthetic data); data_parallel: train windows/s with 1, 2, 4 forced host CPU devices (subprocesses with
  XLA_FLAGS=--xla_force_host_platform_device_count=N), same global batch 32. Not in --quick.

Data: synthetic windows (random smooth motion on the LAFAN1 skeleton with LAFAN1-like bone lengths); a
step's cost does not depend on the values. Writes a JSON with everything (--json) and prints a summary.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import os
import pathlib
import platform
import statistics
import subprocess
import sys
import time
import traceback
from typing import Any, Callable

REPO = pathlib.Path(__file__).resolve().parent.parent
os.environ.setdefault("JAX_PLATFORMS", "cpu")
os.environ.setdefault("JAX_COMPILATION_CACHE_DIR", str(REPO / ".cache" / "jax"))
os.environ.setdefault("JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS", "1.0")
for _path in (str(REPO), str(REPO / "benchmarks")):
    if _path not in sys.path:
        sys.path.insert(0, _path)

import numpy as np  # noqa: E402

import flops as flops_lib  # noqa: E402

TRAIN_BATCH = 32
TRAIN_LENGTH = 48  # lafan1 train.max_length: 50-frame windows, 48 generated frames
INFER_SAMPLES = 64
INFER_LENGTH = 50
BFLOAT16 = "model.matmul_dtype=bfloat16"
TARGETS = {"train_speedup_vs_torch": 3.0, "peak_flops_fraction": 0.30, "infer_64x50_ms": 200.0}


# --------------------------------------------------------------------------------------------- helpers


def log(message: str) -> None:
    print(f"[{time.strftime('%H:%M:%S')}] {message}", flush=True)


def timeit(fn: Callable[[], Any], warmup: int = 1, reps: int = 5) -> dict:
    """Run fn warm-up times, then reps timed times; fn must block until its work is done.

    Returns {"median_s", "min_s", "max_s", "times_s"}.
    """
    for _ in range(warmup):
        fn()
    times = []
    for _ in range(reps):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return summarize(times)


def summarize(times: list[float]) -> dict:
    return {"median_s": statistics.median(times), "min_s": min(times), "max_s": max(times),
            "times_s": [round(t, 6) for t in times]}


def interleaved(fns: dict[str, Callable[[], Any]], warmup: int = 1, reps: int = 5) -> dict:
    """Time several functions side by side: warm-up each, then reps rounds running each once per round."""
    for fn in fns.values():
        for _ in range(warmup):
            fn()
    times: dict[str, list[float]] = {name: [] for name in fns}
    for _ in range(reps):
        for name, fn in fns.items():
            start = time.perf_counter()
            fn()
            times[name].append(time.perf_counter() - start)
    return {name: summarize(values) for name, values in times.items()}


def machine_info() -> dict:
    import jax

    info = flops_lib.cpu_info()
    out = {
        "cpu_model": info["model_name"], "cpu_vendor": info["vendor"], "cpu_family": info["family"],
        "cpu_model_number": info["model"], "cpu_mhz_nominal": info["mhz"], "cores": info["usable_cores"],
        "hypervisor": info["hypervisor"], "simd": [f for f in ("sse4_2", "avx", "avx2", "fma", "avx512f")
                                                   if f in info["flags"]],
        "python": platform.python_version(), "numpy": np.__version__, "jax": jax.__version__,
        "jax_backend": jax.default_backend(), "jax_devices": len(jax.devices()),
        "platform": platform.platform(),
    }
    try:
        import flax
        out["flax"] = flax.__version__
    except ImportError:
        pass
    try:
        import torch
        out["torch"] = torch.__version__
        out["torch_threads"] = torch.get_num_threads()
    except ImportError:
        out["torch"] = None
    try:
        out["load_average_at_start"] = list(os.getloadavg())
    except OSError:
        pass
    return out


def synthetic_dataset(config, num_windows: int, num_frames: int, seed: int = 0) -> dict:
    """Windows shaped like ``features.prepare_dataset``'s output, float32 numpy, leading (N, T).

    Smooth random local rotations (small angles around identity), a walking root (about 1.5 cm/frame),
    random 0/1 contacts, LAFAN1-like bone offsets, FK global positions, phase features in [-1, 1].
    """
    from stitchjax import skeleton as skel

    rng = np.random.default_rng(seed)
    parents = tuple(config.data.parents)
    joints, contacts = len(parents), getattr(config.data, "num_contacts", 4)  # 4: features.NUM_CONTACTS
    t = np.arange(num_frames)[None, :, None, None] / config.data.fps
    freq = rng.uniform(0.5, 2.0, (num_windows, 1, joints, 3))
    phase0 = rng.uniform(0, 2 * np.pi, (num_windows, 1, joints, 3))
    amp = rng.uniform(0.05, 0.4, (num_windows, 1, joints, 3))
    axis_angle = amp * np.sin(2 * np.pi * freq * t + phase0)  # (N, T, J, 3) radians
    angle = np.linalg.norm(axis_angle, axis=-1, keepdims=True)
    axis = axis_angle / np.maximum(angle, 1e-8)
    rotations = np.concatenate([np.cos(angle / 2), np.sin(angle / 2) * axis], axis=-1)
    heading = rng.uniform(0, 2 * np.pi, (num_windows, 1))
    speed = rng.uniform(0.5, 3.0, (num_windows, 1))
    steps = np.arange(num_frames)[None, :]
    bob = 90 + 2 * np.sin(steps / 5.0) + 0 * heading
    root = np.stack([np.cos(heading) * speed * steps, bob, np.sin(heading) * speed * steps], axis=-1)
    root -= root.mean(axis=1, keepdims=True) * np.array([1, 0, 1])
    bone = rng.normal(0, 1, (joints, 3))
    bone = bone / np.linalg.norm(bone, axis=-1, keepdims=True) * rng.uniform(8, 40, (joints, 1))
    bone[0] = 0
    offsets = np.broadcast_to(bone, (num_windows, 1, joints, 3)).copy()
    local_positions = np.broadcast_to(bone, (num_windows, num_frames, joints, 3)).copy()
    local_positions[:, :, 0] = root
    _, global_positions = skel.forward_kinematics(rotations, local_positions, parents)
    contact = (rng.uniform(size=(num_windows, num_frames, contacts)) < 0.5).astype(np.float32)
    phase = rng.uniform(-1, 1, (num_windows, num_frames, 2 * contacts))
    return {
        "rotations": rotations.astype(np.float32),
        "root_positions": root.astype(np.float32),
        "contacts": contact,
        "global_positions": global_positions.astype(np.float32),
        "phase": phase.astype(np.float32),
        "offsets": offsets.astype(np.float32),
    }


def bench_config(batch: int = TRAIN_BATCH, length: int = TRAIN_LENGTH, extra=()):
    """The lafan1 config (the current default model, which the twin mirrors) with batch size and window =
    length + 2 frames."""
    from stitchjax import config as config_lib

    overrides = [f"train.batch_size={batch}", f"data.window={length + 2}", f"train.max_length={length}"]
    return config_lib.apply_overrides(config_lib.load_config("lafan1"), overrides + list(extra))


# -------------------------------------------------------------------------------------- bfloat16 units


BF16_FLAGS = ("amx_bf16", "avx512_bf16")  # x86 /proc/cpuinfo "flags"; aarch64 lists "bf16" under "Features"


def bf16_support(cpuinfo: str | None = None) -> tuple[bool, str]:
    """Whether the CPU has bfloat16 matmul units, and why, from /proc/cpuinfo text (read when None).

    x86: the ``amx_bf16`` or ``avx512_bf16`` flag; aarch64: ``bf16`` in "Features". Without them XLA and
    torch run bfloat16 matmuls by converting to float32, so bfloat16 rows would only measure conversions.
    """
    if cpuinfo is None:
        try:
            cpuinfo = pathlib.Path("/proc/cpuinfo").read_text()
        except OSError as err:
            return False, f"cannot read /proc/cpuinfo ({err.strerror}): bfloat16 units unknown"
    flags: set[str] = set()
    for line in cpuinfo.splitlines():
        key, sep, value = line.partition(":")
        if sep and key.strip().lower() in ("flags", "features"):
            flags.update(value.split())
    found = [f for f in BF16_FLAGS if f in flags] + (["bf16"] if "bf16" in flags else [])
    if found:
        return True, f"CPU flags {', '.join(found)} in /proc/cpuinfo"
    if not flags:
        return False, "no CPU flags in /proc/cpuinfo: bfloat16 units unknown"
    return False, (f"no {', '.join(BF16_FLAGS)} (x86) or bf16 (aarch64) in the /proc/cpuinfo flags: this CPU "
                   "has no bfloat16 units (bfloat16 matmuls would run as float32 plus conversions)")


def bf16_decision(args) -> tuple[bool, str]:
    """(run the bfloat16 rows, reason): --bf16 on/off, or auto = a GPU backend or bfloat16 CPU units."""
    if args.bf16 == "on":
        return True, "--bf16 on"
    if args.bf16 == "off":
        return False, "--bf16 off"
    import jax

    if jax.default_backend() != "cpu":
        return True, f"jax backend {jax.default_backend()}"
    return bf16_support()


# ----------------------------------------------------------------------------------------- jax side


class JaxTrain:
    """A compiled stitchjax train step on synthetic data; ``run()`` does one step and blocks."""

    def __init__(self, config, length: int, num_windows: int | None = None, mesh=None):
        import jax
        import jax.numpy as jnp
        from stitchjax import parallel, specs
        from stitchjax.train import loop as train

        self.config = config
        run = specs.train_spec(config)  # what the train step reads
        self.mesh = parallel.make_mesh() if mesh is None else mesh
        batch = config.train.batch_size
        data = synthetic_dataset(config, num_windows or max(64, 2 * batch), length + 2)
        self.host_data = data
        self.dataset = parallel.shard_dataset(data, self.mesh)
        self.state = train.create_train_state(run, jax.random.PRNGKey(0), None, self.mesh)
        self.length = jnp.int32(length)
        step = train.make_train_step(run, self.mesh)
        start = time.perf_counter()
        if hasattr(step, "update"):  # train_step = jitted sampler, then jitted update (train.py)
            self.sample = step.sample
            batch = self.sample(self.dataset, self.state.key, self.state.step)
            self.compiled = step.update.lower(self.state, batch, self.length).compile()
        else:  # one jitted train_step(state, dataset, length)
            self.sample = None
            self.compiled = step.lower(self.state, self.dataset, self.length).compile()
        self.compile_s = time.perf_counter() - start
        self.metrics = None

    def run(self) -> None:
        """One full train step (batch sampling on device + update), blocking until done."""
        import jax

        if self.sample is not None:
            batch = self.sample(self.dataset, self.state.key, self.state.step)
            self.state, self.metrics = self.compiled(self.state, batch, self.length)
        else:
            self.state, self.metrics = self.compiled(self.state, self.dataset, self.length)
        jax.block_until_ready(self.metrics)

    def flops(self) -> dict:
        hlo = flops_lib.hlo_matmul_flops(self.compiled)
        cost = flops_lib.xla_cost_analysis(self.compiled)
        return {"hlo_matmul_flops": hlo["matmul_flops"], "hlo_dots": hlo["dots"],
                "hlo_loops": hlo["loops"], "hlo_unknown_trip_counts": hlo["unknown_trip_counts"],
                "xla_cost_analysis_flops": cost.get("flops"),
                "xla_cost_analysis_transcendentals": cost.get("transcendentals"),
                "xla_cost_analysis_bytes": cost.get("bytes accessed")}


class JaxInfer:
    """stitchjax inference: `samples` transitions of `length` frames between one pair of keyframes.

    Uses the inference API's model-frame entry point ``inbetween.sample_transitions`` (one jitted, vmapped
    rollout, results copied back to numpy) on ``trained_model.random_model(config)``; falls back to a vmapped
    ``rollout.rollout`` when that API is missing.
    """

    def __init__(self, config, length: int, samples: int, data: dict, seed: int = 0):
        import jax
        import jax.numpy as jnp

        def keyframe(i):
            return {"rotations": data["rotations"][:1, i], "root_position": data["root_positions"][:1, i],
                    "contacts": data["contacts"][:1, i]}

        start, target, offsets = keyframe(0), keyframe(length + 1), data["offsets"][:1, 0]
        try:
            from stitchjax.sample import inbetween, trained_model
            self.model = trained_model.random_model(config, seed=seed)
            self.params, self.phase_params = self.model.params, self.model.phase_params
            self.api = "inbetween.sample_transitions (random_model weights)"
            self.fn = lambda: inbetween.sample_transitions(self.model, start, target, offsets, length, samples, 1)
        except (ImportError, AttributeError):
            from stitchjax.model import networks, rollout as rollout_lib
            from stitchjax.data import phase
            spec = rollout_lib.rollout_spec(config) if hasattr(rollout_lib, "rollout_spec") else config
            key = jax.random.PRNGKey(seed)
            model_spec = networks.model_spec(config) if hasattr(networks, "model_spec") else config
            self.params = networks.init_params(model_spec, key)
            state = config.data.num_joints * 4 + 3 + getattr(config.data, "num_contacts", 4)  # 4: NUM_CONTACTS
            self.phase_params = phase.init_phase_params(key, state, config.phase)
            self.api = "rollout.rollout (vmapped over samples)"
            one_start = jax.tree.map(lambda x: jnp.asarray(x[0]), start)
            one_target = jax.tree.map(lambda x: jnp.asarray(x[0]), target)

            @jax.jit
            def generate(params, phase_params, key):
                keys = jax.random.split(key, samples)
                out = jax.vmap(lambda k: rollout_lib.rollout(params, phase_params, one_start, one_target,
                                                             jnp.asarray(offsets[0]), k, spec, length,
                                                             length))(keys)
                return out["global_positions"]

            self.fn = lambda: np.asarray(generate(self.params, self.phase_params, jax.random.PRNGKey(1)))
        t0 = time.perf_counter()
        self.fn()
        self.compile_s = time.perf_counter() - t0  # first call: compile + one run

    def run(self) -> None:
        self.fn()


# --------------------------------------------------------------------------------------------- sections


def hand_count(config, batch: int, length: int) -> dict:
    """Matmul FLOPs of one train step counted from the layer sizes (see torch_twin.matmul_flops)."""
    import torch_twin

    return torch_twin.matmul_flops(config, batch, length)


def torch_thread_variants(run, one_thread: bool = True) -> dict:
    """Timing functions for a torch callable: {"torch": torch's default thread count, "torch_1_thread"}
    (the latter when one_thread and the default is > 1). Each sets its thread count, runs, then restores
    the default.

    The twin is timed both ways and the faster one is the baseline: eager torch's OpenMP threads can lose
    10x when other processes compete for the cores, 1 thread does not."""
    import torch

    default = torch.get_num_threads()

    def with_threads(threads):
        def timed():
            torch.set_num_threads(threads)
            try:
                run()
            finally:
                torch.set_num_threads(default)
        return timed

    extra = {"torch_1_thread": with_threads(1)} if one_thread and default > 1 else {}
    return {"torch": with_threads(default), **extra}


def with_threads(run, threads: int) -> Callable[[], Any]:
    """``run`` at ``threads`` torch threads (restored afterwards)."""
    import torch

    def timed():
        before = torch.get_num_threads()
        torch.set_num_threads(threads)
        try:
            return run()
        finally:
            torch.set_num_threads(before)
    return timed


def faster_threads(probe) -> tuple[int, dict]:
    """The faster torch thread setting, torch's default or 1, from one timed call of ``probe`` (a short
    version of the work, already warmed up) at each: (threads, {threads: seconds}). On a CPU shared with
    other processes eager torch's OpenMP threads can be 20x slower than 1 thread; on an idle one faster."""
    import torch

    default = torch.get_num_threads()
    seconds = {}
    for threads in dict.fromkeys((1, default)):
        start = time.perf_counter()
        with_threads(probe, threads)()
        seconds[threads] = time.perf_counter() - start
    return min(seconds, key=seconds.get), seconds


PROBE_LENGTH = 8  # transition length of the thread probe's train step / inference call


def thread_key(threads: int, default: int) -> str:
    return "torch" if threads == default else f"torch_{threads}_thread"


COMPILED_WHAT = ("torch.compile (inductor, default mode) of the twin's per-frame generator step "
                 "(Twin._frame_step: state/offset features, phase network, generator, next frame); the Python "
                 "loop over frames, stitching, FK, losses and AdamW stay eager")


def compiled_twin(config, params, phase_params, threads: int):
    """A second twin with the same weights, its per-frame step torch.compile'd (compiled at its first
    calls, at ``threads`` torch threads: inductor's CPU kernels keep the thread count they were built with)."""
    import torch
    import torch_twin

    torch._dynamo.config.recompile_limit = max(torch._dynamo.config.recompile_limit, 64)
    twin = torch_twin.Twin(config)
    twin.load_flax(params, phase_params)
    twin.compile()
    return twin


def timed_functions(args, jax_fn, jax_bf16_fn, torch_fn, compiled_fn, threads: int, default_threads: int) -> dict:
    """The functions a section times side by side: stitchjax, the eager twin (at the probe's thread setting
    with --torch-threads faster, else at each variant), the compiled twin, and where bfloat16 rows run
    (jax_bf16_fn not None) stitchjax in bfloat16 and, outside --quick, the autocast twin (autocast gains the
    eager twin nothing on AMX machines, README; --quick compares bfloat16 with the float32 twin)."""
    if args.torch_threads == "faster":  # the thread setting the probe chose
        torch_fns = {thread_key(threads, default_threads): with_threads(torch_fn, threads)}
    else:
        torch_fns = torch_thread_variants(torch_fn)
    fns = {"jax": jax_fn, **torch_fns, "torch_compiled": compiled_fn}
    if jax_bf16_fn is not None:
        fns["jax_bfloat16"] = jax_bf16_fn
        if not args.quick:
            fns["torch_bfloat16_autocast"] = torch_bfloat16(torch_fn, threads)
    return fns


def best_torch_s(timings: dict, any_precision: bool = False) -> float:
    """The fastest median over the eager float32 torch variants timed (with any_precision: bfloat16 too)."""
    return min(t["median_s"] for name, t in timings.items()
               if name.startswith("torch") and "compiled" not in name and (any_precision or "bfloat16" not in name))


def torch_bfloat16(run, threads: int) -> Callable[[], Any]:
    """``run`` under ``torch.autocast("cpu", dtype=torch.bfloat16)`` at ``threads`` torch threads (the faster
    float32 setting): the twin's counterpart of ``model.matmul_dtype=bfloat16``."""
    import torch

    def timed():
        with torch.autocast("cpu", dtype=torch.bfloat16):
            run()
    return with_threads(timed, threads)


def section_train(args, results: dict) -> dict:
    import torch
    import torch_twin

    batch_size, length = args.train_batch, args.train_length
    run_bf16 = results["bf16"]["run"]
    scan_remat = [f"train.scan_remat={args.scan_remat}"]  # stitchjax only: the same gradients either way
    config = bench_config(batch_size, length, scan_remat)
    log(f"train: compiling stitchjax step (batch {batch_size}, length {length}, train.scan_remat="
        f"{args.scan_remat}) ...")
    jax_train = JaxTrain(config, length)
    log(f"train: compiled in {jax_train.compile_s:.1f} s")
    jax_train_bf16 = None
    if run_bf16:
        log("train: the same with model.matmul_dtype=bfloat16 ...")
        jax_train_bf16 = JaxTrain(bench_config(batch_size, length, [BFLOAT16] + scan_remat), length)
    default_threads = torch.get_num_threads()
    params, phase_params = jax_train.state.params, jax_train.state.phase_params  # before any step donates them
    twin = torch_twin.Twin(config)
    twin.load_flax(params, phase_params)
    batch = torch_twin.batch_to_torch(jax_train.host_data, np.arange(batch_size))
    rng = np.random.default_rng(0)
    steps = max(torch_twin.schedule(config, length)[2:])
    eps0 = torch.from_numpy(rng.standard_normal((batch_size, steps, 2, config.model.latent_dim), dtype=np.float32))
    start = time.perf_counter()
    eager_first = with_threads(lambda: twin.train_step(batch, length, eps=eps0), 1)()  # warm-up
    eager_first_s = time.perf_counter() - start
    twin_step = lambda: twin.train_step(batch, length, rng=rng)  # noqa: E731
    probe_length = min(length, PROBE_LENGTH)
    threads, probe = faster_threads(lambda: twin.train_step(batch, probe_length, rng=rng))
    results["torch_threads"] = threads
    probed = ", ".join(f"{n} thread(s) {t:.2f} s" for n, t in probe.items())
    log(f"train: eager twin first step (1 thread) {eager_first_s:.2f} s; a step at L = {probe_length} takes {probed}: "
        f"the twins run at {threads} thread(s)")
    twin_c = compiled_twin(config, params, phase_params, threads)
    start = time.perf_counter()
    compiled_first = with_threads(lambda: twin_c.train_step(batch, length, eps=eps0), threads)()
    compiled_first_s = time.perf_counter() - start
    loss_diff = abs(compiled_first["loss"] - eager_first["loss"]) / abs(eager_first["loss"])
    log(f"train: compiled twin = {COMPILED_WHAT}; first step (compilation + one step) {compiled_first_s:.1f} s; "
        f"its loss vs the eager twin's on the same weights and noise: relative difference {loss_diff:.1e}")
    rng_c = np.random.default_rng(1)
    compiled_step = with_threads(lambda: twin_c.train_step(batch, length, rng=rng_c), threads)
    fns = timed_functions(args, jax_train.run, jax_train_bf16.run if run_bf16 else None, twin_step, compiled_step,
                          threads, default_threads)
    # Two warm-up calls for jax (a compiled step runs ~40% slower the first time after compilation); the
    # twins have had theirs above.
    jax_train.run()
    if jax_train_bf16 is not None:
        jax_train_bf16.run()
    timings = interleaved(fns, warmup=1, reps=args.train_reps)
    jax_s = timings["jax"]["median_s"]
    torch_s = best_torch_s(timings)
    compiled_s = timings["torch_compiled"]["median_s"]
    flop = jax_train.flops()
    hand = hand_count(config, batch_size, length)
    peak = results["machine"]["peak"]
    fraction = flop["hlo_matmul_flops"] / jax_s / peak["theoretical"]["flops"]
    out = {
        "batch": batch_size, "transition_length": length, "window": length + 2, "reps": args.train_reps,
        "scan_remat": args.scan_remat,
        "model": "lafan1 defaults (posterior next_frame, z at every decoder layer, no LSTM state in the decoder, "
                 "gamma per direction, contact inputs without gradient)",
        "jax_compile_s": jax_train.compile_s, "timings": timings,
        "torch_note": "torch_train_windows_per_s uses the faster of the eager torch thread settings timed",
        "train_windows_per_s": batch_size / jax_s, "torch_train_windows_per_s": batch_size / torch_s,
        "train_speedup_vs_torch": torch_s / jax_s,
        "torch_eager_first_step_s": eager_first_s, "torch_thread_probe_s": probe,
        "torch_threads_timed": args.torch_threads,
        "torch_compiled": {"what": COMPILED_WHAT, "threads": threads,
                           "first_step_s": compiled_first_s,
                           "first_step_note": "compilation (dynamo + inductor, cold or warm inductor cache) plus "
                                              "one train step",
                           "first_step_loss_rel_diff_vs_eager": loss_diff},
        "torch_compiled_train_windows_per_s": batch_size / compiled_s,
        "train_speedup_vs_torch_compiled": compiled_s / jax_s,
        "flops": {**flop, "hand_count_matmul_flops": hand["total"], "hand_count_detail": hand,
                  "hlo_over_hand": flop["hlo_matmul_flops"] / hand["total"]},
        "achieved_matmul_flops_per_s": flop["hlo_matmul_flops"] / jax_s,
        "peak_flops_fraction": fraction,
        "peak_flops_fraction_vs_measured_gemm": flop["hlo_matmul_flops"] / jax_s / peak["measured"]["best"],
        "torch_achieved_matmul_flops_per_s": hand["total"] / torch_s,
        "torch_threads_default": default_threads,
        "jax_loss": float(jax_train.metrics["loss"]),
    }
    if run_bf16:
        bf16_s = timings["jax_bfloat16"]["median_s"]
        out.update({
            "bfloat16_note": "model.matmul_dtype=bfloat16 (bfloat16 matmul operands, float32 accumulation) vs the "
                             "fastest eager twin in float32 or under torch.autocast(bfloat16) (not timed in "
                             "--quick)",
            "jax_bfloat16_compile_s": jax_train_bf16.compile_s,
            "train_bf16_windows_per_s": batch_size / bf16_s,
            "torch_bf16_train_windows_per_s": (batch_size / timings["torch_bfloat16_autocast"]["median_s"]
                                               if "torch_bfloat16_autocast" in timings else "not timed in --quick"),
            "train_bf16_speedup_vs_torch": best_torch_s(timings, any_precision=True) / bf16_s,
        })
    else:
        out["bfloat16_skipped"] = results["bf16"]["reason"]
    log(f"train: stitchjax {batch_size / jax_s:.1f} windows/s, eager twin {batch_size / torch_s:.1f}, compiled twin "
        f"{batch_size / compiled_s:.1f} (batch {batch_size}, L = {length}, medians of {args.train_reps})")
    return out


def section_infer(args, results: dict) -> dict:
    import torch
    import torch_twin

    samples, length = args.infer_samples, args.infer_length
    run_bf16 = results["bf16"]["run"]
    config = bench_config(TRAIN_BATCH, length)
    data = synthetic_dataset(config, 2, length + 2, seed=1)
    log(f"infer: compiling stitchjax inference ({samples} samples x {length} frames) ...")
    jax_infer = JaxInfer(config, length, samples, data)
    jax_infer_bf16 = (JaxInfer(bench_config(TRAIN_BATCH, length, [BFLOAT16]), length, samples, data)
                      if run_bf16 else None)
    twin = torch_twin.Twin(config)
    twin.load_flax(jax_infer.params, jax_infer.phase_params)
    default_threads = torch.get_num_threads()
    torch_fn = twin.make_inference(data, length, samples)
    start = time.perf_counter()
    eager_first = with_threads(torch_fn, 1)()  # warm-up
    eager_first_s = time.perf_counter() - start
    if "torch_threads" in results:  # the train section's probe
        threads, probe = results["torch_threads"], "train section's"
    else:
        threads, probe = faster_threads(twin.make_inference(data, min(length, PROBE_LENGTH), samples))
        results["torch_threads"] = threads
    twin_c = compiled_twin(config, jax_infer.params, jax_infer.phase_params, threads)
    compiled_fn = with_threads(twin_c.make_inference(data, length, samples), threads)
    start = time.perf_counter()
    compiled_first = compiled_fn()  # the same seed: the same noise as eager_first
    compiled_first_s = time.perf_counter() - start
    diff_cm = float((compiled_first - eager_first).abs().max())
    log(f"infer: eager twin first call (1 thread) {eager_first_s:.2f} s, compiled twin ({threads} thread(s)) first "
        f"call (compilation + one call) {compiled_first_s:.1f} s; max difference of their joint positions on the same "
        f"noise {diff_cm:.1e} cm")
    fns = timed_functions(args, jax_infer.run, jax_infer_bf16.run if run_bf16 else None, torch_fn, compiled_fn,
                          threads, default_threads)
    timings = interleaved(fns, warmup=1 if args.quick else 2, reps=args.infer_reps)
    torch_s = best_torch_s(timings)
    jax_s = timings["jax"]["median_s"]
    compiled_s = timings["torch_compiled"]["median_s"]
    out = {"samples": samples, "transition_length": length, "api": jax_infer.api, "reps": args.infer_reps,
           "jax_first_call_s": jax_infer.compile_s, "timings": timings,
           "torch_threads_default": default_threads, "torch_eager_first_call_s": eager_first_s,
           "torch_thread_probe_s": probe, "torch_threads_timed": args.torch_threads,
           "torch_note": "torch_infer_64x50_ms uses the faster of the eager torch thread settings timed",
           "infer_64x50_ms": 1e3 * jax_s,
           "torch_infer_64x50_ms": 1e3 * torch_s,
           "infer_speedup_vs_torch": torch_s / jax_s,
           "torch_compiled": {"what": COMPILED_WHAT, "threads": threads, "first_call_s": compiled_first_s,
                              "first_call_note": "compilation (dynamo + inductor) plus one call",
                              "max_abs_diff_vs_eager_cm": diff_cm},
           "torch_compiled_infer_64x50_ms": 1e3 * compiled_s,
           "infer_speedup_vs_torch_compiled": compiled_s / jax_s}
    if run_bf16:
        bf16_s = timings["jax_bfloat16"]["median_s"]
        out.update({"infer_64x50_bf16_ms": 1e3 * bf16_s,
                    "torch_bf16_infer_64x50_ms": (1e3 * timings["torch_bfloat16_autocast"]["median_s"]
                                                  if "torch_bfloat16_autocast" in timings else "not timed in --quick"),
                    "infer_bf16_speedup_vs_torch": best_torch_s(timings, any_precision=True) / bf16_s})
    else:
        out["bfloat16_skipped"] = results["bf16"]["reason"]
    log(f"infer: stitchjax {1e3 * jax_s:.0f} ms, eager twin {1e3 * torch_s:.0f} ms, compiled twin "
        f"{1e3 * compiled_s:.0f} ms ({samples} samples x {length} frames, medians of {args.infer_reps})")
    return out


def train_point(args, batch: int, length: int, with_torch: bool):
    """Time one (batch, transition length) train step: stitchjax, and the twin if asked (at torch's
    default threads and at 1 thread; the faster counts, as in the headline figures).

    Returns (row, JaxTrain): row = compile_s, jax_s, train_windows_per_s (+ torch_s,
    torch_train_windows_per_s, speedup_vs_torch)."""
    import torch_twin

    jt = JaxTrain(bench_config(batch, length), length)
    fns = {"jax": jt.run}
    if with_torch:
        twin = torch_twin.Twin(jt.config)
        twin.load_flax(jt.state.params, jt.state.phase_params)
        tb = torch_twin.batch_to_torch(jt.host_data, np.arange(batch))
        fns.update(torch_thread_variants(lambda: twin.train_step(tb, length)))
    t = interleaved(fns, warmup=1, reps=1 if args.quick else 3)
    jax_s = t["jax"]["median_s"]
    row = {"compile_s": jt.compile_s, "jax_s": jax_s, "train_windows_per_s": batch / jax_s}
    if with_torch:
        torch_s = best_torch_s(t)
        row.update({"torch_s": torch_s, "torch_train_windows_per_s": batch / torch_s,
                    "speedup_vs_torch": torch_s / jax_s})
    return row, jt


def section_scale_batch(args, results: dict) -> list:
    sizes = (8, 128) if args.quick else (8, 16, 32, 64, 128, 256, 512)
    rows = []
    peak = results["machine"]["peak"]["theoretical"]["flops"]
    for batch in sizes:
        log(f"scale_batch: batch {batch} ...")
        # eager torch at large batch takes minutes per step
        row, jt = train_point(args, batch, TRAIN_LENGTH, with_torch=not args.quick and batch <= 64)
        flop = flops_lib.hlo_matmul_flops(jt.compiled)["matmul_flops"]
        rows.append({"batch": batch, **row, "peak_flops_fraction": flop / row["jax_s"] / peak})
        log(f"  {rows[-1]}")
    return rows


def section_scale_length(args, results: dict) -> list:
    lengths = (10, 100) if args.quick else (10, 20, 30, 48, 70, 100)
    rows = []
    for length in lengths:
        log(f"scale_length: transition length {length} (window {length + 2}) ...")
        row, _ = train_point(args, TRAIN_BATCH, length, with_torch=not args.quick and length <= 48)
        rows.append({"transition_length": length, "window": length + 2, **row})
        log(f"  {rows[-1]}")
    return rows


def data_parallel_worker(devices: int, reps: int) -> None:
    """Subprocess body: train windows/s at batch 32 on `devices` forced host devices; prints JSON."""
    import jax

    assert len(jax.devices()) == devices, (jax.devices(), devices)
    config = bench_config(TRAIN_BATCH, TRAIN_LENGTH)
    jt = JaxTrain(config, TRAIN_LENGTH)
    t = timeit(jt.run, warmup=1, reps=reps)
    print("RESULT " + json.dumps({"devices": devices, "compile_s": jt.compile_s, "step_s": t["median_s"],
                                  "train_windows_per_s": TRAIN_BATCH / t["median_s"], "times_s": t["times_s"]}))


def section_data_parallel(args, results: dict) -> list:
    rows = []
    for devices in (1, 2, 4):
        log(f"data_parallel: {devices} forced host device(s) ...")
        env = dict(os.environ)
        env["XLA_FLAGS"] = (env.get("XLA_FLAGS", "") + f" --xla_force_host_platform_device_count={devices}").strip()
        env["JAX_PLATFORMS"] = "cpu"
        cmd = [sys.executable, str(pathlib.Path(__file__).resolve()), "--worker-devices", str(devices),
               "--worker-reps", str(1 if args.quick else 4)]
        proc = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=1200)
        line = next((l for l in proc.stdout.splitlines() if l.startswith("RESULT ")), None)
        if proc.returncode != 0 or line is None:
            rows.append({"devices": devices, "error": (proc.stderr or proc.stdout)[-2000:]})
        else:
            rows.append(json.loads(line[len("RESULT "):]))
        log(f"  {rows[-1] if 'error' not in rows[-1] else 'error'}")
    base = next((r for r in rows if r.get("devices") == 1 and "step_s" in r), None)
    for row in rows:
        if base and "step_s" in row:
            row["speedup_vs_1_device"] = base["step_s"] / row["step_s"]
    return rows


QUICK_SECTIONS = ["train", "infer"]
SECTIONS = {"train": section_train, "infer": section_infer, "scale_batch": section_scale_batch,
            "scale_length": section_scale_length, "data_parallel": section_data_parallel}


def summary(results: dict) -> dict:
    """The headline figures (flat) from the sections that ran."""
    train_res = results.get("train", {})
    infer_res = results.get("infer", {})
    keys = {
        "train_windows_per_s": train_res.get("train_windows_per_s"),
        "torch_train_windows_per_s": train_res.get("torch_train_windows_per_s"),
        "train_speedup_vs_torch": train_res.get("train_speedup_vs_torch"),
        "torch_compiled_train_windows_per_s": train_res.get("torch_compiled_train_windows_per_s"),
        "train_speedup_vs_torch_compiled": train_res.get("train_speedup_vs_torch_compiled"),
        "torch_compiled_train_first_step_s": train_res.get("torch_compiled", {}).get("first_step_s"),
        "flops_per_train_step": train_res.get("flops", {}).get("hlo_matmul_flops"),
        "peak_flops_fraction": train_res.get("peak_flops_fraction"),
        "infer_64x50_ms": infer_res.get("infer_64x50_ms"),
        "torch_infer_64x50_ms": infer_res.get("torch_infer_64x50_ms"),
        "torch_compiled_infer_64x50_ms": infer_res.get("torch_compiled_infer_64x50_ms"),
        "infer_speedup_vs_torch_compiled": infer_res.get("infer_speedup_vs_torch_compiled"),
        "torch_compiled_infer_first_call_s": infer_res.get("torch_compiled", {}).get("first_call_s"),
        "train_bf16_windows_per_s": train_res.get("train_bf16_windows_per_s"),
        "train_bf16_speedup_vs_torch": train_res.get("train_bf16_speedup_vs_torch"),
        "infer_64x50_bf16_ms": infer_res.get("infer_64x50_bf16_ms"),
        "bf16_rows": results.get("bf16"),
    }
    met = {}
    if keys["train_speedup_vs_torch"] is not None:
        met["train_speedup_vs_torch >= 3"] = keys["train_speedup_vs_torch"] >= TARGETS["train_speedup_vs_torch"]
    if keys["peak_flops_fraction"] is not None:
        met["peak_flops_fraction >= 0.30"] = keys["peak_flops_fraction"] >= TARGETS["peak_flops_fraction"]
    if keys["infer_64x50_ms"] is not None:
        met["infer_64x50_ms < 200"] = keys["infer_64x50_ms"] < TARGETS["infer_64x50_ms"]
    if keys["infer_64x50_bf16_ms"] is not None:
        met["infer_64x50_bf16_ms < 200"] = keys["infer_64x50_bf16_ms"] < TARGETS["infer_64x50_ms"]
    keys["targets_met"] = met
    return keys


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true",
                        help="sections train and infer only, fewer repetitions (< 3 min on 2 cores)")
    parser.add_argument("--json", default=None, help="write all results to this JSON file")
    parser.add_argument("--only", default=None, help="comma-separated sections: " + ",".join(SECTIONS))
    parser.add_argument("--bf16", choices=("auto", "on", "off"), default="auto",
                        help="bfloat16 rows: auto = where the CPU has bfloat16 units (or on a GPU)")
    parser.add_argument("--train-batch", type=int, default=TRAIN_BATCH, help="train section batch size")
    parser.add_argument("--train-length", type=int, default=TRAIN_LENGTH, help="train section transition length")
    parser.add_argument("--infer-samples", type=int, default=INFER_SAMPLES, help="infer section samples")
    parser.add_argument("--infer-length", type=int, default=INFER_LENGTH, help="infer section transition length")
    parser.add_argument("--train-reps", type=int, default=None, help="train repetitions (default 8, --quick 3)")
    parser.add_argument("--infer-reps", type=int, default=None, help="infer repetitions (default 15, --quick 5)")
    parser.add_argument("--torch-threads", choices=("both", "faster"), default=None,
                        help="eager twin timed at torch's default threads and at 1 (both; the default) or only at "
                             "the faster of the two in a one-call probe (faster; the --quick default)")
    parser.add_argument("--scan-remat", default="none",
                        help="train.scan_remat of stitchjax's train step in the train section (none, dots, nothing, "
                             "taped; default none, the config default); the twins compute the same gradients")
    parser.add_argument("--worker-devices", type=int, default=None, help=argparse.SUPPRESS)
    parser.add_argument("--worker-reps", type=int, default=3, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.worker_devices is not None:
        data_parallel_worker(args.worker_devices, args.worker_reps)
        return 0

    wall = time.perf_counter()
    args.train_reps = args.train_reps or (3 if args.quick else 8)
    args.infer_reps = args.infer_reps or (5 if args.quick else 15)
    args.torch_threads = args.torch_threads or ("faster" if args.quick else "both")
    if args.only is not None:
        sections = [s.strip() for s in args.only.split(",") if s.strip()]
    else:
        sections = QUICK_SECTIONS if args.quick else list(SECTIONS)
    unknown = [s for s in sections if s not in SECTIONS]
    if unknown:
        parser.error(f"unknown section(s) {unknown}; choose from {', '.join(SECTIONS)}")
    try:
        import torch  # noqa: F401
    except ImportError:
        parser.error("PyTorch is needed for the twin: pip install -e '.[bench]' (torch is an optional extra)")

    results: dict[str, Any] = {"quick": args.quick, "started_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}
    log("machine info and peak FLOP/s ...")
    results["machine"] = machine_info()
    results["machine"]["peak"] = {
        "theoretical": flops_lib.theoretical_peak_flops(),
        "measured": flops_lib.measured_matmul_peak(sizes=(1024, 2048) if not args.quick else (2048,),
                                                    reps=5 if not args.quick else 3),
    }
    log(f"  theoretical {results['machine']['peak']['theoretical']['flops'] / 1e9:.1f} GFLOP/s, measured GEMM "
        f"{results['machine']['peak']['measured']['best'] / 1e9:.1f} GFLOP/s")
    run_bf16, reason = bf16_decision(args)
    results["bf16"] = {"run": run_bf16, "reason": reason}
    log(f"bfloat16 rows: {'run' if run_bf16 else 'skipped'} ({reason})")
    log(f"sections: {', '.join(sections)}; train batch {args.train_batch}, L = {args.train_length}, "
        f"{args.train_reps} repetitions; infer {args.infer_samples} samples x {args.infer_length} frames, "
        f"{args.infer_reps} repetitions; eager twin threads: {args.torch_threads}"
        + ("; --quick leaves out " + ", ".join(s for s in SECTIONS if s not in sections) if args.quick else ""))
    for name in sections:
        start = time.perf_counter()
        try:
            results[name] = SECTIONS[name](args, results)
        except Exception as err:  # keep the other sections' figures
            traceback.print_exc()
            results[name] = {"error": f"{type(err).__name__}: {err}"}
        log(f"{name}: {time.perf_counter() - start:.1f} s")
    results["summary"] = summary(results)
    results.update({k: v for k, v in results["summary"].items() if k != "targets_met"})  # headline keys at top level
    results["wall_s"] = time.perf_counter() - wall
    try:
        results["machine"]["load_average_at_end"] = list(os.getloadavg())
    except OSError:
        pass
    text = json.dumps(results, indent=2, default=lambda o: o.tolist() if hasattr(o, "tolist") else str(o))
    if args.json:
        pathlib.Path(args.json).write_text(text + "\n")
        log(f"wrote {args.json}")
    print(json.dumps(results["summary"], indent=2))
    log(f"total {results['wall_s']:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
