"""Speed machinery beside the model: same numbers, less time or memory; the paper's model needs none of it.

- :mod:`~stitchjax.accel.matmul`: the bfloat16-operand matmul with its own gradient (``model.matmul_dtype``)
  and the ELU whose derivative comes from its output.
- :mod:`~stitchjax.accel.probes`: ``kernel_matmul``, the generator's matmuls with zero probes and recorded
  inputs.
- :mod:`~stitchjax.accel.scan_gradients`: the generator's weight gradients formed after the rollout's scan
  (``train.weight_gradients_after_scan``).
- :mod:`~stitchjax.accel.tape`: the taped replay of the generator step (``train.scan_remat="taped"``).
"""
