"""Searches over controller parameters, judged by :mod:`feedtune.analysis` with the limits policy.

Each tuner evaluates its candidates with exactly the check its result is judged by (the same plant cases, grid,
interpolation, extension below the FRF and limits), ranks them by the true first crossover and says by which rule
it chose.
"""

from .mcppc import tune_mcppc
from .ppi import tune_ppi

__all__ = ["tune_mcppc", "tune_ppi"]
