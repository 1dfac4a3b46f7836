"""Ablation (paper Table 4): no stitching loss (alpha2 = 0). The lafan1 config with one field changed."""
from stitchjax.config import variant

get_config = variant("lafan1", "loss.stitch_weight=0", name="ablate_no_stitch_loss")
