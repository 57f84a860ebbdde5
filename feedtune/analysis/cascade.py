"""Frequency-domain analysis of a drive cascade (:mod:`feedtune.control.cascade`): the speed loop and the position
loop of a one-encoder axis (or a two-encoder one whose position loop closes on the load), each a SISO loop analysed by
:func:`feedtune.analysis.loop.analyze_loop`.

Plant: ``[x1/u, xp/u]`` [pos/U] -- the motor side and the side the position loop measures (the motor again, or the
load encoder ``x2``): a :class:`~feedtune.models.cascade_plant.CascadePlant` in the model cases, a measured FRF
(speed or position of one channel, or both encoders; converted to position by its quantity) in the measured cases,
continued below its band by the model and above it by the identified roll-off (:mod:`feedtune.analysis.band_edge`).

Cases (:mod:`feedtune.analysis.cases`), for each loop:

* speed loop, ``ideal``, ``ideal_discrete``, ``measured``, ``discrete``: ``L_v = C_v D G_1 H`` with ``C_v`` the PI
  times the current-setpoint filters (continuous, or as executed at ``fs``), ``D`` the speed measurement (``s``, or
  the backward difference ``(1 - z^-1) fs``), ``G_1`` the motor side, ``H`` the case's hold (1; the delay after the
  exact ZOH model; ZOH and delay after the FRF);
* position loop, ``position_ideal`` ... ``position_discrete``: ``L_p = Kv H_N C_v G_p H / (1 + L_v)``, the position
  gain on the closed speed loop from its setpoint to the measured position, with ``H_N`` the hold of the position
  loop's output for ``N`` speed samples (:meth:`~feedtune.control.cascade.CascadeLaw.position_hold`; 1 in the
  continuous cases). Its discrete contours end at the position loop's Nyquist frequency ``fp / 2``: the position loop
  is judged at its own rate, with the images of the closed speed loop above ``fp / 2`` (aliased by the position
  loop's sampling) neglected -- they are small where ``|L_p|`` is small, and the closed speed loop rolls off above its
  own bandwidth. Left out without a position loop (``Kv = 0``).

The limits hold in the checked case of both loops (``discrete`` and ``position_discrete`` on an FRF, the
``ideal_discrete`` pair on the model): :attr:`CascadeAnalysis.loops` names their prefixes
(:func:`feedtune.analysis.limits.check_analysis`). Open-loop poles: none in the right half plane (the plant's are at
the origin or stable, the filters are stable), the position loop's given a stable speed loop (which the speed loop's
own check asks). The figures beside the margins: ``tracking_bandwidth_hz``, the -3 dB band of each loop's closed
loop ``L / (1 + L)`` (the speed loop's and the position loop's bandwidth).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from ..display import AnalysisDisplay, CaseDisplay
from ..errors import DataError
from ..frf import Frf
from ..frf_quality import averages_of
from ..lti import zoh
from ..models.cascade_plant import measured_plant
from .cases import PlantCase, discrete_grid, measured_cases, model_cases, unit_circle
from .loop import LoopMetrics, analyze_loop, model_extension
from .resolution import lightly_damped

POSITION = "position_"
"""Prefix of the position loop's case names."""
LOOPS = ("", POSITION)
"""The loops of a cascade analysis, by the prefix of their case names (speed loop: none)."""
MODEL_GRID_POINTS = 3000
MODEL_GRID_LOW_HZ = 0.1
"""The model cases' grid: log-spaced from 0.1 Hz to just below ``fs / 2``."""


# ------------------------------------------------------------------------------------------ results
@dataclass(frozen=True, repr=False)
class CascadeCase(CaseDisplay):
    """One case of one loop of a cascade.

    Attributes
    ----------
    name : str
        The case (``discrete``, ``position_discrete``, ...).
    loop : str
        ``speed`` or ``position``.
    freq_hz : ndarray
    L, S : ndarray
        Loop and sensitivity [-] on ``freq_hz``.
    metrics : LoopMetrics
    """

    name: str
    loop: str
    freq_hz: np.ndarray
    L: np.ndarray
    S: np.ndarray
    metrics: LoopMetrics

    @property
    def T(self) -> np.ndarray:
        """The closed loop ``L / (1 + L)`` [-]."""
        return self.L * self.S

    def to_dict(self) -> dict:
        """The metrics' figures, the loop, and the closed loop's -3 dB bandwidth [Hz]."""
        return {"loop": self.loop, **self.metrics.to_dict(), "sigma_max_s": float(self.metrics.ms),
                "tracking_bandwidth_hz": closed_loop_bandwidth(self.freq_hz, self.T)}


@dataclass(frozen=True, repr=False)
class CascadeAnalysis(AnalysisDisplay):
    """Every case of both loops; ``cases[name]`` is None when a case needs a missing FRF; no position cases when the
    position loop is open (``Kv = 0``)."""

    cases: dict = field(default_factory=dict)
    loops = LOOPS

    def speed(self, case: str = "discrete") -> CascadeCase | None:
        """A case of the speed loop."""
        return self.cases.get(case)

    def position(self, case: str = "discrete") -> CascadeCase | None:
        """A case of the position loop."""
        return self.cases.get(POSITION + case)


def closed_loop_bandwidth(freq_hz: np.ndarray, T: np.ndarray, tol_db: float = 3.0) -> float | None:
    """The first frequency [Hz] where ``|T|`` leaves ``1 +- tol_db`` dB (None when it never does on the grid)."""
    with np.errstate(divide="ignore"):
        dev = np.abs(20 * np.log10(np.abs(T))) > tol_db
    return float(freq_hz[np.argmax(dev)]) if dev.any() else None


# ------------------------------------------------------------------------------------------ the loops
def loops_on(law, freq_hz, plant_hold: np.ndarray, discrete: bool, which: str) -> np.ndarray:
    """The speed loop ``L_v`` (``which = "speed"``) or the position loop ``L_p`` (``"position"``) of ``law`` for the
    plant with its hold ``plant_hold`` = ``[G_1 H, G_p H]`` (shape ``(2, n)``) on ``freq_hz`` (module docstring)."""
    f = np.asarray(freq_hz, float)
    c = law.speed_controller_response(f, discrete)
    ph = np.asarray(plant_hold)
    lv = c * law.speed_measurement(f, discrete) * ph[0]
    if which == "speed":
        return lv
    hold = law.position_hold(f) if discrete else 1.0
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        return law.kv * hold * c * ph[1] / (1.0 + lv)


def law_features(law, discrete: bool) -> np.ndarray:
    """Lightly damped poles and zeros ``(Hz, damping)`` of the current-setpoint filters (continuous, or their
    sections at ``fs``)."""
    roots = []
    if discrete:
        for b0, b1, b2, _, a1, a2 in law.filter_sos():
            roots += [np.roots([b0, b1, b2]), np.roots([1.0, a1, a2])]
        dt = 1.0 / law.fs
    else:
        dt = None
        for flt in law.enabled_filters:
            for freq, zeta in _quadratics(flt):
                w = 2 * np.pi * freq
                roots.append(np.roots([1.0, 2 * zeta * w, w * w]))
    if not roots:
        return np.empty((0, 2))
    return lightly_damped(np.concatenate([np.atleast_1d(r) for r in roots]), dt)


def _quadratics(flt) -> list[tuple[float, float]]:
    """``(Hz, damping)`` of a drive filter's second-order factors."""
    kind = getattr(flt, "kind", "")
    if kind == "PT2":
        return [(flt.freq_hz, flt.damping)]
    if kind == "second_order":
        return [(flt.num_freq_hz, flt.num_damping), (flt.den_freq_hz, flt.den_damping)]
    return []


class LoopPlant:
    """One plant case of one loop, prepared for the analysis of many laws (a tuner's hundreds): the plant with its
    hold on the case's grid, made once.

    Parameters
    ----------
    pc : PlantCase
        The plant case (plant and model in the ``[x1/u, xp/u]`` layout).
    loop : {"speed", "position"}
    name : str
        The case's name in the analysis.
    """

    def __init__(self, pc: PlantCase, loop: str, name: str) -> None:
        self.pc, self.loop, self.name = pc, loop, name
        f = pc.freq_hz
        self.plant = pc.plant(f)
        self.plant_hold = self.plant * pc.hold(f)

    def top_plant_hold(self) -> np.ndarray:
        """``[G_1 H, G_p H]`` at the grid's last point (the band-top rule of the tuners), shape ``(2, 1)``."""
        return self.plant_hold[:, -1:]


def analyze_loop_case(law, lp: LoopPlant) -> CascadeCase:
    """One case of one loop of ``law`` on a prepared plant case (module docstring)."""
    pc, which = lp.pc, lp.loop
    f = pc.freq_hz

    def evaluate(fr):
        return loops_on(law, fr, pc.plant(fr) * pc.hold(fr), pc.discrete, which)

    L = loops_on(law, f, lp.plant_hold, pc.discrete, which)
    extension = model_extension(f, lp.plant, pc.model_plant,
                                lambda fe, g: loops_on(law, fe, g * pc.hold(fe), pc.discrete, which))
    feats = np.vstack([pc.features, law_features(law, pc.discrete)])
    metrics = analyze_loop(f, L, evaluate=evaluate, features=feats, open_loop_rhp_poles=0, extension=extension,
                           noise_db=pc.noise_db, measured=pc.measured, band_edge=pc.band_edge)
    with np.errstate(divide="ignore", invalid="ignore"):
        S = 1.0 / (1.0 + L)
    return CascadeCase(lp.name, which, f, L, S, metrics)


# ------------------------------------------------------------------------------------------ plant cases
def zoh_plant(plant, fs: float):
    """``zoh_plant(f)``: the exact zero-order-hold discretization of ``plant`` (a
    :class:`~feedtune.models.cascade_plant.CascadePlant`) at ``fs``, ``[x1/u, x2/u]`` at ``z = exp(j 2 pi f / fs)``."""
    A, B, C = plant.state_space()
    Ad, Bd = zoh(A, B, 1.0 / fs)
    eye = np.eye(A.shape[0])

    def evaluate(freq_hz) -> np.ndarray:
        z = unit_circle(np.asarray(freq_hz, float), fs)
        with np.errstate(divide="ignore", invalid="ignore"):
            X = np.linalg.solve(z[:, None, None] * eye - Ad, np.broadcast_to(Bd, (z.size, *Bd.shape)))
        return (C @ X)[..., 0].T

    return evaluate


def _layout(values: np.ndarray, load: bool) -> np.ndarray:
    """``[x1, x2]`` rows -> ``[x1, xp]``: the second row the motor's again unless the position loop is on the load."""
    return values if load else np.stack([values[0], values[0]])


def speed_plant_cases(law, plant, frf: Frf | None = None, *, motor_channel: str | None = None,
                      load_channel: str | None = None, freq_hz=None) -> dict[str, PlantCase | None]:
    """The speed loop's four plant cases (:mod:`feedtune.analysis.cases`) in the ``[x1/u, xp/u]`` layout.

    Parameters
    ----------
    law : CascadeLaw
        Its rate, delay and position encoder.
    plant : CascadePlant
        The model (model cases; the measured plant below its band and above it).
    frf : Frf, optional
        The measured FRF (:func:`measured_plant`).
    motor_channel, load_channel : str, optional
        The FRF's channels.
    freq_hz : array_like, optional
        Grid of the model cases [Hz].
    """
    load = law.position_encoder == "load"
    if load and not plant.two_mass and frf is None:
        raise DataError("the position loop closes on the load encoder: a two-mass model or a two-encoder FRF is "
                        "needed")
    fs, delay = law.fs, law.delay_samples
    f = np.geomspace(MODEL_GRID_LOW_HZ, fs / 2 * 0.999, MODEL_GRID_POINTS) if freq_hz is None else \
        np.asarray(freq_hz, float)
    zp = zoh_plant(plant, fs)

    def model(fr):
        return _layout(plant.response(fr), load)

    def model_zoh(fr):
        return _layout(zp(fr), load)

    cases: dict = dict(model_cases(f, fs, delay, model_plant=model, zoh_plant=model_zoh,
                                   features=plant.features()))
    if frf is None:
        cases["measured"] = cases["discrete"] = None
        return cases
    _check_units(frf, plant, law)
    lines, h, coh, names = measured_plant(frf, motor_channel=motor_channel, load_channel=load_channel, load=load)
    cases.update(measured_cases(lines, h, fs, delay, model_plant=model, coherence=coh,
                                averages=averages_of(frf.meta), features=plant.features(), channels=names))
    return cases


def _check_units(frf: Frf, plant, law) -> None:
    """The FRF, the model and the law in one command and one position unit (DataError naming them)."""
    if frf.input_unit != law.command_unit or frf.output_unit != law.position_unit:
        raise DataError(f"{frf.source}: the FRF is in {frf.output_unit} per {frf.input_unit}, the controller in "
                        f"{law.position_unit} per {law.command_unit}; give the FRF's units (in=, out=) or convert it")
    if plant.command_unit != law.command_unit or plant.position_unit != law.position_unit:
        raise DataError(f"the model is in {plant.position_unit} per {plant.command_unit}, the controller in "
                        f"{law.position_unit} per {law.command_unit}")


def position_plant_cases(law, speed_cases: dict, frf: Frf | None = None, plant=None, *,
                         motor_channel: str | None = None, load_channel: str | None = None) -> dict:
    """The position loop's plant cases: the speed loop's model cases on their grid (the discrete one closed at
    ``fp / 2``), and the measured cases made again with the contour ending at ``fp / 2``."""
    fp = law.fp
    out: dict = {}
    for name in ("ideal", "ideal_discrete"):
        pc = speed_cases[name]
        grid = discrete_grid(pc.freq_hz, fp) if pc.discrete else pc.freq_hz
        out[POSITION + name] = replace(pc, name=POSITION + name, freq_hz=grid)
    if speed_cases.get("discrete") is None or frf is None:
        out[POSITION + "measured"] = out[POSITION + "discrete"] = None
        return out
    load = law.position_encoder == "load"
    lines, h, coh, names = measured_plant(frf, motor_channel=motor_channel, load_channel=load_channel, load=load)
    below = lines < fp / 2
    if below.sum() < 4:
        raise DataError(f"{frf.source}: fewer than 4 lines below the position loop's Nyquist frequency {fp / 2:g} Hz")

    def model(fr):
        return _layout(plant.response(fr), load)

    made = measured_cases(lines[below], h[:, below], fp, law.delay_samples, model_plant=model,
                          coherence=None if coh is None else coh[:, below], averages=averages_of(frf.meta),
                          features=plant.features(), channels=names)
    speed_hold = speed_cases["discrete"].hold
    out[POSITION + "measured"] = replace(made["measured"], name=POSITION + "measured")
    out[POSITION + "discrete"] = replace(made["discrete"], name=POSITION + "discrete", hold=speed_hold)
    return out


def cascade_plant_cases(law, plant, frf: Frf | None = None, **channels) -> dict[str, LoopPlant | None]:
    """Every case of both loops, prepared (:class:`LoopPlant`); without the position loop's when ``Kv = 0`` (open)."""
    speed = speed_plant_cases(law, plant, frf, **channels)
    out: dict = {name: None if pc is None else LoopPlant(pc, "speed", name) for name, pc in speed.items()}
    if law.kv > 0:
        pos = position_plant_cases(law, speed, frf, plant, **channels)
        out.update({name: None if pc is None else LoopPlant(pc, "position", name) for name, pc in pos.items()})
    return out


def analyze_cascade(law, plant, frf: Frf | None = None, *, motor_channel: str | None = None,
                    load_channel: str | None = None, cases: dict | None = None) -> CascadeAnalysis:
    """Analyse a cascade law in every case of both loops (module docstring).

    Parameters
    ----------
    law : CascadeLaw
    plant : CascadePlant
        The model of the axis (model cases; the measured plant's continuation).
    frf : Frf, optional
        Measured FRF of the axis: the motor side alone (speed or position per current setpoint), or both encoders.
    motor_channel, load_channel : str, optional
        Its channels (default: the only one; ``x1/...`` and ``x2/...`` of two).
    cases : dict, optional
        Prepared plant cases (:func:`cascade_plant_cases`) to analyse the law on instead.

    Raises
    ------
    DataError
        Units that differ, a missing channel.
    """
    prepared = cases if cases is not None else cascade_plant_cases(law, plant, frf, motor_channel=motor_channel,
                                                                   load_channel=load_channel)
    return CascadeAnalysis({name: None if lp is None else analyze_loop_case(law, lp)
                            for name, lp in prepared.items()})


def speed_loop_figures(case: CascadeCase | dict | None) -> dict:
    """``first_crossover_hz``, ``ms``, ``pm_deg`` (the smallest ``|PM|`` over every crossover), ``gm_db`` (the
    gain-increase margin, the high-frequency one) of a case: the figures a drive tuning is compared by."""
    if case is None:
        return {}
    from .limits import split_gain_margins

    d = case.to_dict() if isinstance(case, CascadeCase) else case
    pms = [abs(p) for p in d.get("phase_margins_deg") or []]
    up = split_gain_margins(d.get("gain_margins") or [])[0]
    return {"first_crossover_hz": d.get("first_crossover_hz"), "ms": d.get("ms"),
            "pm_deg": min(pms) if pms else None, "gm_db": None if up is None else up[0],
            "stable": d.get("stable")}


def margins_of(figures: dict, base=None, name: str = "a drive's tuning"):
    """Limits no looser than a speed loop's own margins (:func:`speed_loop_figures`): ``Ms`` at most its ``Ms``,
    ``|PM|`` at every crossover at least its smallest, the gain-increase margin at least its own; the base policy's
    other limits (the disk and gain-reduction margins) kept. What "at no worse margins" means when feedtune's tuning
    is compared with another on the same FRF."""
    from .limits import DEFAULT_LIMITS, Limits

    policy = base or DEFAULT_LIMITS
    return Limits(figures.get("ms"), figures.get("pm_deg"), figures.get("gm_db"), policy.disk_margin_min,
                  f"the margins of {name}", policy.gm_low_min_db)


def compare_speed_loops(analyses: dict, case: str = "discrete") -> dict:
    """The speed loops of several cascades on one FRF side by side: ``{"rows": [{"name", "first_crossover_hz",
    "ms", "pm_deg", "gm_db", "stable"}], "reference", "crossover_ratio", "margins_no_worse"}`` -- the ratio of each
    design's first crossover to the first's (the reference, e.g. the drive's own tuning) and whether its margins are
    no worse than the reference's (Ms not higher, the smallest ``|PM|`` and the gain-increase margin not lower)."""
    rows = [{"name": n, **speed_loop_figures(a.cases.get(case))} for n, a in analyses.items()]
    ref = rows[0] if rows else {}
    for r in rows[1:]:
        x0, x1 = ref.get("first_crossover_hz"), r.get("first_crossover_hz")
        r["crossover_ratio"] = None if not x0 or x1 is None else x1 / x0
        r["margins_no_worse"] = bool(
            r.get("stable") and r["ms"] is not None and ref.get("ms") is not None and r["ms"] <= ref["ms"] * (1 + 1e-9)
            and (ref.get("pm_deg") is None or (r["pm_deg"] or 0) >= ref["pm_deg"] * (1 - 1e-9))
            and (ref.get("gm_db") is None or (r["gm_db"] or 0) >= ref["gm_db"] * (1 - 1e-9)))
    return {"case": case, "reference": ref.get("name"), "rows": rows}


__all__ = [
    "LOOPS",
    "POSITION",
    "CascadeAnalysis",
    "CascadeCase",
    "LoopPlant",
    "analyze_cascade",
    "analyze_loop_case",
    "cascade_plant_cases",
    "closed_loop_bandwidth",
    "compare_speed_loops",
    "loops_on",
    "margins_of",
    "speed_loop_figures",
    "speed_plant_cases",
    "zoh_plant",
]
