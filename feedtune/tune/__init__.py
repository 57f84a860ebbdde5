"""Searches over controller parameters, judged by :mod:`feedtune.analysis` with the limits policy.

Each tuner evaluates its candidates with exactly the check its result is judged by (the same plant cases, grid,
interpolation, extension below the FRF and limits), ranks them by the true first crossover and says by which rule
it chose.
"""

from .gantry import tune_gantry_mimo
from .loopshape import tune_loopshape
from .mcppc import tune_mcppc
from .pid import tune_gantry_pid
from .ppi import tune_ppi

__all__ = ["tune_gantry_mimo", "tune_gantry_pid", "tune_loopshape", "tune_mcppc", "tune_ppi"]
