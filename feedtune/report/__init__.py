"""feedtune.report."""
