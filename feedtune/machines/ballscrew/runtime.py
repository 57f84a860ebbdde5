"""Per-sample runtime of an exported ball-screw gains file, executed exactly as a real-time target would.

:class:`GainsRuntime` reads nothing but the gains document (``feedtune design ... --out gains.toml``): the
five gains, the sample rate, the preview, and the second-order sections of the filter pack and of the
three reference paths, and the optional input shaper (``[shaper]``), trajectory pre-filter (``[prefilter]``) and
friction feedforward (``[friction_feedforward]``). It never rebuilds the law from the stored model, so running it
proves that the export is complete. :meth:`GainsRuntime.step` executes the law of ``docs/gains.md`` once per sample::

    xs = shaper(x_r[k+P])                        (the shaper's taps; xs = x_r[k+P] without a [shaper])
    xp = xs + prefilter(xs)                      (xp = xs without a [prefilter])
    x1r = rotary(xp); x2r = table(xp); uff = feedforward(xp)
    v_r = (xp - xp_prev) fs (0 on the first sample); uff += friction(v_r)   (with a [friction_feedforward])
    e1 = x1r - x1[k]; e2 = x2r - x2[k]            (on the first sample e1_prev = e1, e2_prev = e2)
    de1 = (e1 - e1_prev) fs; de2 = (e2 - e2_prev) fs; ie2 += e2 / fs
    u = filter_pack(Kx1 e1 + Kx2 e2 + Kv1 de1 + Kv2 de2 + Ki2 ie2) + uff

Every ``*_sos`` list runs in cascade in transposed direct form II (as ``scipy.signal.sosfilt``), states
zero at start; each section is normalised by its ``a0`` when the file is read.

Fast path: the reference paths (pre-filter and friction feedforward included) do not depend on the
measurements, so :meth:`GainsRuntime.reference_signals`
computes them for a whole trajectory at once (``sosfilt``), and the closed-loop simulation of
:mod:`feedtune.machines.ballscrew.twin` runs only the feedback part per sample (:meth:`GainsRuntime.loop_constants`).
:meth:`GainsRuntime.replay` evaluates the law for recorded measurements without any per-sample loop.

Units: positions [rad] of screw rotation (table travel / ``lead_m_per_rad``), command in the drive's unit
(V), time [s].
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

import numpy as np

from ...control.ballscrew_law import GAIN_NAMES as GAIN_ORDER
from ...control.ballscrew_law import gain_units
from ...control.friction import FrictionFeedforward, reference_velocity
from ...control.shapers import SampledShaper, ShaperFilter
from ...control.sos import SosCascade
from ...errors import DataError
from ...io.gains import check_gains_header, friction_from_section, read_sampling, read_sos, value
from ...io.shaper_file import read_shaper_taps
from ...sim.engine import sample_vector
from .law import compiled_feedback, new_state

SOS_KEYS = {
    "filter_pack": ("filters", "filter_pack_sos"),
    "rotary": ("reference", "rotary_sos"),
    "table": ("reference", "table_sos"),
    "feedforward": ("reference", "feedforward_sos"),
}


# ------------------------------------------------------------------------------------------ reading
def _section(doc: dict, path: tuple[str, str], where: str):
    sec = doc.get(path[0])
    if not isinstance(sec, dict):
        raise DataError(f"{where}: gains file has no [{path[0]}] section")
    if path[1] not in sec:
        raise DataError(f"{where}: gains file has no {path[0]}.{path[1]}")
    return sec[path[1]]


# --------------------------------------------------------------------------------------------- runtime
@dataclass(frozen=True)
class LoopConstants:
    """What the per-sample feedback loop needs (for compiled simulation loops).

    Attributes
    ----------
    gains : ndarray, shape (5,)
        ``Kx1, Kx2, Kv1, Kv2, Ki2`` [V/rad, V/rad, V/(rad/s), V/(rad/s), V/(rad s)].
    filter_pack : ndarray, shape (n, 6)
        Normalised sections of the filter pack.
    fs : float
        Sample rate [Hz].
    delay_samples : int
        Computational delay the design assumed [samples].
    """

    gains: np.ndarray
    filter_pack: np.ndarray
    fs: float
    delay_samples: int


class GainsRuntime:
    """Executes a ball-screw gains document sample by sample (see the module docstring).

    Create it with :meth:`from_document` or :meth:`from_file`; call :meth:`reset` before a new run and
    :meth:`step` once per sample.

    Attributes
    ----------
    fs : float
        Sample rate [Hz].
    delay_samples : int
        Samples between sampling ``x1[k], x2[k]`` and applying ``u`` (assumed by the design).
    preview_samples : int
        ``P``: :meth:`step` expects the reference ``x_r[k+P]``.
    gains : dict
        ``Kx1`` [V/rad], ``Kx2`` [V/rad], ``Kv1`` [V/(rad/s)], ``Kv2`` [V/(rad/s)], ``Ki2`` [V/(rad s)].
    controller : str
        ``"mcppc"`` or ``"ppi"`` (information only).
    command_unit : str
        Unit of ``u`` (``"V"``).
    source : str
        File name or ``"gains document"``.
    friction : FrictionFeedforward or None
        Friction feedforward (``[friction_feedforward]``) [command unit, rad/s].
    prefilter_info : dict or None
        ``{"gains": {K_vel [s] .. K_snap [s^4]}, "lpf_hz": Hz}`` of the ``[prefilter]`` (information; the
        runtime executes ``sos["prefilter"]``, the sections of ``F(z) - 1``).
    shaper : SampledShaper or None
        The input shaper's taps (``[shaper]``), applied to the previewed reference first.
    """

    def __init__(self, gains: dict, sos: dict, fs: float, delay_samples: int, preview_samples: int,
                 controller: str = "", command_unit: str = "V", source: str = "gains document",
                 friction: FrictionFeedforward | None = None, prefilter_info: dict | None = None,
                 shaper: SampledShaper | None = None) -> None:
        self.shaper = shaper
        self._shaper = None if shaper is None else ShaperFilter(shaper)
        self.gains = {k: float(gains[k]) for k in GAIN_ORDER}
        self.sos = {k: np.asarray(v, float) for k, v in sos.items()}
        self.friction = friction
        self.prefilter_info = prefilter_info
        if friction is not None and friction.command_unit != command_unit:
            raise DataError(f"{source}: friction feedforward is in {friction.command_unit!r}, the command in "
                            f"{command_unit!r}")
        self.fs = float(fs)
        self.delay_samples = int(delay_samples)
        self.preview_samples = int(preview_samples)
        self.controller = controller
        self.command_unit = command_unit
        self.source = source
        self._filters = {k: SosCascade(v) for k, v in self.sos.items() if k != "filter_pack"}
        fp = self.sos["filter_pack"]
        self._fp = np.ascontiguousarray(fp / fp[:, 3:4]).ravel() if fp.size else np.zeros(0)
        self._nsec = int(fp.shape[0])
        self._g = np.array([self.gains[k] for k in GAIN_ORDER])
        self._st = new_state(self._nsec)
        self._feedback = compiled_feedback()
        self.reset()

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_document(cls, doc: dict, where: str = "gains document") -> GainsRuntime:
        """Read a gains document (dict from :func:`feedtune.io.read_document`).

        Raises
        ------
        DataError
            Not a ball-screw gains file of schema version 1, or a missing/invalid entry (named).
        """
        check_gains_header(doc, where)
        fs, delay, preview = read_sampling(doc, where)
        sec = doc.get("gains")
        if not isinstance(sec, dict):
            raise DataError(f"{where}: gains file has no [gains] section")
        unit = str(doc.get("units", {}).get("command", "V")) if isinstance(doc.get("units"), dict) else "V"
        units = gain_units(unit)
        gains = {}
        for n in GAIN_ORDER:
            if n not in sec:
                raise DataError(f"{where}: gains.{n} is missing")
            gains[n] = value(sec[n], f"{where}: gains.{n}", units[n])
        sos = {name: read_sos(_section(doc, path, where), f"{where}: {'.'.join(path)}")
               for name, path in SOS_KEYS.items()}
        info = None
        if doc.get("prefilter") is not None:
            sos["prefilter"] = read_sos(_section(doc, ("prefilter", "prefilter_sos"), where),
                                              f"{where}: prefilter.prefilter_sos")
            info = _prefilter_info(doc, where)
        friction = None
        if doc.get("friction_feedforward") is not None:
            friction = friction_from_section(doc["friction_feedforward"], unit, where)
        return cls(gains, sos, fs, delay, preview, str(doc.get("controller", "")), unit, where, friction, info,
                   read_shaper_taps(doc, where))

    @classmethod
    def from_file(cls, path: str | os.PathLike[str]) -> GainsRuntime:
        """Read a ``.toml`` or ``.json`` gains file."""
        from ...io import read_document

        return cls.from_document(read_document(path), str(path))

    # ------------------------------------------------------------------ per sample
    def reset(self) -> None:
        """Zero every filter state and the integrator; the next sample is the first."""
        for f in self._filters.values():
            f.reset()
        if self._shaper is not None:
            self._shaper.reset()
        self._st[:] = 0.0
        self._xp_prev = 0.0
        self._started = False

    def step(self, x_ref_preview: float, x1: float, x2: float) -> float:
        """One sample of the law (``docs/gains.md``).

        Parameters
        ----------
        x_ref_preview : float
            Reference ``x_r[k + preview_samples]`` [rad].
        x1, x2 : float
            Rotary and linear encoder readings at ``k`` [rad].

        Returns
        -------
        float
            Command ``u`` [V], to be applied ``delay_samples`` later.
        """
        f = self._filters
        xp = x_ref_preview if self._shaper is None else self._shaper.step(x_ref_preview)
        if "prefilter" in f:
            xp = xp + f["prefilter"].step(xp)
        x1r = f["rotary"].step(xp)
        x2r = f["table"].step(xp)
        uff = f["feedforward"].step(xp)
        if self.friction is not None:
            v_r = (xp - self._xp_prev) * self.fs if self._started else 0.0
            uff += float(self.friction.command(v_r))
        self._xp_prev = xp
        self._started = True
        ufb = self._feedback(self._st, self._g, self._fp, self._nsec, self.fs, float(x1r - x1), float(x2r - x2))
        return float(ufb) + uff

    # ------------------------------------------------------------------ vectorised helpers
    def previewed(self, x_ref) -> np.ndarray:
        """The sequence ``x_r[k + P]`` fed to :meth:`step` (holding the last value past the end), shaped by the
        ``[shaper]`` from rest when the file has one: ``xs`` of the module docstring [rad]."""
        x = sample_vector(x_ref, "x_ref", min_size=1)
        P = self.preview_samples
        p = x if P == 0 else np.r_[x[P:], np.full(min(P, x.size), x[-1])]
        return p if self.shaper is None else self.shaper.apply(p)

    def prefiltered(self, x_ref) -> np.ndarray:
        """The reference the paths run on: ``xp = xs + prefilter(xs)`` per sample [rad].

        Without a ``[prefilter]`` this is :meth:`previewed`.
        """
        from scipy.signal import sosfilt

        p = self.previewed(x_ref)
        return p + sosfilt(self.sos["prefilter"], p) if "prefilter" in self.sos else p

    def reference_signals(self, x_ref) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Rotary reference ``x1r`` [rad], table reference ``x2r`` [rad] and feedforward ``uff`` [V] per sample.

        ``uff`` includes the friction feedforward of the backward-difference velocity of the pre-filtered
        reference when the file has one.

        Parameters
        ----------
        x_ref : array_like, shape (n,)
            Reference ``x_r[k]`` [rad] for ``k = 0 .. n-1`` (the preview is taken from it).
        """
        from scipy.signal import sosfilt

        p = self.prefiltered(x_ref)
        uff = sosfilt(self.sos["feedforward"], p)
        if self.friction is not None:
            uff = uff + self.friction.command(reference_velocity(p, self.fs))
        return sosfilt(self.sos["rotary"], p), sosfilt(self.sos["table"], p), uff

    def replay(self, x_ref, x1, x2) -> np.ndarray:
        """The commands the law computes for recorded encoder readings, without a per-sample loop [V].

        Equals calling :meth:`reset` and then :meth:`step` for every sample.

        Parameters
        ----------
        x_ref : array_like, shape (n,)
            Reference ``x_r[k]`` [rad].
        x1, x2 : array_like, shape (n,)
            Encoder readings [rad].
        """
        from scipy.signal import sosfilt

        x1r, x2r, uff = self.reference_signals(x_ref)
        n = x1r.size
        e1 = x1r - sample_vector(x1, "x1", n, min_size=1)
        e2 = x2r - sample_vector(x2, "x2", n, min_size=1)
        de1 = np.diff(e1, prepend=e1[0]) * self.fs
        de2 = np.diff(e2, prepend=e2[0]) * self.fs
        ie2 = np.cumsum(e2 / self.fs)
        g = self.gains
        ufb = g["Kx1"] * e1 + g["Kx2"] * e2 + g["Kv1"] * de1 + g["Kv2"] * de2 + g["Ki2"] * ie2
        return sosfilt(self.sos["filter_pack"], ufb) + uff

    def loop_constants(self) -> LoopConstants:
        """Gains and filter-pack sections for a compiled feedback loop."""
        return LoopConstants(np.array([self.gains[k] for k in GAIN_ORDER]), self.sos["filter_pack"].copy(),
                             self.fs, self.delay_samples)

    def check_target(self, fs: float, where: str | None = None) -> None:
        """DataError unless the file was made for sample rate ``fs`` [Hz]."""
        if not math.isclose(self.fs, fs, rel_tol=1e-9):
            raise DataError(f"{where or self.source}: gains were designed for fs = {self.fs:g} Hz, "
                            f"but the target samples at {fs:g} Hz; design again with fs={fs:g}", parameter="fs")

    def to_dict(self) -> dict:
        """JSON-ready description (gains with units, sampling, section counts, pre-filter, friction)."""
        from ...control.prefilter import GAIN_UNITS as PREFILTER_UNITS

        pre = None
        if "prefilter" in self.sos:
            pre = {**(self.prefilter_info or {}), "sections": int(self.sos["prefilter"].shape[0]),
                   "units": {**PREFILTER_UNITS, "lpf_hz": "Hz"}}
        return {
            "source": self.source,
            "controller": self.controller,
            "gains": dict(self.gains),
            "fs_hz": self.fs,
            "delay_samples": self.delay_samples,
            "preview_samples": self.preview_samples,
            "sections": {k: int(v.shape[0]) for k, v in self.sos.items()},
            "prefilter": pre,
            "friction_feedforward": None if self.friction is None else self.friction.to_dict(),
            "shaper": None if self.shaper is None else self.shaper.to_dict(),
            "units": {**gain_units(self.command_unit), "fs_hz": "Hz", "command": self.command_unit},
        }


def _prefilter_info(doc: dict, where: str) -> dict | None:
    """Gains and low-pass of the ``[prefilter]`` (information), None when the section does not give them."""
    from ...io.gains import read_prefilter_gains

    sec = doc["prefilter"]
    if not isinstance(sec, dict) or "gains" not in sec:
        return None
    gains, lpf = read_prefilter_gains(doc, where)
    return {"gains": gains, "lpf_hz": lpf}


