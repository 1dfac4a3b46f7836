"""Speed machinery beside the model: same numbers, less time or memory; the paper's model needs none of it.
The training step opts in (``train.loop.make_update_step``, ``specs.train_spec``) and the sampler's model loader
takes the layers (``sample.trained_model.Model.rollout_spec``); nothing under ``stitchjax.model`` imports it.

- :mod:`~stitchjax.accel.matmul`: the generator's layers (``Dense``, ``LSTMCell``, ``MoEDense``, the same
  parameters as ``model.layers``') on the matmul of ``model.matmul_dtype`` (bfloat16 operands, float32
  accumulation, a custom backward) and the ELU whose derivative comes from its output.
- :mod:`~stitchjax.accel.fast_rollout`: the training step's rollout of a batch, with the fast paths of
  ``train.weight_gradients_after_scan`` and ``train.scan_remat``.
- :mod:`~stitchjax.accel.probes`: ``kernel_matmul``, the generator's matmuls with zero probes and recorded
  inputs.
- :mod:`~stitchjax.accel.scan_gradients`: the generator's weight gradients formed after the rollout's scan
  (``train.weight_gradients_after_scan``).
- :mod:`~stitchjax.accel.tape`: the taped replay of the generator step (``train.scan_remat="taped"``).
"""
