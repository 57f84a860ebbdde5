"""Zeros-poles-gain transfer functions, continuous or discrete, evaluated vectorised on frequency grids.

A :class:`Zpk` is ``gain * prod(x - zeros) / prod(x - poles)`` with ``x = s`` (continuous, ``dt is None``)
or ``x = z`` (discrete with sample time ``dt`` [s]). Frequency responses are evaluated on a whole grid at
once, without a per-frequency Python loop.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .blas import blas_single_threaded
from .errors import UsageError


def _arr(x) -> np.ndarray:
    return np.atleast_1d(np.asarray(x, dtype=complex)).reshape(-1)


@dataclass(frozen=True)
class Zpk:
    """Transfer function in zeros-poles-gain form.

    Parameters
    ----------
    zeros, poles : array_like of complex
        Roots of numerator and denominator [rad/s for continuous; dimensionless z for discrete].
    gain : float
        Leading coefficient ratio (not the DC gain).
    dt : float or None
        Sample time [s] of a discrete transfer function, ``None`` for continuous.

    Examples
    --------
    >>> lpf = Zpk([], [-100.0], 100.0)
    >>> abs(lpf.dc_gain())
    1.0
    """

    zeros: np.ndarray
    poles: np.ndarray
    gain: float
    dt: float | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "zeros", _arr(self.zeros))
        object.__setattr__(self, "poles", _arr(self.poles))
        g = complex(self.gain)
        if abs(g.imag) > 1e-9 * max(1.0, abs(g.real)):
            raise UsageError(f"transfer function gain must be real, got {g}")
        object.__setattr__(self, "gain", float(g.real))
        if self.dt is not None and not self.dt > 0:
            raise UsageError(f"sample time must be > 0 s, got {self.dt}")

    # ------------------------------------------------------------ constructors
    @classmethod
    def constant(cls, k: float, dt: float | None = None) -> Zpk:
        """A static gain ``k``."""
        return cls([], [], k, dt)

    @classmethod
    def from_tf(cls, num, den, dt: float | None = None) -> Zpk:
        """From polynomial coefficients in descending powers."""
        num = np.trim_zeros(np.atleast_1d(np.asarray(num, float)), "f")
        den = np.trim_zeros(np.atleast_1d(np.asarray(den, float)), "f")
        if den.size == 0:
            raise UsageError("transfer function denominator is zero")
        if num.size == 0:
            return cls([], [], 0.0, dt)
        return cls(np.roots(num), np.roots(den), num[0] / den[0], dt)

    # -------------------------------------------------------------- arithmetic
    @property
    def is_discrete(self) -> bool:
        """True for a discrete-time transfer function."""
        return self.dt is not None

    def _check_dt(self, other: Zpk) -> None:
        if self.dt != other.dt:
            raise UsageError(f"cannot combine transfer functions with sample times {self.dt} and {other.dt}")

    def __mul__(self, other: Zpk | float) -> Zpk:
        if isinstance(other, Zpk):
            self._check_dt(other)
            return Zpk(np.r_[self.zeros, other.zeros], np.r_[self.poles, other.poles], self.gain * other.gain, self.dt)
        return Zpk(self.zeros, self.poles, self.gain * float(other), self.dt)

    __rmul__ = __mul__

    def inv(self) -> Zpk:
        """The inverse transfer function ``1 / self``."""
        if self.gain == 0:
            raise UsageError("cannot invert a zero transfer function")
        return Zpk(self.poles, self.zeros, 1.0 / self.gain, self.dt)

    @property
    def relative_degree(self) -> int:
        """Number of poles minus number of zeros."""
        return int(self.poles.size - self.zeros.size)

    # -------------------------------------------------------------- evaluation
    def variable(self, freq_hz) -> np.ndarray:
        """The complex variable ``s = j 2 pi f`` or ``z = exp(j 2 pi f dt)`` on a grid [Hz]."""
        f = np.asarray(freq_hz, dtype=float)
        if self.dt is None:
            return 2j * np.pi * f
        return np.exp(2j * np.pi * f * self.dt)

    def evaluate(self, x) -> np.ndarray:
        """Evaluate at complex points ``x`` (``s`` or ``z``), vectorised."""
        x = np.asarray(x, dtype=complex)
        n_roots = max(self.zeros.size, self.poles.size)
        if n_roots <= _BLOCK * 3 and x.size * n_roots <= _SMALL:  # few points (searches): two calls in all
            xr = x.reshape(1, -1)
            with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
                num = np.prod(xr - self.zeros[:, None], axis=0)
                return (self.gain * num / np.prod(xr - self.poles[:, None], axis=0)).reshape(x.shape)
        out = np.full(x.shape, self.gain, dtype=complex)
        num, den, tmp = np.empty_like(out), np.empty_like(out), np.empty_like(out)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            # loops over roots (a handful), not over frequencies; zeros and poles in blocks of _BLOCK, one complex
            # division per block (the products of a block stay far inside the float range)
            for k in range(0, max(self.zeros.size, self.poles.size), _BLOCK):
                for roots, acc in ((self.zeros[k:k + _BLOCK], num), (self.poles[k:k + _BLOCK], den)):
                    acc.fill(1.0)
                    for r in roots:
                        np.subtract(x, r, out=tmp)
                        acc *= tmp
                out *= num
                out /= den
        return out

    def freqresp(self, freq_hz) -> np.ndarray:
        """Complex frequency response on a grid [Hz]."""
        return self.evaluate(self.variable(freq_hz))

    def dc_gain(self) -> complex:
        """Gain at zero frequency (``s = 0`` or ``z = 1``); inf for integrators."""
        return complex(self.evaluate(np.array([0.0 if self.dt is None else 1.0]))[0])

    def is_stable(self) -> bool:
        """All poles strictly in the left half plane (continuous) or inside the unit circle (discrete)."""
        if self.poles.size == 0:
            return True
        if self.dt is None:
            return bool(np.all(self.poles.real < 0))
        return bool(np.all(np.abs(self.poles) < 1))

    # -------------------------------------------------------------- conversion
    def to_tf(self) -> tuple[np.ndarray, np.ndarray]:
        """Real polynomial coefficients ``(num, den)`` in descending powers."""
        num = (
            np.real_if_close(np.poly(self.zeros) * self.gain, tol=1e6).real
            if self.zeros.size
            else np.array([self.gain])
        )
        den = np.real_if_close(np.poly(self.poles), tol=1e6).real if self.poles.size else np.array([1.0])
        return np.atleast_1d(num).astype(float), np.atleast_1d(den).astype(float)

    def to_sos(self) -> np.ndarray:
        """Second-order sections ``[b0, b1, b2, 1, a1, a2]`` of a proper discrete transfer function.

        Each section is in powers of ``z**-1``. Improper discrete transfer functions must be made causal
        (extra poles at ``z = 0``) before conversion.
        """
        from scipy.signal import zpk2sos

        if self.dt is None:
            raise UsageError("second-order sections are for discrete transfer functions; discretize first")
        if self.zeros.size > self.poles.size:
            raise UsageError("transfer function is improper (more zeros than poles); add a delay first")
        n_delay = self.poles.size - self.zeros.size
        # zpk2sos needs as many zeros as poles: pad with zeros at z = 0 (factors z) and cancel them with
        # explicit delay sections z^-1, so the result equals the transfer function exactly
        sos = zpk2sos(np.r_[self.zeros, np.zeros(n_delay)], self.poles, self.gain, pairing="nearest")
        delays = [[0.0, 0.0, 1.0, 1.0, 0.0, 0.0]] * (n_delay // 2) + [[0.0, 1.0, 0.0, 1.0, 0.0, 0.0]] * (n_delay % 2)
        return np.vstack([sos, *delays]) if delays else sos

    def __repr__(self) -> str:
        kind = "continuous" if self.dt is None else f"dt={self.dt:g} s"
        return f"Zpk(zeros={np.round(self.zeros, 6)}, poles={np.round(self.poles, 6)}, gain={self.gain:g}, {kind})"


_BLOCK = 8
"""Roots multiplied together before one division in :meth:`Zpk.evaluate`."""
_SMALL = 1 << 12
"""Points times roots up to which :meth:`Zpk.evaluate` forms every factor at once."""


def sos_freqresp(sos: np.ndarray, freq_hz, fs: float) -> np.ndarray:
    """Frequency response of second-order sections at sample rate ``fs`` [Hz] on a grid [Hz]."""
    sos = np.atleast_2d(np.asarray(sos, float))
    z1 = np.exp(-2j * np.pi * np.asarray(freq_hz, float) / fs)  # z**-1
    h = np.ones(z1.shape, complex)
    for b0, b1, b2, a0, a1, a2 in sos:
        h *= (b0 + b1 * z1 + b2 * z1 * z1) / (a0 + a1 * z1 + a2 * z1 * z1)
    return h


def delay_response(freq_hz, n_samples: float, fs: float) -> np.ndarray:
    """Response of a delay of ``n_samples`` samples at ``fs`` [Hz]: ``exp(-j w n / fs)``."""
    return np.exp(-2j * np.pi * np.asarray(freq_hz, float) * n_samples / fs)


def zoh_response(freq_hz, fs: float) -> np.ndarray:
    """Zero-order hold ``(1 - exp(-s T)) / (s T)`` on a grid [Hz]; 1 at 0 Hz."""
    w_t = 2 * np.pi * np.asarray(freq_hz, float) / fs
    out = np.ones(w_t.shape, complex)
    nz = w_t != 0
    out[nz] = (1 - np.exp(-1j * w_t[nz])) / (1j * w_t[nz])
    return out


def zoh_double_integrator(mass: float, fs: float, freq_hz) -> np.ndarray:
    """Exact ZOH discretization of ``1/(m s^2)``: ``T^2 (z + 1) / (2 m (z - 1)^2)`` at ``z = e^{j w T}`` [m/V]."""
    T = 1.0 / fs
    z = np.exp(2j * np.pi * np.asarray(freq_hz, float) * T)
    return T * T * (z + 1) / (2 * mass * (z - 1) ** 2)


@blas_single_threaded
def zoh(A: np.ndarray, B: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
    """Exact discretization for inputs held over ``h`` [s]: ``expm([[A, B], [0, 0]] h)``."""
    from scipy.linalg import expm

    n, m = B.shape
    M = np.zeros((n + m, n + m))
    M[:n, :n] = A
    M[:n, n:] = B
    E = expm(M * h)
    return E[:n, :n], E[:n, n:]
