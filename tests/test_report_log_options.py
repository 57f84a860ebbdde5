"""``feedtune report`` reads a foreign log named on its command line with the log options of the analysis commands."""

from __future__ import annotations

import json

from cli_run import run

from feedtune.io import read_log, write_log_csv
from feedtune.log import Log


def test_report_maps_the_columns_of_a_foreign_tracking_log(examples_dir, tmp_path, capsys, monkeypatch):
    log = read_log(examples_dir / "ballscrew_track.csv")
    names = {"x_ref": "cmd", "x2_table": "pos"}
    keep = [k for k in log.signals if k != "e2"]  # a trace with its own names and no error column
    foreign = Log(log.t, {names.get(k, k): log[k] for k in keep}, {names.get(k, k): log.unit(k) for k in keep},
                  {"source": "a drive's trace"})
    write_log_csv(foreign, tmp_path / "trace.csv")
    args = ["report", tmp_path / "trace.csv", "--log-kind", "trace.csv=track", "--out", tmp_path / "r.html", "--json"]
    code, _, err = run(args, capsys, monkeypatch)
    assert code == 1 and "no tracking error 'e2' and no reference 'x_ref'" in err  # without the map
    code, out, err = run([*args, "--map", "x_ref=cmd", "--map", "x2_table=pos", "--force"], capsys, monkeypatch)
    assert code == 0, err
    summary = json.loads(out)
    assert any("Time" in s for s in summary["sections"]), summary
