"""Data pipeline timings (prints figures; not a test).

    python benchmarks/data_pipeline.py [--data ../shared/data/lafan1] [--repeats 3]

- cold: training statistics (subjects 1-4, 50/20) + benchmark test set (subject5, 65/40) with an
  empty, temporary cache folder (BVH parsing, windows, contacts, alignment, cache writes);
- cached: the same calls again (content hashing + loading the cache entries);
- BVH parse throughput: ``stitchjax.data.bvh.load`` over every file of the folder, frames per second.
Timings are in-process (imports excluded: ``import stitchjax.data.lafan1`` is timed separately).
"""
from __future__ import annotations

import argparse
import pathlib
import resource
import sys
import tempfile
import time

REPO = pathlib.Path(__file__).resolve().parent.parent
if str(REPO) not in sys.path:  # run from a checkout without `pip install -e .`
    sys.path.insert(0, str(REPO))


def cpu_seconds() -> float:
    """CPU time of this process and its finished children (the per-file worker processes)."""
    own = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", default=str(REPO.parent / "shared" / "data" / "lafan1"),
                        help="a LAFAN1 folder (.bvh or .bvh.gz files)")
    parser.add_argument("--repeats", type=int, default=3, help="cached runs to time (best is shown)")
    args = parser.parse_args(argv)

    start = time.perf_counter()
    from stitchjax.data import bvh, lafan1
    import_s = time.perf_counter() - start

    files = [p for ps in lafan1.list_files(args.data).values() for p in ps]
    print(f"LAFAN1 folder {args.data}: {len(files)} files; import stitchjax.data.lafan1: {import_s:.2f} s")

    with tempfile.TemporaryDirectory(prefix="stitchjax-bench-") as tmp:
        cpu = cpu_seconds()
        start = time.perf_counter()
        stats = lafan1.train_statistics(args.data, cache_dir=tmp)
        stats_s = time.perf_counter() - start
        start = time.perf_counter()
        test = lafan1.test_windows(args.data, cache_dir=tmp)
        test_s = time.perf_counter() - start
        cpu = cpu_seconds() - cpu
        print(f"cold   : stats {stats_s:.2f} s + test set {test_s:.2f} s = {stats_s + test_s:.2f} s "
              f"wall, {cpu:.2f} CPU-s ({len(test)} test windows; {stats.mean.shape[0]} stats values)")
        best = float("inf")
        for _ in range(max(args.repeats, 1)):
            start = time.perf_counter()
            lafan1.train_statistics(args.data, cache_dir=tmp)
            lafan1.test_windows(args.data, cache_dir=tmp)
            best = min(best, time.perf_counter() - start)
        print(f"cached : stats + test set {best:.3f} s (best of {args.repeats})")

    frames = 0
    cpu = cpu_seconds()
    start = time.perf_counter()
    for path in files:
        frames += bvh.load(path).num_frames
    parse_s = time.perf_counter() - start
    cpu = cpu_seconds() - cpu
    print(f"parse  : {frames} frames in {parse_s:.2f} s = {frames / parse_s:,.0f} frames/s wall, "
          f"{frames / cpu:,.0f} frames per CPU-s (stitchjax.data.bvh.load, one process)")
    try:
        print(f"load average (1 min) during the run: {__import__('os').getloadavg()[0]:.1f} "
              f"on {__import__('os').cpu_count()} cores (other processes slow the wall times)")
    except OSError:
        pass
    return 0


if __name__ == "__main__":
    sys.exit(main())
