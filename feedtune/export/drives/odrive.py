"""ODrive firmware 0.5.x: position and velocity gains of ``axis0.controller.config`` (turns, N m).

Written as odrivetool lines (``odrv0.axis0.controller.config.pos_gain = ...``, ``#`` comments), or with
``json=True`` as the nested JSON ``odrivetool backup-config`` writes and ``restore-config`` reads (no comments there:
the conversions are the same):

* ``pos_gain`` [(turn/s)/turn] = ``Kv`` [1/s] (the same number);
* ``vel_gain`` [N m/(turn/s)] = ``2 pi (Kp + Kp / (fs Tn))``; ``vel_integrator_gain`` [N m/turn] =
  ``2 pi Kp / Tn``: the firmware adds the integrator *before* updating it with the sample's error
  (``controller.cpp``: ``torque += vel_integrator_torque; ... vel_integrator_torque += vel_integrator_gain *
  current_meas_period * v_err``), i.e. ``Kp' e[k] + Ki Ts sum(e[j], j < k)``, which is feedtune's backward-Euler PI
  ``Kp e[k] + Ki Ts sum(e[j], j <= k)`` exactly when ``Kp' = Kp + Ki Ts``;
* ``inertia`` [N m/(turn/s^2)] = ``2 pi J_ff`` (the acceleration feedforward of the trajectory input modes);
* ``encoder.config.bandwidth`` [rad/s] = ``2 pi f`` of the law's PT2 (D = 1) filter, or the firmware's default.

The law the target runs: both loops at the 8 kHz control loop (``current_meas_period``), gains in single
precision, the velocity feedforward at 1, and no current-setpoint filter: ODrive's only filter is its encoder PLL
(``encoder.cpp``: per sample ``p += T v; d = x - p; p += T kp d; v += T ki d``, ``kp = 2 bandwidth``,
``ki = kp^2 / 4``), whose velocity estimate is, in continuous time, the speed through a PT2 at ``bandwidth`` rad/s
with damping 1 (``V / (s X) = ki / (s^2 + kp s + ki)``). The rebuilt law holds that PT2; a file's law whose only filter
is such a PT2 is written as ``encoder.config.bandwidth`` and expressed; any other filter is dropped. What the PT2 does
not capture (the discrete PLL, and the position loop's estimate ``(kp s + ki)/(s^2 + kp s + ki)`` in place of the
PT2) is computed at the crossovers (:func:`pll_model_error_deg`) and the export refused beyond
:data:`MAX_PLL_ERROR_DEG`.
"""

from __future__ import annotations

import json
import math

import numpy as np

from ...control.cascade import CascadeLaw, describe_filter
from ...control.drive_tuning import Pt2Filter
from ...errors import DataError, UsageError
from .common import DriveOptions, DriveText, TargetLaw, f32_text, float32, number, rates, to_motor_frame

NAME = "odrive"
TITLE = "ODrive 0.5.x"
FS_HZ = 8000.0
"""The control loop's rate [Hz] (``current_meas_period`` = 125 us on ODrive v3)."""
DEFAULT_ENCODER_BANDWIDTH = 1000.0
"""``encoder.config.bandwidth``'s default [rad/s]."""
MAX_PLL_ERROR_DEG = 1.0
"""Largest phase difference [deg] at a loop's crossover between the encoder PLL and the PT2 the rebuilt law holds in
its place that the export accepts (:func:`pll_model_error_deg`)."""
MAX_ENCODER_BANDWIDTH = 0.5 * FS_HZ
"""The largest PLL bandwidth [rad/s] written (``pll_kp T = 1`` at 8 kHz: the position estimate is deadbeat)."""
PREFIX = "odrv0.axis0."
TURN = 2 * math.pi


def pll_response(freq_hz, bandwidth: float, fs: float) -> tuple[np.ndarray, np.ndarray]:
    """``(pos_estimate / pos, vel_estimate / backward-difference speed)`` [-] of ODrive's encoder PLL at ``freq_hz``:
    per sample ``p += T v; d = x - p; p += T kp d; v += T ki d`` with ``kp = 2 bandwidth``, ``ki = kp^2 / 4``."""
    t = 1.0 / fs
    kp = 2.0 * bandwidth
    ki = 0.25 * kp * kp
    a = np.array([[1 - t * kp, t * (1 - t * kp)], [-t * ki, 1 - t * t * ki]])
    b = np.array([t * kp, t * ki])
    zi = np.exp(-2j * np.pi * np.asarray(freq_hz, float) / fs)
    # s[k] = A s[k-1] + B x[k]  ->  S = (I - A z^-1)^-1 B X
    det = (1 - a[0, 0] * zi) * (1 - a[1, 1] * zi) - a[0, 1] * a[1, 0] * zi * zi
    p = ((1 - a[1, 1] * zi) * b[0] + a[0, 1] * zi * b[1]) / det
    v = (a[1, 0] * zi * b[0] + (1 - a[0, 0] * zi) * b[1]) / det
    return p, v / ((1 - zi) * fs)


def pll_model_error_deg(crossovers: dict[str, float | None], bandwidth: float, fs: float = FS_HZ) -> float:
    """Largest phase difference [deg] at the crossovers ``{"speed": Hz, "position": Hz}`` between what ODrive's PLL
    feeds each loop and the PT2 filter (``bandwidth / 2 pi`` Hz, D = 1, as feedtune discretizes it) the rebuilt law
    holds in its place: the velocity estimate against the backward-difference speed through the PT2 (speed loop), the
    position estimate against the position through the PT2 (position loop: the PT2 sits in the controller, so the
    law's position loop carries it too)."""
    from ...control.cascade import drive_filter_sos
    from ...control.drive_tuning import Pt2Filter

    b0, b1, b2, _, a1, a2 = drive_filter_sos(Pt2Filter(bandwidth / (2 * math.pi), 1.0), fs)
    worst = 0.0
    for loop, f in crossovers.items():
        if f is None:
            continue
        p, v = pll_response([f], bandwidth, fs)
        zi = np.exp(-2j * np.pi * f / fs)
        pt2 = (b0 + zi * (b1 + zi * b2)) / (1 + zi * (a1 + zi * a2))
        worst = max(worst, abs(math.degrees(np.angle((v[0] if loop == "speed" else p[0]) / pt2))))
    return worst


def bandwidth_of(law: CascadeLaw, options: DriveOptions) -> tuple[float, list[str]]:
    """``(encoder bandwidth [rad/s], dropped filters)``: a law whose only filter is a PT2 with damping 1 is the PLL's
    velocity estimate at ``2 pi f`` (``--encoder-bandwidth`` overrides); any other filter is dropped and the PLL runs
    at ``--encoder-bandwidth`` or the firmware's default."""
    on = law.enabled_filters
    if (len(on) == 1 and isinstance(on[0], Pt2Filter) and abs(on[0].damping - 1.0) < 1e-9
            and 2 * math.pi * on[0].freq_hz <= MAX_ENCODER_BANDWIDTH and options.encoder_bandwidth is None):
        return 2 * math.pi * on[0].freq_hz, []
    dropped = [f"{describe_filter(f)}: ODrive has no current-setpoint filter (its only filter is the encoder PLL's "
               "velocity estimate, a PT2 with D = 1)" for f in on]
    return options.encoder_bandwidth or DEFAULT_ENCODER_BANDWIDTH, dropped


def _parameters(m: CascadeLaw, bandwidth: float) -> list[tuple[str, float, str]]:
    ki = 0.0 if math.isinf(m.tn_s) else m.kp / m.tn_s
    kp_odrive = m.kp + ki / m.fs
    return [
        ("controller.config.pos_gain", m.kv, f"[(turn/s)/turn] = Kv {m.kv:.9g} 1/s (the same number)"),
        ("controller.config.vel_gain", TURN * kp_odrive,
         f"[N*m/(turn/s)] = 2 pi (Kp + Kp/(fs Tn)) = 2 pi ({m.kp:.9g} + {ki / m.fs:.9g}) N*m/(rad/s): the "
         "integrator is added before its update"),
        ("controller.config.vel_integrator_gain", TURN * ki,
         f"[N*m/turn] = 2 pi Kp/Tn = 2 pi x {ki:.9g} N*m/rad"),
        ("controller.config.inertia", TURN * m.inertia_ff,
         f"[N*m/(turn/s^2)] = 2 pi J_ff = 2 pi x {m.inertia_ff:.9g} N*m/(rad/s^2)"),
        ("encoder.config.bandwidth", bandwidth, "[rad/s] encoder PLL bandwidth (position and velocity estimate)"),
    ]


def write(law: CascadeLaw, options: DriveOptions, source: str = "", *, as_json: bool = False) -> DriveText:
    """The odrivetool lines (or backup-config JSON) of ``law`` (module docstring)."""
    if law.position_encoder != "motor":
        raise UsageError(f"{NAME}: the position loop closes on the load encoder; this export writes axis0's own "
                         "encoder loop only", parameter="gains")
    m, frame = to_motor_frame(law, options, NAME)
    fs, _ = rates(law, options, FS_HZ, 1)
    m = m.with_gains(fs=fs, position_ratio=1, filters=())
    bandwidth, dropped = bandwidth_of(law, options)
    if law.kv_ff != 1.0:
        dropped.append(f"velocity feedforward x{law.kv_ff:.6g}: ODrive feeds the setpoint velocity at 1")
    rows = _parameters(m, bandwidth)
    params = {PREFIX + n: float(f32_text(v)) for n, v, _ in rows}
    if as_json:
        tree: dict = {}
        for n, v, _ in rows:
            node = tree.setdefault("axis0", {})
            *path, leaf = n.split(".")
            for p in path:
                node = node.setdefault(p, {})
            node[leaf] = float(f32_text(v))
        return DriveText(json.dumps(tree, indent=4) + "\n", tuple(dropped), params)
    head = [f"# {TITLE}: written by feedtune from {source or 'a cascade gains file'} (odrivetool shell lines)",
            "# law: vel_des = pos_gain (pos_setpoint - pos_estimate) + vel_setpoint; torque = vel_gain (vel_des - "
            "vel_estimate) + integrator, both loops every 125 us (8 kHz)",
            *(f"# conversion: {t}" for t in frame), "# turns: 1 turn = 2 pi rad",
            *(f"# not written: {d}" for d in dropped)]
    body = [f"{PREFIX}{n} = {f32_text(v)}  # {c}" for n, v, c in rows]
    return DriveText("\n".join(head + body) + "\n", tuple(dropped), params)


def _values(text: str, where: str) -> dict[str, str]:
    if text.lstrip().startswith("{"):
        try:
            tree = json.loads(text)
        except json.JSONDecodeError as exc:
            raise DataError(f"{where}: not JSON ({exc.msg} at line {exc.lineno})") from None
        flat: dict[str, str] = {}

        def walk(node, path):
            if isinstance(node, dict):
                for k, v in node.items():
                    walk(v, f"{path}.{k}" if path else k)
            elif isinstance(node, (int, float)) and not isinstance(node, bool):
                flat["odrv0." + path] = repr(node)

        walk(tree, "")
        return flat
    from .common import parse_assignments

    return parse_assignments(text, where, "#")


def read(text: str, where: str, options: DriveOptions, base: CascadeLaw | None = None) -> TargetLaw:
    """The law odrivetool lines or a backup-config JSON of axis0 run (motor frame: rad, N m), and the PLL's lag at
    the loops' crossovers is left to the caller (:func:`pll_lag_deg`); ``base`` gives the computational delay."""
    v = _values(text, where)
    pos_gain = float32(number(v, PREFIX + "controller.config.pos_gain", where))
    vel_gain = float32(number(v, PREFIX + "controller.config.vel_gain", where))
    vel_int = float32(number(v, PREFIX + "controller.config.vel_integrator_gain", where, 0.0))
    inertia = float32(number(v, PREFIX + "controller.config.inertia", where, 0.0))
    bandwidth = float32(number(v, PREFIX + "encoder.config.bandwidth", where, DEFAULT_ENCODER_BANDWIDTH))
    fs = options.fs_hz or FS_HZ
    ki = vel_int / TURN
    kp = vel_gain / TURN - ki / fs
    if kp <= 0:
        raise DataError(f"{where}: vel_gain {vel_gain:g} is not above vel_integrator_gain x current_meas_period "
                        f"({vel_int / fs:g}): no positive proportional gain")
    if not 0 < bandwidth < fs / 2 * 2 * math.pi:
        raise DataError(f"{where}: encoder.config.bandwidth {bandwidth:g} rad/s: expected > 0 and below the Nyquist "
                        f"frequency {fs / 2:g} Hz")
    law = CascadeLaw(kp, math.inf if ki == 0 else kp / ki, (Pt2Filter(bandwidth / (2 * math.pi), 1.0),), pos_gain,
                     fs, 1, base.delay_samples if base else 1, 1.0, inertia / TURN, "motor", "N*m", "rad")
    return TargetLaw(law, (f"encoder PLL at {bandwidth:g} rad/s: its velocity estimate is the PT2 "
                           f"{bandwidth / (2 * math.pi):.6g} Hz, D = 1 of the rebuilt law",),
                     {"encoder_bandwidth": bandwidth})


__all__ = ["DEFAULT_ENCODER_BANDWIDTH", "FS_HZ", "MAX_ENCODER_BANDWIDTH", "MAX_PLL_ERROR_DEG", "NAME", "TITLE",
           "bandwidth_of", "pll_model_error_deg", "pll_response", "read", "write"]
