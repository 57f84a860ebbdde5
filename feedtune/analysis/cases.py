"""The plant side of an analysis case, shared by every machine: what the controller acts on, at any frequency.

Every machine is analysed in four cases (thesis section 3.3): ``ideal`` (model, continuous controller),
``ideal_discrete`` (the model discretized exactly with a zero-order hold, discrete controller and computational
delay; its contour ends at ``fs / 2``), ``measured`` (FRF, continuous controller) and ``discrete`` (FRF, discrete
controller, hold and delay). A :class:`PlantCase` holds one case's plant as a function of frequency (models exactly,
FRFs by :func:`~feedtune.analysis.resolution.interpolate_frf`), what multiplies the controller besides the plant
(``hold``), the model that continues the loop below the FRF's band, and what the resolution needs (lightly damped
roots, measurement scatter). A machine's analysis combines it with its control law; the tuners evaluate candidates
on the same objects, so that they search with exactly the check they are judged by.
"""

from __future__ import annotations

import contextlib
import threading
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import numpy as np

from ..lti import delay_response
from .band_edge import BandEdge, continue_plant
from .resolution import LineNoise, interpolate_frf

CASES = ("ideal", "ideal_discrete", "measured", "discrete")
CHECKED_WITH_FRF = "discrete"
"""The case whose figures are held to the limits when an FRF is given: the measured plant with the controller as
the target runs it."""
CHECKED_WITHOUT_FRF = "ideal_discrete"
CASE_TITLES = {
    "ideal": "model, continuous controller",
    "ideal_discrete": "model (ZOH), discrete controller",
    "measured": "measured FRF, continuous controller",
    "discrete": "measured FRF, discrete controller + ZOH + delay",
}
"""The long title of each case beside its short name (:data:`CASES`): the report's tables and the command line's
summaries say the same."""


@dataclass(frozen=True)
class PlantCase:
    """The plant side of one analysis case.

    Attributes
    ----------
    name : str
        One of :data:`CASES`.
    freq_hz : ndarray
        Base grid [Hz]: the FRF's lines in the measured cases; the model grid, ending at ``fs / 2`` in
        ``ideal_discrete``.
    plant : callable
        ``plant(f)`` -> the plant on ``f`` [Hz], frequency on the last axis (machine-specific channels).
    model_plant : callable
        ``model_plant(f)`` -> the model's plant in the same layout (the loop below the grid, scaled to meet
        ``plant`` at the junction).
    discrete : bool
        The discrete controller acts (else the continuous one).
    hold : callable
        ``hold(f)`` -> what multiplies the controller besides the plant [-]: 1, the delay, or ZOH times delay.
    features : ndarray, shape (k, 2)
        Lightly damped roots (Hz, damping) of the plant's exact part.
    measured : bool
        ``plant`` interpolates an FRF between the lines ``freq_hz``.
    noise_db : ndarray, LineNoise or None
        Scatter [dB] of the measured plant on ``freq_hz`` (array-like; a
        :class:`~feedtune.analysis.resolution.LineNoise` computes it per line where the analysis reads it).
    disturbance : callable or None
        ``disturbance(f)`` -> the model's disturbance-input responses (machine-specific), model cases only.
    band_edge : BandEdge or None
        Measured cases: where the lines prove something and where the plant is continued by the model and its
        identified roll-off (:mod:`feedtune.analysis.band_edge`); ``freq_hz`` then holds the FRF's lines followed by
        the continuation up to ``fs / 2``.
    """

    name: str
    freq_hz: np.ndarray
    plant: Callable[[np.ndarray], np.ndarray]
    model_plant: Callable[[np.ndarray], np.ndarray]
    discrete: bool
    hold: Callable[[np.ndarray], np.ndarray]
    features: np.ndarray
    measured: bool = False
    noise_db: np.ndarray | LineNoise | None = None
    disturbance: Callable[[np.ndarray], np.ndarray] | None = None
    band_edge: BandEdge | None = None

    @property
    def lines_top_hz(self) -> float:
        """The FRF's last line in a measured case, the grid's top in a model case [Hz]."""
        return float(self.band_edge.last_line_hz) if self.band_edge is not None else float(self.freq_hz[-1])


_LOCAL = threading.local()
SHARED_MIN_POINTS = 256
"""Grids at least this long keep their ``z`` inside :func:`analysis_scope`."""
SHARED_GRIDS = 3
"""How many grids keep their ``z`` at a time (the last asked for)."""


def _scope() -> dict:
    st = getattr(_LOCAL, "scope", None)
    if st is None:
        st = _LOCAL.scope = {"depth": 0, "circles": [], "work": {}}
    return st


@contextlib.contextmanager
def analysis_scope() -> Iterator[None]:
    """Inside the block (per thread), :func:`unit_circle` keeps ``z`` of the last :data:`SHARED_GRIDS` grids it was
    asked for (the plant, the hold and the controller of a case share one) and :func:`work_array` hands out the same
    work arrays again; both are released when the outermost block ends."""
    st = _scope()
    st["depth"] += 1
    try:
        yield
    finally:
        st["depth"] -= 1
        if not st["depth"]:
            st["circles"] = []
            st["work"] = {}


def release_shared(grids: bool = True, work: bool = True) -> None:
    """Inside :func:`analysis_scope`, forget the shared ``z`` and ``s`` grids and (or) the work arrays: an analysis
    that is done with them, before it goes on (their memory is then free for what follows)."""
    st = _scope()
    if st["depth"]:
        if grids:
            st["circles"] = []
        if work:
            st["work"] = {}


def work_array(n: int, slot: int) -> np.ndarray:
    """A complex work array of ``n`` elements (contents undefined); inside :func:`analysis_scope` the same memory for
    the same ``slot`` each time (a view of one buffer, grown to the largest ``n``), outside a new array."""
    st = _scope()
    if not st["depth"]:
        return np.empty(n, complex)
    buf = st["work"].get(slot)
    if buf is None or buf.size < n:
        buf = st["work"][slot] = np.empty(n, complex)
    return buf[:n]


def same_lines(a: np.ndarray, b: np.ndarray) -> bool:
    """The 1-d float arrays ``a`` and ``b`` hold the same values, bit for bit (one array, or equal lines)."""
    if a is b:
        return True
    if (a.shape != b.shape or a.ndim != 1 or a.dtype != np.float64 or b.dtype != np.float64
            or not (a.flags.c_contiguous and b.flags.c_contiguous)):
        return False
    if a.size and not (a[0] == b[0] and a[-1] == b[-1]):  # most other grids differ at an end
        return False
    return bool(np.array_equal(a.view(np.int64), b.view(np.int64)))


def _shared(f: np.ndarray, fs: float | None, make: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
    """``make(f)``, inside :func:`analysis_scope` kept for the grid array ``f`` (and ``fs``) and returned again; for a
    grid whose lines are the first lines of a kept one (``ideal_discrete``'s grid closed at ``fs / 2`` and FRF lines
    equal to it below), the first values of the kept result (``make`` works element by element: the same bits)."""
    st = _scope()
    share = st["depth"] > 0 and f.size >= SHARED_MIN_POINTS
    if share:
        for g, r, z in st["circles"]:
            if g is f and r == fs:
                return z
        for g, r, z in st["circles"]:
            if r == fs and g.ndim == 1 and g.size >= f.size and same_lines(g[:f.size], f):
                st["circles"] = [(f, fs, z[:f.size]), *st["circles"]]  # a view: found at once next time
                return st["circles"][0][2]
    z = make(f)
    if share:
        st["circles"] = [(f, fs, z), *st["circles"][:SHARED_GRIDS - 1]]
    return z


def unit_circle(freq_hz, fs: float) -> np.ndarray:
    """``z = exp(j 2 pi f / fs)`` on a grid [Hz], by cosine and sine (faster than the complex exponential).

    Inside :func:`analysis_scope` the result for the same grid array (and rate) is returned again: do not modify it.
    """

    def make(f):
        w = (2 * np.pi / fs) * f
        z = np.empty(w.shape, complex)
        np.cos(w, out=z.real)
        np.sin(w, out=z.imag)
        return z

    return _shared(np.asarray(freq_hz, float), float(fs), make)


def imaginary_axis(freq_hz) -> np.ndarray:
    """``s = j 2 pi f`` [rad/s] on a grid [Hz] (complex). Inside :func:`analysis_scope` the result for the same grid
    array is returned again (the plant and the controller of a case share it): do not modify it."""
    return _shared(np.asarray(freq_hz, float), None, lambda f: 2j * np.pi * f)


def delay_on_circle(freq_hz, n_samples: float, fs: float) -> np.ndarray:
    """A delay of ``n_samples`` samples at ``fs`` [Hz]: ``z^-n`` (as :func:`feedtune.lti.delay_response`)."""
    n = float(n_samples)
    if n != int(n) or not 0 <= n <= 64:
        return delay_response(freq_hz, n_samples, fs)
    zc = np.conj(unit_circle(freq_hz, fs))
    if n == 1:
        return zc
    out = zc.copy() if n >= 1 else np.ones(zc.shape, complex)
    for _ in range(int(n) - 1):
        out *= zc
    return out


def zoh_on_circle(freq_hz, fs: float) -> np.ndarray:
    """Zero-order hold ``(1 - z^-1) / (j w T)`` on a grid [Hz], 1 at 0 Hz (as :func:`feedtune.lti.zoh_response`)."""
    f = np.asarray(freq_hz, float)
    z = unit_circle(f, fs)
    r = (2 * np.pi / fs) * f  # w T, then 1 / (w T)
    nz = r != 0
    out = np.empty(z.shape, complex)
    with np.errstate(divide="ignore", invalid="ignore"):
        np.divide(1.0, r, out=r)
        # (1 - conj z) (-j / (w T)) = (sin / (w T), -(1 - cos) / (w T)): the complex product's terms, bit for bit
        np.multiply(z.imag, r, out=out.real)
        np.subtract(1.0, z.real, out=out.imag)
        out.imag *= r
    np.negative(out.imag, out=out.imag)
    out[~nz] = 1.0
    return out


def _one(f):
    return np.ones(np.shape(f))


_one.identity = True  # the analyses skip multiplying by it


def discrete_grid(freq_hz: np.ndarray, fs: float) -> np.ndarray:
    """The grid below ``fs / 2`` closed at ``fs / 2`` [Hz] (a z-domain contour)."""
    f = np.asarray(freq_hz, float)
    return np.concatenate((f[f < fs / 2], [fs / 2]))


def model_cases(freq_hz: np.ndarray, fs: float, delay_samples: float, *, model_plant, zoh_plant, features,
                disturbance=None, zoh_disturbance=None) -> dict[str, PlantCase]:
    """``ideal`` and ``ideal_discrete`` of a model.

    Parameters
    ----------
    freq_hz : ndarray
        Base grid of the model cases [Hz].
    fs : float
        Controller sample rate [Hz].
    delay_samples : float
        Computational delay [samples].
    model_plant, zoh_plant : callable
        The continuous model and its exact ZOH discretization (at ``z = exp(j w / fs)``) as functions of frequency.
    features : ndarray, shape (k, 2)
        Lightly damped roots of the model (Hz, damping).
    disturbance, zoh_disturbance : callable, optional
        The disturbance-input responses, continuous and ZOH-discretized.
    """

    def delay(fr):
        return delay_on_circle(fr, delay_samples, fs)

    def model_zoh(fr):
        return model_plant(fr) * zoh_on_circle(fr, fs)

    return {
        "ideal": PlantCase("ideal", np.asarray(freq_hz, float), model_plant, model_plant, False, _one, features,
                           disturbance=disturbance),
        "ideal_discrete": PlantCase("ideal_discrete", discrete_grid(freq_hz, fs), zoh_plant, model_zoh, True, delay,
                                    features, disturbance=zoh_disturbance),
    }


def measured_cases(lines_hz: np.ndarray, response: np.ndarray, fs: float, delay_samples: float, *, model_plant,
                   coherence: np.ndarray | None = None, averages: float | None = None, features=None,
                   channels: tuple | None = None) -> dict[str, PlantCase]:
    """``measured`` and ``discrete`` of an FRF, its plant continued where its lines prove nothing
    (:func:`~feedtune.analysis.band_edge.continue_plant`).

    Parameters
    ----------
    lines_hz : ndarray
        The FRF's lines [Hz] (> 0).
    response : ndarray
        The measured plant on the lines, in the machine's layout (frequency last).
    fs : float
        Controller sample rate [Hz].
    delay_samples : float
        Computational delay [samples].
    model_plant : callable
        The model in the same layout, for the loop below the FRF's band and its continuation above it.
    coherence : ndarray, optional
        Coherence of the measured channels (same shape as ``response``), for the scatter estimate.
    averages : float, optional
        Averages of the estimate (:func:`~feedtune.frf_quality.averages_of` of the FRF's metadata).
    features : ndarray, shape (k, 2), optional
        Lightly damped roots of the model (Hz, damping): the continuation is resolved around them.
    channels : tuple of str, optional
        The channels' names (for what the verdict says it assumes).
    """
    f, plant_values, coh, edge = continue_plant(lines_hz, response, model_plant, fs, coherence=coherence,
                                                averages=averages, features=features, channels=channels)
    plant = interpolate_frf(f, plant_values)
    noise = LineNoise(f, plant_values, coh, averages=averages)
    none = np.empty((0, 2))

    def zoh_delay(fr):
        out = zoh_on_circle(fr, fs)
        out *= delay_on_circle(fr, delay_samples, fs)
        return out

    return {
        "measured": PlantCase("measured", f, plant, model_plant, False, _one, none, True, noise, band_edge=edge),
        "discrete": PlantCase("discrete", f, plant, model_plant, True, zoh_delay, none, True, noise, band_edge=edge),
    }
