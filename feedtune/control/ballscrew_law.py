"""The ball-screw control law shared by MC-PPC and P-PI, and its transfer functions.

Both controllers are implemented on the target by one law, executed every sample ``k``::

    x1r = R1(x_r)                    rotary reference (G_r for MC-PPC, identity for P-PI)
    e1 = x1r - x1,  e2 = x_r - x2    position errors [rad]
    de1, de2 = backward differences of e1, e2 divided by T        [rad/s]  (eq. 3.5)
    ie2 = ie2 + T * e2               backward-Euler integral of the table error [rad s]
    u_fb = Kx1 e1 + Kx2 e2 + Kv1 de1 + Kv2 de2 + Ki2 ie2           [V]
    u = G_fp(u_fb) + U_ff(x_r)       filter pack on the feedback, feedforward added after it [V]

In transfer-function form (continuous) ``u = U_ff x_r + K1 (R1 x_r - x1) + K2 (x_r - x2)`` with
``K1 = (Kx1 + Kv1 s) G_fp`` and ``K2 = (Kx2 + Kv2 s + Ki2 / s) G_fp`` (eq. 3.14). P-PI (Figure 3.9) with
``u = G_fp (Kpv + Kiv/s)(Kpx (x_r - x2) + s x_r - s x1) + U_ff x_r`` is the same law with
``Kx1 = Kiv, Kv1 = Kpv, Kx2 = Kpv Kpx, Kv2 = 0, Ki2 = Kiv Kpx`` and ``R1 = 1``.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..lti import Zpk
from .discretize import backward_difference, backward_euler_integrator, matched

GAIN_NAMES = ("Kx1", "Kx2", "Kv1", "Kv2", "Ki2")


def gain_units(command_unit: str = "V") -> dict[str, str]:
    """Units of ``Kx1, Kx2, Kv1, Kv2, Ki2`` for a drive commanded in ``command_unit`` (V, A, N, N*m, %): the
    law's positions are in rad of screw or motor rotation.

    Examples
    --------
    >>> gain_units("A")["Kv2"]
    'A/(rad/s)'
    """
    u = command_unit
    return {"Kx1": f"{u}/rad", "Kx2": f"{u}/rad", "Kv1": f"{u}/(rad/s)", "Kv2": f"{u}/(rad/s)",
            "Ki2": f"{u}/(rad s)"}


def pd_zpk(kp: float, kd: float, ki: float = 0.0) -> Zpk:
    """``kp + kd s + ki / s`` as a continuous Zpk."""
    if ki != 0.0:
        return Zpk.from_tf([kd, kp, ki], [1.0, 0.0])
    if kd == 0.0:
        return Zpk.constant(kp)
    return Zpk.from_tf([kd, kp], [1.0])


@dataclass(frozen=True)
class ReferencePath:
    """A reference filter in continuous form and its causal discrete implementation.

    ``discrete`` includes ``z^-preview`` so that, fed with ``x_r[k + preview]``, it realises the matched
    discretization of ``continuous`` without delay.
    """

    continuous: Zpk
    discrete: Zpk
    preview_samples: int

    def discrete_response(self, freq_hz) -> np.ndarray:
        """Response of the previewed discrete filter (delay compensated) on a grid [Hz]."""
        T = self.discrete.dt
        return self.discrete.freqresp(freq_hz) * np.exp(2j * np.pi * np.asarray(freq_hz) * T * self.preview_samples)


def reference_path(g: Zpk, fs: float, preview: int) -> ReferencePath:
    """Discretize a reference filter and delay it to a common preview of ``preview`` samples."""
    m = matched(g, fs)
    extra = preview - m.delay_samples
    d = m.tf
    if extra > 0:
        d = Zpk(d.zeros, np.r_[d.poles, np.zeros(extra)], d.gain, d.dt)
    return ReferencePath(g, d, preview)


def required_preview(filters: list[Zpk], fs: float) -> int:
    """Largest number of samples any of ``filters`` must look ahead after matched discretization."""
    return max([0, *[matched(g, fs).delay_samples for g in filters]])


@dataclass(frozen=True)
class BallScrewLaw:
    """Gains and filters of the shared ball-screw law (see module docstring).

    Parameters
    ----------
    gains : dict
        ``Kx1, Kx2, Kv1, Kv2, Ki2`` in U/rad, U/rad, U/(rad/s), U/(rad/s), U/(rad s) for a command in U
        (:func:`gain_units`).
    filter_pack : Zpk
        Continuous ``G_fp(s)``.
    rotary_reference : Zpk
        Continuous ``R1(s)`` (``G_r`` of eq. 3.12, or 1).
    feedforward : Zpk
        Continuous ``U_ff(s)`` from ``x_r`` [rad] to ``u`` [V] (``G_ff`` of eq. 3.13 or ``M s^2 + B s``).
    fs : float
        Sample rate [Hz].
    delay_samples : int
        Computational delay between sampling and applying ``u`` [samples].
    """

    gains: dict
    filter_pack: Zpk
    rotary_reference: Zpk
    feedforward: Zpk
    fs: float
    delay_samples: int = 1

    # ----------------------------------------------------------- continuous
    def K1(self) -> Zpk:
        """``(Kx1 + Kv1 s) G_fp`` acting on the rotary error."""
        g = self.gains
        return pd_zpk(g["Kx1"], g["Kv1"]) * self.filter_pack

    def K2(self) -> Zpk:
        """``(Kx2 + Kv2 s + Ki2 / s) G_fp`` acting on the table error."""
        g = self.gains
        return pd_zpk(g["Kx2"], g["Kv2"], g["Ki2"]) * self.filter_pack

    # ------------------------------------------------------------- discrete
    @property
    def T(self) -> float:
        """Sample time [s]."""
        return 1.0 / self.fs

    def filter_pack_discrete(self) -> Zpk:
        """Matched discretization of ``G_fp``."""
        return matched(self.filter_pack, self.fs).tf

    def K1d(self) -> Zpk:
        """Discrete ``(Kx1 + Kv1 (1 - z^-1)/T) G_fp(z)``."""
        return self._discrete_paths[0]

    def K2d(self) -> Zpk:
        """Discrete ``(Kx2 + Kv2 (1 - z^-1)/T + Ki2 T/(1 - z^-1)) G_fp(z)``."""
        return self._discrete_paths[1]

    @cached_property
    def _discrete_paths(self) -> tuple[Zpk, Zpk]:
        """``(K1d, K2d)``, computed once per law (a law is a value; searches and analyses evaluate them often)."""
        g = self.gains
        fp = self.filter_pack_discrete()
        diff = backward_difference(self.fs)
        k1 = _sum_zpk(Zpk.constant(g["Kx1"], self.T), diff * g["Kv1"]) * fp
        parts = [
            Zpk.constant(g["Kx2"], self.T),
            backward_difference(self.fs) * g["Kv2"],
            backward_euler_integrator(self.fs) * g["Ki2"],
        ]
        out = parts[0]
        for p in parts[1:]:
            out = _sum_zpk(out, p)
        return k1, out * fp

    @property
    def preview_samples(self) -> int:
        """Samples of reference look-ahead the discrete reference filters need."""
        return required_preview([self.rotary_reference, self.feedforward], self.fs)

    def reference_paths(self) -> dict[str, ReferencePath]:
        """Discrete rotary reference, feedforward and table reference with a common preview."""
        p = self.preview_samples
        return {
            "rotary": reference_path(self.rotary_reference, self.fs, p),
            "feedforward": reference_path(self.feedforward, self.fs, p),
            "table": reference_path(Zpk.constant(1.0), self.fs, p),
        }

    # --------------------------------------------------------------- notebooks
    def __repr__(self) -> str:
        from ..display import call, params, quantity

        fp = self.filter_pack
        return call("BallScrewLaw", [*params(self.gains, gain_units("U")), "U = command unit",
                                     f"filter pack {fp.poles.size} poles {fp.zeros.size} zeros",
                                     f"fs={quantity(self.fs, 'Hz')}", f"delay={self.delay_samples} sample(s)"])

    def plot(self, freq_hz=None, *, title: str | None = None):
        """``|K1|``, ``|K2|`` and their phase, continuous and discrete (:func:`feedtune.plotting.plot_law`)."""
        from ..display import facade

        return facade("plot_law")(self, freq_hz, title=title)

    def to_control(self, *, discrete: bool = False, delay: bool | None = None, form: str = "tf"):
        """The feedback ``u = [K1 K2] [e1; e2]`` as a python-control system (``discrete=True``: ``dt = 1/fs`` with
        the computational delay; ``form="ss"``: sections, accurate near ``z = 1``);
        :func:`feedtune.interop_control.law_to_control`."""
        from ..display import facade

        return facade("law_to_control")(self, discrete=discrete, delay=delay, form=form)


def _sum_zpk(a: Zpk, b: Zpk) -> Zpk:
    """Sum of two transfer functions with the same sample time (via polynomials)."""
    na, da = a.to_tf()
    nb, db = b.to_tf()
    num = np.polyadd(np.polymul(na, db), np.polymul(nb, da))
    den = np.polymul(da, db)
    if np.allclose(num, 0):
        return Zpk([], [], 0.0, a.dt)
    return Zpk.from_tf(num, den, a.dt)


def ppi_units(command_unit: str = "V") -> dict[str, str]:
    """Units of the P-PI gains ``Kpx, Kpv, Kiv`` for a drive commanded in ``command_unit``."""
    return {"Kpx": "1/s", "Kpv": f"{command_unit}/(rad/s)", "Kiv": f"{command_unit}/rad"}


def all_gain_units(command_unit: str = "V") -> dict[str, str]:
    """:func:`gain_units` and :func:`ppi_units` together (what a gains file of either controller can hold)."""
    return {**gain_units(command_unit), **ppi_units(command_unit)}
