"""feedtune.design."""
