"""feedtune.export."""
