"""The release recipe 1.6 times as long again: `lafan1_cpu_release` with 64000 steps and its learning-rate decay
stretched with it (steps 25600-60800 instead of 16000-38000); nothing else changes (data, validation split,
loss, model, seed). The 40000-step release run's validation curve was still falling over its last 5000 steps
(NPSS ratio at L = 30: 0.799 at step 35000, 0.787 at 40000; the 40000-step study 2026-12-06_release_40k), and the recipe may
use up to about 8 h of training loop; this one is about 3.9 h on 2 CPU cores, so it is trained across stops.

    bin/train --config experiments/2026-12-07_release_64k/lafan1_cpu_release_64k.py --workdir runs/release_64k --data ../shared/data/lafan1
"""
from stitchjax.config import variant

get_config = variant(
    "lafan1_cpu_release",
    "train.max_steps=64000",
    "train.lr_decay_from_step=25600",
    "train.lr_decay_until_step=60800",
    name="lafan1_cpu_release_64k",
)
