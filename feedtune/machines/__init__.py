"""Machines feedtune simulates and deploys to, one sub-package each, and their registry."""

from .registry import Machine, get_machine, load_runtime, machine_names, machine_of_gains

__all__ = ["Machine", "get_machine", "load_runtime", "machine_names", "machine_of_gains"]
