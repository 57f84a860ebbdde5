"""Tracking and rope-snap metrics straight from a recorded (or simulated) log.

These two functions pick the signals of a log the way ``feedtune analyze track|ropesnap`` does, so that the
command line and the report generator give identical numbers:

* :func:`analyze_tracking_log` -- tracking error ``e2`` (or reference minus position), commanded velocity
  and acceleration (``v_ref``/``a_ref`` or derivatives of the reference) ->
  :class:`~feedtune.analysis.metrics.TrackingMetrics`.
* :func:`analyze_ropesnap_log` -- table displacement ``x2_table`` (or the one position column in m) and
  the release instant (``meta["t_release_s"]`` or detected) ->
  :class:`~feedtune.analysis.metrics.RopeSnapMetrics`.

Lengths are in metres [m], times in seconds [s]; a signal in another unit is a :class:`DataError` that
tells how to convert it (``--scale NAME=FACTOR --unit NAME=m``). With ``angular=True`` (the command line's
``analyze track``) a tracking log of a rotary axis in rad (or mrad, urad) is read as it is: its metrics are in rad
(:attr:`~feedtune.analysis.metrics.TrackingMetrics.unit`).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ..errors import DataError, UsageError
from ..log import Log
from .metrics import RopeSnapMetrics, TrackingMetrics, ropesnap_metrics, tracking_metrics

#: Preferred signal names written by the twin experiments (feedtune.machines.ballscrew.experiments).
_ERROR_NAME = "e2"
_TABLE_POSITION_NAME = "x2_table"
_DEFAULT_REFERENCE = "x_ref"
_GANTRY_REFERENCE = "y_ref"
_VELOCITY_NAME = "v_ref"
_ACCELERATION_NAME = "a_ref"
#: Meta key of the release instant written by the rope-snap experiment [s].
_RELEASE_META_KEY = "t_release_s"
#: Units accepted for a length (an empty unit is taken as metres).
_LENGTH_UNITS = ("m", "")
#: Angle units of a rotary axis' log and their factor to rad (``angular=True``).
_ANGLE_UNITS = {"rad": 1.0, "mrad": 1e-3, "urad": 1e-6, "µrad": 1e-6, "μrad": 1e-6}
#: Trajectory derivative names that are never a measured position.
_REFERENCE_DERIVATIVES = ("v_ref", "a_ref", "j_ref", "s_ref")

def _length_signal(log: Log, name: str, role: str) -> np.ndarray:
    """Signal ``name`` in metres, else a DataError naming its unit and the conversion options."""
    x = log.get(name)
    unit = log.unit(name)
    if unit not in _LENGTH_UNITS:
        raise DataError(f"{log.source}: {role} {name!r} is in {unit!r}, expected m; convert it with "
                        f"scale={name}=FACTOR units={name}=m", parameter=("read_log.scale", "read_log.units"))
    return x


def _tracking_signal(log: Log, name: str, role: str, angular: bool) -> tuple[np.ndarray, str]:
    """Signal ``name`` in m (or, ``angular``, in rad) and that unit; a DataError naming its unit otherwise."""
    unit = log.unit(name)
    if angular and unit in _ANGLE_UNITS:
        return log.get(name) * _ANGLE_UNITS[unit], "rad"
    if angular and unit not in _LENGTH_UNITS:
        raise DataError(f"{log.source}: {role} {name!r} is in {unit!r}, expected m or rad; convert it with "
                        f"scale={name}=FACTOR units={name}=m", parameter=("read_log.scale", "read_log.units"))
    return _length_signal(log, name, role), "m"


def _position_candidates(log: Log, exclude: set[str], unit: str = "m") -> list[str]:
    """Signals in ``unit`` that can be a measured table position (not references, errors or derivatives)."""
    units = (unit,) if unit == "m" else tuple(_ANGLE_UNITS)
    return [name for name, u in log.units.items()
            if u in units and name not in exclude and name not in _REFERENCE_DERIVATIVES
            and not name.endswith("_ref") and name != _ERROR_NAME]


def pick_position(log: Log, position: str | None, exclude: set[str], unit: str = "m") -> str:
    """The position column: ``position``, else ``x2_table``, else the single other column in ``unit`` (m, or rad
    for a rotary axis)."""
    if position is not None:
        log.get(position)
        return position
    if _TABLE_POSITION_NAME in log:
        return _TABLE_POSITION_NAME
    candidates = _position_candidates(log, exclude, unit)
    if len(candidates) == 1:
        return candidates[0]
    if not candidates:
        raise DataError(f"{log.source}: no position column ({_TABLE_POSITION_NAME!r} or a signal in m); "
                        f"signals: {', '.join(log.signals) or 'none'}; name it with position= "
                        "(and units=NAME=m)", parameter=("position", "read_log.units"))
    raise DataError(f"{log.source}: several position columns in m ({', '.join(candidates)}); "
                    "choose one with position=", parameter="position")


def _check_name(value: str | None, name: str) -> None:
    if value is not None and (not isinstance(value, str) or not value.strip()):
        raise UsageError(f"{name}: expected a signal name, got {value!r}")


def _commanded_motion(log: Log, reference: str, angular: bool = False) -> tuple[np.ndarray | None, np.ndarray | None]:
    """Commanded velocity [m/s] and acceleration [m/s^2]: logged, else derived from the reference.

    The logged names follow the reference: ``v_ref``/``a_ref`` for ``x_ref``, ``vy_ref``/``ay_ref`` for
    ``y_ref`` (the gantry twin's logs). When the default ``x_ref`` is absent, a logged ``y_ref`` is used.
    """
    if reference == _DEFAULT_REFERENCE and reference not in log and _GANTRY_REFERENCE in log:
        reference = _GANTRY_REFERENCE
    stem = reference[: -len("_ref")] if reference.endswith("_ref") else reference
    names = (_VELOCITY_NAME, _ACCELERATION_NAME) if stem == "x" else (f"v{stem}_ref", f"a{stem}_ref")
    vel = log.get(names[0]) if names[0] in log else None
    acc = log.get(names[1]) if names[1] in log else None
    if vel is None and reference in log:
        vel = np.gradient(_tracking_signal(log, reference, "reference", angular)[0], log.t)
    if acc is None and vel is not None:
        acc = np.gradient(vel, log.t)
    return vel, acc


def analyze_tracking_log(
    log: Log, *, error: str | None = None, reference: str | None = None, position: str | None = None,
    angular: bool = False,
) -> TrackingMetrics:
    """Tracking-error metrics of a log (thesis Table 3.2, §4.5).

    Parameters
    ----------
    log : Log
        Recorded or simulated run (e.g. ``feedtune simulate track`` output).
    error : str, optional
        Column holding the tracking error, commanded minus actual [m]. Default: ``e2`` when present and
        ``position`` is not given; otherwise ``reference - position``.
    reference : str, optional
        Commanded table position [m] (default ``x_ref``; a name given must be in the log).
    position : str, optional
        Measured table position [m]. Default ``x2_table``, else the only other signal in m.
    angular : bool
        Also accept signals in rad, mrad or urad (a rotary axis); the error, reference and position then share one
        of m and rad, and the metrics are in it.

    Returns
    -------
    TrackingMetrics
        Max and RMS error [m, or rad: ``unit``] over the whole run, the constant-velocity and acceleration parts (from
        ``v_ref``/``a_ref`` when logged, else from derivatives of the reference; None when the log has
        neither), and the error amplitude spectrum [m] with its peaks (only for uniform sampling).

    Raises
    ------
    DataError
        A named column is missing, not in m, or no error can be formed.
    """
    _check_name(error, "error")
    _check_name(reference, "reference")
    _check_name(position, "position")
    if reference is not None and reference not in log:  # named, so it must be there (the default may be absent)
        raise DataError(f"{log.source}: no reference {reference!r}; signals: {', '.join(log.signals) or 'none'}",
                        parameter="reference")
    reference = reference or _DEFAULT_REFERENCE
    if error is not None:
        e, unit = _tracking_signal(log, error, "error", angular)
    elif position is None and _ERROR_NAME in log:
        e, unit = _tracking_signal(log, _ERROR_NAME, "error", angular)
    else:
        if reference not in log:
            raise DataError(f"{log.source}: no tracking error {_ERROR_NAME!r} and no reference {reference!r}; "
                            f"signals: {', '.join(log.signals) or 'none'} (name them with error=, or "
                            "reference= and position=)", parameter=("error", "reference", "position"))
        ref, unit = _tracking_signal(log, reference, "reference", angular)
        pos, pos_unit = _tracking_signal(log, pick_position(log, position, {reference}, unit), "position", angular)
        if pos_unit != unit:
            raise DataError(f"{log.source}: the reference {reference!r} is in {unit} and the position in {pos_unit}; "
                            "give both in one unit", parameter="read_log.units")
        e = ref - pos
    vel, acc = _commanded_motion(log, reference, angular)
    metrics = tracking_metrics(log.t, e, vel=vel, acc=acc, spectrum=log.is_uniform())
    return metrics if unit == "m" else replace(metrics, unit=unit)


def _release_from_meta(log: Log) -> float | None:
    """``meta["t_release_s"]`` as a float [s] (CSV metadata arrives as text); None when absent."""
    value = log.meta.get(_RELEASE_META_KEY)
    if value is None:
        return None
    try:
        t_release = float(value)
    except (TypeError, ValueError):
        raise DataError(f"{log.source}: metadata {_RELEASE_META_KEY} = {value!r} is not a time in s") from None
    if not math.isfinite(t_release):
        raise DataError(f"{log.source}: metadata {_RELEASE_META_KEY} = {value!r} is not a finite time in s")
    return t_release


def analyze_ropesnap_log(
    log: Log, *, position: str | None = None, t_release: float | None = None
) -> RopeSnapMetrics:
    """Rope-snap metrics of a log (thesis Fig. 3.14, Fig. 4.17).

    Parameters
    ----------
    log : Log
        Uniformly sampled rope-snap record (e.g. ``feedtune simulate ropesnap`` output).
    position : str, optional
        Table displacement [m]. Default ``x2_table``, else the only signal in m.
    t_release : float, optional
        Release instant [s] on the log's time axis. Default: ``meta["t_release_s"]`` when the log carries
        it, else detected from the displacement (the log must start with quiet pre-release data).

    Returns
    -------
    RopeSnapMetrics
        Peak displacement [m], 5 % settling time [s], amplitude spectral density [m/sqrt(Hz)] and peaks.

    Raises
    ------
    DataError
        No usable position column, non-uniform sampling, or no detectable release.
    """
    _check_name(position, "position")
    name = pick_position(log, position, set())
    x = _length_signal(log, name, "position")
    if t_release is None:
        t_release = _release_from_meta(log)
    return ropesnap_metrics(log.t, x, t_release=t_release)
