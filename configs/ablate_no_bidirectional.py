"""Ablation (paper Table 4): no bidirectional scheme: the forward generator alone generates the whole transition.
The lafan1 config with one field changed."""
from stitchjax.config import variant

get_config = variant("lafan1", "model.bidirectional=false", name="ablate_no_bidirectional")
