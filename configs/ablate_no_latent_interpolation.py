"""Ablation (paper Table 4): no latent interpolation: z sampled from the current-frame Gaussian only. The lafan1
config with one field changed."""
from stitchjax.config import variant

get_config = variant("lafan1", "model.latent_interpolation=false", name="ablate_no_latent_interpolation")
