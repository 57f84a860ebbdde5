"""The gantry twin against the thesis' published control figures (§4.3-4.4), measured as a user would.

The chain is the README's: 2x2 FRFs at x = -0.3, 0, 0.3 m and an x-axis FRF measured on the twin
(``feedtune simulate gantry frf``; ``measure_axis_frf``), the gantry model identified from them
(``feedtune identify gantry``, no ``--mass``), the thesis designs (``feedtune design gantry|pid|loopshape``) and
their figures on the measured FRF with the discrete loop (``feedtune analyze GAINS --frf F``).

The verdicts are recomputed here without :mod:`feedtune.analysis`: loops from the measured FRF times our own
zero-order hold and delay times the discrete controller, singular values in closed form, and closed-loop
stability from the eigenvalues of the twin's exact discrete state space closed with the controller's state
space (ground truth the twin was built with, not a Nyquist count). The PID ceiling is a brute-force search
over ``(kp, kd, ki)``, not :func:`~feedtune.tune.pid.tune_gantry_pid`.

Published figures (seed text ~l. 760-925): x axis 130 Hz at PM 35 deg was "the highest crossover ... while
maintaining adequate stability margins", two 63 deg leads (126 deg, eq. 4.17-4.18), ``|S| < 1`` up to 98 Hz;
y axis MIMO first crossover 52 Hz and Ms 2.6 at 40 Hz; independent PIDs with the same notches and low-pass at a
similar Ms: at most 16 Hz. docs/gantry_twin.md "Calibration" says which twin parameter carries which figure.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy.signal import zpk2ss

from feedtune.analysis.gantry import analyze_axis, analyze_gantry
from feedtune.control.discretize import matched
from feedtune.control.filters import FilterPack, LeadStage, Notch
from feedtune.design.gantry_mimo import design_gantry_mimo
from feedtune.design.loopshape import design_loopshape
from feedtune.identify.gantry import fit_gantry
from feedtune.machines.gantry.experiments import measure_axis_frf, measure_gantry_frf
from feedtune.machines.gantry.twin import I_X, GantryTwin, axis_encoder_row, continuous_system, encoder_matrix
from feedtune.tune.pid import tune_gantry_pid

XS = (-0.3, 0.0, 0.3)
H_THESIS = FilterPack([Notch(110, 0.5, 0.7), Notch(320, 0.2, 0.9), Notch(400, 0.15, 1.0), Notch(940, 0.6, 0.75)],
                       450.0, 2, 0.7, [LeadStage(154.0, 70.0)])  # §4.4.2
H_PID = FilterPack(H_THESIS.notches, 450.0, 2, 0.7)  # "identical notch and low-pass filters", no second lead
X_FILTERS = FilterPack([Notch(186, 0.6, 0.7), Notch(332, 0.3, 0.7), Notch(404, 0.2, 0.7)], 1200.0)  # §4.4.1


# ------------------------------------------------------------------------------------ own loop algebra
def hold_and_delay(f, fs: float, delay: int) -> np.ndarray:
    """``(1 - z^-1)/(s T) z^-delay`` on ``f`` [Hz]: what the sampled loop adds to a continuous plant."""
    s = 2j * np.pi * np.asarray(f, float)
    return (1 - np.exp(-s / fs)) / (s / fs) * np.exp(-s * delay / fs)


def sigma_max(M: np.ndarray) -> np.ndarray:
    """Largest singular value of stacked 2x2 matrices ``(..., 2, 2)`` in closed form."""
    a = np.sum(np.abs(M) ** 2, axis=(-2, -1))
    det = np.abs(M[..., 0, 0] * M[..., 1, 1] - M[..., 0, 1] * M[..., 1, 0])
    return np.sqrt((a + np.sqrt(np.maximum(a * a - 4 * det * det, 0.0))) / 2)


def first_crossing(f, mag):
    """First frequency [Hz] where ``mag`` (last axis on ``f``) falls through 1, log-interpolated; nan if never."""
    mag = np.asarray(mag, float)
    falls = (mag[..., :-1] >= 1) & (mag[..., 1:] < 1)
    i = np.argmax(falls, axis=-1)
    m0 = np.log(np.take_along_axis(mag, i[..., None], -1)[..., 0])
    m1 = np.log(np.take_along_axis(mag, i[..., None] + 1, -1)[..., 0])
    lf = np.log(np.asarray(f, float))
    out = np.exp(lf[i] + m0 / (m0 - m1) * (lf[i + 1] - lf[i]))
    return np.where(falls.any(axis=-1), out, np.nan)[()]


def gantry_plant(frf):
    """``(f, G)`` [Hz, m/V], shape ``(n, 2, 2)``, of a measured 2x2 FRF."""
    G = np.array([[frf.channel(f"y{i}/u{j}") for j in (1, 2)] for i in (1, 2)])
    return frf.freq_hz, np.moveaxis(G, -1, 0)


# ------------------------------------------------------------------------------------ exact stability
def _sections(zeros, poles, gain):
    """A discrete zpk as first/second-order sections (pairs of conjugates or of reals), the gain in the first."""
    def groups(r):
        r = list(np.asarray(r, complex))
        out, reals = [], []
        while r:
            a = r.pop(0)
            if abs(a.imag) > 1e-12:
                out.append([a, r.pop(int(np.argmin([abs(b - np.conj(a)) for b in r])))])
            else:
                reals.append(a)
        out += [reals[i:i + 2] for i in range(0, len(reals), 2)]
        return out

    zs, ps = groups(zeros), groups(poles)
    n = max(len(zs), len(ps))
    if n == 0:  # a constant
        return [(np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), np.array([[float(gain)]]))]
    zs, ps = zs + [[]] * (n - len(zs)), ps + [[]] * (n - len(ps))
    return [tuple(np.atleast_2d(np.real(m)) for m in zpk2ss(np.real_if_close(z), np.real_if_close(p),
                                                             gain if i == 0 else 1.0))
            for i, (z, p) in enumerate(zip(zs, ps, strict=True))]


def series(systems):
    """State space of SISO systems in series, first applied first: ``(A, B, C, D)``."""
    A, B, C, D = systems[0]
    for A2, B2, C2, D2 in systems[1:]:
        n1, n2 = A.shape[0], A2.shape[0]
        A = np.block([[A, np.zeros((n1, n2))], [B2 @ C, A2]])
        B, C, D = np.vstack([B, B2 @ D]), np.hstack([D2 @ C, C2]), D2 @ D
    return A, B.reshape(-1, 1), C.reshape(1, -1), D.reshape(1, 1)


def zpk_state_space(tf):
    """State space of a discrete :class:`~feedtune.lti.Zpk` (controller or filter)."""
    return series(_sections(tf.zeros, tf.poles, tf.gain))


def pid_state_space(kp: float, kd: float, ki: float, fs: float):
    """``kp + kd (1 - z^-1) fs + ki T / (1 - z^-1)`` (backward difference and backward-Euler integral)."""
    n0, n1, n2 = kp + kd * fs + ki / fs, -kp - 2 * kd * fs, kd * fs  # (n0 z^2 + n1 z + n2) / (z^2 - z)
    A = np.array([[1.0, 0.0], [1.0, 0.0]])  # controllable canonical form of the strictly proper part
    return A, np.array([[1.0], [0.0]]), np.array([[n1 + n0, n2]]), np.array([[n0]])


def plant_state_space(twin: GantryTwin, x: float, axis: bool):
    """The twin's exact ZOH discretization with the computational delay: y axis ``(u1, u2) -> (y1, y2)`` or
    x axis ``ux -> x``, without the states the inputs cannot reach (their own blocks, unused features)."""
    A, B = continuous_system(twin.params, x)
    Ad, Bd = twin.discrete_system(x)
    if axis:
        keep = np.arange(A.shape[0]) >= I_X
        cols, C = [2], axis_encoder_row(twin.params)[None]
    else:
        keep = np.arange(A.shape[0]) < I_X
        cols, C = [0, 1], encoder_matrix(twin.params, x)
    keep &= np.array([A[i].any() or A[:, i].any() or B[i].any() for i in range(A.shape[0])])
    Ad, Bd, C = Ad[np.ix_(keep, keep)], Bd[np.ix_(keep, cols)], C[:, keep]
    n, m, d = Ad.shape[0], len(cols), twin.params.delay_samples
    Ap = np.zeros((n + m * d, n + m * d))
    Bp = np.zeros((n + m * d, m))
    Ap[:n, :n] = Ad
    if d == 0:
        Bp[:n] = Bd
    else:
        Ap[:n, n:n + m] = Bd
        for j in range(d - 1):
            Ap[n + m * j:n + m * (j + 1), n + m * (j + 1):n + m * (j + 2)] = np.eye(m)
        Bp[n + m * (d - 1):] = np.eye(m)
    return Ap, Bp, np.hstack([C, np.zeros((C.shape[0], m * d))])


def closed_loop_radius(plant, controllers) -> float:
    """Spectral radius of the plant closed with one SISO controller per channel, ``u_i = K_i(-y_i)``."""
    return float(np.max(np.abs(np.linalg.eigvals(closed_loop_matrix(plant, controllers)))))


def closed_loop_matrix(plant, controllers) -> np.ndarray:
    """State matrix of the plant closed with one SISO controller per channel, ``u_i = K_i(-y_i)``."""
    Ap, Bp, Cp = plant
    m = len(controllers)
    nk = sum(k[0].shape[0] for k in controllers)
    AK, BK, CK, DK = np.zeros((nk, nk)), np.zeros((nk, m)), np.zeros((m, nk)), np.zeros((m, m))
    o = 0
    for i, (A, B, C, D) in enumerate(controllers):
        q = A.shape[0]
        AK[o:o + q, o:o + q], BK[o:o + q, i], CK[i, o:o + q], DK[i, i] = A, B[:, 0], C[0], D[0, 0]
        o += q
    return np.block([[Ap - Bp @ DK @ Cp, Bp @ CK], [-BK @ Cp, AK]])


# ------------------------------------------------------------------------------------ measurements
@pytest.fixture(scope="module")
def measured():
    twin = GantryTwin()
    frfs = [measure_gantry_frf(twin, x, seed=0).frf for x in XS]
    model = fit_gantry(frfs, XS, L=twin.model.L).model  # feedtune identify gantry ... --span 1.484 (README)
    axis = measure_axis_frf(twin, 0.0, seed=0).frf
    return twin, frfs, model, axis


# ------------------------------------------------------------------------------------ x axis (§4.4.1)
def _axis_figures(twin, frf, design):
    """Own loop on the measured FRF: (crossover [Hz], Ms, |S| < 1 up to [Hz], closed-loop spectral radius)."""
    f = frf.freq_hz
    Cd = matched(design.controller(), twin.fs).tf
    L = frf.channel("x/ux") * hold_and_delay(f, twin.fs, twin.params.delay_samples) * Cd.freqresp(f)
    S = np.abs(1 / (1 + L))
    rad = closed_loop_radius(plant_state_space(twin, 0.0, axis=True), [zpk_state_space(Cd)])
    return float(first_crossing(f, np.abs(L))), float(S.max()), float(first_crossing(f, 1 / S)), rad, Cd


def test_x_axis_thesis_design_needs_two_63_deg_leads_and_rejects_up_to_98_hz(measured):
    twin, _, _, frf = measured
    d = design_loopshape(frf, crossover_hz=130.0, pm_deg=35.0, filters=X_FILTERS, fs=twin.fs)
    assert len(d.lead_stages) == 2  # eq. 4.18: a double lead
    assert sum(s.phase_deg for s in d.lead_stages) == pytest.approx(126.0, abs=4.0)  # eq. 4.17: 126 deg (125.3)
    xo, ms, s_below_1, rad, _ = _axis_figures(twin, frf, d)
    assert xo == pytest.approx(130.0, rel=0.01)
    assert s_below_1 == pytest.approx(98.0, rel=0.10)  # thesis: |S| < 1 up to 98 Hz; measured 97.8 Hz
    assert rad < 1.0
    assert 1.5 < ms < 3.0  # "adequate stability margins"; measured 2.33 at 196 Hz
    # the analysis the user runs (feedtune analyze axis.toml --frf F) reports the same
    a = analyze_axis(d, frf).cases["discrete"].to_dict()
    assert a["stable"] and a["ms"] == pytest.approx(ms, rel=1e-3)
    assert a["rejection_band_hz"][1] == pytest.approx(s_below_1, abs=1.0)


def test_no_x_design_of_clearly_higher_crossover_at_the_same_margins(measured):
    twin, _, _, frf = measured
    d130 = design_loopshape(frf, crossover_hz=130.0, pm_deg=35.0, filters=X_FILTERS, fs=twin.fs)
    ms130 = _axis_figures(twin, frf, d130)[1]
    for xo in range(143, 300, 8):  # 10 % and more above 130 Hz, PM 35 deg on the measured FRF
        d = design_loopshape(frf, crossover_hz=float(xo), pm_deg=35.0, filters=X_FILTERS, fs=twin.fs)
        _, ms, _, rad, _ = _axis_figures(twin, frf, d)
        assert ms > ms130 or rad >= 1.0, f"{xo} Hz: Ms {ms:.3g} <= {ms130:.3g} and stable"
    # without the twin's amplifier lag and modes the same design rule goes far higher: the limit is the twin's
    ideal = GantryTwin(replace(twin.params, x_amp_hz=None, x_mode186=None, x_mode332=None, x_mode404=None))
    frf0 = ideal.axis_frf(frf.freq_hz, sampled=False)
    ms0 = _axis_figures(ideal, frf0, design_loopshape(frf0, crossover_hz=130.0, pm_deg=35.0, filters=X_FILTERS))[1]
    _, ms, _, rad, _ = _axis_figures(ideal, frf0, design_loopshape(frf0, crossover_hz=199.0, pm_deg=35.0,
                                                                   filters=X_FILTERS))
    assert ms < ms0 and rad < 1.0


# ------------------------------------------------------------------------------------ independent PIDs
MS_PID = 2.6  # "tuned to give a similar sensitivity peak" as the MIMO design's 2.6


def _pid_search(twin, frf, weights, ms_max, ratios=(1.0,), filters=H_PID):
    """Brute force over (kp, kd, ki) on both sides (side 2 = ratio x side 1): the highest first CoM-loop
    crossover [Hz] with max sigma_max(S) <= ms_max and a stable closed loop.

    The loop is the measured FRF (discrete: hold, delay, discrete controller) and, above its last line up to
    ``fs/2``, the twin's exact sampled response, so that ``Ms`` covers every frequency; the candidates are
    then checked in order of decreasing crossover by the eigenvalues of the closed loop.

    Returns ``(crossover_hz, ms, kp, kd, ki, ratio)`` of the best candidate.
    """
    fs, delay = twin.fs, twin.params.delay_samples
    f, G = gantry_plant(frf)
    n_meas = f.size
    G = G * hold_and_delay(f, fs, delay)[:, None, None]
    f_up = np.geomspace(f[-1] * 1.01, 0.499 * fs, 120)
    f = np.r_[f, f_up]
    G = np.concatenate([G, np.moveaxis(twin.frequency_response(f_up, 0.0), -1, 0)])
    hz = matched(filters.zpk(), fs).tf
    z = np.exp(2j * np.pi * f / fs)
    h, D, Iz = hz.freqresp(f), fs * (1 - 1 / z), (1 / fs) / (1 - 1 / z)
    KP, KD, KI = np.meshgrid(np.geomspace(1e2, 3e7, 32), np.geomspace(3.0, 3e4, 121), np.geomspace(1e3, 1e9, 7),
                             indexing="ij")  # ki > 0: the integrator state is then part of the loop
    gains = np.stack([KP.ravel(), KD.ravel(), KI.ravel()], -1)
    w = np.asarray(weights)
    found = []
    for r in ratios:
        for s in range(0, len(gains), 4096):
            g = gains[s:s + 4096]
            c1 = h * (g[:, :1] + g[:, 1:2] * D + g[:, 2:3] * Iz)  # (b, n) side-1 controller, side 2 = r c1
            c2 = r * c1
            m11, m12 = 1 + G[:, 0, 0] * c1, G[:, 0, 1] * c2  # I + L = I + G diag(c1, c2)
            m21, m22 = G[:, 1, 0] * c1, 1 + G[:, 1, 1] * c2
            a = np.abs(m11) ** 2 + np.abs(m12) ** 2 + np.abs(m21) ** 2 + np.abs(m22) ** 2
            det = np.abs(m11 * m22 - m12 * m21)
            s_min = np.sqrt(np.maximum((a - np.sqrt(np.maximum(a * a - 4 * det * det, 0.0))) / 2, 1e-300))
            ms = (1.0 / s_min).max(axis=1)  # max sigma_max(S) = 1 / min sigma_min(I + L)
            k = n_meas
            lcom = np.abs(w[0] * (m11[:, :k] - 1 + m12[:, :k]) + w[1] * (m21[:, :k] + m22[:, :k] - 1))
            xo = first_crossing(f[:k], lcom)
            ok = (ms <= ms_max) & np.isfinite(xo)
            found += [(xo[j], ms[j], *g[j], r) for j in np.flatnonzero(ok)]
    found.sort(key=lambda row: -row[0])
    # the closed-loop matrix is affine in the six gains (the PID's C and D are): A(g) = A0 + sum g_j E_j
    plant = plant_state_space(twin, 0.0, axis=False)
    hss = zpk_state_space(hz)

    def acl(g1, g2):
        ks = [series([pid_state_space(*g, fs), hss]) for g in (g1, g2)]
        return closed_loop_matrix(plant, ks)

    A0 = acl((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    E = np.stack([acl(tuple(np.eye(6)[j, :3]), tuple(np.eye(6)[j, 3:])) - A0 for j in range(6)])
    rows = np.array(found, float).reshape(-1, 6)
    for s in range(0, len(rows), 2048):
        part = rows[s:s + 2048]
        g = np.column_stack([part[:, 2:5], part[:, 2:5] * part[:, 5:6]])
        radius = np.abs(np.linalg.eigvals(A0 + np.einsum("bj,jkl->bkl", g, E))).max(axis=1)
        stable = np.flatnonzero(radius < 1.0)
        if stable.size:
            return tuple(part[stable[0]])
    return None


def test_pid_state_space_is_the_discrete_pid():
    fs = 15000.0
    f = np.array([0.5, 16.0, 110.0, 3000.0])
    z = np.exp(2j * np.pi * f / fs)
    A, B, C, D = pid_state_space(300.0, 2.0, 5e4, fs)
    got = np.array([(C @ np.linalg.solve(zk * np.eye(2) - A, B) + D)[0, 0] for zk in z])
    assert np.allclose(got, 300.0 + 2.0 * fs * (1 - 1 / z) + 5e4 / fs / (1 - 1 / z), rtol=1e-12)


@pytest.mark.slow
def test_independent_pids_with_the_thesis_filters_stay_near_16_hz(measured):
    twin, frfs, model, _ = measured
    best = _pid_search(twin, frfs[1], model.alpha(0.0), MS_PID)
    assert best is not None
    xo, ms, *_ = best
    # thesis: "the maximum achievable crossover frequency was only 16 Hz"; measured 14.7 Hz. Tolerance -30/+25 %:
    # the search is over all PID gains (the thesis tuned one PID family), a 2 % grid in kd sets the crossover
    assert 0.7 * 16.0 <= xo <= 1.25 * 16.0, best
    assert ms <= MS_PID
    # the library's tuner (feedtune design pid --ms-max 2.6 --frf ...) finds no more than the exhaustive search
    pid = tune_gantry_pid(model, ms_max=MS_PID, filters=H_PID, fs=twin.fs, frf=frfs[1])
    assert pid.tuning["com_crossover_hz"] <= xo * 1.02
    assert pid.tuning["com_crossover_hz"] >= 0.75 * xo


@pytest.mark.slow
def test_unequal_pid_gains_on_the_two_sides_do_not_raise_the_ceiling(measured):
    twin, frfs, model, _ = measured
    even = _pid_search(twin, frfs[1], model.alpha(0.0), MS_PID)
    uneven = _pid_search(twin, frfs[1], model.alpha(0.0), MS_PID, ratios=(0.7, 0.85, 1.2, 1.4))
    assert uneven is None or uneven[0] <= even[0] * 1.05, (even, uneven)


@pytest.mark.slow
def test_without_the_filters_the_same_search_finds_pids_far_above_16_hz(measured):
    # the README path: `design gantry` without the filter pack, then `design pid --match`, which copies the
    # (absent) filters: nothing in the twin's y axis stops a high-gain PID then (the thesis does not quantify the
    # y dynamics that made its filters necessary; see docs/gantry_twin.md). This also shows the search reaches
    # high crossovers where they exist.
    twin, frfs, model, _ = measured
    best = _pid_search(twin, frfs[1], model.alpha(0.0), MS_PID, filters=FilterPack())
    assert best is not None and best[0] > 100.0, best  # measured 312 Hz
    plain = tune_gantry_pid(model, ms_max=2.0, fs=twin.fs, frf=frfs[1])
    assert plain.tuning["com_crossover_hz"] > 100.0  # the README's 182-300 Hz


# ------------------------------------------------------------------------------------ MIMO (§4.4.2)
def _mimo_figures(twin, frf, law, weights):
    """Own figures of the discrete loop on the measured FRF: CoM crossover [Hz], Ms, its frequency [Hz],
    sigma_max(S) < 1 up to [Hz]."""
    f, G = gantry_plant(frf)
    L = G * hold_and_delay(f, twin.fs, twin.params.delay_samples)[:, None, None]
    L = L @ np.moveaxis(law.response_discrete(f), -1, 0)
    S = np.linalg.inv(np.eye(2) + L)
    s = sigma_max(S)
    lcom = np.abs(np.einsum("i,nij,j->n", np.asarray(weights), L, np.ones(2)))
    return float(first_crossing(f, lcom)), float(s.max()), float(f[np.argmax(s)]), float(first_crossing(f, 1 / s))


def test_mimo_thesis_design_on_the_measured_frf(measured):
    twin, frfs, model, _ = measured
    mimo = design_gantry_mimo(model, crossover_hz=60.0, pm_deg=40.0, damping_increase=5.9, filters=H_THESIS,
                              fs=twin.fs)
    xo, ms, ms_hz, s_below_1 = _mimo_figures(twin, frfs[1], mimo.law, model.alpha(0.0))
    a = analyze_gantry(mimo.law, model, frf=frfs[1]).cases["discrete"].to_dict()
    # the analysis also evaluates the FRF between its lines (interpolated): its Ms is at least the lines' maximum
    assert a["stable"] and ms * (1 - 1e-9) <= a["ms"] <= ms * 1.03
    assert a["crossovers_hz"][0] == pytest.approx(xo, rel=0.01)
    # what the twin gives: the design places the CoM crossover at 60 Hz on the identified model, and the
    # measured plant agrees with it there (measured 60.4 Hz; Ms 1.86 at 88 Hz, near the actively damped yaw mode)
    assert xo == pytest.approx(60.0, rel=0.05)
    assert 1.5 < ms < 2.3 and 70.0 < ms_hz < 110.0
    assert s_below_1 == pytest.approx(28.0, rel=0.15)  # thesis: rejection improved up to 28 Hz; measured 31 Hz


@pytest.mark.xfail(strict=True, reason="the thesis' 52 Hz / Ms 2.6 at 40 Hz come from its design choices (loop "
                                       "gain ~0.86 x and an integral ~3 x our default), not from the plant: see "
                                       "docs/gantry_twin.md, Calibration")
def test_mimo_thesis_design_matches_the_published_52_hz_and_ms_2_6(measured):
    twin, frfs, model, _ = measured
    mimo = design_gantry_mimo(model, crossover_hz=60.0, pm_deg=40.0, damping_increase=5.9, filters=H_THESIS,
                              fs=twin.fs)
    xo, ms, _, _ = _mimo_figures(twin, frfs[1], mimo.law, model.alpha(0.0))
    assert xo == pytest.approx(52.0, rel=0.10)
    assert ms == pytest.approx(2.6, rel=0.15)


def test_the_published_mimo_figures_follow_from_the_thesis_design_choices(measured):
    # the same law with its loop gain scaled to put the first crossover at the published 52 Hz (x 0.86) and an
    # integral gain 3 x the default rule (Fig. 4.12 studies aggressive ki): the sensitivity peak then lies at
    # 40 Hz and the rejection band ends at 28 Hz, as published, on the twin's measured FRF
    twin, frfs, model, _ = measured
    mimo = design_gantry_mimo(model, crossover_hz=60.0, pm_deg=40.0, damping_increase=5.9, filters=H_THESIS,
                              fs=twin.fs)
    law = replace(mimo.law, lead_gain=0.86 * mimo.law.lead_gain, ki=3.0 * 0.86 * mimo.law.ki)
    xo, ms, ms_hz, s_below_1 = _mimo_figures(twin, frfs[1], law, model.alpha(0.0))
    assert xo == pytest.approx(52.0, rel=0.15)
    assert ms == pytest.approx(2.6, rel=0.15)
    assert ms_hz == pytest.approx(40.0, abs=5.0)
    assert s_below_1 == pytest.approx(28.0, rel=0.10)
