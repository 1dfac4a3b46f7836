"""The paper's model: the S-CVAE generator and discriminators, the bidirectional rollout, and the losses."""
