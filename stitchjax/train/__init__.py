"""Training: the train state, the jitted step and the loop, the length schedule, resuming and the run's record."""
