"""Many axes over time: a fleet's measurements identified and re-certified on local processes or a Dask cluster, a
Parquet history per axis and measurement, drift caught before the margins fail, and one HTML page (docs/fleet.md).

* :func:`load_manifest`: the fleet (``fleet.toml`` or CSV);
* :func:`run_fleet`: identify, re-certify, append the history, judge the drift, propose re-tunes;
* :func:`read_history`: the history as a pyarrow table;
* :func:`fleet_status`: trends, alarms, forecasts and traffic lights from the history;
* :func:`write_fleet_report`: the fleet's HTML page;
* :func:`simulate_fleet`: a simulated fleet with its truth (tests, benchmarks, trying it out).

pyarrow (the history) and dask distributed (``scheduler=``) are optional extras: ``pip install 'feedtune[fleet]'``.
"""

from .drift import DriftSettings, Trend, trend
from .engine import Engine
from .history import read_history
from .manifest import AxisEntry, Manifest, Measurement, load_manifest
from .run import RunResult, RunSummary, plan_fleet, run_fleet
from .simulated import simulate_fleet
from .status import AxisStatus, FleetStatus, fleet_status

__all__ = [
    "AxisEntry", "AxisStatus", "DriftSettings", "Engine", "FleetStatus", "Manifest", "Measurement", "RunResult",
    "RunSummary", "Trend", "fleet_status", "load_manifest", "plan_fleet", "read_history", "run_fleet",
    "simulate_fleet", "trend", "write_fleet_report",
]


def write_fleet_report(status, path, *, force: bool = False):
    """Write the fleet's HTML page (:func:`feedtune.fleet.report.write_fleet_report`)."""
    from .report import write_fleet_report as write

    return write(status, path, force=force)
