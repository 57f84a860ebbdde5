"""Digital twin of the thesis's ball-screw drive (§3.2.1): what the real drive has and the design model lacks.

The twin is the 2-mass axial model of Table 3.1 (:class:`~feedtune.models.ballscrew.BallScrewModel`,
positions in rad of screw rotation, command in V) plus

* **current loop**: first order, ``wc / (s + wc)`` with ``wc = 2 pi 450 Hz``, between the command and the
  motor torque;
* **torsional modes** near 440 Hz and 1100 Hz as unit-DC-gain zero/pole pairs in the input path
  ``(s^2 + 2 zz wz s + wz^2) / (s^2 + 2 zp wp s + wp^2) (wp/wz)^2`` with ``wz = 0.95 wp``, ``zz = 0.05`` (the
  form of the bundled example FRF) and ``zp = 0.03``, so they appear on ``x1/u`` and ``x2/u`` as in a measured
  FRF; ``zp`` is calibrated (the thesis gives no damping) so that the thesis's MC-PPC on the twin's measured FRF
  has the published peak sensitivities, 2.35 with the s-domain and 3.04 with the discrete controller (§3.3;
  see "Calibration" in docs/twin.md);
* **table pitching mode** at 43 Hz: ``q'' + 2 zeta w q' + w^2 q = w^2 C_p d2_ext``, added to the linear
  encoder reading; only external table forces ``d2_ext`` (rope, cutting force) excite it, the motor cannot
  (the screw acts at the guideway level), as in the thesis;
* **Stribeck friction** (eq. 2.1, asymmetric, :class:`~feedtune.models.friction.StribeckFriction` in V and
  rad/s) at the motor (``d1``) and at the table (``d2``);
* **encoders** quantized to 10 nm of table travel (both) with white measurement noise;
* **command saturation** (+-10 V), 20 kHz sampling and a full sample of computational delay: the command
  computed from ``x1[k], x2[k]`` is held by a zero-order hold from sample ``k + 1``.

Integration: the linear part (current loop, torsional modes, 2-mass mechanics; 9 states) is discretized
exactly for a held input (``scipy.linalg.expm`` of the augmented matrix) over ``T / substeps``. The
friction forces are evaluated from the velocities at the start of every (sub)step and held over it, like
the command: an explicit treatment, first-order accurate in the step; at 20 kHz the velocity change a
friction force causes in one step is about 4e-3 rad/s (4 um/s of table travel), so sticking shows as a
chatter of well below a nanometre. More ``substeps`` refine it.

Every value is a parameter of :class:`TwinParams` (``TwinParams.with_overrides`` takes ``name=value``
pairs); the seed makes noise repeatable. The closed loop runs in a compiled loop (numba) when numba is
installed and in plain Python otherwise (same code, same results).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, fields, replace

import numpy as np

from ...budget import TWIN_SAMPLE_BYTES, check_memory
from ...errors import DataError, UsageError
from ...lti import zoh
from ...models.ballscrew import THESIS_TABLE_3_1, BallScrewModel
from ...sim.engine import choose_engine, compiled, sample_vector
from ...sim.params import non_negative_param, parse_override_value, positive_param
from .law import compiled_feedback, feedback_step, new_state

LEAD = THESIS_TABLE_3_1.lead_m_per_rad
# ------------------------------------------------------------------------------------------ parameters
@dataclass(frozen=True)
class TorsionalMode:
    """A torsional mode in the input path: zero pair at ``zero_ratio * freq_hz`` and pole pair at ``freq_hz``.

    Parameters
    ----------
    freq_hz : float
        Pole (resonance) frequency [Hz].
    zeta_p : float
        Damping of the poles [-]; the default 0.03 is calibrated to the thesis's peak sensitivities (§3.3,
        docs/twin.md "Calibration"; 0.02 before).
    zeta_z : float
        Damping of the zeros [-].
    zero_ratio : float
        Anti-resonance frequency over resonance frequency [-].
    """

    freq_hz: float
    zeta_p: float = 0.03
    zeta_z: float = 0.05
    zero_ratio: float = 0.95


def _default_motor_friction():
    from ...models.friction import StribeckFriction

    return StribeckFriction(dc_pos=0.10, ds_pos=0.16, dc_neg=-0.09, ds_neg=-0.15, omega_pos=0.8, omega_neg=0.6,
                            command_unit="V", velocity_unit="rad/s")


def _default_table_friction():
    from ...models.friction import StribeckFriction

    return StribeckFriction(dc_pos=0.02, ds_pos=0.03, dc_neg=-0.018, ds_neg=-0.027, omega_pos=0.5,
                            command_unit="V", velocity_unit="rad/s")


@dataclass(frozen=True)
class TwinParams:
    """Every parameter of the ball-screw twin (defaults: the thesis's drive, §3.2.1).

    Parameters
    ----------
    model : BallScrewModel
        2-mass axial model (Table 3.1) [V, rad, s].
    torsional : tuple of TorsionalMode
        Torsional modes in the input path (440 and 1100 Hz, pole damping 0.03 calibrated, see
        :class:`TorsionalMode`).
    current_loop_hz : float or None
        Bandwidth of the first-order current loop [Hz]; None: ideal.
    pitch_hz : float or None
        Table pitching mode [Hz]; None: none.
    pitch_zeta : float
        Its damping ratio [-].
    pitch_compliance : float
        Static pitching displacement at the linear encoder per external table force [rad/V].
    friction_motor, friction_table : StribeckFriction or None
        Eq. 2.1 at the motor (velocity ``x1'``) and table (``x2'``) [V, rad/s]; None: no friction.
    quantization_m : float
        Encoder resolution in table travel [m] (both encoders; 0: none).
    noise_m : float
        RMS white measurement noise per encoder in table travel [m].
    u_max : float or None
        Command saturation [V]; None: none.
    fs : float
        Sample rate [Hz].
    delay_samples : int
        Computational delay [samples].
    substeps : int
        Integration sub-steps per sample (friction is re-evaluated at each).
    envelope_m : float
        Following-error trip: the run stops when ``|x2r - x2|`` or ``|x1r - x1|`` exceeds this [m of table
        travel].
    overload_rms : float or None
        I2t overload trip: the run stops when the RMS command over about ``overload_tau_s`` (first-order
        mean of ``u^2``) exceeds this [V], like a drive's thermal protection; it catches oscillations that
        saturation keeps inside the envelope. None: off.
    overload_tau_s : float
        Time constant of that mean [s].
    """

    model: BallScrewModel = THESIS_TABLE_3_1
    torsional: tuple = (TorsionalMode(440.0), TorsionalMode(1100.0))
    current_loop_hz: float | None = 450.0
    pitch_hz: float | None = 43.0
    pitch_zeta: float = 0.03
    pitch_compliance: float = 3e-4
    friction_motor: object = field(default_factory=_default_motor_friction)
    friction_table: object = field(default_factory=_default_table_friction)
    quantization_m: float = 10e-9
    noise_m: float = 3e-9
    u_max: float | None = 10.0
    fs: float = 20000.0
    delay_samples: int = 1
    substeps: int = 1
    envelope_m: float = 1e-3
    overload_rms: float | None = 7.0
    overload_tau_s: float = 0.1

    def __post_init__(self) -> None:
        object.__setattr__(self, "torsional", tuple(self.torsional))
        positive_param(self.fs, "fs", "Hz")
        for name in ("current_loop_hz", "pitch_hz", "u_max"):
            if getattr(self, name) is not None:
                positive_param(getattr(self, name), name, "")
        for name in ("pitch_zeta", "pitch_compliance", "quantization_m", "noise_m"):
            non_negative_param(getattr(self, name), name)
        positive_param(self.envelope_m, "envelope_m", "m")
        positive_param(self.overload_tau_s, "overload_tau_s", "s")
        if self.overload_rms is not None:
            positive_param(self.overload_rms, "overload_rms", "V")
        for name in ("delay_samples", "substeps"):
            v = getattr(self, name)
            if isinstance(v, bool) or int(v) != v or v < (1 if name == "substeps" else 0):
                raise UsageError(f"twin parameter {name} must be an integer >= {1 if name == 'substeps' else 0}, "
                                 f"got {v!r}")
            object.__setattr__(self, name, int(v))
        for m in self.torsional:
            positive_param(m.freq_hz, "torsional freq_hz", "Hz")
            non_negative_param(m.zeta_p, "torsional_zeta_p")
            non_negative_param(m.zeta_z, "torsional_zeta_z")
            positive_param(m.zero_ratio, "torsional_zero_ratio", "")
            if m.freq_hz >= self.fs / 2:
                raise UsageError(f"torsional mode {m.freq_hz:g} Hz is above the Nyquist frequency {self.fs / 2:g} Hz")
        if self.model.lead_m_per_rad <= 0:
            raise UsageError("model lead_m_per_rad must be > 0")

    @classmethod
    def ideal(cls, model: BallScrewModel = THESIS_TABLE_3_1, fs: float = 20000.0, delay_samples: int = 1) -> TwinParams:
        """The 2-mass model alone: no unmodeled dynamics, friction, quantization, noise or saturation."""
        return cls(model=model, torsional=(), current_loop_hz=None, pitch_hz=None, friction_motor=None,
                   friction_table=None, quantization_m=0.0, noise_m=0.0, u_max=None, fs=fs,
                   delay_samples=delay_samples, overload_rms=None)

    @property
    def lead(self) -> float:
        """Screw lead [m/rad]."""
        return self.model.lead_m_per_rad

    def with_overrides(self, overrides: dict) -> TwinParams:
        """A copy with parameters replaced from ``{"name": value}``.

        Names: the fields of this class; ``m1 m2 b1 b2 k c`` (model); ``torsional_hz`` (comma-separated
        frequencies [Hz] or ``none``; new modes get the :class:`TorsionalMode` defaults);
        ``torsional_zeta_p``, ``torsional_zeta_z``, ``torsional_zero_ratio`` (one value for every mode or one
        per mode, comma-separated; applied after ``torsional_hz``); ``friction_motor`` / ``friction_table`` =
        ``none``; and ``friction_motor.dc_pos`` etc. for single friction levels. Values may be strings
        (command line).
        """
        p = self
        items = [(str(key).strip(), raw) for key, raw in overrides.items()]
        items.sort(key=lambda kv: kv[0] != "torsional_hz")  # the modes first, then their damping (stable sort)
        for key, raw in items:
            p = _override(p, key, raw)
        return p

    def to_dict(self) -> dict:
        """JSON-ready parameters with units."""
        fric = {}
        for name in ("friction_motor", "friction_table"):
            f = getattr(self, name)
            fric[name] = None if f is None else f.to_dict()
        return {
            "model": {**self.model.params(), "lead_m_per_rad": self.lead},
            "torsional": [asdict(m) for m in self.torsional],
            "current_loop_hz": self.current_loop_hz,
            "pitch_hz": self.pitch_hz,
            "pitch_zeta": self.pitch_zeta,
            "pitch_compliance": self.pitch_compliance,
            **fric,
            "quantization_m": self.quantization_m,
            "noise_m": self.noise_m,
            "u_max": self.u_max,
            "fs": self.fs,
            "delay_samples": self.delay_samples,
            "substeps": self.substeps,
            "envelope_m": self.envelope_m,
            "overload_rms": self.overload_rms,
            "overload_tau_s": self.overload_tau_s,
            "units": {"model": "V, rad, s (Table 3.1 units)", "lead_m_per_rad": "m/rad", "torsional": "Hz, -",
                      "current_loop_hz": "Hz", "pitch_hz": "Hz", "pitch_zeta": "-", "pitch_compliance": "rad/V",
                      "friction": "V, rad/s", "quantization_m": "m", "noise_m": "m (RMS)", "u_max": "V",
                      "fs": "Hz", "delay_samples": "samples", "substeps": "-", "envelope_m": "m",
                      "overload_rms": "V", "overload_tau_s": "s"},
        }


def _override(p: TwinParams, key: str, raw) -> TwinParams:
    value = parse_override_value(raw, key) if key != "torsional_hz" and key not in _TORSIONAL_KEYS else raw
    names = {f.name for f in fields(TwinParams)}
    if key in ("m1", "m2", "b1", "b2", "k", "c", "lead_m_per_rad"):
        if value is None:
            raise UsageError(f"twin parameter {key} needs a number")
        try:
            return replace(p, model=replace(p.model, **{key: float(value)}))
        except DataError as exc:
            raise UsageError(f"twin parameter {key}: {exc}") from None
    if key == "torsional_hz":
        text = str(raw).strip().lower()
        if text in ("none", "off", ""):
            return replace(p, torsional=())
        try:
            freqs = [float(x) for x in text.split(",")]
        except ValueError:
            raise UsageError(f"twin parameter torsional_hz: expected comma-separated Hz or 'none', got {raw!r}") \
                from None
        return replace(p, torsional=tuple(TorsionalMode(f) for f in freqs))
    if key in _TORSIONAL_KEYS:
        return _override_torsional(p, key, raw)
    if "." in key:
        base, attr = key.split(".", 1)
        if base not in ("friction_motor", "friction_table"):
            raise UsageError(f"unknown twin parameter {key!r}")
        fr = getattr(p, base) or (_default_motor_friction() if base == "friction_motor"
                                  else _default_table_friction())
        if attr not in ("dc_pos", "ds_pos", "dc_neg", "ds_neg", "omega_pos", "omega_neg") or value is None:
            raise UsageError(f"twin parameter {key}: expected {base}.dc_pos|ds_pos|dc_neg|ds_neg|omega_pos|"
                             "omega_neg = number")
        try:
            return replace(p, **{base: replace(fr, **{attr: float(value)})})
        except DataError as exc:
            raise UsageError(f"twin parameter {key}: {exc}") from None
    if key in ("friction_motor", "friction_table"):
        if value is not None:
            raise UsageError(f"twin parameter {key} can only be set to 'none' (or set {key}.dc_pos etc.)")
        return replace(p, **{key: None})
    if key not in names or key in ("model", "torsional"):
        raise UsageError(f"unknown twin parameter {key!r}; known: {', '.join(sorted(_override_names()))}")
    return replace(p, **{key: value})


_TORSIONAL_KEYS = {"torsional_zeta_p": "zeta_p", "torsional_zeta_z": "zeta_z", "torsional_zero_ratio": "zero_ratio"}


def _override_torsional(p: TwinParams, key: str, raw) -> TwinParams:
    """``torsional_zeta_p`` etc.: one value for every mode, or one per mode (comma-separated)."""
    n = len(p.torsional)
    if n == 0:
        raise UsageError(f"twin parameter {key}: the twin has no torsional modes (set torsional_hz first)")
    parts = [raw] if isinstance(raw, (int, float)) and not isinstance(raw, bool) else str(raw).split(",")
    try:
        values = [float(v) for v in parts]
    except ValueError:
        values = []
    if len(values) not in (1, n):
        raise UsageError(f"twin parameter {key}: expected one number or {n} comma-separated numbers (one per "
                         f"torsional mode), got {raw!r}")
    values = values * n if len(values) == 1 else values
    attr = _TORSIONAL_KEYS[key]
    return replace(p, torsional=tuple(replace(m, **{attr: float(v)}) for m, v in zip(p.torsional, values, strict=True)))


def _override_names() -> set[str]:
    base = {f.name for f in fields(TwinParams)} - {"model", "torsional"}
    return base | set(_TORSIONAL_KEYS) | {
        "m1", "m2", "b1", "b2", "k", "c", "lead_m_per_rad", "torsional_hz",
        "friction_motor.{dc_pos,ds_pos,dc_neg,ds_neg,omega_pos,omega_neg}", "friction_table.{...}"}


# ------------------------------------------------------------------------------------------ state space
def _series(a: tuple, b: tuple) -> tuple:
    """State space of ``b`` after ``a`` (SISO blocks ``(A, B, C, D)``)."""
    A1, B1, C1, D1 = a
    A2, B2, C2, D2 = b
    n1, n2 = A1.shape[0], A2.shape[0]
    A = np.zeros((n1 + n2, n1 + n2))
    A[:n1, :n1] = A1
    A[n1:, n1:] = A2
    A[n1:, :n1] = B2 @ C1
    B = np.vstack([B1, B2 @ D1])
    C = np.hstack([D2 @ C1, C2])
    return A, B, C, D2 @ D1


def _torsional_ss(m: TorsionalMode) -> tuple:
    wp = 2 * np.pi * m.freq_hz
    wz = m.zero_ratio * wp
    g = (wp / wz) ** 2
    # g (s^2 + 2 zz wz s + wz^2) / (s^2 + 2 zp wp s + wp^2) = g + (b1 s + b0) / den
    b1 = g * 2 * m.zeta_z * wz - g * 2 * m.zeta_p * wp
    b0 = g * wz**2 - g * wp**2
    A = np.array([[0.0, 1.0], [-(wp**2), -2 * m.zeta_p * wp]])
    return A, np.array([[0.0], [1.0]]), np.array([[b0, b1]]), np.array([[g]])


def _input_path(p: TwinParams) -> tuple:
    """Command -> motor force: current loop then torsional modes (SISO state space, may be empty)."""
    blk = (np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), np.ones((1, 1)))
    if p.current_loop_hz is not None:
        wc = 2 * np.pi * p.current_loop_hz
        blk = _series(blk, (np.array([[-wc]]), np.array([[1.0]]), np.array([[wc]]), np.zeros((1, 1))))
    for m in p.torsional:
        blk = _series(blk, _torsional_ss(m))
    return blk


def continuous_system(p: TwinParams) -> tuple[np.ndarray, np.ndarray]:
    """``(A, B)`` of the in-loop linear part: states ``[x1, x2, x1', x2', input path...]``, inputs ``[u, d1, d2]``.

    ``u`` [V] passes the current loop and torsional modes; ``d1``, ``d2`` [V] act directly on the motor
    and table masses (friction, external forces).
    """
    Am, Bm, _ = p.model.state_space()  # inputs [u, d1, d2]; u and d1 enter alike
    Ai, Bi, Ci, Di = _input_path(p)
    ni = Ai.shape[0]
    n = 4 + ni
    A = np.zeros((n, n))
    A[:4, :4] = Am
    A[4:, 4:] = Ai
    A[:4, 4:] = Bm[:, [0]] @ Ci
    B = np.zeros((n, 3))
    B[:4, 0] = Bm[:, 0] * Di[0, 0]
    B[4:, 0] = Bi[:, 0]
    B[:4, 1] = Bm[:, 1]
    B[:4, 2] = Bm[:, 2]
    return A, B


def pitch_sos(p: TwinParams) -> np.ndarray | None:
    """Second-order section from the held external table force [V] to the pitching reading [rad] at ``fs``."""
    if p.pitch_hz is None or p.pitch_compliance == 0:
        return None
    w = 2 * np.pi * p.pitch_hz
    A = np.array([[0.0, 1.0], [-(w**2), -2 * p.pitch_zeta * w]])
    B = np.array([[0.0], [w**2 * p.pitch_compliance]])
    Ad, Bd = zoh(A, B, 1.0 / p.fs)
    # H(z) = [1 0] (zI - Ad)^-1 Bd as a section in z^-1
    a1, a2 = -np.trace(Ad), np.linalg.det(Ad)
    b1 = Bd[0, 0]
    b2 = Ad[0, 1] * Bd[1, 0] - Ad[1, 1] * Bd[0, 0]
    return np.array([[0.0, b1, b2, 1.0, a1, a2]])


# ------------------------------------------------------------------------------------------ the loop
def _closed_loop(Ad, Bd, Ac, Bc, h, stop_v, n, n_sub, z, znew, x1r, x2r, uff, r, d2, pitch, n1, n2, gains, fs,
                 fp, st, nsec, delay, fr, q1, q2, u_max, env1, env2, i2t_alpha, i2t_limit, status, y1_out, y2_out,
                 u_out, p1_out, p2_out):
    """Closed loop, one sample per iteration (compiled by numba when available; lists work in plain Python).

    ``Ad`` flat (n*n), ``Bd`` flat (n*3): exact update over one sub-step of ``h`` [s]; ``Ac``, ``Bc``: the
    continuous rows of ``x1''`` and ``x2''`` (net force on each mass for the stiction test); ``stop_v``: the
    speeds below which a mass may stick [rad/s]; ``fr`` = 14 friction numbers (motor then table: on, dc+,
    ds+, dc-, ds-, om+, om-, see :func:`_friction_vector`); returns the number of samples
    completed (``< len(x1r)``: a trip at that sample, which is still recorded, with ``status[0]`` = 1 for
    the following-error envelope, 2 for the I2t overload, 3 for a non-finite command).
    """
    n_samples = len(x1r)
    ms = 0.0
    for k in range(n_samples):
        x1 = z[0]
        x2 = z[1]
        p1_out[k] = x1
        p2_out[k] = x2
        y1 = x1 + n1[k]
        y2 = x2 + pitch[k] + n2[k]
        if q1 > 0.0:
            y1 = math.floor(y1 / q1 + 0.5) * q1
        if q2 > 0.0:
            y2 = math.floor(y2 / q2 + 0.5) * q2
        y1_out[k] = y1
        y2_out[k] = y2
        # ---- the law of docs/gains.md (the function GainsRuntime.step calls)
        e1 = x1r[k] - y1
        e2 = x2r[k] - y2
        uc = _feedback(st, gains, fp, nsec, fs, e1, e2) + uff[k] + r[k]
        if uc > u_max:
            uc = u_max
        elif uc < -u_max:
            uc = -u_max
        u_out[k] = uc
        ms += (uc * uc - ms) * i2t_alpha
        if not (abs(e1) <= env1 and abs(e2) <= env2):
            status[0] = 1.0
            return k
        if not abs(uc) <= 1e300:
            status[0] = 3.0
            return k
        if ms > i2t_limit:
            status[0] = 2.0
            return k
        ua = u_out[k - delay] if k >= delay else 0.0
        # ---- plant over one sample (n_sub exact sub-steps, friction held over each)
        d2k = d2[k]
        for _ in range(n_sub):
            phi1 = 0.0
            phi2 = 0.0
            for side in range(2):
                o = 7 * side
                if fr[o] <= 0.0:
                    continue
                v = z[2 + side]
                inv_m = Bc[4 * side + 1]
                direction = v
                if abs(v) < stop_v[side]:
                    a = Bc[3 * side] * ua + Bc[3 * side + 2] * d2k
                    for j in range(n):
                        a += Ac[side * n + j] * z[j]
                    phi = -(a / inv_m + v / (inv_m * h))
                    if (phi >= 0.0 and phi <= -fr[o + 4]) or (phi < 0.0 and -phi <= fr[o + 2]):
                        if side == 0:
                            phi1 = phi
                        else:
                            phi2 = phi
                        continue
                    direction = v + a * h
                f = 0.0
                if direction > 0.0:
                    f = fr[o + 1] + (fr[o + 2] - fr[o + 1]) * math.exp(-abs(v) / fr[o + 5])
                elif direction < 0.0:
                    f = fr[o + 3] + (fr[o + 4] - fr[o + 3]) * math.exp(-abs(v) / fr[o + 6])
                if side == 0:
                    phi1 = -f
                else:
                    phi2 = -f
            in2 = d2k + phi2
            for i in range(n):
                acc = Bd[3 * i] * ua + Bd[3 * i + 1] * phi1 + Bd[3 * i + 2] * in2
                row = i * n
                for j in range(n):
                    acc += Ad[row + j] * z[j]
                znew[i] = acc
            for i in range(n):
                z[i] = znew[i]
    return n_samples


_feedback = feedback_step  # replaced by its compiled version before the loop is compiled


def _compiled_loop():
    """:func:`_closed_loop` compiled with the compiled feedback law."""
    global _feedback
    _feedback = compiled_feedback()
    return compiled(_closed_loop)


def _friction_vector(p: TwinParams) -> np.ndarray:
    out = np.zeros(14)
    for side, f in enumerate((p.friction_motor, p.friction_table)):
        if f is not None:
            out[7 * side: 7 * side + 7] = [1.0, f.dc_pos, f.ds_pos, f.dc_neg, f.ds_neg, f.omega_pos,
                                           f.omega_negative]
    return out


# ------------------------------------------------------------------------------------------ results
@dataclass(frozen=True)
class TwinRun:
    """One closed-loop run of the twin.

    The controller starts ``lead_samples`` (its reference preview) before ``t = 0`` with the reference
    at rest, as on a target that runs before the move starts; those samples have ``t < 0``.

    Attributes
    ----------
    t : ndarray
        Time [s] of the recorded samples.
    x1, x2 : ndarray
        Encoder readings (noise, quantization, pitching on ``x2``) [rad].
    x1_true, x2_true : ndarray
        Motor and table positions of the mechanics [rad].
    u : ndarray
        Command computed at each sample (after saturation) [V]; applied ``delay_samples`` later.
    x1r, x2r : ndarray
        Rotary and table references of the law [rad].
    tripped : bool
        The following error left the safety envelope; the run stopped at ``t[-1]``.
    trip_message : str
        Why it stopped ("" when it did not).
    n_requested : int
        Samples requested from ``t = 0``.
    lead_samples : int
        Samples before ``t = 0``.
    """

    t: np.ndarray
    x1: np.ndarray
    x2: np.ndarray
    x1_true: np.ndarray
    x2_true: np.ndarray
    u: np.ndarray
    x1r: np.ndarray
    x2r: np.ndarray
    tripped: bool
    trip_message: str
    n_requested: int
    lead_samples: int = 0

    def from_zero(self) -> TwinRun:
        """The samples with ``t >= 0`` (at least one)."""
        k = min(self.lead_samples, self.t.size - 1)
        cut = {f: getattr(self, f)[k:] for f in ("t", "x1", "x2", "x1_true", "x2_true", "u", "x1r", "x2r")}
        return replace(self, **cut, lead_samples=self.lead_samples - k)

    def to_dict(self) -> dict:
        """Summary: duration, samples, trip."""
        return {"duration_s": float(self.t[-1]), "n_samples": int(np.sum(self.t >= 0)),
                "n_requested": self.n_requested, "tripped": self.tripped, "trip_message": self.trip_message}


# ------------------------------------------------------------------------------------------ the twin
class BallScrewTwin:
    """The twin built from :class:`TwinParams` (see the module docstring).

    Parameters
    ----------
    params : TwinParams, optional
        Defaults to the thesis's drive.
    """

    def __init__(self, params: TwinParams | None = None) -> None:
        self.params = params or TwinParams()
        p = self.params
        self.A, self.B = continuous_system(p)
        self.n_states = self.A.shape[0]
        self.Ad, self.Bd = zoh(self.A, self.B, 1.0 / p.fs)
        self.Ad_sub, self.Bd_sub = (self.Ad, self.Bd) if p.substeps == 1 else zoh(self.A, self.B,
                                                                                   1 / (p.fs * p.substeps))
        self.pitch_section = pitch_sos(p)

    @property
    def fs(self) -> float:
        """Sample rate [Hz]."""
        return self.params.fs

    @property
    def lead(self) -> float:
        """Screw lead [m/rad]."""
        return self.params.lead

    # ------------------------------------------------------------------ analytic responses
    def frequency_response(self, freq_hz, *, sampled: bool = True) -> dict[str, np.ndarray]:
        """The twin's own u -> x1 and u -> x2 responses [rad/V] (vectorised over the grid).

        Parameters
        ----------
        freq_hz : array_like
            Grid [Hz].
        sampled : bool
            True: what a measurement from the logged command ``u[k]`` to the encoders sees: the exact
            zero-order-hold discretization times the computational delay ``z^-d``. False: the continuous
            plant (current loop, torsional modes, mechanics) alone.

        Returns
        -------
        dict
            ``{"x1": ..., "x2": ...}`` complex responses.
        """
        f = np.asarray(freq_hz, float).reshape(-1)
        if sampled:
            zz = np.exp(2j * np.pi * f / self.fs)
            M = zz[:, None, None] * np.eye(self.n_states) - self.Ad[None]
            X = np.linalg.solve(M, np.broadcast_to(self.Bd[:, :1], (f.size, self.n_states, 1)))[..., 0]
            X = X * zz[:, None] ** (-self.params.delay_samples)
        else:
            s = 2j * np.pi * f
            M = s[:, None, None] * np.eye(self.n_states) - self.A[None]
            X = np.linalg.solve(M, np.broadcast_to(self.B[:, :1], (f.size, self.n_states, 1)))[..., 0]
        return {"x1": X[:, 0], "x2": X[:, 1]}

    def frf(self, freq_hz, *, sampled: bool = True):
        """:meth:`frequency_response` as an :class:`~feedtune.frf.Frf` with channels ``x1/u``, ``x2/u``."""
        from ...frf import Frf

        g = self.frequency_response(freq_hz, sampled=sampled)
        return Frf(np.asarray(freq_hz, float), np.stack([g["x1"], g["x2"]])[:, None, :], ("x1", "x2"), ("u",),
                   "position", input_unit="V", output_unit="rad",
                   meta={"source": "twin analytic FRF" + (" (sampled, with delay)" if sampled else "")})

    # ------------------------------------------------------------------ simulation
    def simulate(self, runtime, x_ref, *, d2=None, excitation=None, seed: int | None = 0,
                 engine: str = "auto", n_samples: int | None = None) -> TwinRun:
        """Run the closed loop with a gains runtime.

        Parameters
        ----------
        runtime : GainsRuntime
            The controller (its sample rate must equal the twin's).
        x_ref : array_like, shape (n,)
            Table reference [rad] per sample; the twin starts at rest at ``x_ref[0]`` (the controller's
            filters, which start from zero, see the reference relative to it).
        d2 : array_like, shape (n,), optional
            External table force [V] held over each sample (rope, cutting force); excites pitching.
        excitation : array_like, shape (n,), optional
            Signal added to the command before saturation [V] (FRF measurement).
        seed : int or None
            Seed of the measurement noise.
        engine : {"auto", "numba", "python"}
            Compiled or plain-Python loop ("auto": numba when installed).
        n_samples : int, optional
            Samples to run (default ``len(x_ref)``); a longer ``x_ref`` then feeds the controller's
            preview past the end instead of holding the last value.

        Returns
        -------
        TwinRun
        """
        runtime.check_target(self.fs)
        x_ref = sample_vector(x_ref, "x_ref")
        n = x_ref.size if n_samples is None else int(n_samples)
        if not 2 <= n <= x_ref.size:
            raise UsageError(f"n_samples must be between 2 and len(x_ref) = {x_ref.size}, got {n_samples!r}")
        check_memory(n * TWIN_SAMPLE_BYTES, f"a twin run of {n / self.fs:g} s at {self.fs:g} Hz ({n:,} samples)")
        d2 = np.zeros(n) if d2 is None else sample_vector(d2, "d2", n)
        r = np.zeros(n) if excitation is None else sample_vector(excitation, "excitation", n)
        lead = runtime.preview_samples
        origin = float(x_ref[0])
        x_full = np.r_[np.zeros(lead), x_ref - origin]
        d2 = np.r_[np.full(lead, d2[0]), d2]
        r = np.r_[np.zeros(lead), r]
        total = n + lead
        x1r, x2r, uff = (s[:total] for s in runtime.reference_signals(x_full))
        noise = self._noise(total, seed)
        pitch = np.zeros(total)
        if self.pitch_section is not None:
            from scipy.signal import sosfilt

            pitch = sosfilt(self.pitch_section, d2)
        k_done, status, y1, y2, u, p1, p2 = self._run_loop(runtime, x1r, x2r, uff, r, d2, pitch, noise, engine)
        m = min(k_done + 1, total)
        tripped = k_done < total
        msg = ""
        if tripped:
            msg = self._trip_message(status, (k_done - lead) / self.fs, x1r[k_done] - y1[k_done],
                                     x2r[k_done] - y2[k_done])
        t = (np.arange(m) - lead) / self.fs
        return TwinRun(t, y1[:m] + origin, y2[:m] + origin, p1[:m] + origin, p2[:m] + origin, u[:m],
                       x1r[:m] + origin, x2r[:m] + origin, tripped, msg, n, lead)

    def _noise(self, n: int, seed: int | None) -> tuple[np.ndarray, np.ndarray]:
        sigma = self.params.noise_m / self.lead
        if sigma == 0:
            return np.zeros(n), np.zeros(n)
        rng = np.random.default_rng(seed)
        return sigma * rng.standard_normal(n), sigma * rng.standard_normal(n)

    def _trip_message(self, status: int, t: float, e1: float, e2: float) -> str:
        p = self.params
        env = p.envelope_m
        if status == 3:
            return f"run stopped at t = {t:.6g} s: the command became non-finite"
        if status == 2:
            return (f"overload trip at t = {t:.6g} s: the RMS command over {p.overload_tau_s:g} s exceeded "
                    f"{p.overload_rms:g} V (drive I2t protection; is the controller unstable on this drive?)")
        which, e = ("table", e2) if not abs(e1) > abs(e2) else ("motor", e1)
        return (f"following-error trip at t = {t:.6g} s: {which} error {abs(e) * self.lead * 1e3:.4g} mm "
                f"left the safety envelope of {env * 1e3:.4g} mm (is the controller unstable on this drive?)")

    def _run_loop(self, runtime, x1r, x2r, uff, r, d2, pitch, noise, engine):
        """Call the closed loop with numpy arrays (numba) or lists (plain Python); same arguments."""
        p = self.params
        lc = runtime.loop_constants()
        n = x1r.size
        h = 1.0 / (p.fs * p.substeps)
        env = p.envelope_m / self.lead
        q = p.quantization_m / self.lead
        u_max = np.inf if p.u_max is None else float(p.u_max)
        fr = _friction_vector(p)
        cap = np.array([max(fr[2], -fr[4]), max(fr[9], -fr[11])])
        stop_v = 2.0 * cap * np.array([self.B[2, 1], self.B[3, 2]]) * h
        ns = self.n_states
        vectors = (self.Ad_sub.ravel(), self.Bd_sub.ravel(), self.A[2:4].ravel(), self.B[2:4].ravel())
        args = [*vectors, h, stop_v, ns, p.substeps, np.zeros(ns), np.zeros(ns), x1r, x2r, uff, r, d2, pitch,
                noise[0], noise[1], lc.gains, runtime.fs, lc.filter_pack.ravel(), new_state(lc.filter_pack.shape[0]),
                lc.filter_pack.shape[0], p.delay_samples, fr, q, q, u_max, env, env,
                1.0 - math.exp(-1.0 / (p.fs * p.overload_tau_s)),
                np.inf if p.overload_rms is None else p.overload_rms**2, np.zeros(1)]
        outs = [np.zeros(n) for _ in range(5)]
        if choose_engine(engine) == "numba":
            k = _compiled_loop()(*args, *outs)
            return (int(k), int(args[-1][0]), *outs)
        py_args = [a.tolist() if isinstance(a, np.ndarray) else a for a in args]
        py_outs = [[0.0] * n for _ in range(5)]
        k = _closed_loop(*py_args, *py_outs)
        return (int(k), int(py_args[-1][0]), *(np.asarray(o) for o in py_outs))

