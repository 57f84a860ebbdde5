"""Machines feedtune simulates and deploys to, one sub-package each, and their registry."""

from .registry import GainsAnalysis, Machine, analyze_gains, get_machine, load_runtime, machine_names, machine_of_gains

__all__ = [
    "GainsAnalysis", "Machine", "analyze_gains", "get_machine", "load_runtime", "machine_names", "machine_of_gains",
]
