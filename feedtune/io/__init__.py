"""feedtune.io."""
