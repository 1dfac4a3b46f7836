"""FLOP accounting for the benchmarks: CPU peak (theoretical and measured) and FLOPs of a jitted function.

Three numbers, kept apart on purpose:

- ``theoretical_peak_flops()``: cores x nominal clock x float32 FLOP per cycle per core of the CPU's vector
  units (FMA = 2 FLOP). This is the denominator of ``peak_flops_fraction`` in run_all.py.
- ``measured_matmul_peak()``: the best float32 GEMM rate numpy (OpenBLAS) and XLA reach here: what
  "achievable" means on this machine, reported beside it.
- ``hlo_matmul_flops(compiled)``: FLOPs of every ``dot`` in the *optimised* HLO of a compiled jax function,
  each multiplied by how many times it runs (``while`` loops from ``lax.scan`` carry a
  ``known_trip_count``). XLA's own ``compiled.cost_analysis()["flops"]`` counts a loop body ONCE, whatever
  its trip count, so for a scanned rollout it undercounts by about the number of frames; both are reported.
"""
from __future__ import annotations

import json
import os
import re
import time
from typing import Any

import numpy as np

__all__ = [
    "cpu_info", "theoretical_peak_flops", "measured_matmul_peak", "xla_cost_analysis",
    "hlo_matmul_flops", "HloFlops",
]


# ------------------------------------------------------------------------------------------ CPU peak


def cpu_info() -> dict:
    """Model name, vendor, family/model numbers, nominal MHz, logical cores and SIMD flags of this CPU."""
    info: dict[str, Any] = {"model_name": "unknown", "vendor": "unknown", "family": None, "model": None,
                            "mhz": None, "flags": []}
    try:
        text = open("/proc/cpuinfo").read()
    except OSError:
        text = ""
    first = text.split("\n\n")[0]
    for line in first.splitlines():
        if ":" not in line:
            continue
        key, value = (part.strip() for part in line.split(":", 1))
        if key == "model name":
            info["model_name"] = value
        elif key == "vendor_id":
            info["vendor"] = value
        elif key == "cpu family":
            info["family"] = int(value)
        elif key == "model":
            info["model"] = int(value)
        elif key == "cpu MHz":
            info["mhz"] = float(value)
        elif key == "flags":
            info["flags"] = value.split()
    info["logical_cores"] = os.cpu_count()
    try:
        info["usable_cores"] = len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        info["usable_cores"] = os.cpu_count()
    info["hypervisor"] = "hypervisor" in info["flags"]
    return info


def _flops_per_cycle(info: dict) -> tuple[int, str]:
    """float32 FLOP per cycle per core, and the reasoning (vector width x FMA pipes x 2)."""
    flags = set(info["flags"])
    vendor, family, model = info["vendor"], info["family"], info["model"]
    if vendor == "AuthenticAMD" and family == 25:
        # Zen 3 (Milan/Vermeer, models 0x00-0x0f, 0x20-0x5f) and Zen 4 (AVX-512 run as 2x256): 2 FMA pipes x 256 bit.
        gen = "Zen 4" if "avx512f" in flags else "Zen 3"
        return 32, f"AMD family 25 ({gen}): 2 FMA pipes x 8 float32 lanes (256 bit) x 2 FLOP"
    if vendor == "AuthenticAMD" and family == 26:
        return 64, "AMD family 26 (Zen 5): 2 FMA pipes x 16 float32 lanes (512 bit) x 2 FLOP"
    if vendor == "AuthenticAMD" and family == 23:
        if model is not None and model >= 0x30:
            return 32, "AMD family 23 model >= 0x30 (Zen 2): 2 FMA pipes x 8 float32 lanes x 2 FLOP"
        return 16, "AMD family 23 (Zen 1): 2 FMA pipes x 4 float32 lanes (128 bit) x 2 FLOP"
    if "avx512f" in flags:
        return 64, "AVX-512 with 2 FMA units assumed: 2 x 16 float32 lanes x 2 FLOP"
    if "fma" in flags and "avx2" in flags:
        return 32, "AVX2 + FMA: 2 FMA units x 8 float32 lanes x 2 FLOP"
    if "avx" in flags:
        return 16, "AVX without FMA: 8-lane add + 8-lane multiply per cycle"
    return 8, "SSE: 4-lane add + 4-lane multiply per cycle"


def theoretical_peak_flops(info: dict | None = None) -> dict:
    """Theoretical float32 peak: usable cores x nominal clock (cpuinfo MHz) x FLOP/cycle/core.

    The nominal clock is what /proc/cpuinfo reports (under KVM, the TSC frequency = base clock); turbo is
    ignored, so a core that boosts can exceed this "peak" on a single thread. Returns
    {"flops", "cores", "ghz", "flops_per_cycle_per_core", "basis"}.
    """
    info = info or cpu_info()
    per_cycle, why = _flops_per_cycle(info)
    ghz = (info["mhz"] or 0.0) / 1000.0
    cores = info["usable_cores"]
    return {"flops": cores * ghz * 1e9 * per_cycle, "cores": cores, "ghz": ghz,
            "flops_per_cycle_per_core": per_cycle,
            "basis": f"{cores} cores x {ghz:.3f} GHz (cpuinfo nominal) x {per_cycle} FLOP/cycle; {why}"}


def _best_rate(fn, flop: float, reps: int) -> float:
    fn()  # warm-up (thread pools, JIT)
    best = float("inf")
    for _ in range(reps):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return flop / best


def measured_matmul_peak(sizes=(1024, 2048), reps: int = 5) -> dict:
    """Best float32 square-GEMM rate (FLOP/s) of numpy (its BLAS) and of jax.jit(jnp.matmul) on CPU."""
    import jax
    import jax.numpy as jnp

    result: dict[str, Any] = {"numpy": 0.0, "jax": 0.0, "by_size": {}}
    rng = np.random.default_rng(0)
    matmul = jax.jit(jnp.matmul)
    for n in sizes:
        a = rng.standard_normal((n, n), dtype=np.float32)
        b = rng.standard_normal((n, n), dtype=np.float32)
        flop = 2.0 * n ** 3
        rate_np = _best_rate(lambda: a @ b, flop, reps)
        ja, jb = jnp.asarray(a), jnp.asarray(b)
        rate_jax = _best_rate(lambda: matmul(ja, jb).block_until_ready(), flop, reps)
        result["by_size"][n] = {"numpy": rate_np, "jax": rate_jax}
        result["numpy"] = max(result["numpy"], rate_np)
        result["jax"] = max(result["jax"], rate_jax)
    result["best"] = max(result["numpy"], result["jax"])
    return result


# ------------------------------------------------------------------------------------- jitted FLOPs


def xla_cost_analysis(compiled) -> dict:
    """``compiled.cost_analysis()`` as a plain dict (older jax returned a one-element list)."""
    analysis = compiled.cost_analysis()
    if isinstance(analysis, (list, tuple)):
        analysis = analysis[0] if analysis else {}
    return dict(analysis or {})


_COMPUTATION = re.compile(r"^(?:ENTRY\s+)?%?([\w.\-]+)\s*\((.*)\)\s*->.*\{\s*$")
_INSTRUCTION = re.compile(r"^\s*(?:ROOT\s+)?%?([\w.\-]+)\s*=\s*(.+?)\s+([\w\-]+)\((.*)$")
_SHAPE = re.compile(r"^[a-z]\w*\[([\d,]*)\]")
_PARAM = re.compile(r"([\w.\-]+):\s*([a-z]\w*\[[\d,]*\])")
_TRIP = re.compile(r'"known_trip_count":\{"n":"(\d+)"\}')


def _dims(shape_text: str) -> tuple[int, ...] | None:
    match = _SHAPE.match(shape_text.strip())
    if not match:
        return None
    body = match.group(1)
    return tuple(int(d) for d in body.split(",")) if body else ()


_DTYPE_BYTES = {"pred": 1, "s8": 1, "u8": 1, "bf16": 2, "f16": 2, "s16": 2, "u16": 2, "f32": 4, "s32": 4, "u32": 4,
                "f64": 8, "s64": 8, "u64": 8}


def _bytes(shape_text: str) -> float:
    """Bytes of an array shape such as ``f32[28,32,512]{2,1,0}`` (0 for tuples and unknown types)."""
    dims = _dims(shape_text)
    dtype = shape_text.strip().split("[", 1)[0]
    return float(np.prod(dims, dtype=np.float64)) * _DTYPE_BYTES.get(dtype, 0) if dims is not None else 0.0


class HloFlops(dict):
    """Result of :func:`hlo_matmul_flops`: {"matmul_flops", "dots", "loops", "unknown_trip_counts",
    "copy_bytes", "update_slice_bytes"}: the last two are the bytes written by ``copy`` instructions (their
    output) and by ``dynamic-update-slice`` (their update operand: the per-step stacking into loop buffers),
    weighted by the same loop trip counts."""


def hlo_matmul_flops(compiled_or_text) -> HloFlops:
    """FLOPs of all dot and convolution instructions of an optimised HLO module, weighted by loop trip counts.

    A dot's FLOPs = 2 x (elements of its output) x (product of the lhs contracting dimensions); a
    convolution's = 2 x (elements of its output) x (kernel elements / output features). The
    multiplicity of a computation is the sum over its call sites of the caller's multiplicity, times the
    ``known_trip_count`` for a ``while`` body (1, and counted in ``unknown_trip_counts``, when XLA does not
    know it). Returns an :class:`HloFlops` dict.
    """
    text = compiled_or_text if isinstance(compiled_or_text, str) else compiled_or_text.as_text()
    computations: dict[str, list[str]] = {}
    params: dict[str, dict[str, tuple]] = {}
    param_texts: dict[str, dict[str, str]] = {}
    entry = None
    current = None
    for line in text.splitlines():
        if current is None:
            match = _COMPUTATION.match(line)
            if match:
                current = match.group(1)
                computations[current] = []
                params[current] = {name: _dims(shape) for name, shape in _PARAM.findall(match.group(2))}
                param_texts[current] = dict(_PARAM.findall(match.group(2)))
                if line.startswith("ENTRY"):
                    entry = current
            continue
        if line.strip() == "}":
            current = None
            continue
        computations[current].append(line)

    calls: dict[str, list[tuple[str, int]]] = {name: [] for name in computations}
    dots: dict[str, list[tuple[str, float]]] = {name: [] for name in computations}
    moves: dict[str, list[tuple[str, float]]] = {name: [] for name in computations}
    unknown = 0
    loops = []
    for name, lines in computations.items():
        shapes = dict(params[name])
        shape_texts = dict(param_texts[name])
        for line in lines:
            match = _INSTRUCTION.match(line)
            if not match:
                continue
            inst, shape_text, opcode, rest = match.groups()
            shapes[inst] = _dims(shape_text)
            shape_texts[inst] = shape_text
            if opcode == "copy":
                moves[name].append(("copy", _bytes(shape_text)))
            elif opcode == "dynamic-update-slice":
                operands = re.findall(r"%([\w.\-]+)", rest.split(")")[0])
                update = shape_texts.get(operands[1], "") if len(operands) > 1 else ""
                moves[name].append(("update", _bytes(update)))
            if opcode == "while":
                body = re.search(r"body=%?([\w.\-]+)", rest)
                cond = re.search(r"condition=%?([\w.\-]+)", rest)
                trip = _TRIP.search(rest)
                count = int(trip.group(1)) if trip else 1
                if not trip:
                    unknown += 1
                loops.append({"name": inst, "trip_count": count if trip else None})
                if body:
                    calls[name].append((body.group(1), count))
                if cond:
                    calls[name].append((cond.group(1), count + 1))
                continue
            for callee in re.findall(r"(?:calls|to_apply)=%?([\w.\-]+)", rest):
                calls[name].append((callee, 1))
            for group in re.findall(r"branch_computations=\{([^}]*)\}", rest):
                for callee in re.findall(r"%?([\w.\-]+)", group):
                    calls[name].append((callee, 1))
            for key in ("true_computation", "false_computation"):
                found = re.search(key + r"=%?([\w.\-]+)", rest)
                if found:
                    calls[name].append((found.group(1), 1))
            if opcode == "dot":
                out = shapes[inst] or ()
                operands = re.findall(r"%([\w.\-]+)", rest.split(")")[0])
                lhs = shapes.get(operands[0]) if operands else None
                contract = re.search(r"lhs_contracting_dims=\{([\d,]*)\}", rest)
                k = 1
                if lhs is not None and contract and contract.group(1):
                    for d in contract.group(1).split(","):
                        k *= lhs[int(d)]
                flops = 2.0 * float(np.prod(out, dtype=np.float64)) * k
                dots[name].append((inst, flops))
            elif opcode == "convolution":
                # each output element sums over the rhs (kernel) dims except its output-feature dim
                out = shapes[inst] or ()
                operands = re.findall(r"%([\w.\-]+)", rest.split(")")[0])
                rhs = shapes.get(operands[1]) if len(operands) > 1 else None
                labels = re.search(r"dim_labels=[^_]*_([0-9a-z]+)->", rest)
                if rhs is not None and labels and "o" in labels.group(1):
                    per_output = float(np.prod(rhs, dtype=np.float64)) / rhs[labels.group(1).index("o")]
                    groups = re.search(r"batch_group_count=(\d+)", rest)
                    per_output /= int(groups.group(1)) if groups else 1
                    dots[name].append((inst, 2.0 * float(np.prod(out, dtype=np.float64)) * per_output))

    multiplicity: dict[str, float] = {}

    def visit(name: str, times: float) -> None:
        if name not in computations:
            return
        multiplicity[name] = multiplicity.get(name, 0.0) + times
        for callee, count in calls[name]:
            visit(callee, times * count)

    if entry is None:
        raise ValueError("no ENTRY computation in the HLO text; pass compiled.as_text() of a jitted function")
    visit(entry, 1.0)
    total = 0.0
    count = 0
    for name, items in dots.items():
        for _, flops in items:
            total += flops * multiplicity.get(name, 0.0)
            count += 1
    moved = {"copy": 0.0, "update": 0.0}
    for name, items in moves.items():
        for kind, size in items:
            moved[kind] += size * multiplicity.get(name, 0.0)
    return HloFlops(matmul_flops=total, dots=count, loops=loops, unknown_trip_counts=unknown,
                    copy_bytes=moved["copy"], update_slice_bytes=moved["update"])


if __name__ == "__main__":  # python benchmarks/flops.py: print this CPU's peak figures
    print(json.dumps({"cpu": {k: v for k, v in cpu_info().items() if k != "flags"},
                      "theoretical": theoretical_peak_flops(),
                      "measured": measured_matmul_peak()}, indent=2, default=str))
