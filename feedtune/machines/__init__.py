"""Machines feedtune simulates, one sub-package each, and their registry; the runtime and analysis of a gains
document by its kind (:mod:`feedtune.machines.gains`)."""

from .gains import GainsAnalysis, Runtime, analyze_gains, gains_format_of, load_runtime
from .registry import Machine, get_machine, machine_names, machines, machines_of

__all__ = [
    "GainsAnalysis", "Machine", "Runtime", "analyze_gains", "gains_format_of", "get_machine", "load_runtime",
    "machine_names", "machines", "machines_of",
]
