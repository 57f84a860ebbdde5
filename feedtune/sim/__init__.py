"""feedtune.sim."""
