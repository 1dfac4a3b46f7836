"""stitchjax: diverse motion in-betweening with dual posture stitching, in JAX.

Data flow (one module per stage; a module imports only from stages to its left):

    rotations -> skeleton -> bvh -> windows -> lafan1 / h36m -> features -> phase
    -> networks -> rollout -> losses -> train -> inbetween -> metrics/baselines/evaluate/plots
"""

__version__ = "0.1.0"
