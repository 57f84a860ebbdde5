"""feedtune: identification and tuning of precision feed drives.

The library is the product; the ``feedtune`` command line is a thin layer over it. Sub-packages:

* :mod:`feedtune.io` -- file readers and writers (FRF CSV/MAT/UFF58, logs, model and gains files)
* :mod:`feedtune.models` -- ball-screw 2-mass model, gantry yaw model, friction
* :mod:`feedtune.identify` -- FRF fits, FRF estimation from logs, least squares on logs, friction
* :mod:`feedtune.design` -- filters, pole-zero matching, MC-PPC, P-PI, loop shaping, gantry MIMO
* :mod:`feedtune.analysis` -- loops, margins, Nyquist, sensitivity, disturbance transfer, metrics
* :mod:`feedtune.sim` -- trajectories, digital twins, the per-sample runtime of exported gains
"""

import os as _os

from ._kernel_cache import kernel_cache_dir

_os.environ.setdefault("NUMBA_CACHE_DIR", kernel_cache_dir())

from .errors import DataError, DesignError, FeedtuneError, UsageError
from .frf import Frf
from .log import Log

__version__ = "0.1.0"

__all__ = ["DataError", "DesignError", "FeedtuneError", "Frf", "Log", "UsageError", "__version__", "kernel_cache_dir"]
