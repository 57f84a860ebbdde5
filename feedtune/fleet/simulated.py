"""A simulated fleet of ball-screw axes measured weekly: files a fleet run reads, and the truth to judge it by.

Each axis is the thesis' 2-mass model (Table 3.1) with its parameters spread over the fleet (:data:`SPREAD`), two
torsional modes and a current loop of its own, and a friction law; a P-PI cascade is installed on it at
commissioning. Every week it is measured the way :mod:`examples.make_examples` builds the example FRFs, in the
frequency domain (cheap, and what a drive's built-in FRF tool delivers): the 2-mass response times the torsional
modes and the current loop, 2 % complex noise and a coherence column, 500 lines over 1-2000 Hz; the parameters of the
week carry a scatter between measurements (:data:`SCATTER`: temperature, preload warm-up) that no single fit sees.
A short reversal log per measurement (500 Hz, 4.75 s, rad and V) comes from the friction law: ``u = J a + b v +
d(v)`` with Stribeck friction ``d``, 10 mV of command noise and a 10 urad encoder.

A share of the axes drifts from an onset week on: the axial stiffness falls by :data:`STIFFNESS_RATE` of its start
value per week (preload loss), or the Coulomb friction rises by :data:`FRICTION_RATE` per week (wear, lubrication).

The installed gains: the nominal P-PI of :data:`NOMINAL_PPI`, its velocity-loop gains scaled by each axis' inertia
identified at commissioning (the velocity-loop bandwidth kept), certified on the commissioning FRF (and backed off by
10 % steps while the certificate fails, as a commissioning engineer would). The truth written beside the files
(``truth.json``) holds every axis' parameters, its drift, and the week its installed gains first fail the limits on
its noise-free plant (a stiffness-drifting axis; bisection to 0.05 weeks).
"""

from __future__ import annotations

import datetime as _dt
import json
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..analysis.limits import DEFAULT_LIMITS, Limits
from ..control.filters import THESIS_FILTER_PACK
from ..errors import UsageError
from ..models.ballscrew import THESIS_TABLE_3_1, BallScrewModel

NOMINAL_PPI = {"Kpx": 83.75733933754506, "Kpv": 1.4093347689611757, "Kiv": 105.09081545895573}
"""The nominal P-PI [1/s, V/(rad/s), V/rad]: ``tune_ppi(THESIS_TABLE_3_1, limits=COMMISSIONING_LIMITS,
filters=THESIS_FILTER_PACK, frf=nominal_frf())``, the limits the commissioning engineer tuned to (stricter than the
certificate's, so that the axes start with margin); ``tests/test_fleet_simulated.py`` tunes it again."""
COMMISSIONING_LIMITS = Limits(2.0, 40.0, 8.0, None, "commissioning")
SPREAD = {"m1": 0.10, "m2": 0.30, "k": 0.15, "c": 0.30, "b1": 0.50, "coulomb": 0.20}
"""Half-width of the uniform spread of each parameter over the fleet, relative to Table 3.1 (0.1 V Coulomb)."""
SCATTER = {"k": 0.015, "c": 0.05, "m2": 0.003, "b1": 0.05, "coulomb": 0.03, "viscous": 0.03}
"""Relative standard deviation of each parameter between two measurements of an unchanged axis."""
STIFFNESS_RATE = 0.02
"""Stiffness loss per week of a drifting axis, relative to its start value."""
FRICTION_RATE = 0.05
"""Coulomb friction rise per week of a drifting axis."""
FRF_NOISE = 0.02
LINES = 500
FS_HZ = 20000.0
LOG_FS_HZ = 500.0
START = _dt.datetime(2025, 1, 6, 8, 0)
TRUTH_HORIZON_WEEKS = 40.0


@dataclass(frozen=True)
class SimulatedAxis:
    """One simulated axis (module docstring).

    Attributes
    ----------
    machine, axis : str
    model : BallScrewModel
        The 2-mass model at week 0.
    torsional_hz : tuple of float
    current_loop_hz : float
    coulomb : float
        Coulomb friction at week 0 [V].
    drift : str or None
        ``stiffness``, ``friction`` or None.
    onset_week : float
    seed : int
    """

    machine: str
    axis: str
    model: BallScrewModel
    torsional_hz: tuple[float, float]
    current_loop_hz: float
    coulomb: float
    drift: str | None
    onset_week: float
    seed: int

    @property
    def id(self) -> str:
        """``machine/axis``."""
        return f"{self.machine}/{self.axis}"

    def drifted(self, week: float) -> tuple[BallScrewModel, float]:
        """The true model and Coulomb friction [V] at ``week`` (no scatter)."""
        age = max(week - self.onset_week, 0.0)
        model, coulomb = self.model, self.coulomb
        if self.drift == "stiffness":
            model = replace(model, k=model.k * max(1.0 - STIFFNESS_RATE * age, 0.05))
        elif self.drift == "friction":
            coulomb = coulomb * (1.0 + FRICTION_RATE * age)
        return model, coulomb

    def unmodelled(self, f: np.ndarray) -> np.ndarray:
        """Torsional modes and current loop: what the 2-mass model lacks."""
        s = 2j * np.pi * f
        wc = 2 * np.pi * self.current_loop_hz
        return _torsional(f, self.torsional_hz[0], 0.05, 0.02) * _torsional(f, self.torsional_hz[1], 0.05, 0.02) \
            * wc / (s + wc)

    def true_frf(self, week: float, model: BallScrewModel | None = None):
        """The noise-free FRF at ``week`` (or of ``model``)."""
        from ..frf import Frf

        f = frequency_grid()
        g = (model or self.drifted(week)[0]).frequency_response(f, keys=("G11", "G21"))
        h = np.stack([g["G11"], g["G21"]]) * self.unmodelled(f)
        return Frf(f, h[:, None, :], ("x1", "x2"), ("u",), "position", input_unit="V", output_unit="rad",
                   meta={"source": f"simulated fleet axis {self.id} (noise-free)"})

    def measured(self, week: float, rng: np.random.Generator):
        """``(Frf, Log, params)``: one measurement at ``week`` with scatter and noise (module docstring)."""
        from ..frf import Frf

        model, coulomb = self.drifted(week)
        k = {n: 1.0 + SCATTER[n] * rng.standard_normal() for n in SCATTER}
        model = replace(model, k=model.k * k["k"], c=model.c * k["c"], m2=model.m2 * k["m2"], b1=model.b1 * k["b1"])
        coulomb *= k["coulomb"]
        f = frequency_grid()
        g = model.frequency_response(f, keys=("G11", "G21"))
        h = np.stack([g["G11"], g["G21"]]) * self.unmodelled(f)
        noise = FRF_NOISE / np.sqrt(2) * (rng.standard_normal(h.shape) + 1j * rng.standard_normal(h.shape))
        h = h * (1 + noise)
        coh = np.clip(1 - 0.5 * np.abs(noise) ** 2 - 0.02 * (f / 2000) ** 2, 0, 1)
        frf = Frf(f, h[:, None, :], ("x1", "x2"), ("u",), "position", coh[:, None, :], input_unit="V",
                  output_unit="rad", meta={"source": f"simulated fleet axis {self.id}, week {week:g}"})
        log = _reversal_log(model.total_inertia, (model.b1 + model.b2) * k["viscous"], coulomb, rng,
                            f"simulated fleet axis {self.id}, week {week:g}")
        return frf, log, {**model.params(), "coulomb": coulomb}


def _torsional(f: np.ndarray, f0: float, zeta_z: float, zeta_p: float) -> np.ndarray:
    """A zero/pole pair with unit gain at 0 Hz (as examples/make_examples.py)."""
    s = 2j * np.pi * f
    w = 2 * np.pi * f0
    wz = w * 0.95
    return (s**2 + 2 * zeta_z * wz * s + wz**2) / (s**2 + 2 * zeta_p * w * s + w**2) * (w / wz) ** 2


def frequency_grid() -> np.ndarray:
    """:data:`LINES` log-spaced lines over 1-2000 Hz."""
    return np.logspace(0, np.log10(2000.0), LINES)


def _reversal_trajectory():
    from ..sim.trajectory import multi_segment

    return multi_segment([0, 6, -6, 0, 20, -20, 0], v_max=30.0, a_max=300.0, j_max=1e4, fs=LOG_FS_HZ, dwell=0.1)


def _reversal_log(inertia: float, viscous: float, coulomb: float, rng, source: str):
    """The reversal log of the friction law (module docstring)."""
    from ..log import Log
    from ..models.friction import StribeckFriction

    tr = _reversal_trajectory()
    law = StribeckFriction(coulomb, 1.6 * coulomb, -0.9 * coulomb, -1.5 * coulomb, 0.8, 0.6, "V", "rad/s")
    u = inertia * tr.acc + viscous * tr.vel + law.force(tr.vel) + 0.01 * rng.standard_normal(tr.pos.size)
    x = np.round((tr.pos + 2e-5 * rng.standard_normal(tr.pos.size)) / 1e-5) * 1e-5
    return Log(tr.t, {"x1": x, "u": u}, {"x1": "rad", "u": "V"}, {"source": source})


def nominal_frf():
    """The nominal axis' noise-free FRF (Table 3.1, torsional modes at 440 and 1100 Hz, 450 Hz current loop)."""
    return SimulatedAxis("nominal", "X", THESIS_TABLE_3_1, (440.0, 1100.0), 450.0, 0.1, None, 0.0, 0).true_frf(0.0)


def make_axes(n_axes: int, drift_share: float = 0.1, seed: int = 1) -> list[SimulatedAxis]:
    """``n_axes`` axes with spread parameters; ``round(drift_share n_axes)`` drift (alternately stiffness and
    friction), chosen at random."""
    rng = np.random.default_rng(seed)
    n_drift = round(drift_share * n_axes)
    drifting = set(rng.choice(n_axes, size=n_drift, replace=False).tolist()) if n_drift else set()
    kinds = iter(["stiffness", "friction"] * n_axes)
    axes = []
    nom = THESIS_TABLE_3_1
    for i in range(n_axes):
        def spread(name):
            return 1.0 + SPREAD[name] * rng.uniform(-1, 1)

        model = replace(nom, m1=nom.m1 * spread("m1"), m2=nom.m2 * spread("m2"), k=nom.k * spread("k"),
                        c=nom.c * spread("c"), b1=nom.b1 * spread("b1"))
        tors = (440.0 * rng.uniform(0.95, 1.05), 1100.0 * rng.uniform(0.95, 1.05))
        drift = next(kinds) if i in drifting else None
        onset = float(rng.uniform(0.5, 4.5)) if drift else 0.0
        axes.append(SimulatedAxis(f"M{i // 2 + 1:03d}", "XY"[i % 2], model, tors, 450.0 * rng.uniform(0.9, 1.1),
                                  0.1 * spread("coulomb"), drift, onset, int(rng.integers(2**31))))
    return axes


def installed_gains(axis: SimulatedAxis, limits: Limits = DEFAULT_LIMITS) -> tuple[dict, dict]:
    """The gains document commissioned on ``axis`` (module docstring) and its commissioning record."""
    from ..design.ppi import design_ppi
    from ..identify.ballscrew import fit_ballscrew
    from ..workflows.deliver import deliver

    rng = np.random.default_rng(axis.seed + 1)
    frf, _, _ = axis.measured(-1.0, rng)
    fit = fit_ballscrew(frf)
    scale = fit.model.total_inertia / THESIS_TABLE_3_1.total_inertia
    for backoff in range(8):
        f = 0.9**backoff
        design = design_ppi(fit.model, Kpx=NOMINAL_PPI["Kpx"], Kpv=NOMINAL_PPI["Kpv"] * scale * f,
                            Kiv=NOMINAL_PPI["Kiv"] * scale * f, filters=THESIS_FILTER_PACK, fs=FS_HZ, delay_samples=1)
        delivery = deliver(design, [("commissioning FRF", frf)], limits, where=f"{axis.id} commissioning")
        if delivery.ok:
            break
    return delivery.document, {"inertia_scale": scale, "backoff": 0.9**backoff, "ok": delivery.ok}


def violation_week(axis: SimulatedAxis, doc: dict, limits: Limits = DEFAULT_LIMITS,
                   horizon: float = TRUTH_HORIZON_WEEKS) -> float | None:
    """The first week the installed gains fail ``limits`` on the noise-free plant (None: not within ``horizon``)."""
    from ..machines.certificate import certify

    def fails(week: float) -> bool:
        return not certify(doc, axis.id, [("truth", axis.true_frf(week))], limits).ok

    if fails(0.0):
        return 0.0
    if axis.drift != "stiffness":
        return None
    prev = 0.0
    for w in np.arange(1.0, horizon + 1.0):
        if fails(float(w)):
            lo, hi = prev, float(w)
            while hi - lo > 0.05:
                mid = 0.5 * (lo + hi)
                lo, hi = (lo, mid) if fails(mid) else (mid, hi)
            return hi
        prev = float(w)
    return None


@dataclass(frozen=True)
class SimulatedFleet:
    """What :func:`simulate_fleet` wrote: the manifest, the truth file and the axes."""

    folder: Path
    manifest: Path
    truth: Path
    axes: tuple[SimulatedAxis, ...]
    weeks: int
    files: int


FRF_FILE_BYTES = 72_000
"""Size of one simulated measurement's FRF file [bytes] (72.0 KB measured; the reversal logs come on top)."""


def _check_disk(root: Path, n_axes: int, weeks: int) -> None:
    """UsageError when the fleet's FRF files alone would not fit in the free space of ``root``'s file system: refused
    before the first file, not after hours of simulation with the disk full."""
    import shutil

    from ..budget import fmt_bytes

    need = float(n_axes) * float(weeks) * FRF_FILE_BYTES
    where = next((p for p in (root, *root.absolute().parents) if p.exists()), Path("."))
    free = shutil.disk_usage(where).free
    if need > free:
        raise UsageError(f"{n_axes} axes x {weeks} weeks would write at least {fmt_bytes(need)} into {root}, more "
                         f"than the {fmt_bytes(free)} free there; simulate fewer axes or weeks",
                         parameter=("n_axes", "weeks"))


def simulate_fleet(folder, n_axes: int = 200, weeks: int = 12, *, drift_share: float = 0.1, seed: int = 1,
                   logs: bool = True, truth: bool = True, force: bool = False) -> SimulatedFleet:
    """Write a simulated fleet into ``folder`` (module docstring): ``fleet.toml``, ``gains/``, ``frf/``, ``logs/``
    and ``truth.json``.

    Parameters
    ----------
    folder : path-like
        A new or empty folder (``force``: an existing fleet's files are replaced).
    n_axes : int
        Axes (two per machine, X and Y).
    weeks : int
        Weekly measurements per axis.
    drift_share : float
        Share of the axes that drift [-].
    seed : int
    logs : bool
        Write a reversal log per measurement (friction).
    truth : bool
        Compute the week each axis' installed gains fail (a few certificates per drifting axis).
    force : bool
        Write into a folder that is not empty.
    """
    from .. import progress
    from ..io import dumps_toml, write_document, write_frf, write_log_csv
    from ..io.atomic import atomic_write_text

    for name, v, low in (("n_axes", n_axes, 1), ("weeks", weeks, 1)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < low:
            raise UsageError(f"{name} must be a whole number >= {low}, got {v!r}", parameter=name)
    if not 0 <= drift_share <= 1:
        raise UsageError(f"drift_share must be in [0, 1], got {drift_share!r}", parameter="drift_share")
    root = Path(folder)
    if root.exists() and any(root.iterdir()) and not force:
        raise UsageError(f"{root} is not empty; give a new or empty folder, or pass force=True", parameter="force")
    _check_disk(root, n_axes, weeks)
    for sub in ("gains", "frf", "logs"):
        (root / sub).mkdir(parents=True, exist_ok=True)
    axes = make_axes(n_axes, drift_share, seed)
    manifest: dict = {"schema": "feedtune.fleet/1", "name": f"simulated fleet ({n_axes} axes, seed {seed})",
                      "defaults": {"structure": "ballscrew", "limits": "textbook",
                                   "log_options": {"position": "x1", "input": "u", "velocity_threshold": 3.0}},
                      "axis": []}
    records, files = [], 0
    with progress.task("simulated axes", total=n_axes) as advance:
        for ax in axes:
            slug = f"{ax.machine}_{ax.axis}"
            doc, commissioning = installed_gains(ax)
            write_document(root / "gains" / f"{slug}.toml", doc, force=force, json_twin=False)
            rng = np.random.default_rng(ax.seed)
            entries = []
            for w in range(weeks):
                date = START + _dt.timedelta(days=7 * w, hours=float(rng.uniform(-20, 20)))
                week = (date - START).total_seconds() / (7 * 86400.0)
                frf, log, _ = ax.measured(week, rng)
                name = f"{slug}_{date:%Y%m%d}"
                write_frf(frf, root / "frf" / f"{name}.csv", force=force)
                entry = {"date": date.isoformat(timespec="minutes"), "frf": f"frf/{name}.csv"}
                files += 1
                if logs:
                    write_log_csv(log, root / "logs" / f"{name}.csv", force=force)
                    entry["log"] = f"logs/{name}.csv"
                    files += 1
                entries.append(entry)
            manifest["axis"].append({"machine": ax.machine, "axis": ax.axis, "gains": f"gains/{slug}.toml",
                                     "measurement": entries})
            records.append({"axis_id": ax.id, "drift": ax.drift, "onset_week": ax.onset_week,
                            "rate_per_week": {"stiffness": -STIFFNESS_RATE, "friction": FRICTION_RATE}.get(ax.drift),
                            "violation_week": violation_week(ax, doc) if truth else None,
                            "commissioning": commissioning, "params": {**ax.model.params(), "coulomb": ax.coulomb},
                            "torsional_hz": list(ax.torsional_hz), "current_loop_hz": ax.current_loop_hz})
            advance()
    manifest_path = root / "fleet.toml"
    atomic_write_text(manifest_path, dumps_toml(manifest), force=force)
    truth_path = root / "truth.json"
    atomic_write_text(truth_path, json.dumps({"start": START.isoformat(), "weeks": weeks, "seed": seed,
                                              "stiffness_rate_per_week": STIFFNESS_RATE,
                                              "friction_rate_per_week": FRICTION_RATE, "scatter": SCATTER,
                                              "axes": records}, indent=1), force=force)
    return SimulatedFleet(root, manifest_path, truth_path, tuple(axes), weeks, files)
