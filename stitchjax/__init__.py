"""stitchjax: diverse motion in-betweening with dual posture stitching, in JAX.

Data flow, one subpackage per stage; a module imports only from its own stage, the stages to its left and the
shared modules at the top (rotations, skeleton, config, specs, checkpoints, parallel):

    data/ (BVH, windows, features) -> model/ (networks, rollout, losses, objective) -> sample/ (inbetween, takes,
    footlock) -> eval/ (metrics, protocols, figures) -> train/ (step, loop, schedule, resume)
    accel/: speed machinery beside the model (the train step and the model loader opt in; the model never imports it)

docs/design.md ("Code map") gives each module's one job.

    model = stitchjax.pretrained()   # the release model shipped in stitchjax/pretrained/, ready to sample
"""

from stitchjax.config import RELEASE_MODEL  # the folder of stitchjax/pretrained/ that pretrained() loads

__version__ = "0.1.0"


def pretrained(name: str | None = None):
    """The release model shipped with the package (``stitchjax.sample.trained_model.pretrained``), ready to sample.

    name: a folder of ``stitchjax/pretrained/`` (default: the release model, ``trained_model.RELEASE_MODEL``).
    Imported on call, so ``import stitchjax`` stays free of jax.
    """
    from stitchjax.sample import trained_model  # reason: jax starts only when a model is asked for

    return trained_model.pretrained() if name is None else trained_model.pretrained(name)
