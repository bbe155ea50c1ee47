"""Dynamic captures: splats that move, turn and fade by themselves (4D Gaussian splats)."""
