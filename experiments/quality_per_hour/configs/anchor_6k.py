"""base_6k with one lever: model.update_anchor=interpolation.

    bin/train --config experiments/quality_per_hour/configs/anchor_6k.py --workdir runs/qph_anchor_6k --data ../shared/data/lafan1
"""
from stitchjax.config import variant

get_config = variant(
    "base_6k",
    "model.update_anchor=interpolation",
    name="qph_anchor_6k",
)
