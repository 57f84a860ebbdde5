"""feedtune.analysis."""
