"""Tests of feedtune.sim.trajectory against hand-derived S-curve numbers and calculus identities."""

from __future__ import annotations

import json
import math
import time
from itertools import pairwise

import numpy as np
import pytest

from feedtune.errors import UsageError
from feedtune.sim.trajectory import (
    Trajectory,
    acceleration_mask,
    constant_velocity_mask,
    multi_segment,
    point_to_point,
)

RTOL = 1e-9
FS = 20000.0
DT = 1.0 / FS

# Thesis §4.5: 200 mm/s, 2 m/s^2, 50 m/s^3; a snap limit of 2000 m/s^4 makes every width a round number.
LONG = {"v_max": 0.2, "a_max": 2.0, "j_max": 50.0}
LONG_SNAP = {**LONG, "s_max": 2000.0}
# Thesis §3.4: 1 g acceleration, jerk 500 m/s^3, snap 1e5 m/s^4 at 200, 500 and 1000 mm/s over 0.1 m.
G = 9.81
BALLSCREW = [{"v_max": v, "a_max": G, "j_max": 500.0, "s_max": 1e5} for v in (0.2, 0.5, 1.0)]


def _limit_values(lim: dict) -> dict:
    out = {"velocity": lim["v_max"], "acceleration": lim["a_max"], "jerk": lim["j_max"]}
    if lim.get("s_max") is not None:
        out["snap"] = lim["s_max"]
    return out


def _assert_within_limits(tr: Trajectory, lim: dict) -> None:
    peaks = tr.peaks()
    for name, limit in _limit_values(lim).items():
        assert peaks[name] <= limit * (1 + RTOL), (name, peaks[name], limit)


# ---------------------------------------------------------------------------------------------- hand cases


def test_all_limits_reached_widths_duration_and_peaks_by_hand():
    # T4 = j/s = 0.025, T3 = a/j = 0.04, T2 = v/a = 0.1, T1 = D/v = 0.5; duration 0.665 s.
    tr = point_to_point(0.1, **LONG_SNAP, fs=FS)
    np.testing.assert_allclose(tr.moves[0].widths, [0.5, 0.1, 0.04, 0.025], rtol=1e-12)
    moving = np.flatnonzero(tr.vel != 0)
    # motion spans (0, 0.665): first moving sample 1, last before 0.665 s = sample 13299
    assert moving[0] == 1 and moving[-1] == 13299
    assert tr.pos[13300] == 0.1 and tr.t[13300] == pytest.approx(0.665, abs=1e-12)
    peaks = tr.peaks()
    np.testing.assert_allclose(
        [peaks["velocity"], peaks["acceleration"], peaks["jerk"], peaks["snap"]], [0.2, 2.0, 50.0, 2000.0],
        rtol=RTOL,
    )


def test_jerk_limited_matches_textbook_s_curve_phase_formulas():
    # 7-segment S-curve, thesis §4.5 limits, 0.1 m: Tj = a/j = 0.04 s, Ta = v/a = 0.1 s, T1 = 0.5 s.
    v, a, j, d = 0.2, 2.0, 50.0, 0.1
    tr = point_to_point(d, **LONG, fs=FS)
    total = d / v + v / a + a / j
    assert tr.moves[0].duration == pytest.approx(0.64, rel=1e-12)
    t = tr.t
    ramp = t <= a / j  # jerk phase: a = j t, v = j t^2 / 2, x = j t^3 / 6
    np.testing.assert_allclose(tr.acc[ramp], j * t[ramp], rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(tr.vel[ramp], j * t[ramp] ** 2 / 2, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(tr.pos[ramp], j * t[ramp] ** 3 / 6, rtol=1e-11, atol=1e-16)
    flat = (t > a / j + 1e-9) & (t < v / a - 1e-9)  # constant acceleration: v = a t - a^2/(2j)
    np.testing.assert_allclose(tr.vel[flat], a * t[flat] - a * a / (2 * j), rtol=1e-12)
    assert np.all(tr.jerk[flat] == 0) and np.all(tr.acc[flat] == pytest.approx(a, rel=1e-12))
    cruise = (t > v / a + a / j + 1e-9) & (t < d / v - 1e-9)  # x = v (t - (Ta + Tj)/2)
    np.testing.assert_allclose(tr.pos[cruise], v * (t[cruise] - (v / a + a / j) / 2), rtol=1e-12)
    assert np.all(tr.vel[cruise] == pytest.approx(v, rel=1e-15))
    assert set(np.unique(np.round(tr.jerk, 9))) == {-j, 0.0, j}
    mirrored = np.interp(total - t[t <= total], t, tr.pos)  # x(T - t) = D - x(t)
    np.testing.assert_allclose(mirrored, d - tr.pos[t <= total], atol=1e-7)  # interp error ~ v dt^2 a


def test_short_jerk_limited_move_without_acc_or_velocity_plateau():
    # Neither v nor a reachable: T1 = 2 tau, T2 = T3 = tau with D = 2 j tau^3. tau = 0.01 s -> D = 1 mm,
    # peaks: v = D / T1 = 0.05 m/s, a = j tau = 5 m/s^2, j = 500 m/s^3.
    tr = point_to_point(1e-3, v_max=0.2, a_max=G, j_max=500.0, fs=FS)
    np.testing.assert_allclose(tr.moves[0].widths, [0.02, 0.01, 0.01], rtol=1e-12)
    assert tr.moves[0].duration == pytest.approx(0.04, rel=1e-12)
    peaks = tr.peaks()
    np.testing.assert_allclose([peaks["velocity"], peaks["acceleration"], peaks["jerk"]], [0.05, 5.0, 500.0],
                               rtol=RTOL)
    assert not constant_velocity_mask(tr).any()


def test_short_snap_limited_move_only_snap_reached():
    # Only s reachable: T4 = T3 = tau, T2 = 2 tau, T1 = 4 tau, D = s * 8 tau^4.
    # s = 1e5, tau = 0.01 -> D = 8 mm; peaks v = D/T1 = 0.2, a = D/(T1 T2) = 10,
    # j = D/(T1 T2 T3) = 1000, snap = 1e5; duration 8 tau.
    tr = point_to_point(8e-3, v_max=1.0, a_max=50.0, j_max=2000.0, s_max=1e5, fs=FS)
    np.testing.assert_allclose(tr.moves[0].widths, [0.04, 0.02, 0.01, 0.01], rtol=1e-9)
    assert tr.moves[0].duration == pytest.approx(0.08, rel=1e-9)
    p = tr.peaks()
    measured = [p["velocity"], p["acceleration"], p["jerk"], p["snap"]]
    np.testing.assert_allclose(measured, [0.2, 10.0, 1000.0, 1e5], rtol=1e-9)


def test_ballscrew_cases_of_thesis_section_3_4():
    d = 0.1
    # 200 mm/s: a is not reached; with T2 = T3 + T4, T3 = A/j, T4 = j/s, T2 = v/A:
    # A^2/j + A j/s = v -> A = 250 (sqrt(0.005^2 + 0.0016) - 0.005) = 8.82782218 m/s^2 (by hand).
    # The widths are then T4 = 0.005, T3 = A/500, T2 = 0.2/A, T1 = 0.5 s.
    tr = point_to_point(d, **BALLSCREW[0], fs=FS)
    _assert_within_limits(tr, BALLSCREW[0])
    a_hand = 8.82782218
    np.testing.assert_allclose(tr.moves[0].widths, [0.5, 0.2 / a_hand, a_hand / 500.0, 0.005], rtol=1e-8)
    p = tr.peaks()
    # no acceleration plateau: the sampled peak lies within s dt^2 / 8 below the continuous one
    assert a_hand - 1e5 * DT**2 / 8 - 1e-7 <= p["acceleration"] <= a_hand + 1e-7
    assert p["velocity"] == pytest.approx(0.2, rel=RTOL) and p["snap"] == pytest.approx(1e5, rel=RTOL)
    # 500 mm/s: every limit reached (T = 0.2, 0.05097, 0.01962, 0.005 s).
    tr = point_to_point(d, **BALLSCREW[1], fs=FS)
    p = tr.peaks()
    np.testing.assert_allclose([p["velocity"], p["acceleration"], p["jerk"], p["snap"]], [0.5, G, 500.0, 1e5],
                               rtol=RTOL)
    assert tr.moves[0].duration == pytest.approx(0.2 + 0.5 / G + G / 500.0 + 500.0 / 1e5, rel=1e-12)
    # 1000 mm/s: no cruise; v solves v^2/a + v (a/j + j/s) = D (quadratic by hand): 0.877028 m/s.
    tr = point_to_point(d, **BALLSCREW[2], fs=FS)
    b = G / 500.0 + 500.0 / 1e5
    v_peak = G / 2 * (math.sqrt(b * b + 4 * d / G) - b)
    assert tr.peaks()["velocity"] == pytest.approx(v_peak, rel=1e-6)
    assert tr.moves[0].duration == pytest.approx(d / v_peak + v_peak / G + b, rel=1e-9)
    assert not constant_velocity_mask(tr).any()
    _assert_within_limits(tr, BALLSCREW[2])


# ---------------------------------------------------------------------------------------------- grid


@pytest.mark.parametrize("snap", [None, "s"])
def test_peaks_never_exceed_limits_and_end_exactly_over_a_grid(snap):
    limit_sets = [
        LONG, {"v_max": 1.0, "a_max": G, "j_max": 500.0}, {"v_max": 0.05, "a_max": 20.0, "j_max": 1e4}
    ]
    for lim in limit_sets:
        lim = dict(lim)
        if snap:
            lim["s_max"] = 4 * lim["j_max"] ** 2 / lim["a_max"]
        for d in (1e-6, 3e-4, 2e-3, 0.013, 0.1, 0.37):
            for sign in (1, -1):
                tr = point_to_point(sign * d, **lim, fs=FS, start=0.25)
                _assert_within_limits(tr, lim)
                assert tr.pos[-1] == 0.25 + sign * d
                w = tr.moves[0].widths
                assert tr.moves[0].duration == pytest.approx(sum(w), rel=1e-12)
                for k in range(len(w) - 1):  # non-overlapping boxes
                    assert w[k] >= sum(w[k + 1:]) * (1 - 1e-15)


def test_long_moves_reach_every_limit():
    for lim in (LONG_SNAP, {**LONG, "s_max": None}, BALLSCREW[1]):
        lim = {k: v for k, v in lim.items() if v is not None}
        tr = point_to_point(0.3, **lim, fs=FS)
        p = tr.peaks()
        for name, limit in _limit_values(lim).items():
            assert p[name] == pytest.approx(limit, rel=RTOL)


# ---------------------------------------------------------------------------------------------- calculus


@pytest.mark.parametrize("lim", [LONG_SNAP, BALLSCREW[0]])
def test_snap_limited_derivatives_agree_with_numerical_differentiation(lim):
    tr = point_to_point(0.05, **lim, fs=FS, dwell_before=0.01, dwell_after=0.01)
    p = tr.peaks()
    inner = slice(1, -1)
    # central difference error <= h^2/6 max|x'''| for smooth x; <= h/2 Lip(x') across kinks.
    err_v = np.abs(np.gradient(tr.pos, DT) - tr.vel)[inner]
    assert err_v.max() <= DT**2 / 6 * p["jerk"] * 1.01 + 1e-12
    err_a = np.abs(np.gradient(tr.vel, DT) - tr.acc)[inner]
    assert err_a.max() <= DT**2 / 6 * p["snap"] * 1.01 + 1e-10
    err_j = np.abs(np.gradient(tr.acc, DT) - tr.jerk)[inner]
    assert err_j.max() <= DT / 2 * p["snap"] * 1.01
    same = np.r_[False, (tr.snap[:-2] == tr.snap[1:-1]) & (tr.snap[1:-1] == tr.snap[2:]), False]
    err_s = np.abs(np.gradient(tr.jerk, DT) - tr.snap)[same]
    assert err_s.max() <= 1e-6 * p["snap"]
    assert same.sum() > 0.9 * tr.n


def test_jerk_limited_derivatives_agree_with_numerical_differentiation():
    tr = point_to_point(0.05, **LONG, fs=FS, dwell_after=0.01)
    p = tr.peaks()
    inner = slice(1, -1)
    assert np.abs(np.gradient(tr.pos, DT) - tr.vel)[inner].max() <= DT**2 / 6 * p["jerk"] * 1.01 + 1e-12
    assert np.abs(np.gradient(tr.vel, DT) - tr.acc)[inner].max() <= DT / 2 * p["jerk"] * 1.01
    same = np.r_[False, (tr.jerk[:-2] == tr.jerk[1:-1]) & (tr.jerk[1:-1] == tr.jerk[2:]), False]
    assert np.abs(np.gradient(tr.acc, DT) - tr.jerk)[same].max() <= 1e-6 * p["jerk"]
    assert np.all(tr.snap == 0)


def test_cumulative_integrals_reproduce_lower_derivatives():
    from scipy.integrate import cumulative_trapezoid

    tr = point_to_point(0.08, **LONG_SNAP, fs=FS)
    p = tr.peaks()
    span = tr.duration
    n_knots = 16
    # trapezoid rule: error <= span h^2/12 max|f''| for smooth f; a kink with slope jump J adds <= J h^2/4.
    jerk = cumulative_trapezoid(tr.snap, tr.t, initial=0.0)
    assert np.abs(jerk - tr.jerk).max() <= n_knots * 2 * p["snap"] * DT  # snap jumps: O(h) per knot
    acc = cumulative_trapezoid(tr.jerk, tr.t, initial=0.0)
    assert np.abs(acc - tr.acc).max() <= n_knots * 2 * p["snap"] * DT**2 / 4
    vel = cumulative_trapezoid(tr.acc, tr.t, initial=0.0)
    assert np.abs(vel - tr.vel).max() <= span * DT**2 / 12 * p["snap"] + 1e-14
    pos = cumulative_trapezoid(tr.vel, tr.t, initial=0.0)
    assert np.abs(pos - tr.pos).max() <= span * DT**2 / 12 * p["jerk"] + 1e-14


def test_jerk_is_continuous_when_snap_is_limited():
    for lim in (LONG_SNAP, *BALLSCREW):
        tr = point_to_point(0.1, **lim, fs=FS)
        assert np.abs(np.diff(tr.jerk)).max() <= lim["s_max"] / FS * (1 + RTOL)
    # without a snap limit the jerk jumps by j_max within one sample
    tr = point_to_point(0.1, **LONG, fs=FS)
    assert np.abs(np.diff(tr.jerk)).max() == pytest.approx(LONG["j_max"], rel=RTOL)


# ---------------------------------------------------------------------------------------------- ends, sign


def test_rest_before_and_after_move_is_exact():
    tr = point_to_point(-0.07, **LONG_SNAP, fs=FS, start=0.3, dwell_before=0.05, dwell_after=0.1)
    before = tr.t < 0.05 - 1e-12
    assert np.all(tr.pos[before] == 0.3)
    move = tr.moves[0]
    after = tr.t >= move.t_end
    assert after.sum() >= round(0.1 * FS)
    assert np.all(tr.pos[after] == 0.3 + -0.07)
    for x in (tr.vel, tr.acc, tr.jerk, tr.snap):
        assert np.all(x[after] == 0) and np.all(x[before] == 0)
    assert tr.duration >= 0.05 + move.duration + 0.1 - 1e-12


def test_negative_distance_is_the_mirror_image():
    fwd = point_to_point(0.123, **LONG_SNAP, fs=FS)
    back = point_to_point(-0.123, **LONG_SNAP, fs=FS)
    np.testing.assert_array_equal(back.t, fwd.t)
    for name in ("pos", "vel", "acc", "jerk", "snap"):
        np.testing.assert_array_equal(getattr(back, name), -getattr(fwd, name))


def test_zero_distance_gives_a_constant_trajectory():
    tr = point_to_point(0.0, **LONG, fs=FS, start=0.02, dwell_after=0.01)
    assert tr.n == 201 and np.all(tr.pos == 0.02) and tr.profile == "constant"
    assert tr.peaks() == {"velocity": 0.0, "acceleration": 0.0, "jerk": 0.0, "snap": 0.0}
    assert point_to_point(0.0, **LONG).n == 2
    assert not constant_velocity_mask(tr).any() and not acceleration_mask(tr).any()


def test_sample_grid_is_uniform_from_zero():
    tr = point_to_point(0.1, **LONG, fs=1000.0)
    assert tr.t[0] == 0.0 and tr.fs == 1000.0
    np.testing.assert_allclose(np.diff(tr.t), 1e-3, rtol=1e-9)


# ---------------------------------------------------------------------------------------------- multi segment


def test_multi_segment_stops_exactly_at_every_waypoint_with_dwells():
    waypoints = [0.0, 0.02, -0.02, -0.02, 0.1]
    dwell = 0.1
    tr = multi_segment(waypoints, **LONG_SNAP, fs=FS, dwell=dwell)
    assert len(tr.moves) == 4
    _assert_within_limits(tr, LONG_SNAP)
    singles = [point_to_point(b - a, **LONG_SNAP, fs=FS).moves[0].duration for a, b in pairwise(waypoints)]
    assert tr.moves[-1].t_end == pytest.approx(sum(singles) + 3 * dwell, rel=1e-12)
    for k, move in enumerate(tr.moves):
        assert move.duration == pytest.approx(singles[k], rel=1e-12)
        assert move.start == waypoints[k] and move.target == waypoints[k + 1]
        rest = (tr.t >= move.t_end) & (tr.t < move.t_end + dwell - 1e-9)
        assert rest.any() and np.all(tr.pos[rest] == waypoints[k + 1]) and np.all(tr.vel[rest] == 0)
    assert tr.pos[-1] == 0.1 and tr.pos[0] == 0.0
    # 0.02 m is shorter than the 0.2 m/s * 0.165 s = 0.033 m that reaching v_max takes; 0.12 m reaches it
    first = tr.t < tr.moves[0].t_end
    assert tr.vel[first].max() < 0.19
    assert tr.vel.max() == pytest.approx(0.2, rel=RTOL)


def test_multi_segment_rejects_bad_waypoints():
    for bad in ([0.1], [], [0.0, float("nan")], [[0.0, 1.0]], "ab"):
        with pytest.raises(UsageError, match="waypoints"):
            multi_segment(bad, **LONG)
    with pytest.raises(UsageError, match="dwell"):
        multi_segment([0, 1e-3], **LONG, dwell=-1)


# ---------------------------------------------------------------------------------------------- masks


def test_masks_mark_cruise_and_transients_by_hand_widths():
    # cruise on [T2 + T3 + T4, T1] = [0.165, 0.5] s; transients on (0, 0.165) and (0.5, 0.665) s.
    tr = point_to_point(0.1, **LONG_SNAP, fs=FS, dwell_after=0.05)
    cruise = constant_velocity_mask(tr)
    expected = (tr.t >= 0.165) & (tr.t <= 0.5)
    # only samples within a few microseconds of the phase boundaries may differ (acc ~ s t^3/6 there)
    differ = np.flatnonzero(cruise != expected)
    assert np.all(np.minimum(np.abs(tr.t[differ] - 0.165), np.abs(tr.t[differ] - 0.5)) < 3 * DT)
    trans = acceleration_mask(tr)
    expected_trans = ((tr.t > 0) & (tr.t < 0.165)) | ((tr.t > 0.5) & (tr.t < 0.665))
    differ = np.flatnonzero(trans != expected_trans)
    edges = np.array([0.0, 0.165, 0.5, 0.665])
    assert np.all(np.min(np.abs(tr.t[differ, None] - edges), axis=1) < 3 * DT)
    assert not np.any(cruise & trans)


def test_mask_rejects_bad_tolerance():
    tr = point_to_point(0.01, **LONG)
    with pytest.raises(UsageError, match="tol"):
        constant_velocity_mask(tr, tol=1.5)
    with pytest.raises(UsageError, match="tol"):
        acceleration_mask(tr, tol=float("nan"))


# ---------------------------------------------------------------------------------------------- hand-over


def test_to_log_and_to_dict():
    tr = point_to_point(0.1, **LONG_SNAP, fs=FS)
    log = tr.to_log()
    assert list(log.signals) == ["x_ref", "v_ref", "a_ref", "j_ref", "s_ref"]
    assert log.units == {"x_ref": "m", "v_ref": "m/s", "a_ref": "m/s^2", "j_ref": "m/s^3", "s_ref": "m/s^4"}
    np.testing.assert_array_equal(log["a_ref"], tr.acc)
    assert list(tr.to_log("y_ref").signals) == ["y_ref", "vy_ref", "ay_ref", "jy_ref", "sy_ref"]
    d = json.loads(json.dumps(tr.to_dict()))
    assert d["duration"] == pytest.approx(0.665, abs=DT) and d["distance"] == pytest.approx(0.1, rel=1e-15)
    assert d["limits"] == {"v_max": 0.2, "a_max": 2.0, "j_max": 50.0, "s_max": 2000.0}
    assert d["units"]["peaks"]["snap"] == "m/s^4" and d["profile"] == "snap-limited"
    assert d["moves"][0]["box_widths_s"] == pytest.approx([0.5, 0.1, 0.04, 0.025], rel=1e-12)


# ---------------------------------------------------------------------------------------------- bad input


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"v_max": 0.0}, "v_max"),
        ({"v_max": -1.0}, "v_max"),
        ({"a_max": float("nan")}, "a_max"),
        ({"j_max": float("inf")}, "j_max"),
        ({"j_max": "fast"}, "j_max"),
        ({"s_max": 0.0}, "s_max"),
        ({"s_max": 100.0}, "s_max"),  # below j^2/a = 1250 m/s^4: jerk limit unreachable
        ({"fs": 0.0}, "fs"),
        ({"fs": -5.0}, "fs"),
        ({"distance": float("nan")}, "distance"),
        ({"start": float("inf")}, "start"),
        ({"dwell_before": -0.1}, "dwell_before"),
        ({"dwell_after": float("nan")}, "dwell_after"),
        ({"distance": 1e3, "fs": 1e5}, "samples"),
    ],
)
def test_bad_input_raises_one_line_usage_error(kwargs, name):
    args = {"distance": 0.1, **LONG, "s_max": None, "fs": FS}
    args.update(kwargs)
    distance = args.pop("distance")
    with pytest.raises(UsageError, match=name) as info:
        point_to_point(distance, **args)
    assert "\n" not in str(info.value)


# ---------------------------------------------------------------------------------------------- speed


def test_ten_second_trajectory_is_fast():
    kwargs = {**LONG_SNAP, "fs": FS, "dwell_after": 0.335}
    point_to_point(1.9, **kwargs)  # warm the caches
    best = math.inf
    for d in (1.9, 1.9000001, 1.9000002):  # different distances: no cached move tables
        t0 = time.perf_counter()
        tr = point_to_point(d, **kwargs)
        best = min(best, time.perf_counter() - t0)
    assert tr.duration == pytest.approx(10.0, abs=1e-3)
    assert best < 0.1
