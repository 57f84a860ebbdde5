"""Benchmark and acceptance of issue 29: a simulated fleet of 200 ball-screw axes x 12 weekly measurements.

Run by hand (a few minutes on 2 cores): ``python benchmarks/bench_fleet.py [--axes 200] [--weeks 12] [--folder DIR]
[--no-dask] [--no-kill]``; ``--folder`` keeps (and reuses) the simulated fleet.

1. The fleet: :func:`feedtune.fleet.simulate_fleet` (10 % of the axes drift: half the axial stiffness -2 %/week, half
   the Coulomb friction +5 %/week, from an onset week in 0.5-4.5), with its truth (``truth.json``).
2. Anchor, measured in this run: the single-task time, the task function run serially in this process on one axis'
   12 measurements after a warm-up (best of 3); the ideal fleet time is that x tasks / cores.
3. The fleet on local processes (every core): wall time of the measurement phase, per measurement and per axis,
   against the ideal (target: within 2x); peak memory of each worker.
4. The same fleet on a Dask LocalCluster of 2 single-threaded workers: identical history (every column, every row).
5. Killed midway (SIGKILL at half the rows) and run again: no duplicate row, no lost measurement.
6. Drift against the truth: a stiffness loss of 10 % detected within 3 measurements in >= 90 % of the stiffness-
   drifting axes; alarms on <= 1 % of the axes that do not drift; the friction drift's detection for information.
7. Forecast against the truth: for every stiffness-drifting axis whose installed gains fail on the noise-free plant,
   the forecast made with the measurements before the failure (the fleet as it was then,
   :func:`feedtune.fleet.fleet_status` ``until=``; at the end of the record when the failure comes later) within
   +-2 weeks of the actual week in >= 80 %.
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

WEEK = dt.timedelta(days=7)


def single_task_seconds(plan, axis_id: str) -> tuple[float, float]:
    """Mean wall and CPU time of the task function on one axis' measurements, serially in this process, best of 3."""
    from feedtune.fleet.task import run_measurement

    tasks = [t for t in plan.tasks if t.axis_id == axis_id]
    run_measurement(tasks[0])  # imports, caches
    best, cpu = float("inf"), float("inf")
    for _ in range(3):
        t0, c0 = time.perf_counter(), time.process_time()
        for t in tasks:
            run_measurement(t)
        best = min(best, (time.perf_counter() - t0) / len(tasks))
        cpu = min(cpu, (time.process_time() - c0) / len(tasks))
    return best, cpu


def kill_and_resume(manifest_path: Path, history: Path, rows: int) -> dict:
    """Run the fleet in a child process, SIGKILL it at about half the rows, run again; count rows and keys."""
    from feedtune.fleet import Engine, load_manifest, read_history, run_fleet
    from feedtune.fleet.history import part_files

    script = ("import sys\nfrom feedtune.fleet import load_manifest, run_fleet\nif __name__ == '__main__':\n"
              "    run_fleet(load_manifest(sys.argv[1]), sys.argv[2], status=False)\n")
    with tempfile.NamedTemporaryFile("w", suffix=".py", delete=False) as fh:
        fh.write(script)
    proc = subprocess.Popen([sys.executable, fh.name, str(manifest_path), str(history)],
                            env={**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1])})
    while proc.poll() is None:
        time.sleep(0.2)
        if part_files(history) and read_history(history, columns=["key"]).num_rows >= rows // 2:
            proc.send_signal(signal.SIGKILL)
            break
    proc.wait()
    os.unlink(fh.name)
    killed = read_history(history, columns=["key"]).num_rows
    with Engine() as engine:
        again = run_fleet(load_manifest(manifest_path), history, engine=engine, status=False).summary
    keys = read_history(history, columns=["key"]).column("key").to_pylist()
    return {"rows_at_kill": killed, "written_after": again.written, "rows": len(keys), "unique_keys": len(set(keys))}


def detection(status, truth: dict, start: dt.datetime) -> dict:
    """Alarms against the truth (module docstring, 6)."""
    by_id = {a.axis_id: a for a in status.axes}
    quiet = [t for t in truth["axes"] if t["drift"] is None]
    false = [t["axis_id"] for t in quiet if by_id[t["axis_id"]].alarms]
    out = {"axes_without_drift": len(quiet), "false_alarms": len(false), "false_alarm_axes": false}
    for kind, param, change in (("stiffness", "k", 0.10), ("friction", "coulomb", 0.10)):
        axes = [t for t in truth["axes"] if t["drift"] == kind]
        delays, missed = [], []
        for t in axes:
            a = by_id[t["axis_id"]]
            dates = [r["measured_at"] for r in a.rows]
            weeks = [(d - start) / WEEK for d in dates]
            reach = t["onset_week"] + change / abs(t["rate_per_week"])  # the loss (rise) reaches 10 %
            first_after = next((i for i, w in enumerate(weeks) if w >= reach), None)
            if first_after is None:  # the change does not reach 10 % within the record: not counted
                continue
            tr = a.trends.get(param)
            if tr is None or not tr.alarm:
                missed.append(t["axis_id"])
            else:
                delays.append(tr.alarm_index - first_after)
        ok = sum(1 for d in delays if d <= 3)
        counted = len(delays) + len(missed)
        out[kind] = {"axes": len(axes), "counted": counted, "within_3": ok,
                     "share_within_3": ok / counted if counted else None, "delays": delays, "missed": missed}
    return out


def forecasts(manifest, history, plan, status, truth: dict, start: dt.datetime, engine) -> dict:
    """Forecasts against the truth (module docstring, 7)."""
    from feedtune.fleet.forecast import run_forecast
    from feedtune.fleet.status import axis_trends, forecast_task

    by_id = {a.axis_id: a for a in status.axes}
    tasks, cases = [], {}
    for t in truth["axes"]:
        if t["drift"] != "stiffness" or t["violation_week"] is None:
            continue
        a = by_id[t["axis_id"]]
        fail = start + t["violation_week"] * WEEK
        rows = [r for r in a.rows if r["measured_at"] < fail]
        entry = manifest.axis(t["axis_id"])
        task = forecast_task(entry, manifest, rows, axis_trends(rows, status.scatter, status.settings), plan,
                             52.0) if rows else None
        cases[t["axis_id"]] = {"actual_week": t["violation_week"], "made_at_week": ((rows[-1]["measured_at"] - start)
                                                                                   / WEEK) if rows else None}
        if task is not None:
            tasks.append(task)
    for task, fc in engine.map_unordered(run_forecast, tasks):
        c = cases[task.axis_id]
        if isinstance(fc, str) or not hasattr(fc, "weeks") or fc.weeks is None:
            c["forecast_week"] = None
            continue
        base = (fc.newest - start) / WEEK
        c.update({"forecast_week": base + fc.weeks, "interval": [base + fc.early, None if fc.late is None else
                                                                 base + fc.late], "limit": fc.limit})
    errors = [c["forecast_week"] - c["actual_week"] for c in cases.values() if c.get("forecast_week") is not None]
    within = sum(1 for e in errors if abs(e) <= 2.0)
    inside = sum(1 for c in cases.values() if c.get("interval") and c["interval"][0] <= c["actual_week"] and (
        c["interval"][1] is None or c["actual_week"] <= c["interval"][1]))
    return {"axes": len(cases), "with_forecast": len(errors), "within_2_weeks": within,
            "share_within_2_weeks": within / len(cases) if cases else None, "in_interval": inside,
            "errors_weeks": sorted(round(e, 2) for e in errors), "cases": cases}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--axes", type=int, default=200)
    ap.add_argument("--weeks", type=int, default=12)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--drift-share", type=float, default=0.1)
    ap.add_argument("--folder", type=Path, default=None)
    ap.add_argument("--no-dask", action="store_true")
    ap.add_argument("--no-kill", action="store_true")
    ap.add_argument("--json", type=Path, default=None, help="write the figures here too")
    args = ap.parse_args()
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

    from feedtune.fleet import Engine, fleet_status, load_manifest, plan_fleet, read_history, run_fleet
    from feedtune.fleet.engine import available_cores
    from feedtune.fleet.simulated import START

    work = Path(tempfile.mkdtemp(prefix="bench_fleet_"))
    folder = args.folder or work / "fleet"
    out: dict = {"axes": args.axes, "weeks": args.weeks, "cores": available_cores()}
    if not (folder / "fleet.toml").exists():
        t0 = time.perf_counter()
        from feedtune.fleet import simulate_fleet

        simulate_fleet(folder, args.axes, args.weeks, seed=args.seed, drift_share=args.drift_share)
        out["simulate_s"] = time.perf_counter() - t0
        print(f"simulated {args.axes} x {args.weeks} in {out['simulate_s']:.1f} s: {folder}")
    truth = json.loads((folder / "truth.json").read_text())
    manifest = load_manifest(folder / "fleet.toml")
    plan = plan_fleet(manifest)
    n_tasks = len(plan.tasks)
    single, single_cpu = single_task_seconds(plan, manifest.axes[0].id)
    ideal = single * n_tasks / out["cores"]
    out.update({"tasks": n_tasks, "single_task_s": single, "single_task_cpu_s": single_cpu, "ideal_fleet_s": ideal,
                "load_average": os.getloadavg()})
    print(f"single task {single * 1e3:.0f} ms wall, {single_cpu * 1e3:.0f} ms CPU (this process, serial); ideal "
          f"fleet {ideal:.1f} s on {out['cores']} cores; load average {os.getloadavg()[0]:.1f}")

    local = work / "local.parquet"
    with Engine() as engine:
        t0 = time.perf_counter()
        result = run_fleet(manifest, local, engine=engine, status=False)
        s = result.summary
        out["local"] = {"engine": s.engine, "measure_wall_s": s.wall_s, "per_task_s": s.wall_s / n_tasks,
                        "per_axis_s": s.wall_s / len(manifest.axes), "ratio_to_ideal": s.wall_s / ideal,
                        "mean_task_cpu_s": sum(s.task_cpu_s) / len(s.task_cpu_s),
                        "worker_peak_rss_mib": {w: v["peak_rss_mib"] for w, v in s.workers.items()}}
        t1 = time.perf_counter()
        status = fleet_status(manifest, local, plan, engine)
        out["local"]["status_wall_s"] = time.perf_counter() - t1
        out["local"]["total_wall_s"] = time.perf_counter() - t0
        print(f"local processes: measurements {s.wall_s:.1f} s ({1e3 * s.wall_s / n_tasks:.1f} ms per measurement, "
              f"{s.wall_s / len(manifest.axes):.2f} s per axis) = {s.wall_s / ideal:.2f} x ideal (target <= 2); "
              f"{1e3 * out['local']['mean_task_cpu_s']:.0f} ms CPU per task in the workers; "
              f"status (drift, forecasts) {out['local']['status_wall_s']:.1f} s; worker peak memory "
              f"{max(out['local']['worker_peak_rss_mib'].values()):.0f} MiB")
        out["detection"] = detection(status, truth, START)
        out["forecast"] = forecasts(manifest, local, plan, status, truth, START, engine)

    if not args.no_dask:
        from distributed import LocalCluster

        dask = work / "dask.parquet"
        with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
            with Engine(scheduler=cluster.scheduler_address) as engine:
                s = run_fleet(manifest, dask, engine=engine, status=False).summary
        same = read_history(dask).equals(read_history(local))
        out["dask"] = {"engine": s.engine, "measure_wall_s": s.wall_s, "identical_history": same}
        print(f"Dask LocalCluster (2 workers): {s.wall_s:.1f} s; history identical to local processes: {same}")
    if not args.no_kill:
        out["kill"] = kill_and_resume(folder / "fleet.toml", work / "killed.parquet", n_tasks)
        k = out["kill"]
        print(f"killed at {k['rows_at_kill']} rows, re-run wrote {k['written_after']}: {k['rows']} rows, "
              f"{k['unique_keys']} keys (expected {n_tasks})")

    d = out["detection"]
    st = d["stiffness"]
    print(f"stiffness drift: {st['within_3']}/{st['counted']} detected within 3 measurements of a 10 % loss "
          f"(target >= 90 %), delays {st['delays']}, missed {st['missed']}")
    fr = d["friction"]
    print(f"friction drift: {fr['within_3']}/{fr['counted']} detected within 3 measurements of +10 %, delays "
          f"{fr['delays']}")
    print(f"false alarms: {d['false_alarms']}/{d['axes_without_drift']} axes without drift (target <= 1 %) "
          f"{d['false_alarm_axes']}")
    f = out["forecast"]
    print(f"forecast: {f['within_2_weeks']}/{f['axes']} within +-2 weeks of the actual failure (target >= 80 %); "
          f"{f['in_interval']} inside their 90 % interval; errors [weeks] {f['errors_weeks']}")
    if args.json:
        args.json.write_text(json.dumps(out, indent=1, default=str))
    shutil.rmtree(work, ignore_errors=True)  # the histories (a --folder fleet stays)


if __name__ == "__main__":
    main()
