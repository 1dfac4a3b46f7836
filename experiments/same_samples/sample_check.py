"""Transitions of the release model at three lengths and three samplings, saved for a byte-for-byte comparison
between two checkouts (either package layout).

    PYTHONPATH=/path/to/before python experiments/same_samples/sample_check.py before.npz
    PYTHONPATH=/path/to/after  python experiments/same_samples/sample_check.py after.npz
    python -c "import numpy as np; a, b = np.load('before.npz'), np.load('after.npz'); print(all(np.array_equal(a[k], b[k]) for k in a))"
"""
import sys, numpy as np
try:
    from stitchjax.data import bvh, bundled
    from stitchjax.sample import inbetween, trained_model
except ImportError:
    from stitchjax import bvh, inbetween, trained_model
    from stitchjax import sample as bundled
model = trained_model.pretrained()
take = bvh.load(bundled.sample_files(["subject5"])[0])
outs = []
for a, L, kw in ((100, 30, {}), (300, 50, dict(noise_scale=1.0, noise_correlation=0.0, noise_ramp_steps=0)), (500, 15, dict(search=4))):
    b = a + L + 1
    start = (take.rotations[[a]], take.positions[[a]], [[1.0, 1.0, 0.0, 0.0]])
    target = (take.rotations[[b]], take.positions[[b]], [[0.0, 0.0, 1.0, 1.0]])
    if hasattr(inbetween, "Keyframes"):  # the Sampling spec (paper's by default)
        r = inbetween.transitions_in_frame(model, start, target, length=L, num_samples=6, seed=3,
                                           sampling=inbetween.Sampling.paper().replace(**kw))
    else:  # loose sampling arguments
        r = inbetween.transitions_in_frame(model, *start, *target, length=L, num_samples=6, seed=3, **kw)
    outs += [np.asarray(x) for x in r if hasattr(x, 'shape')]
np.savez(sys.argv[1], *outs)
