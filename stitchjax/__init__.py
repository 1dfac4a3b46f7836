"""stitchjax: diverse motion in-betweening with dual posture stitching, in JAX.

Data flow (one module per stage; a module imports only from stages to its left):

    rotations -> skeleton -> bvh -> conform -> windows -> lafan1 / h36m / bvh_folder -> phase -> features
    -> datasets -> networks -> rollout -> losses -> schedule / resume / train -> trained_model -> inbetween
    -> takes / latent -> metrics / baselines / evaluate / plots

README.md ("What is where") gives each module's one job.
"""

__version__ = "0.1.0"
