"""The paper's model: the S-CVAE generator and discriminators (``layers``, ``networks``), the bidirectional
rollout (``rollout``, ``stitching``, ``noise``; ``batch`` for training windows), the loss terms (``losses``) and
the objectives (``objective``)."""
