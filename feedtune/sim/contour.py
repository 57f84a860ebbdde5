"""x-y contouring paths with exact derivatives: circles and diamonds at a feed limit (thesis §4.5, Fig. 4.20-4.22).

A path is a closed planar curve ``p(s)`` parametrised by its arc length ``s`` [m] and traversed with the
jerk-limited (or snap-limited) profile ``s(t)`` of :mod:`feedtune.sim.trajectory`, so the feed ``|p'(t)| =
s'(t)`` never exceeds ``v_max`` and the tangential acceleration, jerk (and snap) stay within their limits.
The axis references and their derivatives follow exactly from the chain rule:

* **circle** of diameter ``D`` (``R = D/2``), started at its rightmost point and run counter-clockwise
  (or clockwise): ``p = c + R e^{i theta}``, ``theta = +-s/R``; with ``g = i theta``,
  ``p' = p_r g'``, ``p'' = p_r (g'' + g'^2)``, ``p''' = p_r (g''' + 3 g' g'' + g'^3)``,
  ``p'''' = p_r (g'''' + 4 g' g''' + 3 g''^2 + 6 g'^2 g'' + g'^4)`` (``p_r = R e^{i theta}``, Faa di Bruno).
  One point-to-point move over the circumference ``pi D``: the feed is continuous around the circle and
  the axes see the centripetal acceleration ``s'^2 / R`` on top of the tangential limits.
* **diamond** (a square turned by 45 degrees) of side ``a``, started at its lowest vertex and run
  counter-clockwise (or clockwise): one rest-to-rest move per side (``multi_segment`` over the arc lengths
  ``0, a, 2a, 3a, 4a``), so the path stops at every corner and every derivative stays finite.

The thesis's tests (§4.5): 1 um features at 1 um/s (2.6 um/s^2, 10 um/s^3), 1 mm at 1 mm/s (2.6 mm/s^2,
10 mm/s^3) and 200 mm at 200 mm/s (2 m/s^2, 50 m/s^3); the circle's size is its diameter, the diamond's its
side length. :data:`THESIS_FEATURES` holds them.

The contour error of a measured ``(x, y)`` against the path (:meth:`ContourPath.contour_error`) is the
signed normal distance, positive to the left of the direction of travel (inside a counter-clockwise
contour), as :func:`feedtune.analysis.metrics.contour_error`: exactly ``R - |p - c|`` for a circle
(``|p - c| - R`` clockwise), and the distance to the four sides for a diamond.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import UsageError
from ..log import Log
from .trajectory import Trajectory, multi_segment, point_to_point

SHAPES = ("circle", "diamond")
CIRCLE_SECTORS = 3600
"""The circle's contour error reports the nearest of this many equal sectors as its ``segment``."""

THESIS_FEATURES = {
    "1um": {"size_m": 1e-6, "v_max": 1e-6, "a_max": 2.6e-6, "j_max": 10e-6},
    "1mm": {"size_m": 1e-3, "v_max": 1e-3, "a_max": 2.6e-3, "j_max": 10e-3},
    "200mm": {"size_m": 0.2, "v_max": 0.2, "a_max": 2.0, "j_max": 50.0},
}
"""Feature size [m] and feed limits [m/s, m/s^2, m/s^3] of the contouring tests of §4.5."""


@dataclass(frozen=True, eq=False)
class ContourPath:
    """A sampled x-y contour with exact derivatives on both axes.

    Attributes
    ----------
    shape : str
        ``"circle"`` or ``"diamond"``.
    size_m : float
        Circle diameter or diamond side [m].
    clockwise : bool
        Direction of travel.
    x, y : Trajectory
        Axis references with exact velocity, acceleration, jerk and snap [m, m/s, ...].
    path : Trajectory
        The arc-length profile ``s(t)`` [m] and its derivatives (``path.vel`` is the feed [m/s]).
    vertices : ndarray, shape (m, 2)
        Diamond: its 5 corners (closed). Circle: ``[[centre_x, centre_y]]`` [m].
    """

    shape: str
    size_m: float
    clockwise: bool
    x: Trajectory
    y: Trajectory
    path: Trajectory
    vertices: np.ndarray

    @property
    def t(self) -> np.ndarray:
        """Time [s]."""
        return self.x.t

    @property
    def fs(self) -> float:
        """Sample rate [Hz]."""
        return self.x.fs

    @property
    def feed(self) -> np.ndarray:
        """Speed along the path ``|p'(t)|`` [m/s] from the axis velocities."""
        return np.hypot(self.x.vel, self.y.vel)

    @property
    def radius(self) -> float:
        """Circle radius [m] (NaN for a diamond)."""
        return self.size_m / 2 if self.shape == "circle" else float("nan")

    @property
    def centre(self) -> tuple[float, float]:
        """Circle centre [m] (the diamond's centre for a diamond)."""
        if self.shape == "circle":
            return float(self.vertices[0, 0]), float(self.vertices[0, 1])
        v = self.vertices[:4]
        return float(v[:, 0].mean()), float(v[:, 1].mean())

    def contour_error(self, x, y):
        """Signed normal distance of ``(x, y)`` [m] from the path (positive to the left of travel).

        Returns
        -------
        ContourError
            Circle: ``R - |p - c|`` (counter-clockwise; negated clockwise), ``segment`` the nearest of
            :data:`CIRCLE_SECTORS` equal sectors. Diamond: :func:`~feedtune.analysis.metrics.contour_error`
            on the 5 corners (exact for straight sides).
        """
        from ..analysis.metrics import ContourError, contour_error

        if self.shape == "diamond":
            return contour_error(self.vertices[:, 0], self.vertices[:, 1], x, y)
        px = np.asarray(x, float) - self.vertices[0, 0]
        py = np.asarray(y, float) - self.vertices[0, 1]
        d = self.radius - np.hypot(px, py)
        angle = np.mod(np.arctan2(py, px), 2 * np.pi)
        sector = np.minimum((angle / (2 * np.pi) * CIRCLE_SECTORS).astype(np.intp), CIRCLE_SECTORS - 1)
        return ContourError(distance=-d if self.clockwise else d, segment=sector)

    def to_log(self) -> Log:
        """References as a log: ``x_ref, v_ref, a_ref, j_ref, s_ref`` and ``y_ref, vy_ref, ...``, ``feed``."""
        lx = self.x.to_log("x_ref")
        ly = self.y.to_log("y_ref")
        meta = {"source": f"{self.shape} contour, size {self.size_m:g} m", "shape": self.shape,
                "size_m": self.size_m, "clockwise": int(self.clockwise)}
        units = {**lx.units, **ly.units, "feed": "m/s"}
        return Log(self.t, {**lx.signals, **ly.signals, "feed": self.path.vel}, units, meta)

    def to_dict(self) -> dict:
        """Summary: shape, size, duration, feed, peak axis velocities and accelerations (units in keys)."""
        out = {"shape": self.shape, "size_m": self.size_m, "clockwise": self.clockwise,
               "duration_s": self.x.duration, "n_samples": self.x.n, "fs_hz": self.fs,
               "feed_max_m_per_s": float(np.max(np.abs(self.path.vel))),
               "limits": {k: v for k, v in self.path.limits.items()},
               "x_peaks": self.x.peaks(), "y_peaks": self.y.peaks()}
        if self.shape == "circle":
            out["radius_m"] = self.radius
            out["centripetal_acc_max_m_per_s2"] = float(np.max(self.path.vel**2) / self.radius)
        out["units"] = {"limits": {"v_max": "m/s", "a_max": "m/s^2", "j_max": "m/s^3", "s_max": "m/s^4"},
                        "x_peaks": "m/s, m/s^2, m/s^3, m/s^4", "y_peaks": "m/s, m/s^2, m/s^3, m/s^4"}
        return out


# ------------------------------------------------------------------------------------------ helpers
def _size(value, name: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise UsageError(f"{name} must be a number [m], got {value!r}") from None
    if not (math.isfinite(v) and v > 0):
        raise UsageError(f"{name} must be finite and > 0 [m], got {value!r}")
    return v


def _start(start) -> tuple[float, float]:
    try:
        x0, y0 = (float(v) for v in start)
    except (TypeError, ValueError):
        raise UsageError(f"start must be (x, y) in m, got {start!r}") from None
    if not (math.isfinite(x0) and math.isfinite(y0)):
        raise UsageError(f"start must be finite, got {start!r}")
    return x0, y0


def _axis(t: np.ndarray, derivs: list[np.ndarray], limits: dict, fs: float) -> Trajectory:
    return Trajectory(t, *derivs, limits=limits, sample_rate=fs)


def _circle_axes(s: Trajectory, radius: float, centre: tuple[float, float], sign: float
                 ) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Derivatives 0..4 of ``x`` and ``y`` on the circle for the arc-length profile ``s`` (Faa di Bruno)."""
    th = sign * s.pos / radius
    g1, g2, g3, g4 = (sign * d / radius for d in (s.vel, s.acc, s.jerk, s.snap))
    pr = radius * np.exp(1j * th)
    derivs = [
        pr + complex(*centre),
        pr * (1j * g1),
        pr * (1j * g2 - g1**2),
        pr * (1j * g3 - 3 * g1 * g2 - 1j * g1**3),
        pr * (1j * g4 - 4 * g1 * g3 - 3 * g2**2 - 6j * g1**2 * g2 + g1**4),
    ]
    return [d.real for d in derivs], [d.imag for d in derivs]


def _diamond_axes(s: Trajectory, side: float, corners: np.ndarray
                  ) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Derivatives 0..4 of ``x`` and ``y`` along the four straight sides for the profile ``s``."""
    starts = np.array([m.t_start for m in s.moves])
    k = np.clip(np.searchsorted(starts, s.t, side="right") - 1, 0, 3)
    direction = (corners[1:] - corners[:-1]) / side  # unit vectors of the sides
    along = s.pos - k * side
    dx, dy = direction[k, 0], direction[k, 1]
    xs = [corners[k, 0] + dx * along] + [dx * d for d in (s.vel, s.acc, s.jerk, s.snap)]
    ys = [corners[k, 1] + dy * along] + [dy * d for d in (s.vel, s.acc, s.jerk, s.snap)]
    return xs, ys


# ------------------------------------------------------------------------------------------ generators
def circle(diameter: float, *, v_max: float, a_max: float, j_max: float, s_max: float | None = None,
           fs: float = 15000.0, start=(0.0, 0.0), clockwise: bool = False, dwell_before: float = 0.0,
           dwell_after: float = 0.0) -> ContourPath:
    """A full circle of ``diameter`` [m] from ``start`` (its rightmost point) at the feed limit ``v_max``.

    Parameters
    ----------
    diameter : float
        Circle diameter [m].
    v_max, a_max, j_max : float
        Feed [m/s], tangential acceleration [m/s^2] and jerk [m/s^3] limits along the path.
    s_max : float, optional
        Snap limit [m/s^4] (jerk-continuous profile).
    fs : float
        Sample rate [Hz].
    start : (float, float)
        Start (and end) point [m]; the centre is ``diameter / 2`` to its left.
    clockwise : bool
        Direction of travel.
    dwell_before, dwell_after : float
        Rest at the start point before and after [s].

    Returns
    -------
    ContourPath
    """
    d = _size(diameter, "circle diameter")
    x0, y0 = _start(start)
    radius = d / 2
    s = point_to_point(math.pi * d, v_max=v_max, a_max=a_max, j_max=j_max, s_max=s_max, fs=fs,
                       dwell_before=dwell_before, dwell_after=dwell_after)
    centre = (x0 - radius, y0)
    xs, ys = _circle_axes(s, radius, centre, -1.0 if clockwise else 1.0)
    return ContourPath("circle", d, bool(clockwise), _axis(s.t, xs, s.limits, s.fs), _axis(s.t, ys, s.limits, s.fs),
                       s, np.array([centre]))


def diamond(side: float, *, v_max: float, a_max: float, j_max: float, s_max: float | None = None,
            fs: float = 15000.0, start=(0.0, 0.0), clockwise: bool = False, dwell_before: float = 0.0,
            dwell_after: float = 0.0) -> ContourPath:
    """A diamond (square turned 45 degrees) of ``side`` [m] from ``start`` (its lowest corner).

    Each side is a rest-to-rest move under the limits (see :func:`circle` for the parameters), so the tool
    stops at every corner.

    Returns
    -------
    ContourPath
        ``vertices`` are the 5 corners (the first repeated at the end).
    """
    a = _size(side, "diamond side")
    x0, y0 = _start(start)
    h = a / math.sqrt(2)
    sx = -1.0 if clockwise else 1.0
    corners = np.array([[x0, y0], [x0 + sx * h, y0 + h], [x0, y0 + 2 * h], [x0 - sx * h, y0 + h], [x0, y0]])
    s = multi_segment([0.0, a, 2 * a, 3 * a, 4 * a], v_max=v_max, a_max=a_max, j_max=j_max, s_max=s_max, fs=fs)
    if dwell_before > 0 or dwell_after > 0:
        s = _with_dwells(s, fs, dwell_before, dwell_after)
    xs, ys = _diamond_axes(s, a, corners)
    return ContourPath("diamond", a, bool(clockwise), _axis(s.t, xs, s.limits, s.fs), _axis(s.t, ys, s.limits, s.fs),
                       s, corners)


def _with_dwells(s: Trajectory, fs: float, before: float, after: float) -> Trajectory:
    """``s`` with rest samples added before and after (moves shifted by the leading dwell)."""
    from dataclasses import replace

    if before < 0 or after < 0 or not (math.isfinite(before) and math.isfinite(after)):
        raise UsageError(f"dwells must be finite and >= 0 s, got {before!r}, {after!r}")
    n0, n1 = round(before * fs), round(after * fs)
    pad = [np.r_[np.full(n0, a[0]), a, np.full(n1, a[-1])] for a in (s.pos, s.vel, s.acc, s.jerk, s.snap)]
    for a in pad[1:]:
        a[:n0] = 0.0
        a[a.size - n1:] = 0.0
    t = np.arange(pad[0].size) / fs
    shift = n0 / fs
    moves = tuple(replace(m, t_start=m.t_start + shift, t_end=m.t_end + shift) for m in s.moves)
    return Trajectory(t, *pad, limits=s.limits, sample_rate=fs, moves=moves)


def contour_path(shape: str, size_m: float, **kwargs) -> ContourPath:
    """:func:`circle` or :func:`diamond` by name (``shape`` in :data:`SHAPES`)."""
    name = str(shape).strip().lower()
    if name not in SHAPES:
        raise UsageError(f"contour shape must be one of {', '.join(SHAPES)}, got {shape!r}", parameter="shape")
    return (circle if name == "circle" else diamond)(size_m, **kwargs)


def thesis_path(shape: str, feature: str, *, fs: float = 15000.0, start=(0.0, 0.0), dwell_before: float = 0.05,
                dwell_after: float = 0.2) -> ContourPath:
    """The contour of §4.5 for a feature of :data:`THESIS_FEATURES` (``"1um"``, ``"1mm"``, ``"200mm"``)."""
    if feature not in THESIS_FEATURES:
        raise UsageError(f"feature must be one of {', '.join(THESIS_FEATURES)}, got {feature!r}")
    f = THESIS_FEATURES[feature]
    return contour_path(shape, f["size_m"], v_max=f["v_max"], a_max=f["a_max"], j_max=f["j_max"], fs=fs,
                        start=start, dwell_before=dwell_before, dwell_after=dwell_after)
