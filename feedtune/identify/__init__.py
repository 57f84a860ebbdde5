"""feedtune.identify."""
