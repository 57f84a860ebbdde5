"""feedtune.cli."""
