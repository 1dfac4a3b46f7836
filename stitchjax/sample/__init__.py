"""Sampling: a trained or shipped model, keyframes in, diverse transitions out (takes, foot locking, latents)."""
