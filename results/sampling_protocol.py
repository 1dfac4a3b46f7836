"""The shared options and tail of the sampling-setting scripts (``variance_blend.py``, ``noise_correlation.py``,
``noise_ramp.py``): the paper's protocol for several model methods on the LAFAN1 subject5 test windows, printed and written as JSON."""
from __future__ import annotations

import argparse
import json
import pathlib
import sys

REPO = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from stitchjax import skeleton  # noqa: E402
from stitchjax.eval import evaluate, tables
from stitchjax.data import lafan1


def parser(description: str) -> argparse.ArgumentParser:
    """The options every such script takes: --checkpoint, --data, --lengths, --samples, --json."""
    out = argparse.ArgumentParser(description=description, formatter_class=argparse.RawDescriptionHelpFormatter)
    out.add_argument("--checkpoint", required=True)
    out.add_argument("--data", required=True)
    out.add_argument("--lengths", default="30,50")
    out.add_argument("--samples", type=int, default=10)
    out.add_argument("--json", required=True)
    return out


def evaluate_and_write(methods: dict, settings: dict, data: str, lengths: str, samples: int, json_path: str) -> dict:
    """``evaluate.evaluate_protocol`` of ``methods`` (name -> method) at the comma-separated ``lengths`` on the
    test windows of the LAFAN1 folder ``data``, ``samples`` per window; prints the table, writes ``json_path``
    and returns the results."""
    windows = lafan1.test_windows(data)
    stats = lafan1.train_statistics(data)
    results = evaluate.evaluate_protocol(methods, windows, stats, lengths=tuple(int(x) for x in lengths.split(",")),
                                         samples=samples, feet=tuple(skeleton.LAFAN1_FEET), settings=settings)
    print(tables.format_protocol_table(results))
    pathlib.Path(json_path).parent.mkdir(parents=True, exist_ok=True)
    pathlib.Path(json_path).write_text(json.dumps(results, indent=2) + "\n")
    return results
