"""Per-sample runtime of gantry and x-axis gains files, executed exactly as a real-time target would.

:class:`GantryRuntime` runs a ``kind = "gantry"`` file (``controller = "mimo"``: sensor/actuator averaging,
lead, active damping and actuator-level integral of thesis eq. 4.30; or ``"pid"``: one PID per side), and
:class:`AxisRuntime` a ``kind = "axis"`` file (the loop-shaped x axis, eq. 4.18). Both read nothing but the
document: sampling, gains, second-order sections and the x-position schedule. The execution order is the
one of ``docs/gantry_gains.md`` (also stored in the file as ``law.execution``)::

    r = shaper(y_r[k+P])                           previewed reference [m], shaped when the file has a [shaper]
    d_n = prefilter_n(r)                           s^n G_lpf^(n+1), n = vel, acc, jerk, snap (eq. 4.20/4.32)
    s = schedule(x[k])                             alpha1, alpha2, M(x), pre-filter gains (eq. 4.33)
    ra_i = r + sum_n k_n_i d_n                     per-side pre-filtered reference, P samples ahead
    acc_i = acceleration(ra_i); yr_i = position(ra_i)
    uff = M(x) [acc_1, acc_2]                      inertia feedforward (eq. 4.31)
    e_i = yr_i - y_i[k]                            (first sample: previous errors = current errors)
    mimo: v = lead(alpha1 e_1 + alpha2 e_2); dd = d/dt (e_1 - e_2); ie_i += e_i / fs
          w_1 = alpha1 (v + beta dd + ki ie_1);  w_2 = alpha2 (v - beta dd + ki ie_2)
    pid:  w_i = kp_i e_i + kd_i d/dt e_i + ki_i ie_i
    u_i = filter_pack(w_i) + uff_i                 applied delay_samples later

``d/dt`` is the backward difference times ``fs``, the integrals are backward Euler. Every ``*_sos`` list is a
cascade in transposed direct form II (as ``scipy.signal.sosfilt``), states zero at start, each section
normalised by its ``a0`` when the file is read. The schedule is interpolated linearly in ``x`` and clamped
at the first and last row.

Both runtimes add the optional friction feedforward (``[friction_feedforward]``) to ``uff``: eq. 2.1 + viscous of the
previewed reference's backward-difference velocity ``v_r = (r - r_prev) fs`` [m/s] (0 on the first sample), linear
through zero inside ``+-v_band`` (:mod:`feedtune.control.friction`). :class:`GantryRuntime` splits it between the
drives as the inertia feedforward splits a rigid acceleration (``alpha_i m`` are the row sums of ``M(x)``)::

    d = friction(v_r);  uff_1 += alpha1 d;  uff_2 += alpha2 d          (alpha_i from the schedule row at x[k])

:meth:`GantryRuntime.replay` and :meth:`AxisRuntime.replay` evaluate the same law for recorded signals
without a per-sample loop (``sosfilt``); :func:`feedtune.machines.load_runtime` dispatches on the file's ``kind``.

Units: positions [m], commands in the drive's unit (V), time [s].
"""

from __future__ import annotations

import math
import os

import numpy as np

from ...control.shapers import ShaperFilter
from ...control.sos import sos_filter
from ...errors import DataError, UsageError
from ...io.gains import read_sampling, read_sos, value
from ...io.shaper_file import read_shaper_taps
from ...sim.engine import sample_vector
from .law import GP_NCOL, AxisLawData, GantryLawData, compiled_laws, schedule_row

_PREFILTER_KEYS = ("prefilter_vel_sos", "prefilter_acc_sos", "prefilter_jerk_sos", "prefilter_snap_sos")


# ------------------------------------------------------------------------------------------- helpers
def _sos(doc: dict, sec_name: str, key: str, where: str) -> np.ndarray:
    from ...io.gantry_gains import entry, section

    return read_sos(entry(section(doc, sec_name, where), sec_name, key, where), f"{where}: {sec_name}.{key}")


def _previewed(x: np.ndarray, preview: int) -> np.ndarray:
    """``x[k + P]`` for every ``k``, holding the last value past the end."""
    return x if preview == 0 else np.r_[x[preview:], np.full(min(preview, x.size), x[-1])]


class _Shaped:
    """The optional input shaper of a gantry or axis runtime (``[shaper]``): :meth:`shape` for whole references,
    ``_shape_step`` per sample (identity without one)."""

    shaper = None
    _shaper_filter = None

    def _set_shaper(self, shaper) -> None:
        self.shaper = shaper
        self._shaper_filter = None if shaper is None else ShaperFilter(shaper)

    def shape(self, r) -> np.ndarray:
        """The ``[shaper]`` applied from rest to a reference sequence [m] (``r`` itself without one)."""
        r = np.asarray(r, float)
        return r if self.shaper is None else self.shaper.apply(r)

    def _shape_step(self, r: float) -> float:
        return r if self._shaper_filter is None else self._shaper_filter.step(r)

    def _reset_shaper(self) -> None:
        if self._shaper_filter is not None:
            self._shaper_filter.reset()


def _check_target(fs_file: float, fs: float, where: str) -> None:
    if not math.isclose(fs_file, fs, rel_tol=1e-9):
        raise DataError(f"{where}: gains were designed for fs = {fs_file:g} Hz, but the target samples at "
                        f"{fs:g} Hz; design again with fs={fs:g}", parameter="fs")


def _finite_position(x: float) -> float:
    if x != x or x in (math.inf, -math.inf):  # NaN or infinite
        raise UsageError(f"table position x must be finite [m], got {x}")
    return x


def _check_friction(friction, command_unit: str, source: str) -> None:
    """DataError unless a friction feedforward is in the law's units (command unit, m/s)."""
    if friction.command_unit != command_unit or friction.velocity_unit != "m/s":
        raise DataError(f"{source}: friction feedforward is in {friction.command_unit!r} and "
                        f"{friction.velocity_unit!r}, the law in {command_unit!r} and 'm/s'")


SPLIT_TOL = 1e-6
"""Absolute tolerance [-] of the friction split's check: ``alpha1 + alpha2 = 1`` and ``alpha_i`` = row sum of ``M(x)``
over its total, in every schedule row [-]."""


def _check_split(schedule: np.ndarray, source: str) -> None:
    """DataError unless every schedule row's ``alpha1, alpha2`` split a force as ``M(x)`` splits a rigid acceleration
    (``alpha_i = (M 1)_i / (1^T M 1)``, summing to 1): the friction feedforward is split by ``alpha``."""
    a1, a2, m11, m12, m22 = (schedule[:, i] for i in range(5))
    total = m11 + 2.0 * m12 + m22
    with np.errstate(divide="ignore", invalid="ignore"):
        r1, r2 = (m11 + m12) / total, (m12 + m22) / total
    ok = (np.all(total > 0) and np.allclose(a1 + a2, 1.0, rtol=0.0, atol=SPLIT_TOL)
          and np.allclose(a1, r1, rtol=0.0, atol=SPLIT_TOL) and np.allclose(a2, r2, rtol=0.0, atol=SPLIT_TOL))
    if not ok:
        raise DataError(f"{source}: the friction feedforward is split alpha1 : alpha2 between the drives, but the "
                        "schedule's alpha1, alpha2 are not the row sums of M(x) over its total (summing to 1)")


# ------------------------------------------------------------------------------------------ gantry
class GantryRuntime(_Shaped):
    """Executes a gantry gains document (``kind = "gantry"``, ``controller`` ``"mimo"`` or ``"pid"``).

    Create it with :meth:`from_document` or :meth:`from_file`; call :meth:`reset` before a run and
    :meth:`step` once per sample.

    Attributes
    ----------
    fs : float
        Sample rate [Hz].
    delay_samples : int
        Samples between sampling ``y1[k], y2[k]`` and applying ``u`` (assumed by the design).
    preview_samples : int
        ``P``: :meth:`step` expects the reference ``y_r[k+P]``.
    controller : str
        ``"mimo"`` or ``"pid"``.
    source : str
        File name or ``"gains document"``.
    command_unit : str
        Unit of ``u1, u2`` (``"V"``).
    gains : dict
        MIMO: ``beta`` [V/(m/s)], ``ki`` [V/(m s)]; PID: ``kp1, kp2`` [V/m], ``kd1, kd2`` [V/(m/s)],
        ``ki1, ki2`` [V/(m s)].
    sos : dict of ndarray
        Normalised sections: ``filter_pack``, ``lead`` (MIMO), ``position``, ``acceleration`` and
        ``prefilter_vel`` .. ``prefilter_snap``.
    schedule_x : ndarray
        Table positions [m] of the schedule.
    schedule : ndarray, shape (n_x, 13)
        Rows of :data:`feedtune.io.gantry_gains.SCHEDULE_COLUMNS`.
    friction : FrictionFeedforward or None
        Friction feedforward of the gantry's travel (``[friction_feedforward]``) [command unit, m/s], split
        ``alpha1 : alpha2`` between the drives.
    shaper : SampledShaper or None
        The input shaper's taps (``[shaper]``), applied to the previewed reference first.
    """

    def __init__(self, *, controller: str, gains: dict, sos: dict, schedule_x, schedule, fs: float,
                 delay_samples: int, preview_samples: int, command_unit: str = "V",
                 source: str = "gains document", friction=None, shaper=None) -> None:
        self._set_shaper(shaper)
        self.controller = controller
        self.gains = {k: float(v) for k, v in gains.items()}
        self.sos = {k: np.asarray(v, float) for k, v in sos.items()}
        self.schedule_x = np.asarray(schedule_x, float)
        self.schedule = np.asarray(schedule, float)
        self.fs = float(fs)
        self.delay_samples = int(delay_samples)
        self.preview_samples = int(preview_samples)
        self.command_unit = command_unit
        self.source = source
        self._prefilter_on = bool(np.any(self.schedule[:, 5:] != 0.0))
        if friction is not None:
            _check_friction(friction, command_unit, source)
            _check_split(self.schedule, source)
        self.friction = friction
        self.law = GantryLawData(controller, self.gains, self.sos, self.schedule_x, self.schedule, self.fs,
                                 self._prefilter_on, friction)
        self._step = compiled_laws()[0]
        self._args = self.law.args()
        self._out = self.law.out
        self.reset()

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_document(cls, doc: dict, where: str = "gains document") -> GantryRuntime:
        """Read a gantry gains document (dict from :func:`feedtune.io.read_document`).

        Raises
        ------
        DataError
            Not a gantry gains file of schema version 1, unknown controller, or a missing or invalid
            entry (named in the message).
        """
        from ...io.gantry_gains import (
            GANTRY_CONTROLLERS,
            GANTRY_KIND,
            axis_friction,
            check_header,
            command_unit,
            mimo_gain_units,
            pid_gain_units,
            read_gains,
            read_schedule,
        )

        check_header(doc, where, (GANTRY_KIND,))
        controller = doc.get("controller")
        if controller not in GANTRY_CONTROLLERS:
            raise DataError(f"{where}: controller {controller!r} unknown; expected 'mimo' or 'pid'")
        fs, delay, preview = read_sampling(doc, where)
        unit = command_unit(doc)
        units = mimo_gain_units(unit) if controller == "mimo" else pid_gain_units(unit)
        gains = read_gains(doc, units, where)
        sos = {"filter_pack": _sos(doc, "filters", "filter_pack_sos", where)}
        if controller == "mimo":
            sos["lead"] = _sos(doc, "filters", "lead_sos", where)
        for key in ("position_sos", "acceleration_sos", *_PREFILTER_KEYS):
            sos[key[:-4]] = _sos(doc, "reference", key, where)
        x, table = read_schedule(doc, where)
        return cls(controller=str(controller), gains=gains, sos=sos, schedule_x=x, schedule=table, fs=fs,
                   delay_samples=delay, preview_samples=preview, command_unit=unit, source=where,
                   friction=axis_friction(doc, where), shaper=read_shaper_taps(doc, where))

    @classmethod
    def from_file(cls, path: str | os.PathLike[str]) -> GantryRuntime:
        """Read a ``.toml`` or ``.json`` gantry gains file."""
        from ...io import read_document

        return cls.from_document(read_document(path), str(path))

    # ------------------------------------------------------------------ per sample
    def reset(self) -> None:
        """Zero every filter state and integrator; the next sample is the first."""
        self.law.reset()
        self._reset_shaper()

    def schedule_at(self, x: float) -> tuple:
        """The schedule row at table position ``x`` [m] (linear interpolation, clamped at the ends), as the law
        uses it (:func:`feedtune.machines.gantry.law.schedule_row`).

        Without an active pre-filter only the first five columns (alpha1, alpha2, m11, m12, m22) are
        interpolated.
        """
        law = self.law
        ncol = int(law.par[GP_NCOL])
        row = np.zeros(law.sched.shape[1])
        schedule_row(law.sched_x, law.sched, ncol, _finite_position(float(x)), row)
        return tuple(float(v) for v in row[:ncol])

    def step(self, y_ref_preview: float, y1: float, y2: float, x: float) -> tuple[float, float]:
        """One sample of the law (``docs/gantry_gains.md``; :func:`feedtune.machines.gantry.law.gantry_law_step`).

        Parameters
        ----------
        y_ref_preview : float
            Gantry reference ``y_r[k + preview_samples]`` [m].
        y1, y2 : float
            Left and right encoder readings at ``k`` [m].
        x : float
            Table (x-axis) position [m] used for the schedule.

        Returns
        -------
        (float, float)
            Commands ``u1, u2`` [V], to be applied ``delay_samples`` later.
        """
        out = self._out
        r = self._shape_step(float(y_ref_preview))
        self._step(*self._args, r, float(y1), float(y2), _finite_position(float(x)), out)
        return float(out[0]), float(out[1])

    # ------------------------------------------------------------------ vectorised
    def previewed(self, y_ref) -> np.ndarray:
        """The sequence ``y_r[k + P]`` fed to :meth:`step` (holding the last value past the end), shaped by the
        ``[shaper]`` from rest when the file has one: ``r`` of the module docstring [m]."""
        return self.shape(_previewed(sample_vector(y_ref, "y_ref", min_size=1), self.preview_samples))

    def schedule_table(self, x) -> np.ndarray:
        """Schedule rows for a sequence of positions [m], shape ``(n, 13)`` (vectorised :meth:`schedule_at`)."""
        xs = sample_vector(x, "x", min_size=1)
        return np.column_stack([np.interp(xs, self.schedule_x, col) for col in self.schedule.T])

    def replay(self, y_ref, y1, y2, x) -> tuple[np.ndarray, np.ndarray]:
        """Commands ``(u1, u2)`` [V] for recorded signals, without a per-sample loop.

        Equals :meth:`reset` followed by :meth:`step` on every sample with ``previewed(y_ref)``.

        Parameters
        ----------
        y_ref : array_like, shape (n,)
            Gantry reference ``y_r[k]`` [m] (the preview is taken from it).
        y1, y2 : array_like, shape (n,)
            Encoder readings [m].
        x : array_like, shape (n,) or float
            Table position [m] per sample (a scalar for a fixed table).
        """
        r = self.previewed(y_ref)
        n = r.size
        y1, y2 = sample_vector(y1, "y1", n, min_size=1), sample_vector(y2, "y2", n, min_size=1)
        s = self.schedule_table(np.broadcast_to(np.asarray(x, float), (n,)))
        if self._prefilter_on:
            d = np.column_stack([sos_filter(self.sos[k[:-4]], r) for k in _PREFILTER_KEYS])
            ra1 = r + np.sum(s[:, 5:9] * d, axis=1)
            ra2 = r + np.sum(s[:, 9:13] * d, axis=1)
        else:
            ra1 = ra2 = r
        acc1, acc2 = sos_filter(self.sos["acceleration"], ra1), sos_filter(self.sos["acceleration"], ra2)
        e1 = sos_filter(self.sos["position"], ra1) - y1
        e2 = sos_filter(self.sos["position"], ra2) - y2
        fs, g = self.fs, self.gains
        ie1, ie2 = np.cumsum(e1) / fs, np.cumsum(e2) / fs
        if self.controller == "mimo":
            a1, a2 = s[:, 0], s[:, 1]
            v = sos_filter(self.sos["lead"], a1 * e1 + a2 * e2)
            diff = e1 - e2
            dd = g["beta"] * np.diff(diff, prepend=diff[0]) * fs
            w1 = a1 * (v + dd + g["ki"] * ie1)
            w2 = a2 * (v - dd + g["ki"] * ie2)
        else:
            w1 = g["kp1"] * e1 + g["kd1"] * np.diff(e1, prepend=e1[0]) * fs + g["ki1"] * ie1
            w2 = g["kp2"] * e2 + g["kd2"] * np.diff(e2, prepend=e2[0]) * fs + g["ki2"] * ie2
        h = self.sos["filter_pack"]
        fr = self.friction_feedforward(y_ref)
        return (sos_filter(h, w1) + s[:, 2] * acc1 + s[:, 3] * acc2 + s[:, 0] * fr,
                sos_filter(h, w2) + s[:, 3] * acc1 + s[:, 4] * acc2 + s[:, 1] * fr)

    def friction_feedforward(self, y_ref) -> np.ndarray:
        """The friction feedforward ``d(v_r)`` [command unit] per sample for a gantry reference ``y_r[k]`` [m], before
        its split (``u_i`` gets ``alpha_i d``): eq. 2.1 + viscous of the previewed reference's backward-difference
        velocity [m/s]; zeros without a ``[friction_feedforward]``."""
        from ...control.friction import reference_velocity

        r = self.previewed(y_ref)
        if self.friction is None:
            return np.zeros(r.size)
        return self.friction.command(reference_velocity(r, self.fs))

    # ------------------------------------------------------------------ checks and description
    def check_target(self, fs: float, where: str | None = None) -> None:
        """DataError unless the file was made for sample rate ``fs`` [Hz]."""
        _check_target(self.fs, fs, where or self.source)

    def to_dict(self) -> dict:
        """JSON-ready description (gains with units, sampling, section counts, schedule range)."""
        from ...io.gantry_gains import mimo_gain_units, pid_gain_units

        units = mimo_gain_units(self.command_unit) if self.controller == "mimo" else pid_gain_units(self.command_unit)
        return {
            "source": self.source,
            "kind": "gantry",
            "controller": self.controller,
            "gains": dict(self.gains),
            "fs_hz": self.fs,
            "delay_samples": self.delay_samples,
            "preview_samples": self.preview_samples,
            "sections": {k: int(v.shape[0]) for k, v in self.sos.items()},
            "schedule_x_m": [float(self.schedule_x[0]), float(self.schedule_x[-1])],
            "schedule_rows": int(self.schedule_x.size),
            "prefilter_active": self._prefilter_on,
            "friction_feedforward": None if self.friction is None else self.friction.to_dict(),
            "shaper": None if self.shaper is None else self.shaper.to_dict(),
            "units": {**units, "fs_hz": "Hz", "schedule_x_m": "m", "command": self.command_unit},
        }


# -------------------------------------------------------------------------------------------- axis
class AxisRuntime(_Shaped):
    """Executes a loop-shaped axis gains document (``kind = "axis"``, thesis eq. 4.18-4.20).

    Attributes
    ----------
    fs, delay_samples, preview_samples, controller, source, command_unit
        As :class:`GantryRuntime` (``controller = "loopshape"``).
    mass : float
        Feedforward mass ``m_x`` [V/(m/s^2)] (eq. 4.19).
    prefilter_gains : tuple of float
        ``k_vel`` [s], ``k_acc`` [s^2], ``k_jerk`` [s^3], ``k_snap`` [s^4] (eq. 4.20).
    sos : dict of ndarray
        ``controller`` (K (Ti s + 1)/s x leads x filters, matched), ``position``, ``acceleration``,
        ``prefilter_vel`` .. ``prefilter_snap``.
    friction : FrictionFeedforward or None
        Friction feedforward (``[friction_feedforward]``) [command unit, m/s].
    shaper : SampledShaper or None
        The input shaper's taps (``[shaper]``), applied to the previewed reference first.
    """

    def __init__(self, *, sos: dict, mass: float, prefilter_gains, fs: float, delay_samples: int,
                 preview_samples: int, controller: str = "loopshape", command_unit: str = "V",
                 source: str = "gains document", friction=None, shaper=None) -> None:
        self._set_shaper(shaper)
        self.sos = {k: np.asarray(v, float) for k, v in sos.items()}
        self.mass = float(mass)
        self.prefilter_gains = tuple(float(v) for v in prefilter_gains)
        self.fs = float(fs)
        self.delay_samples = int(delay_samples)
        self.preview_samples = int(preview_samples)
        self.controller = controller
        self.command_unit = command_unit
        self.source = source
        if friction is not None:
            _check_friction(friction, command_unit, source)
        self.friction = friction
        self._prefilter_on = any(v != 0.0 for v in self.prefilter_gains)
        self.law = AxisLawData(self.sos, self.mass, self.prefilter_gains, self._prefilter_on, self.fs, friction)
        self._step = compiled_laws()[1]
        self._args = self.law.args()
        self.reset()

    @classmethod
    def from_document(cls, doc: dict, where: str = "gains document") -> AxisRuntime:
        """Read an axis gains document; DataError names the missing or invalid entry."""
        from ...io.gantry_gains import (
            AXIS_KIND,
            PREFILTER_TERMS,
            PREFILTER_UNITS,
            axis_friction,
            check_header,
            command_unit,
        )
        from ...io.gantry_gains import entry as get
        from ...io.gantry_gains import section as sec

        check_header(doc, where, (AXIS_KIND,))
        fs, delay, preview = read_sampling(doc, where)
        unit = command_unit(doc)
        sos = {"controller": _sos(doc, "filters", "controller_sos", where)}
        for key in ("position_sos", "acceleration_sos", *_PREFILTER_KEYS):
            sos[key[:-4]] = _sos(doc, "reference", key, where)
        ff = sec(doc, "feedforward", where)
        mass = value(get(ff, "feedforward", "mass", where), f"{where}: feedforward.mass", f"{unit}/(m/s^2)")
        pre = sec(doc, "prefilter", where)
        gains = [value(get(pre, "prefilter", f"k_{t}", where), f"{where}: prefilter.k_{t}", PREFILTER_UNITS[t])
                 for t in PREFILTER_TERMS]
        return cls(sos=sos, mass=mass, prefilter_gains=gains, fs=fs, delay_samples=delay, preview_samples=preview,
                   controller=str(doc.get("controller", "loopshape")), command_unit=unit, source=where,
                   friction=axis_friction(doc, where), shaper=read_shaper_taps(doc, where))

    @classmethod
    def from_file(cls, path: str | os.PathLike[str]) -> AxisRuntime:
        """Read a ``.toml`` or ``.json`` axis gains file."""
        from ...io import read_document

        return cls.from_document(read_document(path), str(path))

    def reset(self) -> None:
        """Zero every filter state; the next sample is the first."""
        self.law.reset()
        self._reset_shaper()

    def step(self, x_ref_preview: float, x: float) -> float:
        """One sample: reference ``x_r[k + preview_samples]`` [m] and encoder ``x[k]`` [m] -> ``u_x`` [V]
        (:func:`feedtune.machines.gantry.law.axis_law_step`)."""
        return float(self._step(*self._args, self._shape_step(float(x_ref_preview)), float(x)))

    def previewed(self, x_ref) -> np.ndarray:
        """The sequence ``x_r[k + P]`` fed to :meth:`step` (holding the last value past the end), shaped by the
        ``[shaper]`` from rest when the file has one [m]."""
        return self.shape(_previewed(sample_vector(x_ref, "x_ref", min_size=1), self.preview_samples))

    def replay(self, x_ref, x) -> np.ndarray:
        """Commands [V] for a recorded reference ``x_r[k]`` and encoder ``x[k]`` [m], without a per-sample loop."""
        r = self.previewed(x_ref)
        xm = sample_vector(x, "x", r.size, min_size=1)
        ra = r.copy()
        if self._prefilter_on:
            for k, key in zip(self.prefilter_gains, _PREFILTER_KEYS, strict=True):
                ra = ra + k * sos_filter(self.sos[key[:-4]], r)
        e = sos_filter(self.sos["position"], ra) - xm
        return sos_filter(self.sos["controller"], e) + self.feedforward(x_ref)

    def feedforward(self, x_ref) -> np.ndarray:
        """The feedforward ``uff`` [command unit] per sample for a reference ``x_r[k]`` [m]: the mass times the
        acceleration filter of the previewed reference, plus the friction of its backward-difference velocity
        [m/s] when the file has a ``[friction_feedforward]``."""
        from ...control.friction import reference_velocity

        r = self.previewed(x_ref)
        uff = self.mass * sos_filter(self.sos["acceleration"], r)
        if self.friction is not None:
            uff = uff + self.friction.command(reference_velocity(r, self.fs))
        return uff

    def check_target(self, fs: float, where: str | None = None) -> None:
        """DataError unless the file was made for sample rate ``fs`` [Hz]."""
        _check_target(self.fs, fs, where or self.source)

    def to_dict(self) -> dict:
        """JSON-ready description."""
        return {
            "source": self.source,
            "kind": "axis",
            "controller": self.controller,
            "mass": self.mass,
            "prefilter_gains": dict(zip(("k_vel", "k_acc", "k_jerk", "k_snap"), self.prefilter_gains, strict=True)),
            "fs_hz": self.fs,
            "delay_samples": self.delay_samples,
            "preview_samples": self.preview_samples,
            "sections": {k: int(v.shape[0]) for k, v in self.sos.items()},
            "friction_feedforward": None if self.friction is None else self.friction.to_dict(),
            "shaper": None if self.shaper is None else self.shaper.to_dict(),
            "units": {"mass": f"{self.command_unit}/(m/s^2)", "k_vel": "s", "k_acc": "s^2", "k_jerk": "s^3",
                      "k_snap": "s^4", "fs_hz": "Hz", "command": self.command_unit},
        }
