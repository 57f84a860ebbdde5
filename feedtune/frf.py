"""The :class:`Frf` value type: a measured or modelled frequency response function.

Conventions
-----------
* Frequencies in Hz, strictly increasing, finite, non-negative.
* ``response[i, j, n]`` is output ``i`` over input ``j`` at ``freq_hz[n]`` with the ``exp(+j w t)``
  convention (a pure delay ``T`` has phase ``-w T``).
* ``quantity`` says what the outputs measure: ``"position"``, ``"velocity"`` or ``"acceleration"``.
  :meth:`Frf.as_quantity` converts between them by powers of ``j w``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from .errors import DataError

QUANTITIES = ("position", "velocity", "acceleration")
_ORDER = {"position": 0, "velocity": 1, "acceleration": 2}


def normalize_quantity(name: str, where: str = "quantity") -> str:
    """Map user spellings (``pos``, ``vel``, ``acc``, ``displacement``...) to a canonical quantity."""
    key = str(name).strip().lower()
    aliases = {
        "position": "position",
        "pos": "position",
        "displacement": "position",
        "disp": "position",
        "velocity": "velocity",
        "vel": "velocity",
        "speed": "velocity",
        "acceleration": "acceleration",
        "acc": "acceleration",
        "accel": "acceleration",
    }
    if key not in aliases:
        raise DataError(f"{where}: unknown quantity {name!r}; expected position, velocity or acceleration")
    return aliases[key]

MAX_FREQ_HZ = 10e6
"""Highest frequency of an FRF [Hz]: the Nyquist frequency of the fastest drive sampling is far below."""


def check_frequency_grid(freq_hz: np.ndarray, where: str) -> np.ndarray:
    """Validate a frequency grid (1-D, at least 2 lines, finite, 0 .. :data:`MAX_FREQ_HZ`, strictly increasing);
    return it as float array."""
    f = np.asarray(freq_hz, dtype=float)
    if f.ndim != 1 or f.size < 2:
        raise DataError(f"{where}: frequency column must be a 1-D list of at least 2 frequencies, got "
                        f"{f.size if f.ndim == 1 else f.shape}")
    if not np.all(np.isfinite(f)):
        bad = int(np.flatnonzero(~np.isfinite(f))[0])
        raise DataError(f"{where}: frequency value at row {bad + 1} is not finite")
    if np.any(f < 0):
        raise DataError(f"{where}: frequencies must be >= 0 Hz")
    if np.any(f > MAX_FREQ_HZ):
        bad = int(np.flatnonzero(f > MAX_FREQ_HZ)[0])
        raise DataError(f"{where}: frequency {f[bad]:g} Hz at row {bad + 1} is above {MAX_FREQ_HZ / 1e6:g} MHz, "
                        "beyond any drive's FRF (a unit or a corrupt row?)")
    d = np.diff(f)
    if np.any(d <= 0):
        bad = int(np.flatnonzero(d <= 0)[0])
        kind = "duplicate" if d[bad] == 0 else "decreasing"
        raise DataError(
            f"{where}: frequencies must be strictly increasing; {kind} value {f[bad + 1]:g} Hz at row {bad + 2}"
        )
    return f


@dataclass(frozen=True)
class Frf:
    """Frequency response function of a multi-input multi-output system.

    Parameters
    ----------
    freq_hz : ndarray, shape (n_freq,)
        Frequency grid [Hz].
    response : ndarray of complex, shape (n_out, n_in, n_freq)
        Output over input, in ``output_unit / input_unit``.
    outputs, inputs : tuple of str
        Channel names, e.g. ``("x1", "x2")`` and ``("u",)``.
    quantity : str
        What the outputs measure: position, velocity or acceleration.
    coherence : ndarray, shape (n_out, n_in, n_freq), optional
        Magnitude-squared coherence [-] in 0..1.
    input_unit, output_unit : str
        Units of the input (e.g. ``"V"``) and of the position outputs (e.g. ``"rad"``, ``"m"``).
    meta : dict
        Free-form metadata (source file, comments).
    """

    freq_hz: np.ndarray
    response: np.ndarray
    outputs: tuple[str, ...]
    inputs: tuple[str, ...]
    quantity: str = "position"
    coherence: np.ndarray | None = None
    input_unit: str = "V"
    output_unit: str = "rad"
    meta: Mapping[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        where = str(self.meta.get("source", "FRF"))
        f = check_frequency_grid(self.freq_hz, where)
        h = np.asarray(self.response, dtype=complex)
        if h.ndim != 3 or h.shape[2] != f.size:
            raise DataError(f"{where}: response must have shape (n_out, n_in, {f.size}), got {h.shape}")
        if h.shape[:2] != (len(self.outputs), len(self.inputs)):
            raise DataError(f"{where}: response shape {h.shape[:2]} does not match channel names")
        if not np.all(np.isfinite(h)):
            raise DataError(f"{where}: response contains NaN or infinite values")
        coh = None
        if self.coherence is not None:
            coh = np.asarray(self.coherence, dtype=float)
            if coh.shape != h.shape:
                raise DataError(f"{where}: coherence shape {coh.shape} differs from response shape {h.shape}")
            with np.errstate(invalid="ignore"):
                bad = np.argwhere((coh < 0) | (coh > 1))
            if bad.size:
                o, i, k = (int(v) for v in bad[0])
                raise DataError(f"{where}: coherence {coh[o, i, k]:g} of {self.outputs[o]}/{self.inputs[i]} at "
                                f"{f[k]:g} Hz is outside 0..1")
        object.__setattr__(self, "freq_hz", f)
        object.__setattr__(self, "response", h)
        object.__setattr__(self, "outputs", tuple(self.outputs))
        object.__setattr__(self, "inputs", tuple(self.inputs))
        object.__setattr__(self, "quantity", normalize_quantity(self.quantity, where))
        object.__setattr__(self, "coherence", coh)
        object.__setattr__(self, "meta", dict(self.meta))

    # ------------------------------------------------------------------ access
    @property
    def source(self) -> str:
        """Where the data came from (file name) or ``"FRF"``."""
        return str(self.meta.get("source", "FRF"))

    @property
    def position_m(self) -> float | None:
        """Table position [m] the FRF was measured at (``meta["x_m"]``, written by the gantry twin and kept in FRF
        files), or None when it is not recorded or not a finite number."""
        raw = self.meta.get("x_m")
        try:
            x = float(raw)
        except (TypeError, ValueError):
            return None
        return x if math.isfinite(x) else None

    @property
    def channels(self) -> list[str]:
        """Channel names ``"OUT/IN"`` in row-major order."""
        return [f"{o}/{i}" for o in self.outputs for i in self.inputs]

    def index(self, channel: str) -> tuple[int, int]:
        """Return ``(i_out, i_in)`` of a channel named ``"OUT/IN"``."""
        try:
            out, inp = channel.split("/")
            return self.outputs.index(out), self.inputs.index(inp)
        except ValueError:
            raise DataError(f"{self.source}: no channel {channel!r}; available: {', '.join(self.channels)}") from None

    def has(self, channel: str) -> bool:
        """True if the channel ``"OUT/IN"`` exists."""
        out, _, inp = channel.partition("/")
        return out in self.outputs and inp in self.inputs

    def channel(self, channel: str) -> np.ndarray:
        """Complex response of one channel ``"OUT/IN"``."""
        i, j = self.index(channel)
        return self.response[i, j]

    def channel_coherence(self, channel: str) -> np.ndarray | None:
        """Coherence [-] of one channel, or None when not measured."""
        if self.coherence is None:
            return None
        i, j = self.index(channel)
        return self.coherence[i, j]

    # ------------------------------------------------------------- transforms
    def as_quantity(self, quantity: str) -> Frf:
        """Return the FRF converted to ``quantity`` (multiplying by ``(j w)**n``).

        Converting to a lower derivative order divides by ``j w`` and therefore needs ``freq_hz > 0``.
        """
        q = normalize_quantity(quantity)
        n = _ORDER[q] - _ORDER[self.quantity]
        if n == 0:
            return self
        if n < 0 and np.any(self.freq_hz <= 0):
            raise DataError(f"{self.source}: cannot convert {self.quantity} FRF to {q} at 0 Hz; drop that row")
        jw = 2j * np.pi * self.freq_hz
        return replace(self, response=self.response * jw**n, quantity=q)

    def select(self, lo_hz: float | None = None, hi_hz: float | None = None) -> Frf:
        """Return the part of the FRF with ``lo_hz <= f <= hi_hz``."""
        m = np.ones(self.freq_hz.size, bool)
        if lo_hz is not None:
            m &= self.freq_hz >= lo_hz
        if hi_hz is not None:
            m &= self.freq_hz <= hi_hz
        coh = None if self.coherence is None else self.coherence[..., m]
        return replace(self, freq_hz=self.freq_hz[m], response=self.response[..., m], coherence=coh)

    @classmethod
    def from_channels(
        cls,
        freq_hz: np.ndarray,
        channels: Mapping[str, np.ndarray],
        *,
        coherence: Mapping[str, np.ndarray] | None = None,
        quantity: str = "position",
        input_unit: str = "V",
        output_unit: str = "rad",
        meta: Mapping[str, str] | None = None,
        outputs: Sequence[str] | None = None,
        inputs: Sequence[str] | None = None,
    ) -> Frf:
        """Build an FRF from ``{"OUT/IN": complex array}``; missing channels of the grid are an error."""
        meta = dict(meta or {})
        where = meta.get("source", "FRF")
        names = []
        for name in channels:
            if name.count("/") != 1 or not all(name.split("/")):
                raise DataError(f"{where}: channel name {name!r} must look like OUT/IN, e.g. x2/u")
            names.append(name.split("/"))
        outs = list(outputs) if outputs else list(dict.fromkeys(o for o, _ in names))
        ins = list(inputs) if inputs else list(dict.fromkeys(i for _, i in names))
        f = np.asarray(freq_hz, dtype=float)
        h = np.zeros((len(outs), len(ins), f.size), complex)
        coh = np.full(h.shape, np.nan) if coherence else None
        have = set()
        for (o, i), (name, val) in zip(names, channels.items(), strict=True):
            h[outs.index(o), ins.index(i)] = np.asarray(val, complex)
            have.add((o, i))
            if coherence and name in coherence:
                coh[outs.index(o), ins.index(i)] = np.asarray(coherence[name], float)
        missing = [f"{o}/{i}" for o in outs for i in ins if (o, i) not in have]
        if missing:
            raise DataError(
                f"{where}: channel(s) {', '.join(missing)} missing to complete the {len(outs)}x{len(ins)} FRF matrix"
            )
        # channels without a coherence column keep NaN ("not measured")
        return cls(f, h, tuple(outs), tuple(ins), quantity, coh, input_unit, output_unit, meta)

    # --------------------------------------------------------------- notebooks
    def __repr__(self) -> str:
        from .display import call, frf_parts

        return call("Frf", frf_parts(self))

    def _repr_html_(self) -> str:
        from .display import frf_html

        return frf_html(self)

    def plot(self, channels: Sequence[str] | None = None, *, model=None, title: str | None = None):
        """Magnitude [dB], phase [deg] and coherence [-] per channel (``feedtune.report`` figure).

        Parameters
        ----------
        channels : sequence of str, optional
            Channels ``"OUT/IN"`` to draw (default all).
        model : object, optional
            A model with ``frf(freq_hz, quantity)`` (ball screw) or an :class:`Frf`, drawn dashed on this grid.
        title : str, optional
            Figure title (default the source).

        Returns
        -------
        matplotlib.figure.Figure
        """
        from .display import facade

        return facade("plot_frf")(self, channels, model=model, title=title)

    def to_dataframe(self):
        """A pandas DataFrame: index ``freq_hz`` [Hz], one complex column per channel ``OUT/IN`` [response unit],
        and ``coherence OUT/IN`` [-] columns when measured; units in ``attrs["units"]``."""
        import pandas as pd

        from .display import frf_unit

        data = {ch: self.channel(ch) for ch in self.channels}
        if self.coherence is not None:
            data.update({f"coherence {ch}": self.channel_coherence(ch) for ch in self.channels})
        frame = pd.DataFrame(data, index=pd.Index(self.freq_hz, name="freq_hz"))
        unit = frf_unit(self)
        frame.attrs["units"] = {"freq_hz": "Hz", **{ch: unit for ch in self.channels},
                                **{f"coherence {ch}": "-" for ch in self.channels}}
        frame.attrs["source"] = self.source
        return frame

    def to_control(self):
        """This FRF as a python-control ``FrequencyResponseData`` (frequencies in rad/s; needs ``control``).

        Examples
        --------
        >>> import numpy as np
        >>> f = Frf(np.array([1.0, 10.0]), np.ones((1, 1, 2)), ("x1",), ("u",))
        >>> f.to_control().omega.tolist() == (2 * np.pi * f.freq_hz).tolist()
        True
        """
        from .display import facade

        return facade("frf_to_control")(self)

    @classmethod
    def from_control(cls, sys, **kwargs) -> Frf:
        """An :class:`Frf` from a python-control system: a ``FrequencyResponseData`` on its own grid, or an LTI
        system evaluated on ``freq_hz`` (keyword, [Hz]); see :func:`feedtune.interop_control.frf_from_control`."""
        from .display import facade

        return facade("frf_from_control")(sys, **kwargs)
