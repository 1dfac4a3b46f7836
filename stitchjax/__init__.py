"""stitchjax: diverse motion in-betweening with dual posture stitching, in JAX.

Data flow (one module per stage; a module imports only from stages to its left):

    rotations -> skeleton -> bvh -> conform -> windows -> lafan1 / h36m / bvh_folder -> phase -> features
    -> datasets -> networks -> rollout -> losses -> schedule / resume / train -> trained_model -> inbetween
    -> takes / latent -> metrics / baselines / evaluate / plots

README.md ("What is where") gives each module's one job.

    model = stitchjax.pretrained()   # the release model shipped in stitchjax/models/, ready to sample
"""

__version__ = "0.1.0"
RELEASE_MODEL = "lafan1_cpu_release"  # the folder of stitchjax/models/ that pretrained() loads


def pretrained(name: str | None = None):
    """The release model shipped with the package (``stitchjax.trained_model.pretrained``), ready to sample.

    name: a folder of ``stitchjax/models/`` (default: the release model, ``trained_model.RELEASE_MODEL``).
    Imported on call, so ``import stitchjax`` stays free of jax.
    """
    from stitchjax import trained_model  # reason: jax starts only when a model is asked for

    return trained_model.pretrained() if name is None else trained_model.pretrained(name)
