"""The project file (feedtune.toml; feedtune.io.project_file, feedtune.cli.project_args) and the provenance every
command-written document records (feedtune.io.provenance).

A project folder is built in tmp from the examples (the three FRFs of examples/ballscrew_frf_m{70,100,130}.csv and
the model ``feedtune identify ballscrew`` fits to examples/ballscrew_frf.csv). ``tune``, ``analyze`` and ``report``
run there without arguments must give the numbers of the explicit command (compared in the documents and envelopes
they write); the digests recorded must be ``hashlib.sha256`` of the files; bad project files are one line naming
the file and the key.
"""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path

import pytest
from cli_run import run

from feedtune.io import read_document
from feedtune.io.project_file import project_document, read_project, relative_to, write_project
from feedtune.io.provenance import created_by_text

FRFS = [f"ballscrew_frf_m{m}.csv" for m in (70, 100, 130)]
PPC = ["--beta", "4", "--pole-hz", "50", "--zeta", "0.7", "--lpf", "800"]


def sha(path: Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


@pytest.fixture(scope="module")
def model_text(examples_dir, tmp_path_factory) -> bytes:
    """The model ``feedtune identify ballscrew`` fits to the example FRF (once per module)."""
    from feedtune.identify.ballscrew import fit_ballscrew
    from feedtune.io import read_frf, save_model

    folder = tmp_path_factory.mktemp("model")
    save_model(folder / "model.toml", fit_ballscrew([read_frf(examples_dir / "ballscrew_frf.csv")]).model)
    return (folder / "model.toml").read_bytes()


@pytest.fixture
def project(tmp_path, examples_dir, model_text, monkeypatch) -> Path:
    """A project folder: model, the three FRFs, feedtune.toml naming them; the current folder."""
    for name in FRFS:
        shutil.copy(examples_dir / name, tmp_path / name)
    (tmp_path / "model.toml").write_bytes(model_text)
    doc = project_document(name="x axis", model="model.toml", frf=FRFS, gains="gains.toml",
                           limits={"profile": "textbook"},
                           commands={"tune": {"structure": "mcppc", "lpf": 800, "filters": "identical"},
                                     "report": {"out": "report.html"}})
    write_project(tmp_path / "feedtune.toml", doc)
    monkeypatch.chdir(tmp_path)
    return tmp_path


def _json(args, capsys, monkeypatch) -> dict:
    code, out, err = run([*args, "--json"], capsys, monkeypatch)
    assert code == 0, err
    return json.loads(out)


def _numbers(node):
    """Every number of a JSON value, in order (what two runs of one computation must share)."""
    if isinstance(node, bool) or node is None or isinstance(node, str):
        return []
    if isinstance(node, (int, float)):
        return [node]
    if isinstance(node, dict):
        return [x for k in sorted(node) for x in _numbers(node[k])]
    return [x for v in node for x in _numbers(v)]


# ------------------------------------------------------------------------------------------ the library
def test_paths_are_written_relative_and_read_back_resolved(tmp_path, examples_dir):
    sub = tmp_path / "axis"
    sub.mkdir()
    frf = examples_dir / "ballscrew_frf_m70.csv"
    doc = project_document(model=relative_to(frf, sub), frf=[relative_to(frf, sub)], gains="gains.toml")
    assert not Path(doc["axis"]["model"]).is_absolute() and doc["axis"]["model"].startswith("..")
    write_project(sub / "feedtune.toml", doc)
    p = read_project(sub / "feedtune.toml")
    assert p.model.resolve() == frf.resolve() and p.frf[0].resolve() == frf.resolve()
    assert p.gains == sub / "gains.toml"  # the output of tune: need not exist
    with pytest.raises(Exception, match="exists"):
        write_project(sub / "feedtune.toml", doc)
    write_project(sub / "feedtune.toml", doc, force=True)


@pytest.mark.parametrize("text, culprit", [
    ('schema = "feedtune.project/1"\n[axis]\nfrf = "a.csv"\n', "axis.frf: expected a list"),
    ('schema = "feedtune.project/1"\n[axis]\nmodel = "nosuch.toml"\n', "axis.model: "),
    ('schema = "feedtune.project/1"\n[tunes]\nlpf = 1\n', "tunes"),
    ('schema = "feedtune.project/1"\n[limits]\nms_max = "big"\n', "limits.ms_max"),
    ('schema = "feedtune.project/2"\n', "feedtune.project/2"),
    ('schema = "feedtune.model/1"\n', "expected a project file"),
    ('schema = "feedtune.project/1"\n[tune\n', "feedtune.toml"),
])
def test_bad_project_files_are_one_line_naming_the_file_and_key(text, culprit, tmp_path):
    from feedtune.errors import DataError

    (tmp_path / "feedtune.toml").write_text(text)
    with pytest.raises(DataError) as info:
        read_project(tmp_path / "feedtune.toml")
    assert "\n" not in str(info.value) and "feedtune.toml" in str(info.value) and culprit in str(info.value)


def test_created_by_reads_both_spellings():
    assert created_by_text({"created_by": "feedtune 0.1.0"}) == "feedtune 0.1.0"
    assert created_by_text({"created_by": {"feedtune": "0.1.0", "command": "feedtune tune"}}) == \
        "feedtune 0.1.0: feedtune tune"
    assert created_by_text({}) == "feedtune"


# ------------------------------------------------------------------------------------------ the command line
def test_analyze_without_arguments_is_the_explicit_command(project, capsys, monkeypatch):
    text = (project / "feedtune.toml").read_text()  # [analyze] frf: the section's value wins over [axis]
    (project / "feedtune.toml").write_text(text + f'\n[analyze]\nfrf = ["{FRFS[1]}"]\n')
    code, _, err = run(["design", "ppc", "model.toml", *PPC, "--out", "gains.toml"], capsys, monkeypatch)
    assert code == 0, err
    explicit = _json(["analyze", "gains.toml", "--frf", FRFS[1], "--limits", "textbook"], capsys, monkeypatch)
    code, out, err = run(["analyze", "--json"], capsys, monkeypatch)
    assert code == 0, err
    assert err.splitlines()[0] == (f"feedtune: project feedtune.toml: feedtune analyze gains gains.toml --frf "
                                   f"{FRFS[1]} --limits textbook --json")
    from_project = json.loads(out)
    assert from_project["inputs"] == explicit["inputs"]
    assert _numbers(from_project["verdict"]) == _numbers(explicit["verdict"])
    assert from_project["verdict"]["certificate"]["frfs"][0]["frf"] == FRFS[1]
    # from another folder with --project; a typed option wins over the project's
    monkeypatch.chdir(project.parent)
    elsewhere = _json(["analyze", "--project", project.name, "--limits", "thesis"], capsys, monkeypatch)
    assert elsewhere["check"]["limits"]["profile"] == "thesis"
    assert _numbers(elsewhere["verdict"]["certificate"]["frfs"][0]["items"][0]["value"]) == \
        _numbers(explicit["verdict"]["certificate"]["frfs"][0]["items"][0]["value"])


def test_documents_record_the_command_and_the_digests_of_their_inputs(project, capsys, monkeypatch):
    args = ["design", "ppc", "model.toml", *PPC, "--frf", FRFS[0], "--allow-unstable", "--out", "gains.toml"]
    code, _, err = run(args, capsys, monkeypatch)
    assert code == 0, err
    doc = read_document("gains.toml")
    made = doc["created_by"]
    assert made["command"] == "feedtune " + " ".join(args)
    assert made["feedtune"] and "project" not in made
    assert made["inputs"] == [{"file": "model.toml", "sha256": sha(project / "model.toml")},
                              {"file": FRFS[0], "sha256": sha(project / FRFS[0])}]
    assert read_document("gains.json")["created_by"] == made  # the JSON twin says the same
    assert doc["certificate"]["frfs"][0]["sha256"] == made["inputs"][1]["sha256"]  # one digest of the FRF
    from feedtune.io.gains_certificate import read_certificate

    assert read_certificate(doc).valid  # created_by lies outside the gains digest


def test_project_errors_are_one_line(project, capsys, monkeypatch):
    cases = [
        (["tune", "--project", "nosuch.toml"], 2, "--project nosuch.toml"),
        (["analyze", "track", "x.csv", "--project", "feedtune.toml"], 2, "takes no project file"),
        (["tune", "--project"], 2, "--project needs"),
    ]
    text = (project / "feedtune.toml").read_text()
    for bad, culprit in (("[tune]\n", "[tune]\nforce = true\n"), ("[tune]\n", "[tune]\nlfp = 800\n"),
                         ('lpf = 800', 'lpf = [800, 900]'), ('filters = "identical"', 'filters = true')):
        other = project / f"bad{len(cases)}.toml"
        other.write_text(text.replace(bad, culprit, 1))
        key = {"force": "tune.force", "lfp": "tune.lfp", "lpf = [": "tune.lpf", "filters = true": "tune.filters"}
        cases.append((["tune", "--project", other.name], 1, next(v for k, v in key.items() if k in culprit)))
    for args, code_expected, culprit in cases:
        code, _out, err = run(args, capsys, monkeypatch)
        lines = [line for line in err.splitlines() if not line.startswith("feedtune: project ")]
        assert code == code_expected, (args, err)
        assert len(lines) == 1 and culprit in lines[0] and "Traceback" not in err, (args, err)
    assert not (project / "gains.toml").exists()  # nothing written


def test_project_init_writes_a_file_the_commands_read(tmp_path, examples_dir, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    frf = examples_dir / FRFS[0]
    args = ["project", "init", "--model", frf, "--frf", frf, "--gains", "g.toml", "--structure", "ppi",
            "--set", "tune.filters=own", "--set", "report.pdf=true", "--ms-max", "2.2"]
    code, _out, err = run(args, capsys, monkeypatch)
    assert code == 0, err
    p = read_project(tmp_path / "feedtune.toml")
    assert p.model.resolve() == frf.resolve() and p.frf == (p.model,)
    assert p.section("tune") == {"structure": "ppi", "filters": "own"} and p.section("report") == {"pdf": True}
    assert p.limits == {"ms_max": 2.2}
    code, _, err = run(args, capsys, monkeypatch)
    assert code == 2 and "exists" in err and "--force" in err
    code, _, err = run([*args, "--set", "tune.lfp=1", "--force"], capsys, monkeypatch)
    assert code == 2 and "tune.lfp" in err and len(err.splitlines()) == 1


@pytest.mark.slow
def test_tune_and_report_without_arguments_reproduce_the_explicit_commands(project, capsys, monkeypatch):
    frfs = [a for f in FRFS for a in ("--frf", f)]
    explicit = _json(["tune", "mcppc", "model.toml", *frfs, "--lpf", "800", "--filters", "identical",
                      "--out", "explicit.toml"], capsys, monkeypatch)
    code, out, err = run(["tune", "--json"], capsys, monkeypatch)
    assert code == 0, err
    assert "feedtune: project feedtune.toml: feedtune tune mcppc model.toml" in err
    from_project = json.loads(out)
    assert _numbers(from_project["gains"]) == _numbers(explicit["gains"])
    a, b = read_document("explicit.toml"), read_document("gains.toml")
    assert _numbers(a["gains"]) == _numbers(b["gains"]) and _numbers(a["filters"]) == _numbers(b["filters"])
    assert a["certificate"]["gains_sha256"] == b["certificate"]["gains_sha256"]
    made = b["created_by"]
    assert made["project"] == "feedtune.toml" and made["project_sha256"] == sha(project / "feedtune.toml")
    assert [e["sha256"] for e in made["inputs"]] == [sha(project / f) for f in ("model.toml", *FRFS)]
    code, _, err = run(["tune"], capsys, monkeypatch)  # the result is there: replaced only with --force
    assert code == 2 and "--force" in err
    # the report of the project's files, as the explicit command
    explicit = _json(["report", "model.toml", "gains.toml", *FRFS, "--out", "explicit.html"], capsys, monkeypatch)
    from_project = _json(["report"], capsys, monkeypatch)
    for key in ("sections", "figures", "tables", "warnings"):
        assert from_project[key] == explicit[key], key
    html = (project / "report.html").read_text()
    assert "Made by <code>feedtune report model.toml gains.toml" in html and "(project feedtune.toml)" in html


def test_frf_pieces_are_cut_as_the_frf_option_cuts_them(tmp_path, monkeypatch):
    """A report input of pieces keeps a SPEC's ``+`` (``scale=1e+3``) and a file name's ``+``: each file resolved in
    the project's folder, each SPEC as written; the record of inputs names the files (once: ``...,scale=1e+sub/3``
    and an input ``3``)."""
    from feedtune.cli.guard import _input_files
    from feedtune.cli.project_args import _resolve_piece
    from feedtune.io.project_file import Project

    sub = tmp_path / "sub"
    sub.mkdir()
    for name in ("a.csv", "b+c.csv"):
        (sub / name).write_text("x")
    monkeypatch.chdir(tmp_path)
    project = Project(sub / "feedtune.toml", None)
    assert _resolve_piece(project, "a.csv:x1/u,scale=1e+3") == "sub/a.csv:x1/u,scale=1e+3"
    assert _resolve_piece(project, "a.csv:x1/u+b+c.csv:x2/u") == "sub/a.csv:x1/u+sub/b+c.csv:x2/u"
    monkeypatch.chdir(sub)
    assert _input_files({"frf": ["a.csv:x1/u,scale=1e+3+b+c.csv:x2/u"]}, ("frf",)) == ["a.csv", "b+c.csv"]


def test_project_init_into_a_folder_and_limits_checked_before_writing(tmp_path, examples_dir, capsys, monkeypatch):
    """``--out DIR`` writes DIR/feedtune.toml (the help's promise); a limit no command would accept (Ms <= 0.5) is
    refused by init, naming the option, and nothing is written."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "axis").mkdir()
    frf = examples_dir / FRFS[0]
    code, _out, err = run(["project", "init", "--frf", frf, "--out", "axis"], capsys, monkeypatch)
    assert code == 0, err
    assert read_project(tmp_path / "axis" / "feedtune.toml").frf[0].resolve() == frf.resolve()
    code, _out, err = run(["project", "init", "--frf", frf, "--ms-max", "0.5", "--out", "p.toml"], capsys,
                          monkeypatch)
    assert code == 2 and "--ms-max" in err and len(err.splitlines()) == 1 and not (tmp_path / "p.toml").exists()
