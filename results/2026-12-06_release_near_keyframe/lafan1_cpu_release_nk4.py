"""The release recipe with the state and FK terms weighted 4x on each direction's first generated frame
(`loss.near_keyframe_weight=4`), the one change the validation ablation's near-keyframe rows earned
(results/2026-12-04_validation_ablation); nothing else changes (40000 steps, data, validation split, seed).

    bin/train --config results/2026-12-06_release_near_keyframe/lafan1_cpu_release_nk4.py --workdir runs/release_nk4 --data ../shared/data/lafan1
"""
from stitchjax.config import variant

get_config = variant(
    "lafan1_cpu_release",
    "loss.near_keyframe_weight=4",
    name="lafan1_cpu_release_nk4",
)
