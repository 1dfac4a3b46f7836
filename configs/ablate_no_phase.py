"""Ablation (paper Table 4): no phase modulation: plain MLP decoder, no phase network. The lafan1 config with one
field changed."""
from stitchjax.config import variant

get_config = variant("lafan1", "model.phase_modulation=false", name="ablate_no_phase")
