"""Digital twin of the thesis's linear-motor T-gantry (§4.2-4.3): the identified model plus what it lacks.

The twin is the yaw model of eq. 4.1-4.4 with the table-position dependent inertia of eq. 4.16
(:class:`~feedtune.models.gantry.GantryModel`, positions in m, commands and forces in V, the thesis's
control-signal equivalents) plus

* the **x-axis table** (mass ``m_x``, its own linear motor, position ``x`` along the beam): ``x`` sets
  ``alpha(x)`` and ``J(x)`` of the gantry; the reaction of the x motor force ``f_x`` turns the gantry by the
  torque ``-x_reaction_arm_m * f_x`` [V m] (its line of action is offset from the gantry's guideway);
* lightly damped **structural modes** in the motor-to-encoder paths (320 Hz, unattributed in the thesis,
  the 382 Hz bending of the beam about z, both ends in phase, and a mode at 940 Hz that the thesis' filter
  pack notches): modal coordinates ``eta`` driven by the generalised forces, read by the encoders with their
  mode shapes; the **x axis** has its own modes (186, 332, 404 Hz, where the thesis' x notches are);
* **amplifiers**: a 2nd-order low-pass from command to force per motor (``amp_hz`` for the y motors, off by
  default; ``x_amp_hz`` for the x motor, calibrated to the lead the thesis needed at 130 Hz, eq. 4.17);
* the **216 Hz pitching mode** of the gantry, excited only by forces on the table (rope, cutting force), not
  by the motors (they act at the CoM height, §4.3.3): it deflects the table relative to the beam (static
  compliance 1/32.5 N/um, §4.5) and the encoders see a fraction of it;
* a **machine-base mode** near 23 Hz (§4.5): the reaction ``-(f1 + f2)`` of the y motors and a random floor
  force drive the base; the encoders and the interferometer measure relative to it;
* **encoder quantization** (4 um signal period interpolated 1024 times) and noise, **PWM-like white noise**
  on every motor force, **command saturation** (+-10 V), 15 kHz sampling and one sample of computational
  delay (the command computed from the readings at sample ``k`` is held from sample ``k + 1``).

Coordinates: ``y1``, ``y2`` (left/right encoders) relative to the base [m]; the base ``yb`` absolute [m];
``x`` [m] the table. With ``f = [f1, f2]`` the motor forces, ``tau`` the x-reaction torque and ``F_t`` the
table force, the generalised forces on ``(y1, y2)`` are ``g = f + tau/L [-1, 1] + F_t w(x)`` with the
lever weights ``w(x) = [1 - p/L, p/L]`` of the table at ``p = table_offset + x`` from the left actuator, and
(eq. 4.3)::

    f_i'' + 2 zeta_a w_a f_i' + w_a^2 f_i = w_a^2 c_i          (amplifiers; f_i = c_i without them)
    M(x) (y'' + [1, 1] yb'') + C y' + K y = g
    m_b yb'' + c_b yb' + k_b yb = -(f1 + f2) + F_floor
    eta_r'' + 2 zeta_r w_r eta_r' + w_r^2 eta_r = (gain_r / m) phi_r . g
    q'' + 2 zeta_p w_p q' + w_p^2 q = w_p^2 C_t F_t
    m_x x'' = fx,   xi_j'' + 2 zeta_j w_j xi_j' + w_j^2 xi_j = (gain_j / m_x) phi_motor,j fx

with ``c_i`` the commands (after the computational delay, plus PWM noise) and ``tau = -x_reaction_arm_m fx``.
Encoders read ``y_i + sum_r phi_ri eta_r + frac w_i(x) q`` and ``x + sum_j phi_encoder,j xi_j`` (plus noise,
quantized); the interferometer on the table reads ``w(x) . y + q``.

Integration: the 28 linear states (:data:`STATE_NAMES`, the x axis included) are discretized exactly for inputs
held over a sample (``expm`` of the augmented matrix) at every point of a grid in ``x`` (``x_min_m .. x_max_m``
in steps of ``x_grid_m``, 5 mm by default: 201 points over +-0.5 m), and the step uses the matrices linearly
interpolated at the table's current position (``x`` changes slowly against the sample rate; the terms
proportional to ``x'`` that a moving mass adds are neglected; the x-axis rows do not depend on ``x``). The step
multiplies ``[Ad Bd]`` by the states and inputs over its non-zero entries only, in blocks of four rows, and
interpolates only the entries that depend on ``x`` (:class:`_Tables`). One function (compiled by numba when
installed, the same code in plain Python otherwise) advances the plant by one sample; with the runtimes of gains
files, plant and both laws run in one compiled loop (well over 100 times real time at 15 kHz), other controllers
cost one Python call of their ``step`` per sample plus a few microseconds.

Every value is a field of :class:`GantryTwinParams` (``with_overrides`` takes ``name=value`` strings); the
seed makes noise repeatable; a following-error envelope, an I2t overload limit and the table's travel stop
a run with a clear message.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace

import numpy as np

from ..._kernel_cache import PendingKernel
from ...budget import TWIN_SAMPLE_BYTES, check_memory
from ...errors import DataError, UsageError
from ...lti import zoh
from ...models.gantry import PARAM_NAMES as MODEL_PARAMS
from ...models.gantry import THESIS_GANTRY, GantryModel
from ...sim.engine import choose_engine, kernel, sample_vector
from ...sim.params import finite_param, non_negative_param, parse_override_value, positive_param

STATE_NAMES = ("y1", "y2", "v1", "v2", "yb", "vb", "eta320", "eta320_dot", "eta382", "eta382_dot", "q", "q_dot",
               "eta940", "eta940_dot", "f1", "f1_dot", "f2", "f2_dot",
               "x", "vx", "xi186", "xi186_dot", "xi332", "xi332_dot", "xi404", "xi404_dot", "fx", "fx_dot")
INPUT_NAMES = ("u1", "u2", "ux", "F_table", "F_floor")
N_STATES = len(STATE_NAMES)
N_INPUTS = len(INPUT_NAMES)
# first state of each block (see STATE_NAMES)
I_MODE = {"mode320": 6, "bending": 8, "mode940": 12}
I_AMP = (14, 16, 26)  # amplifier of u1, u2, ux: force and its rate
I_X = 18
I_XMODE = {"x_mode186": 20, "x_mode332": 22, "x_mode404": 24}
Y_MODES = tuple(I_MODE)
X_MODES = tuple(I_XMODE)
MODE_FIELDS = Y_MODES + X_MODES
# record columns of the kernel
REC = ("y1", "y2", "x", "u1", "u2", "ux", "y1_true", "y2_true", "x_true", "y_table", "y_base")
N_REC = len(REC)
N_NOISE = 6  # encoder y1, y2, x; command (PWM) noise u1, u2, ux
N_EXT = 5  # table force, floor force, excitation on u1, u2, ux
TRAVEL_TOL_M = 1e-3


# ------------------------------------------------------------------------------------------ parameters
@dataclass(frozen=True)
class StructuralMode:
    """A lightly damped mode in the motor-to-encoder paths, in modal form.

    Parameters
    ----------
    freq_hz : float
        Natural frequency [Hz].
    zeta : float
        Damping ratio [-].
    gain : float
        Total gantry mass over the modal mass, ``m / m_r`` [-]: at resonance the mode adds
        ``gain * phi_i phi_j / (2 zeta)`` times the rigid-body response ``1 / (m w^2)`` to ``y_i / u_j``.
    shape : (float, float)
        Mode shape at the left and right encoder/actuator [-].
    """

    freq_hz: float
    zeta: float = 0.02
    gain: float = 0.05
    shape: tuple[float, float] = (1.0, 1.0)

    def __post_init__(self) -> None:
        positive_param(self.freq_hz, "mode freq_hz", "Hz")
        non_negative_param(self.zeta, "mode zeta")
        non_negative_param(self.gain, "mode gain")
        try:
            a, b = (float(v) for v in self.shape)
        except (TypeError, ValueError):
            raise UsageError(f"mode shape must be two numbers (left, right), got {self.shape!r}") from None
        if not (math.isfinite(a) and math.isfinite(b)):
            raise UsageError(f"mode shape must be finite, got {self.shape!r}")
        object.__setattr__(self, "shape", (a, b))

    def to_dict(self) -> dict:
        """JSON-ready dict (Hz, -)."""
        return {"freq_hz": self.freq_hz, "zeta": self.zeta, "gain": self.gain, "shape": list(self.shape)}


@dataclass(frozen=True)
class GantryTwinParams:
    """Every parameter of the gantry twin (defaults: the thesis's T-gantry, §4.2-4.5).

    Parameters
    ----------
    model : GantryModel
        Eq. 4.16 (``m, L, J0, d, m_x, c, k, alpha1_0, dalpha1_dx``) [V, m, s]; ``m_x`` is also the x-axis mass.
    force_constant_n_per_v : float
        Motor force per volt of command [N/V] (assumed, the thesis gives forces in V); converts the rope
        force and the machine compliance given in N.
    table_offset_m : float or None
        Distance from the left actuator to the table at ``x = 0`` [m]; None: ``L / 2`` (the centre).
    x_min_m, x_max_m : float
        Travel of the table [m]; also the range of the discretization grid. Leaving it stops the run.
    x_grid_m : float
        Spacing of the grid in ``x`` on which the discrete matrices are precomputed [m].
    mode320, bending, mode940 : StructuralMode or None
        y modes in the motor-to-encoder paths: the 320 Hz mode (shape assumed ``(1, -0.6)``), the 382 Hz beam
        bending (ends in phase, ``(1, 1)``) and the mode near 940 Hz that the thesis' filter pack notches
        (shape assumed). ``shape`` is (left, right).
    x_mode186, x_mode332, x_mode404 : StructuralMode or None
        x-axis modes at the frequencies the thesis' x notches address (§4.4.1); ``gain`` is ``m_x`` over the
        modal mass and ``shape`` is (at the x motor, at the x encoder): a negative product is a mode the
        encoder sees in antiphase to the motor (non-collocated).
    amp_hz, amp_zeta : float or None, float
        Current loops of the two y amplifiers: a 2nd-order low-pass from command to force, natural frequency
        [Hz] and damping ratio [-]; None: ideal amplifiers.
    x_amp_hz, x_amp_zeta : float or None, float
        The same for the x motor's amplifier [Hz, -].
    pitch_hz : float or None
        Pitching mode [Hz], excited only by table forces; None: none.
    pitch_zeta : float
        Its damping ratio [-].
    table_compliance_m_per_n : float
        Static deflection of the table per table force [m/N] (thesis: 32.5 N/um).
    pitch_encoder_fraction : float
        Fraction of the table's pitching deflection the encoders see [-].
    base_hz : float or None
        Machine-base mode [Hz]; None: rigid base.
    base_zeta : float
        Its damping ratio [-].
    base_mass_ratio : float
        Base mass over the gantry mass ``m`` [-].
    floor_m : float
        RMS base displacement caused by the random floor force [m].
    x_reaction_arm_m : float
        Arm of the x motor's reaction torque on the gantry [m].
    pwm_noise_v : float
        RMS white noise on every motor force, per sample [V].
    quantization_m : float
        Encoder resolution [m] (all three encoders; 0: none).
    noise_m : float
        RMS white encoder noise [m].
    u_max : float or None
        Command saturation [V]; None: none.
    fs : float
        Sample rate [Hz].
    delay_samples : int
        Computational delay [samples].
    envelope_m : float
        Following-error trip: ``|y_ref - y1|``, ``|y_ref - y2|`` or ``|x_ref - x|`` above this stops the run [m].
    overload_rms : float or None
        I2t trip: a first-order mean of ``u^2`` of any motor above ``overload_rms^2`` stops the run [V].
    overload_tau_s : float
        Time constant of that mean [s].
    """

    model: GantryModel = THESIS_GANTRY
    force_constant_n_per_v: float = 30.0
    table_offset_m: float | None = None
    x_min_m: float = -0.5
    x_max_m: float = 0.5
    x_grid_m: float = 0.005
    mode320: StructuralMode | None = StructuralMode(320.0, 0.02, 0.05, (1.0, -0.6))
    bending: StructuralMode | None = StructuralMode(382.0, 0.015, 0.05, (1.0, 1.0))
    mode940: StructuralMode | None = StructuralMode(940.0, 0.02, 0.05, (1.0, 1.0))
    x_mode186: StructuralMode | None = StructuralMode(186.0, 0.1, 0.04, (1.0, 1.0))
    x_mode332: StructuralMode | None = StructuralMode(332.0, 0.03, 0.2, (1.0, 1.0))
    x_mode404: StructuralMode | None = StructuralMode(404.0, 0.03, 0.2, (1.0, 1.0))
    amp_hz: float | None = None
    amp_zeta: float = 0.7
    x_amp_hz: float | None = 360.0
    x_amp_zeta: float = 0.7
    pitch_hz: float | None = 216.0
    pitch_zeta: float = 0.03
    table_compliance_m_per_n: float = 1.0 / 32.5e6
    pitch_encoder_fraction: float = 0.1
    base_hz: float | None = 23.0
    base_zeta: float = 0.05
    base_mass_ratio: float = 30.0
    floor_m: float = 5e-9
    x_reaction_arm_m: float = 0.05
    pwm_noise_v: float = 0.005
    quantization_m: float = 4e-6 / 1024
    noise_m: float = 1e-9
    u_max: float | None = 10.0
    fs: float = 15000.0
    delay_samples: int = 1
    envelope_m: float = 0.5e-3
    overload_rms: float | None = 7.0
    overload_tau_s: float = 0.1

    def __post_init__(self) -> None:
        if not isinstance(self.model, GantryModel):
            raise UsageError("twin parameter model must be a GantryModel")
        for name in ("force_constant_n_per_v", "x_grid_m", "fs", "envelope_m", "overload_tau_s",
                     "base_mass_ratio"):
            positive_param(getattr(self, name), name, "")
        for name in ("pitch_hz", "base_hz", "u_max", "overload_rms", "table_offset_m", "amp_hz",
                     "x_amp_hz"):
            if getattr(self, name) is not None:
                positive_param(getattr(self, name), name, "")
        for name in ("pitch_zeta", "table_compliance_m_per_n", "pitch_encoder_fraction", "base_zeta", "floor_m",
                     "pwm_noise_v", "quantization_m", "noise_m", "amp_zeta", "x_amp_zeta"):
            non_negative_param(getattr(self, name), name)
        for name in ("x_min_m", "x_max_m", "x_reaction_arm_m"):
            finite_param(getattr(self, name), name)
        if not self.x_min_m < self.x_max_m:
            raise UsageError(f"twin parameters need x_min_m < x_max_m, got {self.x_min_m:g} .. {self.x_max_m:g} m")
        if self.x_grid_m > (self.x_max_m - self.x_min_m) / 2:
            raise UsageError(f"twin parameter x_grid_m = {self.x_grid_m:g} m is too coarse for the travel "
                             f"{self.x_min_m:g} .. {self.x_max_m:g} m")
        d = self.delay_samples
        if isinstance(d, bool) or int(d) != d or d < 0:
            raise UsageError(f"twin parameter delay_samples must be an integer >= 0, got {d!r}")
        object.__setattr__(self, "delay_samples", int(d))
        for name in MODE_FIELDS:
            mode = getattr(self, name)
            if mode is not None and not isinstance(mode, StructuralMode):
                raise UsageError(f"twin parameter {name} must be a StructuralMode or None")
            if mode is not None and mode.freq_hz >= self.fs / 2:
                raise UsageError(f"twin parameter {name}.freq_hz = {mode.freq_hz:g} Hz is above the Nyquist "
                                 f"frequency {self.fs / 2:g} Hz")
        for name in ("amp_hz", "x_amp_hz"):
            v = getattr(self, name)
            if v is not None and v >= self.fs / 2:
                raise UsageError(f"twin parameter {name} = {v:g} Hz is above the Nyquist frequency {self.fs / 2:g} Hz")
        for x in (self.x_min_m, self.x_max_m):
            self.model.alpha(x)  # UsageError when the travel puts the CoM outside the span

    @classmethod
    def ideal(cls, model: GantryModel = THESIS_GANTRY, fs: float = 15000.0, delay_samples: int = 1
              ) -> GantryTwinParams:
        """Eq. 4.16 alone: no structural, pitching or base modes, ideal amplifiers, no noise, quantization or
        saturation; the x axis a pure mass."""
        return cls(model=model, mode320=None, bending=None, mode940=None, x_mode186=None, x_mode332=None,
                   x_mode404=None, amp_hz=None, x_amp_hz=None, pitch_hz=None, base_hz=None, floor_m=0.0,
                   x_reaction_arm_m=0.0, pwm_noise_v=0.0, quantization_m=0.0, noise_m=0.0, u_max=None, fs=fs,
                   delay_samples=delay_samples, overload_rms=None)

    @property
    def table_offset(self) -> float:
        """Distance from the left actuator to the table at ``x = 0`` [m]."""
        return self.model.L / 2 if self.table_offset_m is None else float(self.table_offset_m)

    @property
    def rope_v_per_n(self) -> float:
        """Command-equivalent force per newton [V/N]."""
        return 1.0 / self.force_constant_n_per_v

    def x_grid(self) -> np.ndarray:
        """The table positions [m] at which the discrete matrices are precomputed."""
        n = max(2, round((self.x_max_m - self.x_min_m) / self.x_grid_m) + 1)
        return np.linspace(self.x_min_m, self.x_max_m, n)

    def with_overrides(self, overrides: dict) -> GantryTwinParams:
        """A copy with parameters replaced from ``{"name": value}`` (values may be strings).

        Names: the fields of this class; the model parameters ``m L J0 d m_x c k alpha1_0 dalpha1_dx``;
        a mode (``mode320``, ``bending``, ``mode940``, ``x_mode186``, ``x_mode332``, ``x_mode404``) = ``none``,
        or ``mode320.freq_hz``, ``.zeta``, ``.gain``, ``.shape`` (``shape=1,-0.6``); ``pitch_hz``, ``base_hz``,
        ``amp_hz``, ``x_amp_hz``, ``u_max``, ``overload_rms`` = ``none`` switch those off.
        """
        p = self
        for key, raw in overrides.items():
            p = _override(p, str(key).strip(), raw)
        return p

    def to_dict(self) -> dict:
        """JSON-ready parameters with units."""
        out: dict = {"model": self.model.params()}
        for f in fields(self):
            if f.name == "model":
                continue
            v = getattr(self, f.name)
            out[f.name] = v.to_dict() if isinstance(v, StructuralMode) else v
        out["table_offset_m"] = self.table_offset
        out["units"] = {
            "model": "V, m, s (eq. 4.16 units)", "force_constant_n_per_v": "N/V", "table_offset_m": "m",
            "x_min_m": "m", "x_max_m": "m", "x_grid_m": "m", **dict.fromkeys(MODE_FIELDS, "Hz, -, -, -"),
            "amp_hz": "Hz", "amp_zeta": "-", "x_amp_hz": "Hz", "x_amp_zeta": "-",
            "pitch_hz": "Hz", "pitch_zeta": "-", "table_compliance_m_per_n": "m/N", "pitch_encoder_fraction": "-",
            "base_hz": "Hz", "base_zeta": "-", "base_mass_ratio": "-", "floor_m": "m (RMS)",
            "x_reaction_arm_m": "m", "pwm_noise_v": "V (RMS)", "quantization_m": "m", "noise_m": "m (RMS)",
            "u_max": "V", "fs": "Hz", "delay_samples": "samples", "envelope_m": "m", "overload_rms": "V",
            "overload_tau_s": "s"}
        return out


def _override_mode(p: GantryTwinParams, key: str, raw) -> GantryTwinParams:
    base, _, attr = key.partition(".")
    if not attr:
        if parse_override_value(raw, key) is not None:
            raise UsageError(f"twin parameter {key} can only be set to 'none' (or set {key}.freq_hz etc.)")
        return replace(p, **{base: None})
    mode = getattr(p, base) or getattr(GantryTwinParams(), base)
    if attr == "shape":
        try:
            value = tuple(float(v) for v in str(raw).split(","))
        except ValueError:
            raise UsageError(f"twin parameter {key}: expected LEFT,RIGHT numbers, got {raw!r}") from None
        if len(value) != 2:
            raise UsageError(f"twin parameter {key}: expected two numbers LEFT,RIGHT, got {raw!r}")
    elif attr in ("freq_hz", "zeta", "gain"):
        value = parse_override_value(raw, key)
        if value is None:
            raise UsageError(f"twin parameter {key} needs a number")
    else:
        raise UsageError(f"twin parameter {key}: expected {base}.freq_hz|zeta|gain|shape")
    return replace(p, **{base: replace(mode, **{attr: value})})


def _override(p: GantryTwinParams, key: str, raw) -> GantryTwinParams:
    names = {f.name for f in fields(GantryTwinParams)} - {"model"}
    if key in MODEL_PARAMS:
        value = parse_override_value(raw, key)
        if value is None:
            raise UsageError(f"twin parameter {key} needs a number")
        try:
            return replace(p, model=replace(p.model, **{key: float(value)}))
        except DataError as exc:
            raise UsageError(f"twin parameter {key}: {exc}") from None
    if key.split(".")[0] in MODE_FIELDS:
        return _override_mode(p, key, raw)
    if key not in names:
        known = sorted(names | set(MODEL_PARAMS) | {"mode320.{freq_hz,zeta,gain,shape}", "bending.{...}"})
        raise UsageError(f"unknown twin parameter {key!r}; known: {', '.join(known)}")
    return replace(p, **{key: parse_override_value(raw, key)})


# ------------------------------------------------------------------------------------------ state space
def table_weights(p: GantryTwinParams, x):
    """Lever weights ``(1 - s, s)``, ``s = (table_offset + x) / L``, of the table between the actuators [-].

    ``x`` [m] may be a number or an array (the weights are then arrays).
    """
    s = (p.table_offset + (float(x) if np.ndim(x) == 0 else np.asarray(x, float))) / p.model.L
    return 1.0 - s, s


def continuous_system(p: GantryTwinParams, x: float) -> tuple[np.ndarray, np.ndarray]:
    """``(A, B)`` of the linear states (:data:`STATE_NAMES`) at table position ``x`` [m].

    Inputs (:data:`INPUT_NAMES`): the commands ``u1, u2, ux`` [V] as they reach the amplifiers (PWM noise
    included), the table force ``F_table`` [V] (positive +y) and the floor force on the base ``F_floor`` [V].
    With ``amp_hz`` (``x_amp_hz``) the motor forces are the states ``f1, f2`` (``fx``), a 2nd-order low-pass of
    the commands, otherwise the commands themselves. The x motor's reaction turns the gantry by
    ``-x_reaction_arm_m fx``.
    """
    model = p.model
    at = model.at(x)
    L = model.L
    w1, w2 = table_weights(p, x)
    A = np.zeros((N_STATES, N_STATES))
    B = np.zeros((N_STATES, N_INPUTS))
    # motor forces f1, f2, fx as rows on the states (amplifier outputs) or on the inputs (ideal amplifiers)
    force_s = np.zeros((3, N_STATES))
    force_i = np.zeros((3, N_INPUTS))
    for j, i in enumerate(I_AMP):
        hz, zeta = (p.amp_hz, p.amp_zeta) if j < 2 else (p.x_amp_hz, p.x_amp_zeta)
        if hz is None:
            force_i[j, j] = 1.0
            continue
        wa = 2 * np.pi * hz
        force_s[j, i] = 1.0
        A[i, i + 1] = 1.0
        A[i + 1, i] = -(wa**2)
        A[i + 1, i + 1] = -2 * zeta * wa
        B[i + 1, j] = wa**2
    # generalised forces on (y1, y2): g = Gs z + Gi u = f + tau/L [-1, 1] + F_t w(x), tau = -arm fx
    tau_dir = -p.x_reaction_arm_m / L * np.array([-1.0, 1.0])
    Gs = force_s[:2] + np.outer(tau_dir, force_s[2])
    Gi = force_i[:2] + np.outer(tau_dir, force_i[2])
    Gi[:, 3] = (w1, w2)
    if p.base_hz is not None:
        mb = p.base_mass_ratio * model.m
        wb = 2 * np.pi * p.base_hz
        A[4, 5] = 1.0
        A[5, 4] = -(wb**2)
        A[5, 5] = -2 * p.base_zeta * wb
        A[5] -= (force_s[0] + force_s[1]) / mb  # reaction of the y motors
        B[5] -= (force_i[0] + force_i[1]) / mb
        B[5, 4] += 1.0 / mb
    Minv = np.linalg.inv(at.M)
    A[0, 2] = A[1, 3] = 1.0
    A[2:4, 0:2] = -Minv @ at.K
    A[2:4, 2:4] = -Minv @ at.C
    A[2:4] += Minv @ Gs
    B[2:4] += Minv @ Gi
    A[2:4] -= A[5]  # relative coordinates: minus the base acceleration
    B[2:4] -= B[5]
    for name, j in I_MODE.items():
        mode = getattr(p, name)
        if mode is None:
            continue
        _modal_rows(A, j, mode)
        phi = np.asarray(mode.shape)
        A[j + 1] += mode.gain / model.m * (phi @ Gs)
        B[j + 1] += mode.gain / model.m * (phi @ Gi)
    if p.pitch_hz is not None:
        wp = 2 * np.pi * p.pitch_hz
        A[10, 11] = 1.0
        A[11, 10] = -(wp**2)
        A[11, 11] = -2 * p.pitch_zeta * wp
        B[11, 3] = wp**2 * p.table_compliance_m_per_n * p.force_constant_n_per_v
    # x axis: the table m_x x'' = fx and its modes, driven by the x motor
    A[I_X, I_X + 1] = 1.0
    A[I_X + 1] += force_s[2] / model.m_x
    B[I_X + 1] += force_i[2] / model.m_x
    for name, j in I_XMODE.items():
        mode = getattr(p, name)
        if mode is None:
            continue
        _modal_rows(A, j, mode)
        A[j + 1] += mode.gain / model.m_x * mode.shape[0] * force_s[2]
        B[j + 1] += mode.gain / model.m_x * mode.shape[0] * force_i[2]
    return A, B


def _modal_rows(A: np.ndarray, j: int, mode: StructuralMode) -> None:
    """``eta'' + 2 zeta w eta' + w^2 eta`` in rows ``j, j + 1``."""
    w = 2 * np.pi * mode.freq_hz
    A[j, j + 1] = 1.0
    A[j + 1, j] = -(w**2)
    A[j + 1, j + 1] = -2 * mode.zeta * w


def encoder_matrix(p: GantryTwinParams, x: float) -> np.ndarray:
    """Rows ``y1``, ``y2`` of the encoder readings (without noise and quantization) on the states."""
    C = np.zeros((2, N_STATES))
    C[0, 0] = C[1, 1] = 1.0
    w = table_weights(p, x)
    for i in range(2):
        for name, j in I_MODE.items():
            mode = getattr(p, name)
            if mode is not None:
                C[i, j] = mode.shape[i]
        C[i, 10] = p.pitch_encoder_fraction * w[i]
    return C


def axis_encoder_row(p: GantryTwinParams) -> np.ndarray:
    """The x encoder reading (without noise and quantization) on the states: table plus its modes."""
    c = np.zeros(N_STATES)
    c[I_X] = 1.0
    for name, j in I_XMODE.items():
        mode = getattr(p, name)
        if mode is not None:
            c[j] = mode.shape[1]
    return c


def floor_force_rms(p: GantryTwinParams) -> float:
    """RMS of the white floor force per sample [V] that moves the (free) base by ``floor_m`` RMS."""
    if p.base_hz is None or p.floor_m == 0:
        return 0.0
    from scipy.linalg import solve_discrete_lyapunov

    mb = p.base_mass_ratio * p.model.m
    wb = 2 * np.pi * p.base_hz
    A = np.array([[0.0, 1.0], [-(wb**2), -2 * p.base_zeta * wb]])
    Ad, Bd = zoh(A, np.array([[0.0], [1.0 / mb]]), 1.0 / p.fs)
    P = solve_discrete_lyapunov(Ad, Bd @ Bd.T)
    return p.floor_m / math.sqrt(P[0, 0])


# ------------------------------------------------------------------------------------------ the kernel
# indices into the parameter vector of the kernel
(P_XMIN, P_INV_DX, P_NGRID, P_L, P_OFFSET, P_FRAC, P_PA1, P_PA2, P_PB1, P_PB2, P_PC1, P_PC2, P_XE1, P_XE2, P_XE3, P_Q,
 P_UMAX, P_ENV, P_I2T_A, P_I2T_LIM, P_DELAY, P_ORIGIN, P_XLO, P_XHI) = range(24)
N_PAR = 24
_IX = I_X
_IM1, _IM2, _IM3 = I_MODE["mode320"], I_MODE["bending"], I_MODE["mode940"]
_IX1, _IX2, _IX3 = I_XMODE["x_mode186"], I_XMODE["x_mode332"], I_XMODE["x_mode404"]
_NS = N_STATES
_NI = N_INPUTS
_RB = 4  # rows per block of the step's matrix product


def _measure(k, z, par, noise, rec):
    """Encoder readings at sample ``k`` from the state (noise added, quantized); recorded in ``rec``."""
    x = z[_IX]
    s = (par[P_OFFSET] + x) / par[P_L]
    w1 = 1.0 - s
    q = z[10]
    frac = par[P_FRAC]
    y1t = z[0] + par[P_PA1] * z[_IM1] + par[P_PB1] * z[_IM2] + par[P_PC1] * z[_IM3] + frac * w1 * q
    y2t = z[1] + par[P_PA2] * z[_IM1] + par[P_PB2] * z[_IM2] + par[P_PC2] * z[_IM3] + frac * s * q
    xt = x + par[P_XE1] * z[_IX1] + par[P_XE2] * z[_IX2] + par[P_XE3] * z[_IX3]
    origin = par[P_ORIGIN]
    y1 = origin + y1t + noise[k * 6]
    y2 = origin + y2t + noise[k * 6 + 1]
    xm = xt + noise[k * 6 + 2]
    res = par[P_Q]
    if res > 0.0:
        y1 = math.floor(y1 / res + 0.5) * res
        y2 = math.floor(y2 / res + 0.5) * res
        xm = math.floor(xm / res + 0.5) * res
    o = k * 11
    rec[o] = y1
    rec[o + 1] = y2
    rec[o + 2] = xm
    rec[o + 6] = origin + z[0]
    rec[o + 7] = origin + z[1]
    rec[o + 8] = x
    rec[o + 9] = origin + w1 * z[0] + s * z[1] + q
    rec[o + 10] = z[4]
    return y1, y2, xm


def _step(k, u1, u2, ux, z, znew, buf, work, par, noise, ext, ref, rec, cptr, ccol, cval, vptr, vcol, vtab,
          vdif):
    """Apply the commands computed at sample ``k`` and advance the plant to sample ``k + 1``.

    ``z``: the states, then the inputs held over the sample (written here); ``znew``: scratch of the padded rows;
    ``cptr .. vdif``: the blocked ``[Ad Bd]`` of :class:`_Tables` (the products are written for :data:`_RB` = 4).

    Returns a status: 0 running, 1 following-error envelope, 2 I2t overload, 3 non-finite command, 4 the
    table left its travel (sample ``k`` is recorded; the plant is not advanced).
    """
    o = k * 5
    c1 = u1 + ext[o + 2]
    c2 = u2 + ext[o + 3]
    cx = ux + ext[o + 4]
    umax = par[P_UMAX]
    r = k * 11
    if not (abs(c1) <= 1e300 and abs(c2) <= 1e300 and abs(cx) <= 1e300):
        rec[r + 3] = 0.0
        rec[r + 4] = 0.0
        rec[r + 5] = 0.0
        return 3
    c1 = min(max(c1, -umax), umax)
    c2 = min(max(c2, -umax), umax)
    cx = min(max(cx, -umax), umax)
    rec[r + 3] = c1
    rec[r + 4] = c2
    rec[r + 5] = cx
    d = int(par[P_DELAY])
    nb = d + 1
    j = (k % nb) * 3
    buf[j] = c1
    buf[j + 1] = c2
    buf[j + 2] = cx
    a = par[P_I2T_A]
    work[0] += (c1 * c1 - work[0]) * a
    work[1] += (c2 * c2 - work[1]) * a
    work[2] += (cx * cx - work[2]) * a
    env = par[P_ENV]
    yr = ref[2 * k]
    xr = ref[2 * k + 1]
    if not (abs(yr - rec[r]) <= env and abs(yr - rec[r + 1]) <= env and abs(xr - rec[r + 2]) <= env):
        return 1
    lim = par[P_I2T_LIM]
    if work[0] > lim or work[1] > lim or work[2] > lim:
        return 2
    x = z[_IX]
    if x < par[P_XLO] or x > par[P_XHI]:
        return 4
    f1 = 0.0
    f2 = 0.0
    fx = 0.0
    if k >= d:
        j = ((k - d) % nb) * 3
        f1 = buf[j]
        f2 = buf[j + 1]
        fx = buf[j + 2]
    n = _NS
    z[n] = f1 + noise[k * 6 + 3]
    z[n + 1] = f2 + noise[k * 6 + 4]
    z[n + 2] = fx + noise[k * 6 + 5]
    z[n + 3] = ext[o]
    z[n + 4] = ext[o + 1]
    # [Ad Bd] [z; u] in blocks of 4 rows (_Tables): the constant columns, then the varying ones interpolated
    # between the grid points around the table
    ng = int(par[P_NGRID])
    sx = (x - par[P_XMIN]) * par[P_INV_DX]
    i = int(sx) if sx > 0.0 else 0
    if i > ng - 2:
        i = ng - 2
    w = min(max(sx - i, 0.0), 1.0)
    ov = i * 4 * len(vcol)
    for blk in range(len(cptr) - 1):
        a0 = 0.0
        a1 = 0.0
        a2 = 0.0
        a3 = 0.0
        for j in range(cptr[blk], cptr[blk + 1]):
            zc = z[ccol[j]]
            q = 4 * j
            a0 += cval[q] * zc
            a1 += cval[q + 1] * zc
            a2 += cval[q + 2] * zc
            a3 += cval[q + 3] * zc
        for j in range(vptr[blk], vptr[blk + 1]):
            zc = z[vcol[j]]
            q = ov + 4 * j
            a0 += (vtab[q] + w * vdif[q]) * zc
            a1 += (vtab[q + 1] + w * vdif[q + 1]) * zc
            a2 += (vtab[q + 2] + w * vdif[q + 2]) * zc
            a3 += (vtab[q + 3] + w * vdif[q + 3]) * zc
        q = 4 * blk
        znew[q] = a0
        znew[q + 1] = a1
        znew[q + 2] = a2
        znew[q + 3] = a3
    for row in range(n):
        z[row] = znew[row]
    return 0


# ------------------------------------------------------------------------------------------ results
@dataclass(frozen=True)
class GantryRun:
    """One closed-loop run of the gantry twin (all positions [m], commands [V], time [s]).

    The controllers start ``lead_samples`` (their reference preview) before ``t = 0`` with the references
    at rest; those samples have ``t < 0``.

    Attributes
    ----------
    t : ndarray
        Time [s].
    y1, y2, x : ndarray
        Encoder readings (noise, quantization, structural modes and pitching included) [m].
    y1_true, y2_true, x_true : ndarray
        Rigid-body encoder positions relative to the base and the table position [m].
    y_table : ndarray
        Interferometer reading of the table in y: the beam at the table plus the pitching deflection [m].
    y_base : ndarray
        Machine-base displacement [m].
    u1, u2, ux : ndarray
        Commands computed at each sample after saturation, excitation included [V]; applied
        ``delay_samples`` later.
    y_ref, x_ref : ndarray
        References at each sample [m].
    tripped : bool
        A safety limit stopped the run at ``t[-1]``.
    trip_message : str
        Why ("" when it did not stop).
    n_requested : int
        Samples requested from ``t = 0``.
    lead_samples : int
        Samples before ``t = 0``.
    """

    t: np.ndarray
    y1: np.ndarray
    y2: np.ndarray
    x: np.ndarray
    y1_true: np.ndarray
    y2_true: np.ndarray
    x_true: np.ndarray
    y_table: np.ndarray
    y_base: np.ndarray
    u1: np.ndarray
    u2: np.ndarray
    ux: np.ndarray
    y_ref: np.ndarray
    x_ref: np.ndarray
    tripped: bool
    trip_message: str
    n_requested: int
    lead_samples: int = 0

    ARRAYS = ("t", "y1", "y2", "x", "y1_true", "y2_true", "x_true", "y_table", "y_base", "u1", "u2", "ux",
              "y_ref", "x_ref")

    def from_zero(self) -> GantryRun:
        """The samples with ``t >= 0`` (at least one)."""
        k = min(self.lead_samples, self.t.size - 1)
        return replace(self, **{a: getattr(self, a)[k:] for a in self.ARRAYS}, lead_samples=self.lead_samples - k)

    def to_dict(self) -> dict:
        """Summary: duration [s], samples, trip."""
        return {"duration_s": float(self.t[-1]), "n_samples": int(np.sum(self.t >= 0)),
                "n_requested": self.n_requested, "tripped": self.tripped, "trip_message": self.trip_message}


# ------------------------------------------------------------------------------------------ the twin
@dataclass(frozen=True)
class _Tables:
    """The exact ZOH matrices on the position grid, and their sparse form for the per-sample step.

    The plant's blocks (rigid body, yaw, structural, pitching and base modes, x axis) are coupled only where the
    physics couples them, so most entries of ``[Ad Bd]`` are exactly zero at every grid point (153 of 924 are not,
    on the default twin), and of those most do not depend on the position (99). The step multiplies ``[Ad Bd]`` by
    ``[z; u]`` in blocks of :data:`_RB` = 4 consecutive rows (the last padded with zero rows): for each block the
    columns where one of its rows has a non-zero entry, as 4 values each (the block's rows, zeros included), first
    the columns whose values do not depend on the position (``ccol``, values ``cval``, block ``b`` from ``cptr[b]``
    to ``cptr[b + 1]``), then those whose values do (``vcol``, ``vptr``), interpolated per sample from their values
    at each grid point ``vtab`` and the differences to the next one ``vdif`` (flat per grid point: ``4 len(vcol)``
    values). Each row's sum runs over the constant columns, then the varying ones, each in column order; the padded
    zeros add nothing.
    """

    xs: np.ndarray
    Ad: np.ndarray  # (n_grid, n_states, n_states)
    Bd: np.ndarray  # (n_grid, n_states, n_inputs)
    cptr: np.ndarray  # (n_blocks + 1,) int64
    ccol: np.ndarray  # (n_ccol,) int64, columns of [z; u]
    cval: np.ndarray  # (4 n_ccol,)
    vptr: np.ndarray  # (n_blocks + 1,) int64
    vcol: np.ndarray  # (n_vcol,) int64
    vtab: np.ndarray  # (n_grid * 4 n_vcol,)
    vdif: np.ndarray  # (n_grid * 4 n_vcol,)

    @classmethod
    def build(cls, xs: np.ndarray, Ad: np.ndarray, Bd: np.ndarray) -> _Tables:
        """With the blocked sparse form of ``[Ad Bd]`` (see the class docstring)."""
        n_grid, n, _ = Ad.shape
        n_blocks = -(-n // _RB)
        M = np.zeros((n_grid, n_blocks * _RB, n + Bd.shape[2]))
        M[:, :n] = np.concatenate([Ad, Bd], axis=2)
        nonzero = np.any(M != 0.0, axis=0)
        varies = np.any(M != M[:1], axis=0)
        cptr, ccol, vptr, vcol = [0], [], [0], []
        for b in range(n_blocks):
            rows = slice(b * _RB, (b + 1) * _RB)
            var = np.any(varies[rows], axis=0)
            ccol += np.flatnonzero(np.any(nonzero[rows], axis=0) & ~var).tolist()
            vcol += np.flatnonzero(var).tolist()
            cptr.append(len(ccol))
            vptr.append(len(vcol))
        blocks = np.repeat(np.arange(n_blocks), np.diff(cptr))
        cval = np.stack([M[0, b * _RB:(b + 1) * _RB, c] for b, c in zip(blocks, ccol, strict=True)]).ravel() \
            if ccol else np.zeros(0)
        blocks = np.repeat(np.arange(n_blocks), np.diff(vptr))
        vtab = np.stack([M[:, b * _RB:(b + 1) * _RB, c] for b, c in zip(blocks, vcol, strict=True)], axis=1) \
            if vcol else np.zeros((n_grid, 0, _RB))
        vtab = vtab.reshape(n_grid, -1)
        vdif = np.diff(vtab, axis=0, append=vtab[-1:])
        i64 = np.int64
        return cls(xs, Ad, Bd, np.array(cptr, i64), np.array(ccol, i64), np.ascontiguousarray(cval),
                   np.array(vptr, i64), np.array(vcol, i64), np.ascontiguousarray(vtab).ravel(),
                   np.ascontiguousarray(vdif).ravel())

    def interpolated(self, x: float) -> tuple[np.ndarray, np.ndarray]:
        """``(Ad, Bd)`` at table position ``x`` [m] as the step interpolates them: ``M_i + w (M_i+1 - M_i)``."""
        sx = (x - self.xs[0]) * (1.0 / (self.xs[1] - self.xs[0]))
        i = min(int(sx) if sx > 0.0 else 0, self.xs.size - 2)
        w = min(max(sx - i, 0.0), 1.0)
        return self.Ad[i] + w * (self.Ad[i + 1] - self.Ad[i]), self.Bd[i] + w * (self.Bd[i + 1] - self.Bd[i])


class GantryTwin:
    """The gantry twin built from :class:`GantryTwinParams` (see the module docstring).

    Parameters
    ----------
    params : GantryTwinParams, optional
        Defaults to the thesis's gantry.
    """

    def __init__(self, params: GantryTwinParams | None = None) -> None:
        self.params = params or GantryTwinParams()
        self._tables: _Tables | None = None

    @property
    def fs(self) -> float:
        """Sample rate [Hz]."""
        return self.params.fs

    @property
    def model(self) -> GantryModel:
        """The rigid/yaw model of eq. 4.16 inside the twin."""
        return self.params.model

    def tables(self) -> _Tables:
        """Exact ZOH matrices on the grid :meth:`GantryTwinParams.x_grid` (computed once, one BLAS thread)."""
        if self._tables is None:
            from scipy.linalg import expm

            from ...blas import single_threaded_blas

            xs = self.params.x_grid()
            aug = np.zeros((xs.size, N_STATES + N_INPUTS, N_STATES + N_INPUTS))
            for i, x in enumerate(xs):
                aug[i, :N_STATES, :N_STATES], aug[i, :N_STATES, N_STATES:] = continuous_system(self.params, x)
            with single_threaded_blas():
                E = expm(aug / self.fs)  # batched: exact ZOH at every grid point
            self._tables = _Tables.build(xs, np.ascontiguousarray(E[:, :N_STATES, :N_STATES]),
                                         np.ascontiguousarray(E[:, :N_STATES, N_STATES:]))
        return self._tables

    def discrete_system(self, x: float) -> tuple[np.ndarray, np.ndarray]:
        """Exact zero-order-hold ``(Ad, Bd)`` over one sample at table position ``x`` [m]."""
        A, B = continuous_system(self.params, x)
        return zoh(A, B, 1.0 / self.fs)

    def interpolated_system(self, x: float) -> tuple[np.ndarray, np.ndarray]:
        """``(Ad, Bd)`` as the simulation uses them: linear interpolation on the grid at ``x`` [m]."""
        return self.tables().interpolated(x)

    # ------------------------------------------------------------------ analytic responses
    def frequency_response(self, freq_hz, x: float, *, sampled: bool = True) -> np.ndarray:
        """The twin's own ``(u1, u2) -> (y1, y2)`` encoder response at table position ``x`` [m/V].

        Parameters
        ----------
        freq_hz : array_like
            Grid [Hz].
        x : float
            Table position [m].
        sampled : bool
            True: what a measurement from the logged commands to the encoder readings sees (exact ZOH
            discretization times ``z^-delay``). False: the continuous plant.

        Returns
        -------
        ndarray of complex, shape (2, 2, n_freq)
        """
        f = np.asarray(freq_hz, float).reshape(-1)
        C = encoder_matrix(self.params, x)
        if sampled:
            Ad, Bd = self.discrete_system(x)
            zz = np.exp(2j * np.pi * f / self.fs)
            Mz = zz[:, None, None] * np.eye(N_STATES) - Ad[None]
            X = np.linalg.solve(Mz, np.broadcast_to(Bd[:, :2], (f.size, N_STATES, 2)))
            X = X * zz[:, None, None] ** (-self.params.delay_samples)
        else:
            A, B = continuous_system(self.params, x)
            s = 2j * np.pi * f
            Ms = s[:, None, None] * np.eye(N_STATES) - A[None]
            X = np.linalg.solve(Ms, np.broadcast_to(B[:, :2], (f.size, N_STATES, 2)))
        return np.einsum("ij,fjk->ikf", C, X)

    def frf(self, freq_hz, x: float, *, sampled: bool = True):
        """:meth:`frequency_response` as an :class:`~feedtune.frf.Frf` (``y1, y2`` [m] over ``u1, u2`` [V])."""
        from ...frf import Frf

        f = np.asarray(freq_hz, float)
        return Frf(f, self.frequency_response(f, x, sampled=sampled), ("y1", "y2"), ("u1", "u2"), "position",
                   input_unit="V", output_unit="m",
                   meta={"source": f"gantry twin analytic FRF at x = {x:g} m" + (" (sampled)" if sampled else ""),
                         "x_m": f"{x:g}"})

    def axis_frequency_response(self, freq_hz, *, sampled: bool = True) -> np.ndarray:
        """The twin's own x-axis response ``ux -> x`` (encoder) [m/V]; the table position does not matter.

        Parameters
        ----------
        freq_hz : array_like
            Grid [Hz].
        sampled : bool
            True: exact ZOH discretization times ``z^-delay`` (what a measurement from the logged command sees);
            False: the continuous plant.

        Returns
        -------
        ndarray of complex, shape (n_freq,)
        """
        f = np.asarray(freq_hz, float).reshape(-1)
        c = axis_encoder_row(self.params)
        if sampled:
            Ad, Bd = self.discrete_system(0.0)
            zz = np.exp(2j * np.pi * f / self.fs)
            X = np.linalg.solve(zz[:, None, None] * np.eye(N_STATES) - Ad[None],
                                np.broadcast_to(Bd[:, 2:3], (f.size, N_STATES, 1)))[..., 0]
            X = X * zz[:, None] ** (-self.params.delay_samples)
        else:
            A, B = continuous_system(self.params, 0.0)
            s = 2j * np.pi * f
            X = np.linalg.solve(s[:, None, None] * np.eye(N_STATES) - A[None],
                                np.broadcast_to(B[:, 2:3], (f.size, N_STATES, 1)))[..., 0]
        return X @ c

    def axis_frf(self, freq_hz, *, sampled: bool = True):
        """:meth:`axis_frequency_response` as an :class:`~feedtune.frf.Frf` (``x`` [m] over ``ux`` [V])."""
        from ...frf import Frf

        f = np.asarray(freq_hz, float)
        h = self.axis_frequency_response(f, sampled=sampled)
        return Frf(f, h.reshape(1, 1, -1), ("x",), ("ux",), "position", input_unit="V", output_unit="m",
                   meta={"source": "gantry twin analytic x-axis FRF" + (" (sampled)" if sampled else "")})

    # ------------------------------------------------------------------ simulation
    def simulate(self, gantry, axis, y_ref, *, x_ref=0.0, table_force=None, excitation=None, seed: int | None = 0,
                 engine: str = "auto", n_samples: int | None = None) -> GantryRun:
        """Run the closed loop: ``gantry`` on ``y1, y2`` and ``axis`` on the table.

        The controllers see references and readings relative to where the run starts (``y_ref[0]``,
        ``x_ref[0]``), as a target whose filters are initialised at the current position; the gantry
        controller gets the absolute table position ``x`` for its schedule. The logs hold absolute values.

        Parameters
        ----------
        gantry : object
            Gantry controller: ``fs``, ``preview_samples``, ``reset()``, ``check_target(fs)`` and
            ``step(y_ref[k+P], y1, y2, x) -> (u1, u2)`` [m -> V] (e.g. ``GantryRuntime``).
        axis : object
            x-axis controller: same attributes and ``step(x_ref[k+P], x) -> u_x`` [V] (e.g. ``AxisRuntime``).
        y_ref : array_like, shape (n,)
            Gantry reference [m]; the gantry starts at rest at ``y_ref[0]``.
        x_ref : float or array_like, shape (n,)
            Table reference [m]; the table starts at rest at ``x_ref[0]``.
        table_force : array_like, shape (n,), optional
            Force on the table in +y [V] held over each sample (rope); excites the pitching mode.
        excitation : array_like, shape (n, 2) or (n, 3), optional
            Signals added to ``u1, u2`` (and ``u_x``) before saturation [V].
        seed : int or None
            Seed of the encoder, force and floor noise.
        engine : {"auto", "numba", "python"}
            Compiled or plain-Python plant step.
        n_samples : int, optional
            Samples to run (default ``len(y_ref)``); a longer reference feeds the previews.

        Returns
        -------
        GantryRun
        """
        for ctrl, name in ((gantry, "gantry controller"), (axis, "x-axis controller")):
            _check_controller(ctrl, name)
            ctrl.check_target(self.fs)
        y_ref = sample_vector(y_ref, "y_ref")
        n = y_ref.size if n_samples is None else int(n_samples)
        if not 2 <= n <= y_ref.size:
            raise UsageError(f"n_samples must be between 2 and len(y_ref) = {y_ref.size}, got {n_samples!r}")
        check_memory(n * TWIN_SAMPLE_BYTES, f"a twin run of {n / self.fs:g} s at {self.fs:g} Hz ({n:,} samples)")
        x_ref = np.full(y_ref.size, float(x_ref)) if np.ndim(x_ref) == 0 else sample_vector(x_ref, "x_ref", y_ref.size)
        if not np.all((x_ref >= self.params.x_min_m) & (x_ref <= self.params.x_max_m)):
            raise UsageError(f"x_ref leaves the table travel {self.params.x_min_m:g} .. {self.params.x_max_m:g} m")
        force = np.zeros(n) if table_force is None else sample_vector(table_force, "table_force", n)
        exc = np.zeros((n, 3))
        if excitation is not None:
            e = np.asarray(excitation, float)
            if e.ndim != 2 or e.shape[0] != n or e.shape[1] not in (2, 3) or not np.all(np.isfinite(e)):
                raise UsageError(f"excitation: expected a finite array of shape ({n}, 2) or ({n}, 3) [V]")
            exc[:, : e.shape[1]] = e
        pg, pa = int(gantry.preview_samples), int(axis.preview_samples)
        lead = max(pg, pa)
        total = n + lead
        tail = max(pg, pa) + 1
        y_full = np.r_[np.full(lead, y_ref[0]), y_ref, np.full(tail, y_ref[-1])]
        x_full = np.r_[np.full(lead, x_ref[0]), x_ref, np.full(tail, x_ref[-1])]
        ext = np.zeros((total, N_EXT))
        ext[lead:, 0] = force
        ext[:lead, 0] = force[0]
        ext[lead:, 2:5] = exc
        noise = self._noise(total, seed)
        ext[:, 1] = noise[1]
        ref = np.column_stack([y_full[:total], x_full[:total]])
        gantry.reset()
        axis.reset()
        k_done, status, rec = self._run(gantry, axis, y_full, x_full, pg, pa, float(y_ref[0]), float(x_ref[0]),
                                        noise[0], ext, ref, total, engine)
        m = min(k_done + 1, total)
        rec = rec[:m]
        tripped = status != 0
        t = (np.arange(m) - lead) / self.fs
        msg = self._trip_message(status, t[-1], ref[m - 1], rec[-1]) if tripped else ""
        cols = {name: rec[:, i] for i, name in enumerate(REC)}
        return GantryRun(t, cols["y1"], cols["y2"], cols["x"], cols["y1_true"], cols["y2_true"], cols["x_true"],
                         cols["y_table"], cols["y_base"], cols["u1"], cols["u2"], cols["ux"], ref[:m, 0].copy(),
                         ref[:m, 1].copy(), tripped, msg, n, lead)

    def _noise(self, n: int, seed: int | None) -> tuple[np.ndarray, np.ndarray]:
        """``(per-sample noise (n, 6), floor force (n,))`` from one generator."""
        p = self.params
        rng = np.random.default_rng(seed)
        noise = np.zeros((n, N_NOISE))
        if p.noise_m > 0:
            noise[:, :3] = p.noise_m * rng.standard_normal((n, 3))
        if p.pwm_noise_v > 0:
            noise[:, 3:] = p.pwm_noise_v * rng.standard_normal((n, 3))
        sigma_floor = floor_force_rms(p)
        floor = sigma_floor * rng.standard_normal(n) if sigma_floor > 0 else np.zeros(n)
        return noise, floor

    def _parameter_vector(self, y_origin: float) -> np.ndarray:
        p = self.params
        tb = self.tables()
        par = np.zeros(N_PAR)
        par[P_XMIN] = tb.xs[0]
        par[P_INV_DX] = 1.0 / (tb.xs[1] - tb.xs[0])
        par[P_NGRID] = tb.xs.size
        par[P_L] = p.model.L
        par[P_OFFSET] = p.table_offset
        par[P_FRAC] = p.pitch_encoder_fraction if p.pitch_hz is not None else 0.0
        for idx, mode in (((P_PA1, P_PA2), p.mode320), ((P_PB1, P_PB2), p.bending), ((P_PC1, P_PC2), p.mode940)):
            if mode is not None:
                par[idx[0]], par[idx[1]] = mode.shape
        for idx, mode in ((P_XE1, p.x_mode186), (P_XE2, p.x_mode332), (P_XE3, p.x_mode404)):
            if mode is not None:
                par[idx] = mode.shape[1]
        par[P_Q] = p.quantization_m
        par[P_UMAX] = np.inf if p.u_max is None else p.u_max
        par[P_ENV] = p.envelope_m
        par[P_I2T_A] = 1.0 - math.exp(-1.0 / (p.fs * p.overload_tau_s))
        par[P_I2T_LIM] = np.inf if p.overload_rms is None else p.overload_rms**2
        par[P_DELAY] = p.delay_samples
        par[P_ORIGIN] = y_origin
        par[P_XLO] = p.x_min_m - TRAVEL_TOL_M
        par[P_XHI] = p.x_max_m + TRAVEL_TOL_M
        return par

    def _run(self, gantry, axis, y_full, x_full, pg, pa, y0, x0, noise, ext, ref, total, engine):
        """The per-sample loop. Returns (k_done, status, rec).

        With the numba engine and the runtimes of gains files (:class:`~feedtune.machines.gantry.runtime.
        GantryRuntime`, :class:`~feedtune.machines.gantry.runtime.AxisRuntime`), plant and laws run in one compiled
        loop (:func:`_closed_loop`, calling the laws of :mod:`feedtune.machines.gantry.law`); other controllers
        (duck-typed objects with ``step``) are stepped from Python around the compiled plant step.
        """
        tb = self.tables()
        z0 = np.zeros(N_STATES + N_INPUTS)  # the states, then the inputs held over the sample
        z0[I_X] = x0  # at rest, the table at x0
        arrays = [z0, np.zeros((tb.cptr.size - 1) * _RB), np.zeros(3 * (self.params.delay_samples + 1)), np.zeros(3),
                  self._parameter_vector(y0), noise.ravel(), ext.ravel(), ref.ravel(), np.zeros(total * N_REC),
                  tb.cptr, tb.ccol, tb.cval, tb.vptr, tb.vcol, tb.vtab, tb.vdif]
        if choose_engine(engine) == "numba" and _compiled_laws(gantry, axis):
            loop = _compiled_loop()
            # the compiled loop calls the laws, not the runtimes' step: their [shaper] is applied here, from rest
            # (as step applies it: the references are 0 before the previews start, lead >= pg, pa)
            yr = np.ascontiguousarray(gantry.shape(y_full - y0))
            xr = np.ascontiguousarray(axis.shape(x_full - x0))
            k, status = loop(total, pg, pa, y0, x0, yr, xr, *arrays, *gantry.law.args(), gantry.law.out,
                             *axis.law.args())
            return int(k), int(status), arrays[8].reshape(total, N_REC)
        if choose_engine(engine) == "numba" and _holding(gantry, axis):
            from .experiments import holding_state, set_holding_state

            hp, hs = holding_state(gantry, axis)
            yr = np.ascontiguousarray(y_full - y0)
            xr = np.ascontiguousarray(x_full - x0)
            k, status = _compiled_holding_loop()(total, pg, pa, y0, x0, yr, xr, *arrays, hp, hs)
            set_holding_state(gantry, axis, hs)
            return int(k), int(status), arrays[8].reshape(total, N_REC)
        measure, step = kernel(_measure, engine), kernel(_step, engine)
        if choose_engine(engine) == "python":
            arrays = [a.tolist() for a in arrays]
        z, znew, buf, work, par, nz, ex, rf, rec, cptr, ccol, cval, vptr, vcol, vtab, vdif = arrays
        y1, y2, x = measure(0, z, par, nz, rec)
        g_step, a_step = gantry.step, axis.step
        yr = (y_full - y0).tolist()  # the controllers' filters start at zero: positions relative to the start
        xr = (x_full - x0).tolist()
        status = 0
        k = 0
        last = total - 1
        for k in range(total):
            u1, u2 = g_step(yr[k + pg], y1 - y0, y2 - y0, x)
            ux = a_step(xr[k + pa], x - x0)
            status = step(k, float(u1), float(u2), float(ux), z, znew, buf, work, par, nz, ex, rf, rec, cptr, ccol,
                          cval, vptr, vcol, vtab, vdif)
            if status:
                break
            if k < last:
                y1, y2, x = measure(k + 1, z, par, nz, rec)
        return k, int(status), np.asarray(rec, float).reshape(total, N_REC)

    def _trip_message(self, status: int, t: float, ref_row: np.ndarray, rec_row: np.ndarray) -> str:
        p = self.params
        if status == 3:
            return f"run stopped at t = {t:.6g} s: a controller returned a non-finite command"
        if status == 2:
            return (f"overload trip at t = {t:.6g} s: the RMS command of a motor over {p.overload_tau_s:g} s "
                    f"exceeded {p.overload_rms:g} V (drive I2t protection; is a controller unstable on this "
                    "machine?)")
        if status == 4:
            return (f"travel trip at t = {t:.6g} s: the table at x = {rec_row[8]:.6g} m left its travel "
                    f"{p.x_min_m:g} .. {p.x_max_m:g} m")
        errs = {"y1": ref_row[0] - rec_row[0], "y2": ref_row[0] - rec_row[1], "x": ref_row[1] - rec_row[2]}
        which = max(errs, key=lambda key: abs(errs[key]))
        return (f"following-error trip at t = {t:.6g} s: the {which} error {abs(errs[which]) * 1e3:.4g} mm left "
                f"the safety envelope of {p.envelope_m * 1e3:.4g} mm (is a controller unstable on this machine?)")


def _compiled_laws(gantry, axis) -> bool:
    """Both controllers are runtimes of gains files, whose laws the compiled loop runs."""
    from .runtime import AxisRuntime, GantryRuntime

    return type(gantry) is GantryRuntime and type(axis) is AxisRuntime


_m = _s = _g = _a = None  # the compiled callees of _closed_loop, set by _compiled_loop before it is compiled


def _closed_loop(total, pg, pa, y0, x0, yr, xr, z, znew, buf, work, par, nz, ex, rf, rec, cptr, ccol, cval, vptr,
                 vcol, vtab, vdif, g_sos, g_seg, g_w, g_wofs, g_par, g_st, g_sx, g_sched, g_out, a_sos, a_seg,
                 a_w, a_par, a_st):
    """Plant and both control laws, one sample per iteration (the loop of :meth:`GantryTwin._run` with the laws of
    :mod:`feedtune.machines.gantry.law`); returns ``(last sample, status)``."""
    y1, y2, x = _m(0, z, par, nz, rec)
    status = 0
    k = 0
    for k in range(total):
        _g(g_sos, g_seg, g_w, g_wofs, g_par, g_st, g_sx, g_sched, yr[k + pg], y1 - y0, y2 - y0, x, g_out)
        ux = _a(a_sos, a_seg, a_w, a_par, a_st, xr[k + pa], x - x0)
        status = _s(k, g_out[0], g_out[1], ux, z, znew, buf, work, par, nz, ex, rf, rec, cptr, ccol, cval, vptr,
                    vcol, vtab, vdif)
        if status != 0:
            break
        if k < total - 1:
            y1, y2, x = _m(k + 1, z, par, nz, rec)
    return k, status


def _holding(gantry, axis) -> bool:
    """Both controllers are the built-in holding controllers of the identification runs, which the compiled
    holding loop runs."""
    from .experiments import AxisHoldingController, HoldingController

    return type(gantry) is HoldingController and type(axis) is AxisHoldingController


def _pid(hs, i, hp, j, e):
    """One step of the holding controllers' PID (:class:`~feedtune.machines.gantry.experiments._PidState`, the same
    operations in the same order): state ``hs[i:i + 4]`` = (previous error, has one, integral, rate), gains
    ``hp[j:j + 5]`` = (kp, ki, kd, low-pass pole a, fs)."""
    if hs[i + 1] == 0.0:
        hs[i] = e
        hs[i + 1] = 1.0
    a = hp[j + 3]
    fs = hp[j + 4]
    hs[i + 3] = a * hs[i + 3] + (1.0 - a) * (e - hs[i]) * fs
    hs[i] = e
    hs[i + 2] += e / fs
    return hp[j] * e + hp[j + 1] * hs[i + 2] + hp[j + 2] * hs[i + 3]


_p = None  # the compiled PID step, set by _compiled_holding_loop before it is compiled


def _holding_closed_loop(total, pg, pa, y0, x0, yr, xr, z, znew, buf, work, par, nz, ex, rf, rec, cptr, ccol, cval,
                         vptr, vcol, vtab, vdif, hp, hs):
    """Plant and the holding controllers (:class:`~feedtune.machines.gantry.experiments.HoldingController`,
    :class:`~feedtune.machines.gantry.experiments.AxisHoldingController`), one sample per iteration: the loop of
    :meth:`GantryTwin._run` with their ``step`` written out. ``hp``: gains (CoM PID, yaw PID, x PID, alpha1, L),
    ``hs``: their states (see :func:`~feedtune.machines.gantry.experiments.holding_state`)."""
    y1, y2, x = _m(0, z, par, nz, rec)
    a1 = hp[15]
    span = hp[16]
    status = 0
    k = 0
    for k in range(total):
        yref = yr[k + pg]
        e1 = yref - (y1 - y0)
        e2 = yref - (y2 - y0)
        f_total = _p(hs, 0, hp, 0, a1 * e1 + (1.0 - a1) * e2)
        tau = _p(hs, 4, hp, 5, (e2 - e1) / span) / span
        ux = _p(hs, 8, hp, 10, xr[k + pa] - (x - x0))
        status = _s(k, a1 * f_total - tau, (1.0 - a1) * f_total + tau, ux, z, znew, buf, work, par, nz, ex, rf, rec,
                    cptr, ccol, cval, vptr, vcol, vtab, vdif)
        if status != 0:
            break
        if k < total - 1:
            y1, y2, x = _m(k + 1, z, par, nz, rec)
    return k, status


_HOLDING_LOOP: list = []


def _compiled_holding_loop():
    """:func:`_holding_closed_loop` compiled by numba (once per process, cached on disk), its callees inlined, without
    reference counting (as :func:`_compiled_loop`)."""
    if not _HOLDING_LOOP:
        import numba

        from .law import compiled_inline

        global _m, _s, _p
        _m, _s, _p = compiled_inline(_measure), compiled_inline(_step), compiled_inline(_pid)
        _HOLDING_LOOP.append(numba.njit(cache=True, nogil=True, _nrt=False)(_holding_closed_loop))
    return _HOLDING_LOOP[0]


_LOOP: list = []

_PENDING = PendingKernel()
""":func:`_closed_loop` compiling in another process (a first run's background compile), waited for at its first
use (:func:`feedtune.workflows.warmup.ensure_kernels`)."""

set_kernel_pending = _PENDING.set


def _compiled_loop():
    """:func:`_closed_loop` compiled by numba (once per process, cached on disk) with its callees inlined (the
    plant's measure and step, both laws and their sections and schedule, :func:`~feedtune.machines.gantry.law.
    compiled_inline`) and without reference counting (``_nrt=False``): the loop allocates nothing and only borrows
    the arrays it is given, while numba would otherwise count a reference to every array argument of every inlined
    call, every sample (a third of the loop's time)."""
    if not _LOOP:
        import numba

        from .law import compiled_inline, compiled_laws

        global _m, _s, _g, _a
        _g, _a = compiled_laws()
        _m, _s = compiled_inline(_measure), compiled_inline(_step)
        _LOOP.append(numba.njit(cache=True, nogil=True, _nrt=False)(_closed_loop))
    _PENDING.wait()  # compiled elsewhere into the cache: loaded from it at the first call
    return _LOOP[0]


def _check_controller(ctrl, name: str) -> None:
    missing = [a for a in ("fs", "preview_samples", "reset", "step", "check_target") if not hasattr(ctrl, a)]
    if missing:
        raise UsageError(f"{name} lacks {', '.join(missing)}; expected a GantryRuntime/AxisRuntime-like object")
    pv = ctrl.preview_samples
    if isinstance(pv, bool) or int(pv) != pv or pv < 0:
        raise UsageError(f"{name}: preview_samples must be an integer >= 0, got {pv!r}")


__all__ = ["GantryRun", "GantryTwin", "GantryTwinParams", "StructuralMode", "axis_encoder_row", "continuous_system",
           "encoder_matrix", "floor_force_rms", "table_weights"]
