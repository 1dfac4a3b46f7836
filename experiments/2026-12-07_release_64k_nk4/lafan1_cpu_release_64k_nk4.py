"""The 64000-step release recipe with the state and FK terms weighted 4x on each direction's first generated
frame (`loss.near_keyframe_weight=4`); nothing else changes (64000 steps, the decay over 25600-60800, data,
validation split, seed). The weight was earned by the validation ablation's near-keyframe rows
(experiments/2026-12-04_validation_ablation) and lowered SLDE at 40000 steps (the study 2026-12-06_release_near_keyframe, experiments/README.md).

    bin/train --config experiments/2026-12-07_release_64k_nk4/lafan1_cpu_release_64k_nk4.py --workdir runs/release_64k_nk4 --data ../shared/data/lafan1
"""
from stitchjax.config import variant

get_config = variant(
    "lafan1_cpu_release",
    "loss.near_keyframe_weight=4",
    name="lafan1_cpu_release_64k_nk4",
)
