"""feedtune: identification and tuning of precision feed drives.

The library is the product; the ``feedtune`` command line is a thin layer over it. The public API is importable
from here (loaded on first use, so ``import feedtune`` and ``feedtune --help`` stay fast)::

    from feedtune import read_frf, fit_ballscrew, design_mcppc, analyze_ballscrew, THESIS_FILTER_PACK

    frf = read_frf("examples/ballscrew_frf.csv")
    model = fit_ballscrew([frf]).model
    design = design_mcppc(model, beta=4, pole_hz=50, zeta=0.7, filters=THESIS_FILTER_PACK)
    analysis = analyze_ballscrew(design.law(), model, frf)
    analysis.discrete.ms, analysis.plot("nyquist"), analysis.to_dataframe()

Sub-packages:

* :mod:`feedtune.io` -- file readers and writers (FRF CSV/MAT/UFF58, logs, model and gains files)
* :mod:`feedtune.models` -- ball-screw 2-mass model, gantry yaw model, rigid body, friction
* :mod:`feedtune.identify` -- FRF fits, FRF estimation from logs, least squares on logs, friction
* :mod:`feedtune.control` -- controller value types: laws, filter packs, pre-filters, discretization
* :mod:`feedtune.design` -- MC-PPC, P-PI, loop shaping, gantry MIMO and PID, pre-filter fit
* :mod:`feedtune.tune` -- searches over controller parameters under one limits policy
* :mod:`feedtune.analysis` -- loops, margins, Nyquist, sensitivity, disturbance transfer, metrics
* :mod:`feedtune.sim`, :mod:`feedtune.machines` -- trajectories, digital twins, the runtime of gains files
* :mod:`feedtune.interop_control` -- to and from python-control (``to_control``, ``from_control``)
"""

from . import _kernel_cache
from ._kernel_cache import kernel_cache_dir
from .errors import DataError, DesignError, FeedtuneError, UsageError

_kernel_cache.install()  # the kernel cache folder is chosen and checked when numba is first imported

__version__ = "0.1.0"

_LAZY = {
    # value types
    "Frf": "frf", "Log": "log",
    # files
    "read_frf": "io", "write_frf": "io", "read_log": "io", "write_log_csv": "io", "load_model": "io",
    "save_model": "io", "read_document": "io", "write_document": "io", "merge_logs": "log_merge",
    # models
    "BallScrewModel": "models", "GantryModel": "models", "GantryModelAtX": "models", "RigidBodyModel": "models",
    "StribeckFriction": "models", "THESIS_TABLE_3_1": "models", "THESIS_GANTRY": "models",
    # identification
    "fit_ballscrew": "identify", "fit_gantry": "identify", "fit_gantry_frf": "identify", "fit_rigid": "identify",
    "identify_friction": "identify", "fit_stribeck": "identify", "estimate_frf": "identify",
    "fit_mass_distribution": "identify",
    # controllers and designs
    "FilterPack": "control.filters", "Notch": "control.filters", "LeadStage": "control.filters",
    "THESIS_FILTER_PACK": "control.filters", "BallScrewLaw": "control.ballscrew_law",
    "PrefilterGains": "control.prefilter", "Zpk": "lti",
    "design_mcppc": "design.mcppc", "design_ppi": "design.ppi", "design_gantry_mimo": "design.gantry_mimo",
    "design_gantry_pid": "design.gantry_pid", "design_loopshape": "design.loopshape",
    "fit_prefilter": "design.prefilter",
    # tuning
    "tune_mcppc": "tune", "tune_ppi": "tune", "tune_gantry_mimo": "tune", "tune_gantry_pid": "tune",
    "tune_loopshape": "tune",
    # analysis
    "analyze_ballscrew": "analysis.ballscrew", "analyze_gantry": "analysis.gantry", "analyze_axis": "analysis.gantry",
    "check_design": "analysis.check", "Limits": "analysis.limits", "limits_profile": "analysis.limits",
    "tracking_metrics": "analysis.metrics", "ropesnap_metrics": "analysis.metrics",
    # simulation, machines, export, report
    "point_to_point": "sim", "multi_segment": "sim", "Trajectory": "sim",
    "get_machine": "machines", "load_runtime": "machines", "analyze_gains": "machines",
    "c_header": "export.c_header", "build_report": "report.build", "write_report": "report.build",
    "run_machine_demo": "workflows",
    # python-control
    "to_control": "interop_control", "from_control": "interop_control",
}
"""Public names loaded on first access: ``{name: module under feedtune}``."""

__all__ = ["DataError", "DesignError", "FeedtuneError", "UsageError", "__version__", "kernel_cache_dir"]
__all__ += sorted(_LAZY)


def __getattr__(name: str):
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'feedtune' has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(f".{module}", __name__), name)
    globals()[name] = value  # the next access is a plain global lookup
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))


def _load_facades() -> None:
    """Import the facades, which register their functions in feedtune.display (display.facade), through which the
    value types' .plot(), .to_control() and .from_control() reach them. display.facade calls this on first use, so
    ``import feedtune`` (and the command line's start, whose interrupt handler comes first) stays cheap."""
    from . import interop_control, plotting  # noqa: F401
