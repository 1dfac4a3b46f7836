"""The largest joint jumps of foot-locking settings on an artefact set of training takes (never subject5).

    python experiments/2026-12-06_footlock_v6/jumps.py --data /path/to/lafan1 --cache /tmp/artefacts.npz \
        --candidates experiments/2026-12-06_footlock_v6/candidates.json --json jumps.json

The validation split's 376 windows were too few to show a rare jump: version 5 passed the jump rule there at
both samplings, then made a 43.6 cm joint jump on one test transition at L = 30 (the model alone: 36.5 cm).
This set is the test takes' three motions as performed by training subjects (``TAKES``: a fall, floor work and
obstacle locomotion, none of them a validation or test file), sampled by the release model at L = 30 and 50,
10 samples, at the paper's sampling and at the release model's default sampling (cached in --cache). For the
model alone and each candidate it reports the largest per-frame joint jump (cm) and the largest knee-angle
change (degrees per frame) by sampling and length.
"""
import argparse
import json
import os
import sys
import time

import jax
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import measure  # noqa: E402
import tune  # noqa: E402

from stitchjax.data import lafan1  # noqa: E402
from stitchjax.sample import footlock, trained_model  # noqa: E402
from stitchjax.skeleton import forward_kinematics  # noqa: E402

TAKES = ("fallAndGetUp1_subject4", "ground1_subject1", "obstacles1_subject1")
SAMPLINGS = {"paper": {}, "default": {"noise_scale": 2.0, "noise_correlation": 0.95, "noise_ramp_steps": 4}}
LENGTHS = (30, 50)


def extremes(rotations, positions, parents):
    """(largest per-frame joint jump (cm), largest knee-angle change (degrees per frame)) of (B, S, T, ...)."""
    _, g = forward_kinematics(rotations, positions, parents)
    jump = float(np.linalg.norm(np.diff(g, axis=2), axis=-1).max())
    return jump, float(np.abs(np.diff(measure.knee_angles(g), axis=2)).max())


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", default="../shared/data/lafan1")
    parser.add_argument("--cache", required=True, help=".npz prefix: <cache>_<sampling>.npz, sampled when missing")
    parser.add_argument("--candidates", required=True, help="JSON file {name: {FootLockConfig field: value}}")
    parser.add_argument("--default-sampling", default=None,
                        help="JSON of the default sampling's fields, in place of SAMPLINGS['default'] (a later "
                             "release model's default)")
    parser.add_argument("--json", required=True)
    args = parser.parse_args(argv)
    samplings = dict(SAMPLINGS)
    if args.default_sampling:
        samplings["default"] = json.loads(args.default_sampling)
    t0 = time.time()
    windows = lafan1.build_windows([os.path.join(args.data, f"{t}.bvh") for t in TAKES], 65, 40, workers=1)
    parents = tuple(windows.skeleton.parents)
    rot, pos, con = (np.asarray(x, np.float64) for x in (windows.rotations, windows.positions, windows.contacts))
    candidates = json.load(open(args.candidates))
    out = {"takes": TAKES, "windows": int(len(rot)), "samples": 10, "samplings": samplings, "rows": {}}
    model = None
    for sampling, kwargs in samplings.items():
        path = f"{os.path.splitext(args.cache)[0]}_{sampling}.npz"
        if os.path.exists(path):
            cache = dict(np.load(path))
        else:
            model = model or trained_model.pretrained()
            cache = {}
            for length in LENGTHS:
                r, p, c = tune.sample(model, rot, pos, con, length, 10, sampling=kwargs)
                cache.update({f"r{length}": r, f"p{length}": p, f"c{length}": c})
            np.savez(path, **cache)
        for length in LENGTHS:
            r, p, c = cache[f"r{length}"], cache[f"p{length}"], cache[f"c{length}"]
            key = f"{sampling}/L{length}"
            out["rows"].setdefault("model", {})[key] = extremes(r, p, parents)
            for name, fields in candidates.items():
                locked, _, _ = footlock.lock_transitions(r, p, c, windows.skeleton, measure.FEET,
                                                         footlock.FootLockConfig(**fields), sample_axis=1)
                out["rows"].setdefault(name, {})[key] = extremes(locked, p, parents)
                jax.clear_caches()
            print(key, {n: f"{v[key][0]:.1f} cm {v[key][1]:.1f} deg" for n, v in out["rows"].items()}, flush=True)
    out["seconds"] = time.time() - t0
    out["command"] = "python " + " ".join(sys.argv)
    with open(args.json, "w") as f:
        json.dump(out, f, indent=1)


if __name__ == "__main__":
    main()
