"""Per-sample runtime of a cascade gains file (``kind = "cascade"``), executed as a drive executes it.

:class:`CascadeRuntime` reads nothing but the document (sampling, gains, the position loop's ratio and encoder, the
filters' sections) and runs :func:`feedtune.machines.cascade.law.cascade_step` once per speed-loop sample: the order
of ``[law].execution`` (docs/cascade.md). :meth:`CascadeRuntime.replay` computes the same commands for recorded
signals without a per-sample loop (the position loop on every ``N``-th sample with ``numpy``, the PI by a cumulative
sum, the filters by ``sosfilt``): a second implementation the per-sample law is checked against.

Units: positions in the axis' unit (rad or m), the command in the drive's (A, N m, V).
"""

from __future__ import annotations

import math
import os

import numpy as np

from ...control.sos import sos_filter
from ...errors import DataError
from ...sim.engine import sample_vector
from .law import CascadeLawData, cascade_step, compiled_step


class CascadeRuntime:
    """Executes a cascade gains document.

    Attributes
    ----------
    fs : float
        Speed-loop rate [Hz].
    position_ratio : int
        Speed samples per position-loop sample.
    delay_samples : int
        Computational delay the design assumed [samples]: the target applies each command that much later.
    preview_samples : int
        0: the position setpoint is read at the sample it is meant for.
    kp, tn_s, kv, kv_ff, inertia_ff : float
        The gains (``tn_s`` inf: no integral action).
    load_encoder : bool
        The position loop closes on the load encoder ``x2``.
    sos : ndarray, shape (n, 6)
        The current-setpoint filters' sections, normalised.
    command_unit, position_unit, source : str
    """

    preview_samples = 0

    def __init__(self, *, fs: float, position_ratio: int, delay_samples: int, kp: float, tn_s: float, kv: float,
                 kv_ff: float, inertia_ff: float, load_encoder: bool, sos, command_unit: str = "A",
                 position_unit: str = "rad", source: str = "gains document", engine: str = "auto") -> None:
        from ...sim.engine import choose_engine

        self.fs, self.position_ratio, self.delay_samples = float(fs), int(position_ratio), int(delay_samples)
        self.kp, self.tn_s, self.kv, self.kv_ff, self.inertia_ff = kp, tn_s, kv, kv_ff, inertia_ff
        self.load_encoder = bool(load_encoder)
        self.sos = np.array(sos, float).reshape(-1, 6)
        self.command_unit, self.position_unit, self.source = command_unit, position_unit, source
        self.law = CascadeLawData(self.fs, self.position_ratio, kp, tn_s, kv, kv_ff, inertia_ff, self.load_encoder,
                                  self.sos)
        self._step = compiled_step() if choose_engine(engine) == "numba" else cascade_step
        self._args = self.law.args()
        self.reset()

    @classmethod
    def from_document(cls, doc: dict, where: str = "gains document", engine: str = "auto") -> CascadeRuntime:
        """Read a cascade gains document; DataError names the missing or invalid entry."""
        from ...io.cascade_gains import cascade_from_document

        law, _, sos = cascade_from_document(doc, where)
        return cls(fs=law.fs, position_ratio=law.position_ratio, delay_samples=law.delay_samples, kp=law.kp,
                   tn_s=law.tn_s, kv=law.kv, kv_ff=law.kv_ff, inertia_ff=law.inertia_ff,
                   load_encoder=law.position_encoder == "load", sos=sos, command_unit=law.command_unit,
                   position_unit=law.position_unit, source=where, engine=engine)

    @classmethod
    def from_file(cls, path: str | os.PathLike[str]) -> CascadeRuntime:
        """Read a ``.toml`` or ``.json`` cascade gains file."""
        from ...io import read_document

        return cls.from_document(read_document(path), str(path))

    @property
    def fp(self) -> float:
        """Position-loop rate [Hz]."""
        return self.fs / self.position_ratio

    def reset(self) -> None:
        """Every state to rest; the next sample is the first (a position-loop sample)."""
        self.law.reset()

    def step(self, r: float, x1: float, x2: float | None = None) -> float:
        """One speed-loop sample: position setpoint ``r``, motor encoder ``x1``, load encoder ``x2`` (the motor's
        when None) [pos] -> the current setpoint [U]."""
        return float(self._step(*self._args, float(r), float(x1), float(x1 if x2 is None else x2)))

    def replay(self, r, x1, x2=None) -> np.ndarray:
        """The commands [U] for recorded setpoints ``r[k]`` and encoders ``x1[k]`` (``x2[k]``) [pos], without a
        per-sample loop (module docstring)."""
        rr = sample_vector(r, "r", min_size=1)
        n = rr.size
        a = sample_vector(x1, "x1", n, min_size=1)
        b = a if x2 is None else sample_vector(x2, "x2", n, min_size=1)
        N, fs, fp = self.position_ratio, self.fs, self.fp
        rp = rr[::N]
        xp = (b if self.load_encoder else a)[::N]
        vr = np.diff(rp, prepend=rp[0]) * fp
        ar = np.diff(vr, prepend=0.0) * fp
        w = np.repeat(self.kv * (rp - xp) + self.kv_ff * vr, N)[:n]
        iff = np.repeat(self.inertia_ff * ar, N)[:n]
        e = w - np.diff(a, prepend=a[0]) * fs
        integral = np.cumsum((0.0 if math.isinf(self.tn_s) else self.kp / (fs * self.tn_s)) * e)
        return sos_filter(self.sos, self.kp * e + integral + iff) if self.sos.size else self.kp * e + integral + iff

    def check_target(self, fs: float, where: str | None = None) -> None:
        """DataError unless the file was made for the speed-loop rate ``fs`` [Hz]."""
        if not math.isclose(self.fs, fs, rel_tol=1e-9):
            raise DataError(f"{where or self.source}: gains were designed for a speed loop at fs = {self.fs:g} Hz, "
                            f"but the target samples at {fs:g} Hz; design again with fs={fs:g}", parameter="fs")

    def to_dict(self) -> dict:
        """JSON-ready description."""
        u, p = self.command_unit, self.position_unit
        return {"source": self.source, "kind": "cascade", "fs_hz": self.fs, "position_fs_hz": self.fp,
                "position_ratio": self.position_ratio, "delay_samples": self.delay_samples, "Kp": self.kp,
                "Tn": None if math.isinf(self.tn_s) else self.tn_s, "Kv": self.kv, "kv_ff": self.kv_ff,
                "J_ff": self.inertia_ff, "position_encoder": "load" if self.load_encoder else "motor",
                "sections": int(self.sos.shape[0]),
                "units": {"Kp": f"{u}/({p}/s)", "Tn": "s", "Kv": "1/s", "J_ff": f"{u}/({p}/s^2)", "command": u,
                          "position": p}}


__all__ = ["CascadeRuntime"]
