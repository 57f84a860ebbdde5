"""Experiments on the ball-screw twin (thesis §3.2.1, §3.4), each giving the log a real test would record.

* :func:`measure_frf` -- the drive excited (random-phase multisine, chirp or PRBS) under a weak stabilising
  controller; the log holds ``r`` (excitation), ``u``, ``x1``, ``x2`` and the FRF ``x1/u``, ``x2/u`` is
  estimated from it indirectly (``(r -> y) / (r -> u)``) with its coherence.
* :func:`run_tracking` -- a trajectory under a gains file; the log holds ``x_ref`` and its derivatives,
  ``x1``, ``x2``, ``u`` and the table tracking error ``e2``.
* :func:`run_ropesnap` -- a constant table force (a string pulling the table) released at ``t_release``;
  the log holds the table displacement and ``u``.
* :func:`run_cut` -- slotting at constant feed: the cutting force at the tooth-passing frequency on the
  table while the tool is in the workpiece (§3.4: 4-flute 25.4 mm end mill, 3500 rpm, 200 mm/s).
* :func:`measure_closed_loop` -- the closed-loop ``x_r -> x2`` response by a sine sweep (multisine of
  reference lines), to compare with the frequency-domain analysis.

Positions in the logs: encoders ``x1``, ``x2`` in rad of screw rotation (the model's unit, what the FRF
fit expects), table travel and references in m. Commands and forces in V.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from ...errors import DataError, UsageError
from ...log import Log
from ...sim.excitations import chirp_period, drift_reference, multisine, prbs_period, ropesnap_force
from ...sim.experiment import ExperimentResult
from ...sim.params import excitation_settings, positive_setting, release_settings
from .twin import BallScrewTwin, TwinRun

EXCITATIONS = ("multisine", "chirp", "prbs")




@dataclass(frozen=True)
class ClosedLoopResponse:
    """Closed-loop responses measured on the twin at the reference lines.

    Attributes
    ----------
    freq_hz : ndarray
        Measured lines [Hz].
    tracking : ndarray
        ``x2 / x_r`` [-] (table encoder over reference).
    rotary : ndarray
        ``x1 / x_r`` [-].
    """

    freq_hz: np.ndarray
    tracking: np.ndarray
    rotary: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def to_dict(self) -> dict:
        """Magnitudes and phases of ``x2/x_r`` per line (units in the keys)."""
        return {"freq_hz": self.freq_hz.tolist(), "tracking_mag": np.abs(self.tracking).tolist(),
                "tracking_phase_deg": np.angle(self.tracking, deg=True).tolist()}


# ------------------------------------------------------------------------------------------ helpers
def _trip_meta(run: TwinRun) -> dict:
    return {"trip": run.trip_message} if run.tripped else {}

MAX_DRIFT_M_PER_S = 10.0
"""Fastest table speed of an FRF run with drift [m/s]: feed drives move at most a few m/s."""


def _base_signals(twin: BallScrewTwin, run: TwinRun) -> tuple[dict, dict]:
    sig = {"x1": run.x1, "x2": run.x2, "u": run.u, "x2_table": run.x2 * twin.lead}
    units = {"x1": "rad", "x2": "rad", "u": "V", "x2_table": "m"}
    return sig, units










def weak_controller(twin: BallScrewTwin, bandwidth_hz: float = 10.0):
    """A weak P-PI (velocity crossover ``bandwidth_hz``) built from the twin's inertia, as a gains runtime.

    It only holds the axis in place during an FRF measurement, as the factory tuning of a real drive would;
    no filter pack, no feedforward that matters at standstill.
    """
    from ...design.ppi import design_ppi
    from ...io.gains import gains_document
    from .runtime import GainsRuntime

    w = 2 * np.pi * positive_setting(bandwidth_hz, "weak-controller bandwidth", "Hz")
    m = twin.params.model
    kpv = m.total_inertia * w
    design = design_ppi(m, Kpx=w / 4, Kpv=kpv, Kiv=kpv * w / 4, fs=twin.fs, delay_samples=twin.params.delay_samples)
    return GainsRuntime.from_document(gains_document(design), "weak stabilising P-PI")


def measure_frf(
    twin: BallScrewTwin,
    *,
    excitation: str = "multisine",
    rms: float = 1.0,
    f_lo: float = 2.0,
    f_hi: float = 2000.0,
    period_s: float = 0.5,
    periods: int = 6,
    drift_m_per_s: float = 0.05,
    controller=None,
    seed: int | None = 0,
    engine: str = "auto",
    keep_sampling: bool = False,
) -> ExperimentResult:
    """Measure the FRF ``u -> x1, x2`` under a weak stabilising controller.

    Parameters
    ----------
    twin : BallScrewTwin
    excitation : {"multisine", "chirp", "prbs"}
        Random-phase multisine (default), logarithmic chirp repeated every period, or maximum-length PRBS
        (period ``2^n - 1`` clock ticks, about ``period_s``). All three are periodic, so the FRF is the
        leakage-free periodic estimate averaged over the periods after the first.
    rms : float
        RMS of the excitation added to the command [V].
    f_lo, f_hi : float
        Excited band [Hz] (PRBS: ``f_hi`` sets the clock, about ``2.5 f_hi``; the FRF keeps ``f_lo..f_hi``).
    period_s : float
        Period of the multisine/chirp [s]; the line spacing is ``1 / period_s`` [Hz].
    periods : int
        Periods run; the first is dropped as transient.
    drift_m_per_s : float
        Constant table speed [m/s] during the measurement (reached within the first period). Moving in
        one direction keeps the friction at its sliding level instead of switching at every reversal,
        which would distort the FRF (the practice on real drives); 0 measures at standstill.
    controller : GainsRuntime, optional
        Stabilising controller; default :func:`weak_controller`.
    seed : int or None
        Seed of the multisine phases and the measurement noise.
    engine : str
        Simulation engine (see :meth:`BallScrewTwin.simulate`).
    keep_sampling : bool
        False (default): the zero-order hold and the computational delay, which the logged ``u[k] -> x[k]``
        contains, are divided out (:func:`feedtune.frf_sampling.remove_sampling`), so the FRF is the continuous
        plant (``twin.frequency_response(f, sampled=False)``) that the fit and the analysis expect. True: the
        FRF as estimated from the log (``sampled=True``), marked ``sampling = "not_removed"``.

    Returns
    -------
    ExperimentResult
        ``log`` with ``r, u, x1, x2`` and ``frf`` with ``x1/u``, ``x2/u`` [rad/V] and coherence.
    """
    from ...frf_sampling import mark_sampling_kept, remove_sampling
    from ...identify.frf_estimate import estimate_frf

    kind = str(excitation).strip().lower()
    if kind not in EXCITATIONS:
        raise UsageError(f"excitation must be one of {', '.join(EXCITATIONS)}, got {excitation!r}")
    rms, f_lo, f_hi, period_s, periods = excitation_settings(twin.fs, rms, f_lo, f_hi, period_s, periods,
                                                             u_max=twin.params.u_max)
    if not (isinstance(drift_m_per_s, (int, float)) and abs(drift_m_per_s) <= MAX_DRIFT_M_PER_S):
        raise UsageError(f"drift_m_per_s={drift_m_per_s!r}: a feed drive's table moves at most "
                         f"{MAX_DRIFT_M_PER_S:g} m/s", parameter="drift_m_per_s")
    rng = np.random.default_rng(seed)
    if kind == "multisine":
        one = multisine(twin.fs, period_s, f_lo, f_hi, rms, rng)
    elif kind == "chirp":
        one = chirp_period(twin.fs, period_s, f_lo, f_hi, rms)
    else:
        one = prbs_period(twin.fs, period_s, f_hi, rms)
    r = np.tile(one, int(periods))
    ctrl = controller if controller is not None else weak_controller(twin)
    x_ref = drift_reference(twin.fs, r.size + ctrl.preview_samples, drift_m_per_s, min(0.2, one.size / twin.fs / 2))
    run = twin.simulate(ctrl, x_ref / twin.lead, excitation=r, seed=seed, engine=engine, n_samples=r.size).from_zero()
    m = run.t.size
    meta = {"source": f"twin FRF measurement ({kind})", "experiment": "frf", "excitation": kind,
            "controller": ctrl.source, **_trip_meta(run)}
    log = Log(run.t, {"r": r[:m], "u": run.u, "x1": run.x1, "x2": run.x2}, {"r": "V", "u": "V", "x1": "rad",
                                                                             "x2": "rad"}, meta)
    summary = {"excitation": kind, "rms_V": rms, "drift_m_per_s": float(drift_m_per_s), "band_hz": [f_lo, f_hi],
               "period_s": one.size / twin.fs,
               "periods": int(periods), "u_peak_V": float(np.max(np.abs(run.u)))}
    if run.tripped:
        return ExperimentResult("frf", log, run, summary)
    hi = f_hi if kind != "prbs" else min(f_hi, twin.fs / 2 * 0.999)
    frf = estimate_frf(log, input="u", outputs=["x1", "x2"], reference="r", method="periodic",
                       period_samples=one.size, transient_periods=1, freq_range=(f_lo, hi))
    frf = replace(frf, meta={**frf.meta, "source": meta["source"]})
    if keep_sampling:
        frf = mark_sampling_kept(frf, twin.fs)
    else:
        frf = remove_sampling(frf, twin.fs, twin.params.delay_samples)
    summary["sampling_removed"] = not keep_sampling
    coh = frf.coherence
    summary["n_lines"] = int(frf.freq_hz.size)
    summary["coherence_min"] = float(np.min(coh)) if coh is not None else None
    return ExperimentResult("frf", log, run, summary, frf=frf)


# ------------------------------------------------------------------------------------------ tracking
def trajectory_from_log(source, fs: float | None = None):
    """A :class:`~feedtune.sim.trajectory.Trajectory` from a trajectory log (``feedtune trajectory`` output).

    Parameters
    ----------
    source : Log or path-like
        Uniformly sampled log with ``x_ref`` [m]; ``v_ref``, ``a_ref``, ``j_ref``, ``s_ref`` are used when
        present and computed by numerical differentiation otherwise.
    fs : float, optional
        Required sample rate [Hz] (DataError when the log differs).
    """
    from ...io import read_log
    from ...log import log_signal_names
    from ...sim.trajectory import Trajectory

    log = source if isinstance(source, Log) else read_log(source)
    names = log_signal_names("x_ref")
    pos = log.get("x_ref")
    if log.unit("x_ref") not in ("m", ""):
        raise DataError(f"{log.source}: x_ref is in {log.unit('x_ref')!r}; the trajectory must be in m")
    if not log.is_uniform(1e-6):
        raise DataError(f"{log.source}: the trajectory must be uniformly sampled")
    if fs is not None and not math.isclose(log.fs, fs, rel_tol=1e-6):
        raise DataError(f"{log.source}: the trajectory is sampled at {log.fs:g} Hz; the twin runs at {fs:g} Hz "
                        f"(generate it with fs={fs:g})", parameter="fs")
    derivs = [pos]
    for name in names[1:]:
        derivs.append(log.get(name) if name in log else np.gradient(derivs[-1], log.dt))
    t = log.t - log.t[0]
    return Trajectory(t, *derivs, limits={}, sample_rate=log.fs)


def run_tracking(twin: BallScrewTwin, runtime, trajectory, *, seed: int | None = 0, engine: str = "auto",
                 d2=None, kind: str = "track") -> ExperimentResult:
    """Run a trajectory (:class:`~feedtune.sim.trajectory.Trajectory`, table travel in m) under ``runtime``.

    Returns
    -------
    ExperimentResult
        ``log``: ``x_ref, v_ref, a_ref, j_ref, s_ref`` [m, m/s, ...], ``x1, x2`` [rad], ``u`` [V],
        ``x2_table`` [m] and the table tracking error ``e2 = x_ref - x2_table`` [m]; ``metrics``:
        :class:`~feedtune.analysis.metrics.TrackingMetrics` of ``e2``.
    """
    from ...analysis.metrics import tracking_metrics

    if not math.isclose(trajectory.fs, twin.fs, rel_tol=1e-9):
        raise UsageError(f"the trajectory is sampled at {trajectory.fs:g} Hz; the twin runs at {twin.fs:g} Hz "
                         f"(generate it with fs={twin.fs:g})", parameter="fs")
    run = twin.simulate(runtime, trajectory.pos / twin.lead, d2=d2, seed=seed, engine=engine).from_zero()
    m = run.t.size
    ref = trajectory.to_log()
    sig = {k: v[:m] for k, v in ref.signals.items()}
    units = dict(ref.units)
    s2, u2 = _base_signals(twin, run)
    sig.update(s2)
    units.update(u2)
    sig["e2"] = sig["x_ref"] - sig["x2_table"]
    units["e2"] = "m"
    if d2 is not None:
        sig["d2"] = np.asarray(d2, float)[:m]
        units["d2"] = "V"
    meta = {"source": f"twin {kind} run", "experiment": kind, "controller": runtime.controller,
            "gains": runtime.source, **_trip_meta(run)}
    log = Log(run.t, sig, units, meta)
    summary = {"controller": runtime.controller, "v_max_m_per_s": trajectory.limits.get("v_max"),
               "duration_s": float(run.t[-1])}
    if run.tripped:
        return ExperimentResult(kind, log, run, summary)
    met = tracking_metrics(run.t, sig["e2"], vel=sig["v_ref"], acc=sig["a_ref"])
    summary["tracking"] = met.to_dict()
    summary["max_um"] = met.overall.max_abs * 1e6
    summary["rms_um"] = met.overall.rms * 1e6
    return ExperimentResult(kind, log, run, summary, metrics=met)




def run_ropesnap(twin: BallScrewTwin, runtime, *, force: float = 0.5, t_release: float = 0.6,
                 after_s: float = 1.0, record_before_s: float = 0.1, seed: int | None = 0,
                 engine: str = "auto") -> ExperimentResult:
    """Rope snap: a table force of ``force`` [V] (pulling towards -x) is held, then released at ``t_release``.

    The force is ramped in over the first 0.1 s and the controller holds the table at 0 until the release;
    the log covers ``record_before_s`` before the release to ``after_s`` after it.

    Returns
    -------
    ExperimentResult
        ``log``: ``x2`` [rad], ``x2_table`` (displacement) [m], ``x1`` [rad], ``u`` [V], ``d2`` [V];
        ``metrics``: :class:`~feedtune.analysis.metrics.RopeSnapMetrics` (peak, 5 % settling time, ASD).
    """
    from ...analysis.metrics import ropesnap_metrics

    force, t_release, after_s, record_before_s = release_settings(twin.fs, force, t_release, after_s,
                                                                  record_before_s, hold_limit=twin.params.u_max)
    if t_release < 0.1 + record_before_s:
        raise UsageError(f"t_release must leave the 0.1 s preload ramp and {record_before_s:g} s of record before "
                         f"it, i.e. be >= {0.1 + record_before_s:g} s, got {t_release:g}")
    d2 = ropesnap_force(twin.fs, t_release + after_s, force, t_release)
    run = twin.simulate(runtime, np.zeros(d2.size), d2=d2, seed=seed, engine=engine).from_zero()
    sig, units = _base_signals(twin, run)
    sig["d2"] = d2[: run.t.size]
    units["d2"] = "V"
    keep = run.t >= t_release - record_before_s - 0.5 / twin.fs
    if run.tripped and keep.sum() < 2:
        keep = np.ones(run.t.size, bool)
    meta = {"source": "twin rope-snap run", "experiment": "ropesnap", "controller": runtime.controller,
            "gains": runtime.source, "t_release_s": t_release, "force_V": force, **_trip_meta(run)}
    log = Log(run.t[keep], {k: v[keep] for k, v in sig.items()}, units, meta)
    summary = {"controller": runtime.controller, "force_V": force, "t_release_s": t_release}
    if run.tripped:
        return ExperimentResult("ropesnap", log, run, summary)
    met = ropesnap_metrics(log.t, log["x2_table"], t_release=t_release)
    summary["ropesnap"] = {k: v for k, v in met.to_dict().items() if k not in ("asd_freq_hz", "asd_m_per_rthz")}
    summary["peak_um"] = met.peak * 1e6
    summary["settling_time_s"] = met.settling_time
    return ExperimentResult("ropesnap", log, run, summary, metrics=met)


# ------------------------------------------------------------------------------------------ cutting
@dataclass(frozen=True)
class SlotCut:
    """A slotting cut (thesis §3.4) as a table force [V-equivalent].

    Parameters
    ----------
    flutes : int
        Number of teeth.
    spindle_rpm : float
        Spindle speed [1/min]; tooth passing at ``flutes * rpm / 60`` [Hz].
    tool_diameter_m : float
        End-mill diameter [m]; the engagement grows over one radius of travel on entry.
    start_m, length_m : float
        Workpiece edge position and length of the cut [m of table travel].
    mean_force : float
        Mean feed-direction force in full engagement [V], opposing the feed.
    tooth_force : float
        Amplitude of its tooth-passing component [V].
    """

    flutes: int = 4
    spindle_rpm: float = 3500.0
    tool_diameter_m: float = 25.4e-3
    start_m: float = 0.05
    length_m: float = 0.12
    mean_force: float = 0.3
    tooth_force: float = 0.3

    @property
    def tooth_hz(self) -> float:
        """Tooth-passing frequency [Hz]."""
        return self.flutes * self.spindle_rpm / 60.0

    def force(self, t: np.ndarray, pos: np.ndarray, vel: np.ndarray) -> np.ndarray:
        """Table force [V] for tool position ``pos`` [m] and feed ``vel`` [m/s] at times ``t`` [s].

        Engagement rises linearly over the tool radius after the edge at ``start_m`` and ends abruptly
        at ``start_m + length_m`` (the last chip breaks free: a step disturbance, as in the thesis).
        """
        r = self.tool_diameter_m / 2
        rel = (pos - self.start_m) * np.sign(self.length_m)
        engage = np.clip((rel + r) / r, 0.0, 1.0) * (rel <= abs(self.length_m))
        tooth = np.cos(2 * np.pi * self.tooth_hz * t)
        return -np.sign(vel) * engage * (self.mean_force + self.tooth_force * tooth)


def run_cut(twin: BallScrewTwin, runtime, trajectory, cut: SlotCut | None = None, *, seed: int | None = 0,
            engine: str = "auto") -> ExperimentResult:
    """Tracking with the slotting force of ``cut`` on the table (excites pitching); see :func:`run_tracking`."""
    cut = cut or SlotCut()
    d2 = cut.force(trajectory.t, trajectory.pos, trajectory.vel)
    if not np.any(d2):
        raise UsageError(f"the trajectory never reaches the workpiece at {cut.start_m:g} m; "
                         "adjust the cut start/length or the move")
    res = run_tracking(twin, runtime, trajectory, seed=seed, engine=engine, d2=d2, kind="cut")
    summary = dict(res.summary)
    summary["cut"] = {"tooth_passing_hz": cut.tooth_hz, "flutes": cut.flutes, "spindle_rpm": cut.spindle_rpm,
                      "tool_diameter_m": cut.tool_diameter_m, "start_m": cut.start_m, "length_m": cut.length_m,
                      "mean_force_V": cut.mean_force, "tooth_force_V": cut.tooth_force}
    in_cut = np.flatnonzero(d2 != 0)
    summary["cut"]["t_enter_s"] = float(trajectory.t[in_cut[0]])
    summary["cut"]["t_exit_s"] = float(trajectory.t[in_cut[-1]])
    return ExperimentResult("cut", res.log, res.run, summary, metrics=res.metrics)


# ------------------------------------------------------------------------------------------ closed loop
def measure_closed_loop(twin: BallScrewTwin, runtime, freq_hz, *, amplitude_m: float = 1e-6,
                        period_s: float = 0.2, periods: int = 3, seed: int | None = 0,
                        engine: str = "auto") -> ClosedLoopResponse:
    """Closed-loop ``x_r -> x2`` and ``x_r -> x1`` measured with a periodic sum of sines as the reference.

    The requested frequencies are rounded to the line grid ``1 / period_s`` [Hz]; the first period is
    dropped as transient and the last because the preview runs past the end of the reference.

    Parameters
    ----------
    twin : BallScrewTwin
    runtime : GainsRuntime
    freq_hz : array_like
        Frequencies to measure [Hz].
    amplitude_m : float
        Amplitude of each sine in table travel [m].
    period_s : float
        Period of the reference [s].
    periods : int
        Periods simulated (>= 3).
    """
    f = np.atleast_1d(np.asarray(freq_hz, float))
    n = round(period_s * twin.fs)
    k = np.unique(np.clip(np.round(f * period_s).astype(int), 1, n // 2 - 1))
    if isinstance(periods, bool) or int(periods) != periods or periods < 3:
        raise UsageError(f"periods must be an integer >= 3, got {periods!r}")
    rng = np.random.default_rng(seed)
    t = np.arange(n * int(periods)) / twin.fs
    phase = 2 * np.pi * rng.random(k.size)
    x_ref = amplitude_m / twin.lead * np.sin(2 * np.pi * (k / period_s)[:, None] * t[None] + phase[:, None]).sum(0)
    run = twin.simulate(runtime, x_ref, seed=seed, engine=engine).from_zero()
    if run.tripped:
        raise DataError(run.trip_message)
    seg = slice(n, n * (int(periods) - 1))
    spec = np.fft.rfft(np.vstack([x_ref[seg], run.x2[seg], run.x1[seg]]).reshape(3, -1, n), axis=-1).mean(1)[:, k]
    return ClosedLoopResponse(k / period_s, spec[1] / spec[0], spec[2] / spec[0])
