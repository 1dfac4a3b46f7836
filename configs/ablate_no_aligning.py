"""Ablation (paper Table 4): no bidirectional aligning: each generator targets the given end keyframe. The lafan1
config with one field changed."""
from stitchjax.config import variant

get_config = variant("lafan1", "model.bidirectional_aligning=false", name="ablate_no_aligning")
