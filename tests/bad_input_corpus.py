"""The standing corpus of bad inputs (issue 26): every command given malformed, truncated, huge, non-finite, wrong-kind
and nested inputs, absurd options, outputs that cannot or must not be written, run in-process.

Each :class:`Case` is one command line and the answer docs/conventions.md promises: the exit code (2: the command
line is wrong by itself; 1: the inputs are wrong or do not fit it), exactly one ``feedtune: error: ...`` line on
stderr that names the culprit (the option, the file, the key), and nothing written. :func:`run_case` runs one
through :func:`feedtune.cli.main.main` in this process (a few ms: the command-line tree is built once) and
:func:`classify` sorts the outcome:

* ``clean``: the promised answer;
* ``internal error``: ``feedtune: internal error: ...``;
* ``traceback``: an exception escaped (or a traceback on stderr);
* ``accepted bad``: exit 0;
* ``unclear``: the right code but not one line naming the culprit;
* ``wrong code``: another exit code;
* ``wrote``: files left in the case's folder;
* ``hang``: stopped after the time limit (:data:`TIME_LIMIT_S`).

``tests/test_bad_input_corpus.py`` asserts every case clean; ``python benchmarks/bad_input_corpus.py`` prints the table
of classes per command (and runs it against another source tree with ``--root``, e.g. the code before a change).
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import shlex
import shutil
import signal
import sys
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
EXAMPLES = REPO / "examples"
TIME_LIMIT_S = 60.0
"""A case still running after this long is stopped and classed ``hang``."""

CLASSES = ("clean", "internal error", "traceback", "accepted bad", "unclear", "wrong code", "wrote", "hang")

Maker = Callable[[Path, Path], None]
"""Writes one input file of a case: ``maker(fixtures, path)``."""


@dataclass(frozen=True)
class Case:
    """One bad command line.

    Attributes
    ----------
    command : str
        The command (``"design gantry"``), for the table.
    args : str
        The rest of the command line (shell syntax); ``{fx}`` is the fixture folder.
    code : int
        The exit code docs/conventions.md promises.
    culprit : str
        Text the one stderr line must contain (the option, the file, the key).
    files : tuple of (str, Maker)
        Input files written into the case's folder first.
    family : str
        What kind of bad input (for the table).
    slow : bool
        Needs more than a fraction of a second (in the slow set).
    """

    command: str
    args: str
    code: int
    culprit: str
    files: tuple = ()
    family: str = "option"
    slow: bool = False

    @property
    def id(self) -> str:
        return f"{self.command} {self.args}"[:90].replace("{fx}/", "")

    def argv(self, fx: Path) -> list[str]:
        return [*self.command.split(), *shlex.split(self.args.replace("{fx}", str(fx)))]


@dataclass
class Outcome:
    """What a run did: exit code, stdout, stderr, an escaped exception, the files it left, whether it hung."""

    code: int | None
    out: str
    err: str
    escaped: str | None = None
    left: list[str] = field(default_factory=list)
    hung: bool = False


# ------------------------------------------------------------------------------------------ input files
def text(s: str) -> Maker:
    return lambda fx, p: p.write_text(s, encoding="utf-8")


def raw(b: bytes) -> Maker:
    return lambda fx, p: p.write_bytes(b)


def edited(name: str, fn: Callable[[str], str]) -> Maker:
    """A fixture file's text changed by ``fn``."""
    return lambda fx, p: p.write_text(fn((fx / name).read_text(encoding="utf-8")), encoding="utf-8")


def cut(name: str, fraction: float) -> Maker:
    """A fixture file truncated to ``fraction`` of its bytes."""

    def make(fx, p):
        b = (fx / name).read_bytes()
        p.write_bytes(b[: int(len(b) * fraction)])

    return make


def doc(name: str, fn: Callable[[dict], object], fmt: str = "toml") -> Maker:
    """A fixture document (TOML) changed by ``fn`` (which edits the dict in place), written as TOML or JSON."""

    def make(fx, p):
        import tomllib

        d = tomllib.loads((fx / name).read_text())
        fn(d)
        if fmt == "json":
            p.write_text(json.dumps(d, indent=1, allow_nan=True))
        else:
            import tomli_w

            p.write_text(tomli_w.dumps(d))

    return make


def replace_line(name: str, old: str, new: str) -> Maker:
    return edited(name, lambda s: s.replace(old, new, 1))


def fifo() -> Maker:
    return lambda fx, p: os.mkfifo(p)


def sparse(size: int, head: bytes = b"") -> Maker:
    def make(fx, p):
        with open(p, "wb") as fh:
            fh.write(head)
            fh.truncate(size)

    return make


def symlink_to(target: str) -> Maker:
    return lambda fx, p: os.symlink(target.replace("{fx}", str(fx)), p)


def folder() -> Maker:
    return lambda fx, p: p.mkdir()


def frf_rows(name: str, fn: Callable[[list[list[str]]], None]) -> Maker:
    """An FRF (or log) CSV fixture whose data rows (lists of cells) ``fn`` edits in place."""

    def make(fx, p):
        lines = (fx / name).read_text().splitlines()
        head = [ln for ln in lines if ln.startswith("#")]
        body = [ln for ln in lines if not ln.startswith("#")]
        rows = [r.split(",") for r in body[1:]]
        fn(rows)
        p.write_text("\n".join([*head, body[0], *(",".join(r) for r in rows)]) + "\n")

    return make


def header_edit(name: str, fn: Callable[[list[str]], None]) -> Maker:
    """A CSV fixture whose header cells ``fn`` edits in place."""

    def make(fx, p):
        lines = (fx / name).read_text().splitlines()
        k = next(i for i, ln in enumerate(lines) if not ln.startswith("#"))
        cells = lines[k].split(",")
        fn(cells)
        lines[k] = ",".join(cells)
        p.write_text("\n".join(lines) + "\n")

    return make


def set_cell(row: int, col: int, value: str) -> Callable[[list[list[str]]], None]:
    def fn(rows):
        rows[row][col] = value

    return fn


def mat_file(variables: Callable[[], dict]) -> Maker:
    def make(fx, p):
        import scipy.io

        scipy.io.savemat(p, variables())

    return make


def mat73(build: Callable) -> Maker:
    """A MATLAB v7.3 file (HDF5 with the MATLAB user block) whose datasets ``build(h5file)`` creates."""

    def make(fx, p):
        import h5py

        with h5py.File(p, "w", userblock_size=512) as f:
            build(f)
        with open(p, "r+b") as fh:
            fh.write(
                b"MATLAB 7.3 MAT-file, Platform: GLNXA64, HDF5 schema 1.00 .".ljust(116, b" ")
                + b"\0" * 8
                + b"\x00\x02IM"
            )

    return make


def _h5_double(f, name, shape, data=None):
    import numpy as np

    if data is None:
        ds = f.create_dataset(name, shape=shape, dtype=float, chunks=(1, min(shape[1], 1 << 16)))
    else:
        ds = f.create_dataset(name, data=np.asarray(data, float))
    ds.attrs["MATLAB_class"] = np.bytes_("double")


def mdf_cut(fraction: float) -> Maker:
    def make(fx, p):
        b = (fx / "log.mf4").read_bytes()
        p.write_bytes(b[: int(len(b) * fraction)])

    return make


def nested_json(depth: int, schema: str = "feedtune.model/1") -> Maker:
    return text('{"schema": "' + schema + '", "kind": "ballscrew", "x": ' + "[" * depth + "]" * depth + "}")


def nested_json_objects(depth: int) -> Maker:
    return text('{"schema": "feedtune.model/1", "x": ' + '{"a": ' * depth + "1" + "}" * depth + "}")


def nested_toml_arrays(depth: int) -> Maker:
    return text('schema = "feedtune.model/1"\nx = ' + "[" * depth + "]" * depth + "\n")


def nested_toml_tables(depth: int) -> Maker:
    return text('schema = "feedtune.model/1"\n\n[' + ".".join(["a"] * depth) + "]\nb = 1\n")


def nested_toml_inline(depth: int) -> Maker:
    return text('schema = "feedtune.model/1"\nx = ' + "{a = " * depth + "1" + "}" * depth + "\n")


def binary_without_nul(n: int = 200_000) -> Maker:
    def make(fx, p):
        import random

        rng = random.Random(1)
        p.write_bytes(bytes(rng.randrange(1, 256) for _ in range(n)))

    return make


# ------------------------------------------------------------------------------------------ fixtures
def build_fixtures(fx: Path) -> Path:
    """The valid inputs the cases refer to as ``{fx}/NAME``: example FRFs and logs, models and gains files of every
    kind (about 1 s)."""
    import numpy as np

    from feedtune.control.filters import THESIS_FILTER_PACK
    from feedtune.design.gantry_mimo import design_gantry_mimo
    from feedtune.design.gantry_pid import design_gantry_pid
    from feedtune.design.loopshape import design_loopshape
    from feedtune.design.mcppc import design_mcppc
    from feedtune.design.ppi import design_ppi
    from feedtune.io import save_model, write_document
    from feedtune.io.gains import gains_document
    from feedtune.io.gantry_gains import axis_gains_document, gantry_gains_document
    from feedtune.log import Log
    from feedtune.models import THESIS_TABLE_3_1
    from feedtune.models.friction import StribeckFriction
    from feedtune.models.gantry import THESIS_GANTRY

    fx.mkdir(parents=True, exist_ok=True)
    for src, dst in (
        ("ballscrew_frf.csv", "bs_frf.csv"),
        ("ballscrew_frf.mat", "bs_frf.mat"),
        ("ballscrew_frf.uff", "bs_frf.uff"),
        ("gantry_frf_x0.csv", "g_frf.csv"),
        ("gantry_frf_x-0.3.csv", "g_frf_m.csv"),
        ("gantry_frf_x0.3.csv", "g_frf_p.csv"),
        ("ballscrew_track.csv", "track.csv"),
        ("ballscrew_ropesnap.csv", "rs.csv"),
        ("ballscrew_reversals.csv", "rev.csv"),
        ("ballscrew_frf_m70.csv", "bs_frf_m70.csv"),
        ("vendor/klipper_calibration_data_x.csv", "psd.csv"),
        ("vendor/motor_bode.csv", "motor_bode.csv"),
        ("vendor/load_bode.csv", "load_bode.csv"),
        ("vendor/auto_servo_tuning.xml", "ast.xml"),
    ):
        shutil.copyfile(EXAMPLES / src, fx / dst)
    (fx / "fleet.toml").write_text(
        'schema = "feedtune.fleet/1"\nname = "corpus fleet"\n\n[defaults]\nstructure = "ballscrew"\n'
        'limits = "textbook"\n\n[[axis]]\nmachine = "M1"\naxis = "X"\ngains = "bs_gains.toml"\n\n'
        '[[axis.measurement]]\ndate = "2025-01-06T19:02"\nfrf = "bs_frf.csv"\n'
    )
    save_model(fx / "bs_model.toml", THESIS_TABLE_3_1, force=True)
    save_model(fx / "g_model.toml", THESIS_GANTRY, force=True)
    save_model(fx / "fr.toml", StribeckFriction(dc_pos=0.1, ds_pos=0.16, dc_neg=-0.09, ds_neg=-0.15, omega_pos=2e-3,
                                                command_unit="V"), force=True)
    write_document(
        fx / "bs_gains.toml", gains_document(design_mcppc(THESIS_TABLE_3_1, filters=THESIS_FILTER_PACK)), force=True
    )
    write_document(
        fx / "ppi_gains.toml",
        gains_document(design_ppi(THESIS_TABLE_3_1, Kpx=30.0, Kpv=2.0, Kiv=1000.0, filters=THESIS_FILTER_PACK)),
        force=True,
    )
    write_document(fx / "g_gains.toml", gantry_gains_document(design_gantry_mimo(THESIS_GANTRY)), force=True)
    write_document(
        fx / "pid_gains.toml",
        gantry_gains_document(design_gantry_pid(THESIS_GANTRY, kp=1000.0, kd=10.0, ki=100.0)),
        force=True,
    )
    write_document(
        fx / "a_gains.toml", axis_gains_document(design_loopshape(0.6977, crossover_hz=100, pm_deg=35)), force=True
    )
    from feedtune.design.cascade import design_cascade
    from feedtune.export.drives import DriveOptions, export_drive
    from feedtune.io.cascade_gains import cascade_gains_document
    from feedtune.models.rigid import RigidBodyModel

    cascade = cascade_gains_document(design_cascade(RigidBodyModel(2e-3, 1e-3, command_unit="A",
                                                                   position_unit="rad"), kp=0.5, tn_s=0.02, kv=30.0))
    write_document(fx / "c_gains.toml", cascade, force=True)
    written = export_drive(cascade, "sinamics", DriveOptions(torque_constant=1.0)).written
    (fx / "c.sinamics.txt").write_text(written.text)
    rng = np.random.default_rng(0)
    t = np.arange(5000) / 5000.0
    u = rng.standard_normal(t.size)
    x1 = np.convolve(u, np.exp(-np.arange(50) / 10.0), "same") * 1e-3
    log = Log(t, {"u": u, "x1": x1, "x2": 0.9 * x1}, {"u": "V", "x1": "rad", "x2": "rad"}, {"source": "frflog"})
    from feedtune.io import write_log_csv

    write_log_csv(log, fx / "frflog.csv", force=True)
    (fx / "daq.csv").write_text(
        "# feedtune log\nt [s],f [V]\n" + "".join(f"{k / 2000:.6f},{np.sin(k / 50):.6f}\n" for k in range(4000))
    )
    (fx / "traj.csv").write_text(
        "# feedtune log\nt [s],x_ref [m]\n"
        + "".join(f"{k / 20000:.6f},{0.01 * min(k, 2000) / 2000:.8f}\n" for k in range(4000))
    )
    try:
        import asammdf

        mdf = asammdf.MDF()
        mdf.append(
            [asammdf.Signal(np.sin(40 * t), t, name="u", unit="V"), asammdf.Signal(1e-3 * t, t, name="x2", unit="rad")]
        )
        mdf.save(fx / "log.mf4", overwrite=True)
    except ImportError:  # the optional extra
        pass
    return fx


# ------------------------------------------------------------------------------------------ the cases
FX = "{fx}"
BS_MODEL, G_MODEL = f"{FX}/bs_model.toml", f"{FX}/g_model.toml"
BS_GAINS, G_GAINS, A_GAINS, PID_GAINS = (
    f"{FX}/bs_gains.toml",
    f"{FX}/g_gains.toml",
    f"{FX}/a_gains.toml",
    f"{FX}/pid_gains.toml",
)
BS_FRF, G_FRF = f"{FX}/bs_frf.csv", f"{FX}/g_frf.csv"
TRACK, RS, REV, FRFLOG = f"{FX}/track.csv", f"{FX}/rs.csv", f"{FX}/rev.csv", f"{FX}/frflog.csv"
DAQ = f"{FX}/daq.csv"
PSD, AST = f"{FX}/psd.csv", f"{FX}/ast.xml"
PIECES = f"{FX}/motor_bode.csv:x1/u {FX}/load_bode.csv:x2/u"
MANIFEST = f"{FX}/fleet.toml"

BASES: dict[str, str] = {
    "identify ballscrew": BS_FRF,
    "identify rigid": f"{REV} --position x2 --input u",
    "identify friction": f"{REV} --position x2 --input u --model {BS_MODEL}",
    "identify gantry": f"{G_FRF} --x 0 --span 1.484",
    "identify mass": f"{TRACK} {RS} --x 0 --x 0.1",
    "frf": f"{FRFLOG} --input u --output x1,x2",
    "design ppc": f"{BS_MODEL} --beta 4 --pole-hz 50 --zeta 0.7",
    "design ppi": f"{BS_MODEL} --kpx 30 --kpv 2 --kiv 1000",
    "design loopshape": f"{G_MODEL} --crossover-hz 100 --pm-deg 35",
    "design gantry": G_MODEL,
    "design pid": f"{G_MODEL} --kp 1000 --kd 10 --ki 100",
    "tune": f"mcppc {BS_MODEL} --frf {BS_FRF}",
    "prefilter": f"{TRACK} --gains {BS_GAINS}",
    "report": f"{BS_GAINS} {BS_FRF} -o r.html",
    "trajectory": "--distance 0.1 --v-max 0.2 --a-max 5 --j-max 500 -o t.csv",
    "demo": "--out d",
    "analyze gains": f"{BS_GAINS} --frf {BS_FRF}",
    "analyze track": TRACK,
    "analyze ropesnap": RS,
    "export c": f"{BS_GAINS} -o g.h",
    "export drive": f"sinamics {FX}/c_gains.toml -o d.txt --torque-constant 1",
    "import drive": f"sinamics {FX}/c.sinamics.txt -o b.toml",
    "simulate frf": "-o s.csv",
    "simulate track": f"-g {BS_GAINS} --distance 0.05 -o s.csv",
    "simulate ropesnap": f"-g {BS_GAINS} -o s.csv",
    "simulate cut": f"-g {BS_GAINS} -o s.csv",
    "simulate gantry frf": "-o s.csv --period 0.1 --periods 2",
    "simulate gantry axis-frf": "-o s.csv --period 0.1 --periods 2",
    "simulate gantry mass": "-o s.csv",
    "simulate gantry ropesnap": f"-g {G_GAINS} -o s.csv",
    "simulate gantry track": f"-g {G_GAINS} -o s.csv",
    "simulate gantry contour": f"-g {G_GAINS} --axis-gains {A_GAINS} -o s.csv",
    "log convert": f"{TRACK} -o c.csv",
    "log merge": f"{TRACK} {DAQ} -o m.csv",
    "log resample": f"{REV} --fs 1000 -o r.csv",
    "frf merge": f"{PIECES} -o m.csv",
    "frf info": BS_FRF,
    "identify resonances": PSD,
    "fleet simulate": "fl --axes 2 --weeks 2",
    "fleet run": f"{MANIFEST} --history h.parquet",
    "fleet report": f"{MANIFEST} --history h.parquet -o f.html",
    "project init": f"--model {BS_MODEL} -o p.toml",
}
"""A valid command line of every command, into which the generated cases put one bad option value."""


def _c(command, args, code, culprit, family="option", files=(), slow=False) -> Case:
    return Case(command, args, code, culprit, tuple(files), family, slow)


def option_cases() -> list[Case]:
    """Every option that takes a number given ``nan`` and ``1e400`` (float) or ``1.5`` and ``abc`` (integer): usage
    errors naming the option, before any work (generated from the command tree)."""
    import inspect

    import typer.models

    from feedtune.cli.help_text import iter_commands
    from feedtune.cli.main import app

    out = []
    for path, info in iter_commands(app):
        base = BASES.get(path)
        if base is None:
            continue
        for p in inspect.signature(info.callback).parameters.values():
            d = p.default
            if not isinstance(d, typer.models.OptionInfo):
                continue
            ann = str(p.annotation)
            decl = next((x for x in d.param_decls if x.startswith("--")), None)
            if decl is None:
                continue
            if "tuple[float, float]" in ann:
                values = ("nan 1", "1 1e400")
            elif "float" in ann:
                values = ("nan", "1e400")
            elif "int" in ann and "bool" not in ann:
                values = ("1.5", "abc")
            else:
                continue
            for v in values:
                out.append(
                    _c(
                        path,
                        f"{base} {decl} {v}",
                        2,
                        decl,
                        "non-finite option" if "float" in ann else "malformed option",
                    )
                )
    return out


def _json_doc(name, fn):
    return doc(name, fn, "json")


def _set(path: str, value):
    """A document edit: ``d[a][b]... = value`` for ``path`` ``"a.b"``."""

    def fn(d):
        keys = path.split(".")
        node = d
        for k in keys[:-1]:
            node = node[int(k)] if isinstance(node, list) else node[k]
        node[keys[-1]] = value

    return fn


def _del(path: str):
    def fn(d):
        keys = path.split(".")
        node = d
        for k in keys[:-1]:
            node = node[k]
        del node[keys[-1]]

    return fn


def hand_cases() -> list[Case]:
    """The cases of the issues (26, 27 and 14) and the families around them, written out."""
    import numpy as np

    cases: list[Case] = []
    add = cases.append
    L = "a" * 300

    # ---------------------------------------------------------------- every command: the parser
    for command, base in BASES.items():
        add(_c(command, f"{base} --no-such-option", 2, "--no-such-option", "parser"))
        add(_c(command, f"{base} --json --json --jsn", 2, "--jsn", "parser"))
    for command in (
        "identify ballscrew",
        "identify rigid",
        "identify friction",
        "identify gantry",
        "frf estimate",
        "design ppc",
        "design ppi",
        "design loopshape",
        "design gantry",
        "design pid",
        "prefilter",
        "analyze gains",
        "analyze track",
        "analyze ropesnap",
        "export c",
        "log convert",
        "log merge",
        "identify mass",
    ):
        add(_c(command, "", 2, "missing", "parser"))
    for command, culprit in (("design cascade", "MODEL|FRF"), ("design shaper", "--psd"), ("explore", "GAINS"),
                             ("export klipper", "SHAPER"), ("export marlin", "SHAPER"), ("export linuxcnc", "GAINS")):
        add(_c(command, "", 2, culprit, "parser"))
    add(_c("warmup", "--jobs 2", 2, "--jobs", "parser"))
    add(_c("explore", f"{BS_GAINS} --frf {BS_FRF} -o page.txt", 2, "--out", "output"))
    add(_c("nope", "", 2, "nope", "parser"))
    add(_c("simulate", "nope", 2, "nope", "parser"))
    add(_c("design ppc", f"{BS_MODEL} extra", 2, "extra", "parser"))
    add(_c("simulate frf", "-o", 2, "-o", "parser"))
    add(_c("simulate frf", "-o s.csv --seed -1", 2, "--seed", "parser"))
    add(_c("simulate frf", "-o s.csv --excitation sawtooth", 2, "sawtooth", "parser"))
    add(_c("simulate frf", "-o s.csv --engine gpu", 2, "--engine", "parser"))
    add(_c("frf", f"{FRFLOG} --input u --output x1 --skip-rows -1", 2, "--skip-rows", "parser"))
    add(_c("analyze track", f"{TRACK} --skip-rows -1", 2, "--skip-rows", "parser"))
    add(_c("identify ballscrew", f"{BS_FRF} --frf-skip-rows -3", 2, "--frf-skip-rows", "parser"))
    add(_c("demo", "robot --out d", 2, "robot", "parser"))
    add(_c("tune", f"pidd {G_MODEL} --frf {G_FRF}", 2, "pidd", "parser"))
    add(_c("export c", f"{BS_GAINS} -o g.h --anti-windup sometimes", 2, "--anti-windup", "parser"))
    add(_c("export c", f"{BS_GAINS} -o g.h --prefix '9bad'", 2, "--prefix", "parser"))
    add(_c("export c", f"{BS_GAINS} -o g.h --prefix 'a b'", 2, "--prefix", "parser"))
    add(_c("export c", f"{BS_GAINS} -o g.h --anti-windup clamp", 2, "--u-max", "option"))
    add(_c("design ppc", f"{BS_MODEL} --limits lax", 2, "--limits", "parser"))
    add(_c("identify ballscrew", f"{BS_FRF} --quantity jerk", 2, "--quantity", "parser"))
    add(_c("identify friction", f"{REV} --position x2 --input u --law coulomb", 2, "--law", "parser"))

    # ---------------------------------------------------------------- absurd option values (issue 26 (d), accepted)
    add(_c("design gantry", f"{G_MODEL} --x-points 10000000 -o o.toml", 2, "--x-points", "budget"))
    add(_c("design pid", f"{G_MODEL} --x-points 10000000 -o o.toml", 2, "--x-points", "budget"))
    add(_c("design gantry", f"{G_MODEL} --x-points 0", 2, "--x-points"))
    add(_c("design gantry", f"{G_MODEL} --x-points -5", 2, "--x-points"))
    add(_c("design gantry", f"{G_MODEL} --x-min 0.3 --x-max -0.3", 2, "--x-min"))
    add(_c("simulate frf", "-o s.csv --period 10000", 2, "--period", "budget"))
    add(_c("simulate frf", "-o s.csv --periods 1000000", 2, "--periods", "budget"))
    add(_c("simulate frf", "-o s.csv --periods 0", 2, "--periods"))
    add(_c("simulate frf", "-o s.csv --periods -2", 2, "--periods"))
    add(_c("simulate frf", "-o s.csv --period 0", 2, "--period"))
    add(_c("simulate frf", "-o s.csv --period -1", 2, "--period"))
    add(_c("simulate frf", "-o s.csv --f-lo 500 --f-hi 100", 2, "--f-lo"))
    add(_c("simulate frf", "-o s.csv --f-hi 1e9", 2, "--f-hi"))
    add(_c("simulate frf", "-o s.csv --f-lo -5", 2, "--f-lo"))
    add(_c("simulate frf", "-o s.csv --rms -1", 2, "--rms"))
    add(_c("simulate frf", "-o s.csv --rms 0", 2, "--rms"))
    add(_c("simulate frf", "-o s.csv --rms 1e30", 2, "--rms"))
    add(_c("simulate frf", "-o s.csv --drift 1e6", 2, "--drift"))
    add(_c("simulate frf", "-o s.csv --period 1e-9", 2, "--period"))
    add(_c("simulate frf", "-o s.csv --param k=nan", 2, "--param"))
    add(_c("simulate frf", "-o s.csv --param nosuch=1", 2, "nosuch"))
    add(_c("simulate frf", "-o s.csv --param k", 2, "--param"))
    add(_c("simulate frf", "-o s.csv --param k=-5", 2, "k"))
    add(_c("simulate ropesnap", f"-g {BS_GAINS} -o s.csv --after 1e6", 2, "--after", "budget"))
    add(_c("simulate ropesnap", f"-g {BS_GAINS} -o s.csv --after -1", 2, "--after"))
    add(_c("simulate ropesnap", f"-g {BS_GAINS} -o s.csv --t-release -1", 2, "--t-release"))
    add(_c("simulate ropesnap", f"-g {BS_GAINS} -o s.csv --t-release 1e7", 2, "--t-release", "budget"))
    add(_c("simulate ropesnap", f"-g {BS_GAINS} -o s.csv --rope-force 1e30", 2, "--rope-force"))
    add(_c("simulate cut", f"-g {BS_GAINS} -o s.csv --rpm 1e12", 2, "--rpm"))
    add(_c("simulate cut", f"-g {BS_GAINS} -o s.csv --rpm 0", 2, "--rpm"))
    add(_c("simulate cut", f"-g {BS_GAINS} -o s.csv --rpm -100", 2, "--rpm"))
    add(_c("simulate cut", f"-g {BS_GAINS} -o s.csv --flutes 0", 2, "--flutes"))
    add(_c("simulate cut", f"-g {BS_GAINS} -o s.csv --flutes 100000", 2, "--flutes"))
    add(_c("simulate cut", f"-g {BS_GAINS} -o s.csv --speed 0", 2, "--speed"))
    add(_c("simulate cut", f"-g {BS_GAINS} -o s.csv --speed 1e-9", 2, "--speed", "budget"))
    add(_c("simulate cut", f"-g {BS_GAINS} -o s.csv --cut-length 1e6", 2, "--cut-length", "budget"))
    add(_c("simulate cut", f"-g {BS_GAINS} -o s.csv --tool-diameter -1", 2, "--tool-diameter"))
    add(_c("simulate track", f"-g {BS_GAINS} -o s.csv --distance 1e9", 2, "--distance", "budget"))
    add(_c("simulate track", f"-g {BS_GAINS} -o s.csv --distance 0.05 --v-max 0", 2, "--v-max"))
    add(_c("simulate track", f"-g {BS_GAINS} -o s.csv --distance 0.05 --v-max 1e-12", 2, "--v-max", "budget"))
    add(_c("simulate track", f"-g {BS_GAINS} -o s.csv --distance 0.05 --a-max -1", 2, "--a-max"))
    add(_c("simulate track", f"-g {BS_GAINS} -o s.csv --distance 0.05 --dwell-after 1e7", 2, "--dwell-after", "budget"))
    add(_c("simulate track", f"-g {BS_GAINS} -o s.csv --distance 0.05 --dwell-before -1", 2, "--dwell-before"))
    add(_c("simulate track", f"-g {BS_GAINS} -o s.csv --distance 0.05 --waypoints 0,0.1", 2, "--waypoints"))
    add(_c("simulate track", f"-g {BS_GAINS} -o s.csv --waypoints 0,abc", 2, "--waypoints"))
    add(_c("simulate track", f"-g {BS_GAINS} -o s.csv --waypoints 0,nan", 2, "--waypoints"))
    add(_c("simulate track", f"-g {BS_GAINS} -o s.csv", 2, "--distance"))
    add(_c("simulate gantry frf", "-o s.csv --x 0 --x 0 --x 0", 2, "--x"))
    add(_c("simulate gantry frf", "-o s.csv --x 5", 2, "--x"))
    add(_c("simulate gantry frf", "-o s.csv --periods 1000000", 2, "--periods", "budget"))
    add(_c("simulate gantry frf", "-o s.csv --period 10000", 2, "--period", "budget"))
    add(_c("simulate gantry axis-frf", "-o s.csv --periods 1000000", 2, "--periods", "budget"))
    add(_c("simulate gantry axis-frf", "-o s.csv --x 99", 2, "--x"))
    add(_c("simulate gantry mass", "-o s.csv --cycles 100000000", 2, "--cycles", "budget"))
    add(_c("simulate gantry mass", "-o s.csv --cycles 0", 2, "--cycles"))
    add(_c("simulate gantry mass", "-o s.csv --v-max -1", 2, "--v-max"))
    add(_c("simulate gantry ropesnap", f"-g {G_GAINS} -o s.csv --after 1e6", 2, "--after", "budget"))
    add(_c("simulate gantry ropesnap", f"-g {G_GAINS} -o s.csv --x 7", 2, "--x"))
    add(_c("simulate gantry track", f"-g {G_GAINS} -o s.csv --dwell-after 1e7", 2, "--dwell-after", "budget"))
    add(_c("simulate gantry track", f"-g {G_GAINS} -o s.csv --test slow", 2, "--test", "parser"))
    add(_c("simulate gantry contour", f"-g {G_GAINS} --axis-gains {A_GAINS} -o s.csv --size 1e6", 2, "--size"))
    add(
        _c(
            "simulate gantry contour",
            f"-g {G_GAINS} --axis-gains {A_GAINS} -o s.csv --v-max 1e-9",
            2,
            "--v-max",
            "budget",
        )
    )
    add(
        _c(
            "simulate gantry contour",
            f"-g {G_GAINS} --axis-gains {A_GAINS} -o s.csv --shape star",
            2,
            "--shape",
            "parser",
        )
    )
    add(_c("trajectory", "--distance 0.1 --v-max 0.2 --a-max 5 --j-max 500 --fs 1e12 -o t.csv", 2, "--fs", "budget"))
    add(_c("trajectory", "--distance 1e12 --v-max 0.2 --a-max 5 --j-max 500 -o t.csv", 2, "--distance", "budget"))
    add(_c("trajectory", "--distance 0.1 --v-max 0.2 --a-max 5 --j-max 500 --fs 0 -o t.csv", 2, "--fs"))
    add(_c("trajectory", "--distance 0.1 --v-max -0.2 --a-max 5 --j-max 500 -o t.csv", 2, "--v-max"))
    add(
        _c(
            "trajectory",
            "--distance 0.1 --v-max 0.2 --a-max 5 --j-max 500 --dwell 1e9 -o t.csv",
            2,
            "--dwell",
            "budget",
        )
    )
    add(_c("trajectory", "--v-max 0.2 --a-max 5 --j-max 500 -o t.csv", 2, "--distance"))
    add(_c("trajectory", "--distance 0.1 --waypoints 0,1 --v-max 0.2 --a-max 5 --j-max 500 -o t.csv", 2, "--waypoints"))
    add(_c("trajectory", "--distance 0.1 --v-max 0.2 --a-max 5 --j-max 500 -o t.txt", 2, "t.txt", "output"))
    add(_c("design ppc", f"{BS_MODEL} --fs 1", 2, "--fs"))
    add(_c("design ppc", f"{BS_MODEL} --fs 1e-300", 2, "--fs"))
    add(_c("design ppc", f"{BS_MODEL} --fs -5", 2, "--fs"))
    add(_c("design ppc", f"{BS_MODEL} --beta 0.5 --pole-hz 50 --zeta 0.7", 2, "--beta"))
    add(_c("design ppc", f"{BS_MODEL} --beta 4 --pole-hz -50 --zeta 0.7", 2, "--pole-hz"))
    add(_c("design ppc", f"{BS_MODEL} --beta 4 --pole-hz 50 --zeta -1", 2, "--zeta"))
    add(_c("design ppc", f"{BS_MODEL} --beta 4 --pole-hz 1e9 --zeta 0.7", 2, "--pole-hz"))
    add(_c("design ppc", f"{BS_MODEL} --notch 420,0.55", 2, "--notch"))
    add(_c("design ppc", f"{BS_MODEL} --notch 420,nan,0.7", 2, "--notch"))
    add(_c("design ppc", f"{BS_MODEL} --notch -420,0.55,0.7", 2, "--notch"))
    add(_c("design ppc", f"{BS_MODEL} --notch 1e9,0.55,0.7", 2, "--notch"))
    add(_c("design ppc", f"{BS_MODEL} --notch abc", 2, "--notch"))
    add(_c("design ppc", f"{BS_MODEL} --lpf -1", 2, "--lpf"))
    add(_c("design ppc", f"{BS_MODEL} --lpf 1e9", 2, "--lpf"))
    add(_c("design ppc", f"{BS_MODEL} --delay-samples -1", 2, "--delay-samples"))
    add(_c("design ppc", f"{BS_MODEL} --delay-samples 100000000", 2, "--delay-samples"))
    add(_c("design ppc", f"{BS_MODEL} --ms-max 0.5", 2, "--ms-max"))
    add(_c("design ppc", f"{BS_MODEL} --pm-min 200", 2, "--pm-min"))
    add(_c("design ppc", f"{BS_MODEL} --gm-min -3", 2, "--gm-min"))
    add(_c("design ppc", f"{BS_MODEL} --dm-min 5", 2, "--dm-min"))
    add(_c("design ppc", f"{BS_MODEL} --friction-band 1e300", 2, "--friction-band"))
    add(_c("design ppc", f"{BS_MODEL} --friction-band 0", 2, "--friction-band"))
    add(_c("design ppc", f"{BS_MODEL} --friction-band -1", 2, "--friction-band"))
    add(_c("design ppc", f"{BS_MODEL} --friction-band nan", 2, "--friction-band"))
    add(_c("design ppc", f"{BS_MODEL} --friction {FX}/fr.toml --friction-band 1e300", 2, "--friction-band"))
    add(_c("design ppi", f"{BS_MODEL} --kpx 1e300 --kpv 1 --kiv 1", 2, "--kpx"))
    add(_c("design ppi", f"{BS_MODEL} --kpx -30 --kpv 2 --kiv 1000", 2, "--kpx"))
    add(_c("design ppi", f"{BS_MODEL} --kpx 30 --kpv 0 --kiv 1000", 2, "--kpv"))
    add(_c("design ppi", f"{BS_MODEL} --kpx 30", 2, "--kpv"))
    add(_c("design ppi", f"{BS_MODEL} --fs 1", 2, "--fs"))
    add(_c("design loopshape", f"{G_MODEL} --crossover-hz -100 --pm-deg 35", 2, "--crossover-hz"))
    add(_c("design loopshape", f"{G_MODEL} --crossover-hz 100 --pm-deg 200", 2, "--pm-deg"))
    add(_c("design loopshape", f"{G_MODEL} --crossover-hz 1e9 --pm-deg 35", 2, "--crossover-hz"))
    add(_c("design loopshape", f"{G_MODEL} --crossover-hz 100 --pm-deg 35 --lpf-order 7", 2, "--lpf-order"))
    add(_c("design gantry", f"{G_MODEL} --crossover-hz -60", 2, "--crossover-hz"))
    add(_c("design gantry", f"{G_MODEL} --crossover-hz 1e9", 2, "--crossover-hz"))
    add(_c("design gantry", f"{G_MODEL} --pm-deg 0", 2, "--pm-deg"))
    add(_c("design gantry", f"{G_MODEL} --fs 10", 2, "--fs"))
    add(_c("design pid", f"{G_MODEL} --kp -1 --kd 10 --ki 100", 2, "--kp"))
    add(_c("design pid", f"{G_MODEL} --kp 1000", 2, "--kd"))
    add(
        _c(
            "identify friction",
            f"{REV} --position x2 --input u --steady-state --plateau-min-duration 1e9",
            1,
            "--plateau-min-duration",
            "budget",
        )
    )
    add(
        _c(
            "identify friction",
            f"{REV} --position x2 --input u --steady-state --plateau-min-duration -1",
            2,
            "--plateau-min-duration",
        )
    )
    add(
        _c(
            "identify friction",
            f"{REV} --position x2 --input u --steady-state --plateau-vel-tol -1",
            2,
            "--plateau-vel-tol",
        )
    )
    add(
        _c(
            "identify friction",
            f"{REV} --position x2 --input u --model {BS_MODEL} --bandwidth-hz -5",
            2,
            "--bandwidth-hz",
        )
    )
    add(_c("identify friction", f"{REV} --position x2 --input u --model {BS_MODEL} --lpf-hz 1e9", 2, "--lpf-hz"))
    add(_c("identify friction", f"{REV} --position x2 --input u --model {BS_MODEL} --min-speed -1", 2, "--min-speed"))
    add(_c("identify friction", f"{REV} --position x2 --input u --mass -1", 2, "--mass"))
    add(_c("identify friction", f"{REV} --position x2 --input u --steady-state --model {BS_MODEL}", 2, "--model"))
    add(_c("identify rigid", f"{REV} --position x2 --input u --lpf-hz -5", 2, "--lpf-hz"))
    add(_c("identify rigid", f"{REV} --position x2 --input u --lpf-hz 1e9", 2, "--lpf-hz"))
    add(_c("identify rigid", f"{REV} --position x2 --input u --filter-order 0", 2, "--filter-order"))
    add(_c("identify rigid", f"{REV} --position x2 --input u --filter-order 99", 2, "--filter-order"))
    add(_c("identify rigid", f"{REV} --position x2 --input u --decimate 0", 2, "--decimate"))
    add(_c("identify rigid", f"{REV} --position x2 --input u --decimate 100000000", 1, "--decimate"))
    add(_c("identify rigid", f"{REV} --position x2 --input u --velocity-threshold -1", 2, "--velocity-threshold"))
    add(_c("identify ballscrew", f"{BS_FRF} --band 100 10", 2, "--band"))
    add(_c("identify ballscrew", f"{BS_FRF} --band -1 100", 2, "--band"))
    add(_c("identify ballscrew", f"{BS_FRF} --lead -1", 2, "--lead"))
    add(_c("identify ballscrew", f"{BS_FRF} --channel x9/u", 1, "x9/u"))
    add(_c("identify gantry", f"{G_FRF} --x 0 --span -1", 2, "--span"))
    add(_c("identify gantry", f"{G_FRF} --x 0 --x 1 --span 1.484", 2, "--x"))
    add(_c("identify gantry", f"{FX}/g_frf_m.csv {G_FRF} {FX}/g_frf_p.csv --x 0 --x 0 --x 0 --span 1.484", 2, "--x"))
    add(_c("identify gantry", f"{G_FRF} --x 0 --span 1.484 --m-x -1", 2, "--m-x"))
    add(_c("identify mass", f"{TRACK} {RS} --x 0", 2, "--x"))
    add(_c("identify mass", f"{TRACK} {RS} --x 0 --x 0", 2, "--x"))
    add(_c("frf", f"{FRFLOG} --input u --output x1 --remove-sampling 1000000", 2, "--remove-sampling"))
    add(_c("frf", f"{FRFLOG} --input u --output x1 --remove-sampling -1", 2, "--remove-sampling"))
    add(_c("frf", f"{FRFLOG} --input u --output x1 --nperseg 1", 2, "--nperseg"))
    add(_c("frf", f"{FRFLOG} --input u --output x1 --nperseg 100000000", 1, "--nperseg"))
    add(_c("frf", f"{FRFLOG} --input u --output x1 --overlap 1.5", 2, "--overlap"))
    add(_c("frf", f"{FRFLOG} --input u --output x1 --band 1000 10", 2, "--band"))
    add(_c("frf", f"{FRFLOG} --input u --output x1 --period-samples 0", 2, "--period-samples"))
    add(_c("frf", f"{FRFLOG} --input u --output x1 --fs 0", 2, "--fs"))
    add(_c("frf", f"{FRFLOG} --input u --output ,", 2, "--output"))
    add(_c("frf", f"{FRFLOG} --input u --output x1 --map a", 2, "--map"))
    add(_c("frf", f"{FRFLOG} --input u --output x1 --scale u=abc", 2, "--scale"))
    add(_c("frf", f"{FRFLOG} --input u --output x1 --scale u=0", 2, "--scale"))
    add(_c("frf", f"{FRFLOG} --input u --output x1 --scale u=nan", 2, "--scale"))
    add(_c("frf", f"{FRFLOG} --input u --output x1 --time t --fs 1000", 2, "--fs"))
    add(_c("frf", f"{FRFLOG} --input u --output x1 -o f.xyz", 2, "f.xyz", "output"))
    add(_c("prefilter", f"{TRACK} --gains {BS_GAINS} --lpf-hz -1", 2, "--lpf-hz"))
    add(_c("prefilter", f"{TRACK} --gains {BS_GAINS} --orders vel,wobble", 2, "--orders"))
    add(_c("report", f"{BS_GAINS} -o r.html --log-kind zzz", 2, "--log-kind"))
    add(_c("report", f"{BS_GAINS} -o r.pdf", 2, "r.pdf", "output"))
    add(_c("analyze ropesnap", f"{RS} --t-release -5", 2, "--t-release"))
    add(_c("analyze ropesnap", f"{RS} --t-release 1e9", 2, "--t-release"))
    add(_c("analyze gains", f"{BS_GAINS} --ms-max 1", 2, "--ms-max"))
    add(_c("export c", f"{BS_GAINS} -o g.h --u-max -1", 2, "--u-max"))
    add(_c("export c", f"{BS_GAINS} -o g.h --u-max 0", 2, "--u-max"))
    add(_c("tune", f"mcppc {BS_MODEL} --frf {BS_FRF} --fs 1", 2, "--fs"))
    add(_c("tune", f"mcppc {BS_MODEL} --frf {BS_FRF} --delay-samples -1", 2, "--delay-samples"))
    add(_c("tune", f"mcppc {BS_MODEL} --frf {BS_FRF} --filters cheap", 2, "--filters"))
    add(_c("tune", f"ppi {BS_MODEL} --frf {BS_FRF} --lpf-order 3", 2, "--lpf-order"))
    add(_c("demo", "--out d --seed -1", 2, "--seed", "parser"))
    add(_c("demo", "--out d --engine fpga", 2, "--engine", "parser"))
    add(_c("log merge", f"{TRACK} {DAQ} -o m.csv --fs 1e9", 2, "--fs", "budget"))
    add(_c("log merge", f"{TRACK} {DAQ} -o m.csv --fs -1", 2, "--fs"))
    add(_c("log merge", f"{TRACK} {DAQ} -o m.csv --shift u=nan", 2, "--shift"))
    add(_c("log merge", f"{TRACK} {DAQ} -o m.csv --shift u=inf", 2, "--shift"))
    add(_c("log merge", f"{TRACK} {DAQ} -o m.csv --shift u=abc", 2, "--shift"))
    add(_c("log merge", f"{TRACK} {DAQ} -o m.csv --shift u=1e9", 1, "--shift"))
    add(_c("log merge", f"{TRACK} {DAQ} -o m.csv --offset u=nan", 2, "--offset"))
    add(_c("log merge", f"{TRACK} {DAQ} -o m.csv --offset u=mean:0", 2, "--offset"))
    add(_c("log merge", f"{TRACK} {DAQ} -o m.csv --scale u=inf", 2, "--scale"))
    add(_c("log merge", f"{TRACK} -o m.csv", 2, "two or more"))
    add(_c("log merge", f"{TRACK} {DAQ} -o m.csv --integrate x", 2, "--integrate"))
    add(_c("log convert", f"{TRACK} -o c.csv --keep ,", 2, "--keep"))
    add(_c("log convert", f"{TRACK} -o c.csv --time ' '", 2, "--time"))
    add(_c("log convert", f"{TRACK} -o c.csv --unit u", 2, "--unit"))
    add(_c("log convert", f"{TRACK} -o c.mat", 2, "c.mat", "output"))

    # ---------------------------------------------------------------- names the inputs lack (exit 1: the data)
    add(_c("log convert", f"{TRACK} -o c.csv --keep nosuch", 1, "nosuch", "name"))
    add(_c("log convert", f"{TRACK} -o c.csv --map a=nosuch", 1, "nosuch", "name"))
    add(_c("log convert", f"{TRACK} -o c.csv --scale nosuch=2", 1, "nosuch", "name"))
    add(_c("log convert", f"{TRACK} -o c.csv --unit nosuch=V", 1, "nosuch", "name"))
    add(_c("log convert", f"{TRACK} -o c.csv --time nosuch", 1, "nosuch", "name"))
    add(_c("log merge", f"{TRACK} {DAQ} -o m.csv --shift nosuch=0.1", 1, "nosuch", "name"))
    add(_c("log merge", f"{TRACK} {DAQ} -o m.csv --integrate x=nosuch", 1, "nosuch", "name"))
    add(_c("log merge", f"{TRACK} {DAQ} -o m.csv --offset nosuch=1", 1, "nosuch", "name"))
    add(_c("log merge", f"{TRACK} {DAQ} -o m.csv --scale nosuch=2", 1, "nosuch", "name"))
    add(_c("log merge", f"{TRACK} {RS} -o m.csv", 1, "x2_table", "name"))
    add(_c("analyze track", f"{TRACK} --error nosuch", 1, "nosuch", "name"))
    add(_c("analyze track", f"{TRACK} --reference nosuch", 1, "nosuch", "name"))
    add(_c("analyze ropesnap", f"{RS} --position nosuch", 1, "nosuch", "name"))
    add(_c("frf", f"{FRFLOG} --input nosuch --output x1", 1, "nosuch", "name"))
    add(_c("frf", f"{FRFLOG} --input u --output x1,nosuch", 1, "nosuch", "name"))
    add(_c("identify rigid", f"{REV} --position nosuch --input u", 1, "nosuch", "name"))
    add(_c("identify friction", f"{REV} --position x2 --input nosuch --model {BS_MODEL}", 1, "nosuch", "name"))
    add(_c("prefilter", f"{TRACK} --gains {BS_GAINS} --reference nosuch", 1, "nosuch", "name"))
    add(_c("identify ballscrew", f"{BS_FRF} --frf-scale x9/u=2", 1, "x9/u", "name"))
    add(
        _c(
            "identify ballscrew",
            f"{BS_FRF} --frf-map freq=nosuch --frf-map x1/u.re=a --frf-map x1/u.im=b",
            1,
            "nosuch",
            "name",
        )
    )
    add(_c("identify mass", f"{TRACK} {RS} --x 0 --x 0.1 --acc-ref nosuch", 1, "nosuch", "name"))
    add(_c("analyze gains", f"{BS_GAINS} --frf {G_FRF}", 1, "g_frf.csv", "wrong kind"))

    # ---------------------------------------------------------------- input files: missing, folder, empty, binary
    file_commands = {
        "identify ballscrew": "{f}",
        "identify gantry": "{f} --x 0 --span 1.484",
        "design ppc": "{f}",
        "design ppi": "{f}",
        "design gantry": "{f}",
        "design loopshape": "{f} --crossover-hz 100 --pm-deg 35",
        "design pid": "{f}",
        "analyze gains": "{f}",
        "export c": "{f} -o g.h",
        "analyze track": "{f}",
        "analyze ropesnap": "{f}",
        "log convert": "{f} -o c.csv",
        "frf": "{f} --input u --output x1",
        "identify rigid": "{f} --position x2 --input u",
        "prefilter": "{f} --gains " + BS_GAINS,
        "tune": "mcppc {f} --frf " + BS_FRF,
        "simulate track": "-g {f} --distance 0.05 -o s.csv",
        "simulate gantry track": "-g {f} -o s.csv",
        "report": "{f} -o r.html",
    }
    doc_commands = {
        "design ppc",
        "design ppi",
        "design gantry",
        "design loopshape",
        "design pid",
        "analyze gains",
        "export c",
        "tune",
        "simulate track",
        "simulate gantry track",
    }
    for command, pattern in file_commands.items():
        is_doc = command in doc_commands
        ext = ".toml" if is_doc else ".csv"
        add(_c(command, pattern.replace("{f}", "missing" + ext), 1, "missing" + ext, "file"))
        add(_c(command, pattern.replace("{f}", "dir" + ext), 1, "dir" + ext, "file", [("dir" + ext, folder())]))
        add(_c(command, pattern.replace("{f}", "empty" + ext), 1, "empty" + ext, "file", [("empty" + ext, raw(b""))]))
        add(
            _c(
                command,
                pattern.replace("{f}", "bin" + ext),
                1,
                "bin" + ext,
                "file",
                [("bin" + ext, raw(b"\x00\x01\x02\xff" * 1000))],
            )
        )
        add(
            _c(
                command,
                pattern.replace("{f}", "junk" + ext),
                1,
                "junk" + ext,
                "file",
                [("junk" + ext, binary_without_nul(20_000))],
            )
        )
        add(
            _c(
                command,
                pattern.replace("{f}", "input.xyz"),
                1,
                "input.xyz",
                "file",
                [("input.xyz", text("a,b\n1,2\n"))],
            )
        )
        add(
            _c(
                command,
                pattern.replace("{f}", "link" + ext),
                1,
                "link" + ext,
                "file",
                [("link" + ext, symlink_to("nowhere" + ext))],
            )
        )
    if hasattr(os, "mkfifo"):
        for command in ("analyze track", "identify ballscrew", "design ppc"):
            ext = ".toml" if command == "design ppc" else ".csv"
            add(
                _c(
                    command,
                    file_commands[command].replace("{f}", "pipe" + ext),
                    1,
                    "pipe" + ext,
                    "file",
                    [("pipe" + ext, fifo())],
                )
            )

    # ---------------------------------------------------------------- wrong-kind files (exit 1)
    for command, pattern, wrong, needed in (
        ("design ppc", "{f}", G_MODEL, "g_model.toml"),
        ("design ppi", "{f}", G_MODEL, "g_model.toml"),
        ("tune", "mcppc {f} --frf " + BS_FRF, G_MODEL, "g_model.toml"),
        ("tune", "ppi {f} --frf " + BS_FRF, G_MODEL, "g_model.toml"),
        ("design gantry", "{f}", BS_MODEL, "bs_model.toml"),
        ("design pid", "{f}", BS_MODEL, "bs_model.toml"),
        ("tune", "gantry {f} --frf " + G_FRF + " --x 0", BS_MODEL, "bs_model.toml"),
        ("design loopshape", "{f} --crossover-hz 100 --pm-deg 35", BS_MODEL, "bs_model.toml"),
        ("design ppc", "{f}", BS_GAINS, "bs_gains.toml"),
        ("design gantry", "{f}", G_GAINS, "g_gains.toml"),
        ("analyze gains", "{f}", BS_MODEL, "bs_model.toml"),
        ("analyze gains", "{f}", G_MODEL, "g_model.toml"),
        ("export c", "{f} -o g.h", BS_MODEL, "bs_model.toml"),
        ("export c", "{f} -o g.h", G_MODEL, "g_model.toml"),
        ("simulate gantry track", "-g {f} -o s.csv", BS_GAINS, "bs_gains.toml"),
        ("simulate gantry track", "-g {f} -o s.csv", A_GAINS, "a_gains.toml"),
        ("simulate gantry ropesnap", "-g {f} -o s.csv", BS_GAINS, "bs_gains.toml"),
        ("simulate gantry contour", "-g {f} --axis-gains " + A_GAINS + " -o s.csv", A_GAINS, "a_gains.toml"),
        ("simulate gantry contour", "-g " + G_GAINS + " --axis-gains {f} -o s.csv", G_GAINS, "g_gains.toml"),
        ("simulate track", "-g {f} --distance 0.05 -o s.csv", G_GAINS, "g_gains.toml"),
        ("simulate ropesnap", "-g {f} -o s.csv", A_GAINS, "a_gains.toml"),
        ("simulate cut", "-g {f} -o s.csv", G_MODEL, "g_model.toml"),
        ("simulate frf", "-g {f} -o s.csv", G_GAINS, "g_gains.toml"),
        ("prefilter", TRACK + " --gains {f}", BS_MODEL, "bs_model.toml"),
        ("prefilter", TRACK + " --gains {f}", G_GAINS, "g_gains.toml"),
        ("identify friction", REV + " --position x2 --input u --model {f}", G_GAINS, "g_gains.toml"),
        ("identify ballscrew", "{f}", TRACK, "track.csv"),
        ("identify ballscrew", "{f}", G_FRF, "g_frf.csv"),
        ("identify gantry", "{f} --x 0 --span 1.484", BS_FRF, "bs_frf.csv"),
        ("analyze track", "{f}", BS_FRF, "bs_frf.csv"),
        ("analyze ropesnap", "{f}", BS_FRF, "bs_frf.csv"),
        ("frf", "{f} --input u --output x1", BS_FRF, "bs_frf.csv"),
        ("design ppc", "{f}", BS_FRF, "bs_frf.csv"),
        ("analyze gains", "{f}", BS_FRF, "bs_frf.csv"),
        ("tune", "mcppc " + BS_MODEL + " --frf {f}", TRACK, "track.csv"),
        ("tune", "mcppc " + BS_MODEL + " --frf {f}", G_FRF, "g_frf.csv"),
        ("design ppc", BS_MODEL + " --beta 4 --pole-hz 50 --zeta 0.7 --frf {f}", G_FRF, "g_frf.csv"),
        ("design ppc", BS_MODEL + " --friction {f}", G_MODEL, "g_model.toml"),
        ("report", "{f} -o r.html", f"{FX}/traj.csv", "traj.csv"),
    ):
        add(_c(command, pattern.replace("{f}", wrong), 1, needed, "wrong kind"))

    # ---------------------------------------------------------------- documents (issue 26 (b), (c))
    bs, bj = "bs_model.toml", "g_model.json"
    readers = (
        ("design ppc", "{f}"),
        ("analyze gains", "{f}"),
        ("export c", "{f} -o g.h"),
        ("simulate ropesnap", "-g {f} -o s.csv"),
    )
    for depth in (100, 10_000, 100_000):
        for command, pattern in readers:
            add(
                _c(
                    command,
                    pattern.replace("{f}", "deep.json"),
                    1,
                    "deep.json",
                    "nesting",
                    [("deep.json", nested_json(depth))],
                )
            )
            add(
                _c(
                    command,
                    pattern.replace("{f}", "deep.toml"),
                    1,
                    "deep.toml",
                    "nesting",
                    [("deep.toml", nested_toml_arrays(depth))],
                )
            )
        add(_c("design gantry", "deepo.json", 1, "deepo.json", "nesting", [("deepo.json", nested_json_objects(depth))]))
        add(_c("design gantry", "deept.toml", 1, "deept.toml", "nesting", [("deept.toml", nested_toml_tables(depth))]))
        add(_c("design gantry", "deepi.toml", 1, "deepi.toml", "nesting", [("deepi.toml", nested_toml_inline(depth))]))
    add(_c("design ppc", "huge.toml", 1, "huge.toml", "size", [("huge.toml", sparse(200 << 20, b"# x\n"))]))
    add(
        _c(
            "analyze gains",
            "huge.json",
            1,
            "huge.json",
            "size",
            [("huge.json", text('{"schema": "feedtune.gains/1", "x": [' + "1," * 3_000_000 + "1]}"))],
        )
    )
    add(
        _c(
            "design ppc",
            "int.json",
            1,
            "5001 digits",
            "big number",
            [
                (
                    "int.json",
                    edited(
                        "bs_model.json", lambda s: s.replace('"value": 0.', '"value": ' + "9" * 5001 + ', "x": 0.', 1)
                    ),
                )
            ],
        )
    )
    add(
        _c(
            "design gantry",
            "int.toml",
            1,
            "int.toml",
            "big number",
            [("int.toml", edited("g_model.toml", lambda s: s.replace("value = ", "value = " + "9" * 400 + " #", 1)))],
        )
    )
    add(
        _c(
            "design gantry",
            "int2.toml",
            1,
            "int2.toml",
            "big number",
            [("int2.toml", edited("g_model.toml", lambda s: s.replace("value = ", "value = " + "9" * 5000 + " #", 1)))],
        )
    )
    add(
        _c(
            "simulate gantry track",
            "-g int.toml -o s.csv",
            1,
            "int.toml",
            "big number",
            [("int.toml", edited("g_gains.toml", lambda s: s.replace("fs_hz = ", "fs_hz = " + "4" * 400 + " #", 1)))],
        )
    )
    add(
        _c(
            "analyze gains",
            "inf.toml",
            1,
            "delay_samples",
            "non-finite",
            [("inf.toml", edited("bs_gains.toml", lambda s: s.replace("delay_samples = 1", "delay_samples = inf")))],
        )
    )
    add(
        _c(
            "analyze gains",
            "inf.json",
            1,
            "delay_samples",
            "non-finite",
            [
                (
                    "inf.json",
                    edited("bs_gains.json", lambda s: s.replace('"delay_samples": 1', '"delay_samples": "inf"')),
                )
            ],
        )
    )
    add(
        _c(
            "analyze gains",
            "big.toml",
            1,
            "delay_samples",
            "big number",
            [("big.toml", edited("bs_gains.toml", lambda s: s.replace("delay_samples = 1", "delay_samples = 1e300")))],
        )
    )
    add(
        _c(
            "export c",
            "inf.toml -o g.h",
            1,
            "delay_samples",
            "non-finite",
            [("inf.toml", edited("bs_gains.toml", lambda s: s.replace("delay_samples = 1", "delay_samples = inf")))],
        )
    )
    add(
        _c(
            "export c",
            "neg.toml -o g.h",
            1,
            "delay_samples",
            "non-finite",
            [("neg.toml", edited("bs_gains.toml", lambda s: s.replace("delay_samples = 1", "delay_samples = -3")))],
        )
    )
    add(
        _c(
            "export c",
            "frac.toml -o g.h",
            1,
            "delay_samples",
            "non-finite",
            [("frac.toml", edited("bs_gains.toml", lambda s: s.replace("delay_samples = 1", "delay_samples = 1.5")))],
        )
    )
    add(
        _c(
            "analyze gains",
            "nanfs.toml",
            1,
            "fs_hz",
            "non-finite",
            [("nanfs.toml", edited("bs_gains.toml", lambda s: s.replace("fs_hz = ", "fs_hz = nan #", 1)))],
        )
    )
    add(
        _c(
            "design ppc",
            "nan.toml",
            1,
            "nan.toml",
            "non-finite",
            [("nan.toml", edited(bs, lambda s: s.replace("value = ", "value = nan #", 1)))],
        )
    )
    add(
        _c(
            "design ppc",
            "ninf.toml",
            1,
            "ninf.toml",
            "non-finite",
            [("ninf.toml", edited(bs, lambda s: s.replace("value = ", "value = -inf #", 1)))],
        )
    )
    add(
        _c(
            "design gantry",
            "inf.json",
            1,
            "inf.json",
            "non-finite",
            [("inf.json", edited(bj, lambda s: s.replace('"value": ', '"value": "inf", "x": ', 1)))],
        )
    )
    add(
        _c(
            "design gantry",
            "nan.json",
            1,
            "nan.json",
            "non-finite",
            [("nan.json", edited(bj, lambda s: s.replace('"value": ', '"value": NaN, "x": ', 1)))],
        )
    )
    add(
        _c(
            "design ppc",
            "str.toml",
            1,
            "str.toml",
            "wrong type",
            [("str.toml", edited(bs, lambda s: s.replace("value = ", 'value = "heavy" #', 1)))],
        )
    )
    add(
        _c(
            "design ppc",
            "neg.toml",
            1,
            "neg.toml",
            "implausible",
            [("neg.toml", edited(bs, lambda s: s.replace("value = ", "value = -1.0 #", 1)))],
        )
    )
    # schema versions: newer minor accepted (with a note), other majors refused
    for major in ("0", "2", "99"):
        add(
            _c(
                "design gantry",
                "v.toml",
                1,
                "feedtune.model/" + major,
                "schema",
                [
                    (
                        "v.toml",
                        edited("g_model.toml", lambda s, m=major: s.replace("feedtune.model/1", f"feedtune.model/{m}")),
                    )
                ],
            )
        )
        add(
            _c(
                "analyze gains",
                "v.toml",
                1,
                "feedtune.gains/" + major,
                "schema",
                [
                    (
                        "v.toml",
                        edited(
                            "bs_gains.toml", lambda s, m=major: s.replace("feedtune.gains/1", f"feedtune.gains/{m}")
                        ),
                    )
                ],
            )
        )
    add(
        _c(
            "design gantry",
            "v.toml",
            1,
            "v.toml",
            "schema",
            [("v.toml", edited("g_model.toml", lambda s: s.replace("feedtune.model/1", "feedtune.model/one")))],
        )
    )
    add(
        _c(
            "design gantry",
            "v.toml",
            1,
            "v.toml",
            "schema",
            [("v.toml", edited("g_model.toml", lambda s: s.replace('schema = "feedtune.model/1', '# "')))],
        )
    )
    add(
        _c(
            "design gantry",
            "v.toml",
            1,
            "feedtune.gains",
            "schema",
            [("v.toml", edited("g_model.toml", lambda s: s.replace("feedtune.model/1", "feedtune.gains/1")))],
        )
    )
    add(_c("design ppc", "syntax.toml", 1, "syntax.toml", "syntax", [("syntax.toml", text("schema = \n[[[\n"))]))
    add(_c("design ppc", "syntax.json", 1, "syntax.json", "syntax", [("syntax.json", text('{"schema": '))]))
    add(_c("design ppc", "list.json", 1, "list.json", "syntax", [("list.json", text("[1, 2]"))]))
    add(_c("design ppc", "latin.toml", 1, "latin.toml", "encoding", [("latin.toml", raw(b'schema = "\xe9"\n'))]))
    add(
        _c(
            "design ppc",
            "nokind.toml",
            1,
            "nokind.toml",
            "structure",
            [("nokind.toml", edited(bs, lambda s: s.replace('kind = "ballscrew"', "")))],
        )
    )
    add(
        _c(
            "analyze gains",
            "nogains.toml",
            1,
            "gains",
            "structure",
            [("nogains.toml", edited("bs_gains.toml", lambda s: s.replace("[gains]", "[gainz]")))],
        )
    )
    add(
        _c(
            "analyze gains",
            "badsos.toml",
            1,
            "badsos.toml",
            "structure",
            [
                (
                    "badsos.toml",
                    edited("bs_gains.toml", lambda s: s.replace("filter_pack_sos = [", "filter_pack_sos = [[1,2],")),
                )
            ],
        )
    )

    # ---------------------------------------------------------------- FRF files (issue 26 accepted / internal)
    f = "bs_frf.csv"
    frf_cmds = (
        ("identify ballscrew", "{f}"),
        ("design ppc", BS_MODEL + " --beta 4 --pole-hz 50 --zeta 0.7 --frf {f}"),
        ("analyze gains", BS_GAINS + " --frf {f}"),
    )
    frf_bad = [
        ("lastf.csv", frf_rows(f, set_cell(-1, 0, "1.8e308")), "lastf.csv", "frequency"),
        ("inff.csv", frf_rows(f, set_cell(-1, 0, "inf")), "inff.csv", "frequency"),
        ("decr.csv", frf_rows(f, lambda rows: rows.reverse()), "decr.csv", "frequency"),
        ("dup.csv", frf_rows(f, lambda rows: rows.insert(5, list(rows[5]))), "dup.csv", "frequency"),
        ("negf.csv", frf_rows(f, set_cell(0, 0, "-1")), "negf.csv", "frequency"),
        ("coh.csv", frf_rows(f, set_cell(10, 3, "1.7")), "coh.csv", "coherence"),
        ("cohn.csv", frf_rows(f, set_cell(10, 3, "-0.2")), "cohn.csv", "coherence"),
        ("nan.csv", frf_rows(f, set_cell(10, 1, "nan")), "nan.csv", "line"),
        ("huge.csv", frf_rows(f, set_cell(10, 1, "1e400")), "huge.csv", "line"),
        ("text.csv", frf_rows(f, set_cell(10, 2, "abc")), "text.csv", "line"),
        ("short.csv", frf_rows(f, lambda rows: rows[20].pop()), "short.csv", "short.csv"),
        ("long.csv", frf_rows(f, lambda rows: rows[20].append("5")), "long.csv", "line"),
        ("one.csv", frf_rows(f, lambda rows: rows.__delitem__(slice(1, None))), "one.csv", "one.csv"),
        ("noframe.csv", header_edit(f, lambda c: c.__setitem__(0, "hz")), "noframe.csv", "noframe.csv"),
        ("badcol.csv", header_edit(f, lambda c: c.__setitem__(1, "x1/u.foo")), "badcol.csv", "x1/u.foo"),
        ("dupcol.csv", header_edit(f, lambda c: c.__setitem__(4, "x1/u.re")), "dupcol.csv", "x1/u.re"),
        ("cut.csv", cut(f, 0.5), None, None),
        ("bom.csv", edited(f, lambda s: "\ufeff\ufeff" + s), "bom.csv", "bom.csv"),
        ("semi.csv", text("freq_hz;x1/u.mag_db;x1/u.phase_deg\n1;0;-11;0\n2;1;2\n"), "semi.csv", "semi.csv"),
        (
            "semiint.csv",
            text("freq_hz;x1/u.re;x1/u.im\n" + "".join(f"{k};{10**400};1\n" for k in range(1, 30))),
            "semiint.csv",
            "semiint.csv",
        ),
        (
            "intbig.csv",
            text("freq_hz,x1/u.re,x1/u.im\n" + "".join(f"{k},{'9' * 400},1\n" for k in range(1, 30))),
            "intbig.csv",
            "intbig.csv",
        ),
        (
            "allint.csv",
            text("freq_hz;x1/u.re;x1/u.im\n" + "".join(f"{k};{k * 10**30};1\n" for k in range(1, 30))),
            "allint.csv",
            "allint.csv",
        ),
        (
            "zero.csv",
            text("freq_hz,x1/u.re,x1/u.im\n" + "".join(f"{k},0,0\n" for k in range(1, 300))),
            "zero.csv",
            "zero.csv",
        ),
        (
            "negmag.csv",
            text("freq_hz,x1/u.mag,x1/u.phase_deg\n" + "".join(f"{k},-1,0\n" for k in range(1, 300))),
            "negmag.csv",
            "mag",
        ),
        ("crlf.csv", edited(f, lambda s: s.replace("\n", "\r\n").replace("1.0,", "a,", 1)), "crlf.csv", "crlf.csv"),
        ("devzero.csv", sparse(1 << 20), "devzero.csv", "devzero.csv"),
    ]
    for name, maker, culprit, _ in frf_bad:
        for command, pattern in frf_cmds:
            add(_c(command, pattern.replace("{f}", name), 1, culprit or name, "frf file", [(name, maker)]))
    add(
        _c(
            "identify ballscrew",
            "sparse.csv",
            1,
            "sparse.csv",
            "budget",
            [("sparse.csv", sparse(10 << 30, b"freq_hz,x1/u.re,x1/u.im\n1,2,3\n"))],
        )
    )
    add(
        _c(
            "analyze gains",
            f"{BS_GAINS} --frf sparse.csv",
            1,
            "sparse.csv",
            "budget",
            [("sparse.csv", sparse(10 << 30, b"freq_hz,x1/u.re,x1/u.im\n1,2,3\n"))],
        )
    )
    add(
        _c(
            "identify ballscrew",
            "coh.mat",
            1,
            "coh.mat",
            "frf file",
            [
                (
                    "coh.mat",
                    mat_file(
                        lambda: {
                            "freq_hz": np.arange(1.0, 301.0),
                            "H1": np.exp(-1j * np.arange(300) / 50.0),
                            "H2": np.ones(300) + 0j,
                            "coh1": np.full(300, 1.3),
                            "coh2": np.full(300, 0.9),
                        }
                    ),
                )
            ],
        )
    )
    add(
        _c(
            "identify ballscrew",
            "decr.mat",
            1,
            "decr.mat",
            "frf file",
            [
                (
                    "decr.mat",
                    mat_file(
                        lambda: {
                            "freq_hz": np.arange(300.0, 0.0, -1.0),
                            "H1": np.ones(300) + 0j,
                            "H2": np.ones(300) + 0j,
                        }
                    ),
                )
            ],
        )
    )
    add(
        _c(
            "identify ballscrew",
            "inf.mat",
            1,
            "inf.mat",
            "frf file",
            [
                (
                    "inf.mat",
                    mat_file(
                        lambda: {
                            "freq_hz": np.r_[np.arange(1.0, 300.0), np.inf],
                            "H1": np.ones(300) + 0j,
                            "H2": np.ones(300) + 0j,
                        }
                    ),
                )
            ],
        )
    )
    add(
        _c(
            "identify ballscrew",
            "big73.mat",
            1,
            "big73.mat",
            "budget",
            [
                (
                    "big73.mat",
                    mat73(
                        lambda f: (
                            _h5_double(f, "freq_hz", (1, 2_000_000_000)),
                            _h5_double(f, "H1", (1, 2_000_000_000)),
                        )
                    ),
                )
            ],
        )
    )
    add(_c("identify ballscrew", "cut.mat", 1, "cut.mat", "frf file", [("cut.mat", cut("bs_frf.mat", 0.5))]))
    add(_c("identify ballscrew", "cut.uff", 1, "cut.uff", "frf file", [("cut.uff", cut("bs_frf.uff", 0.5))]))
    add(
        _c(
            "identify ballscrew",
            "bad.uff",
            1,
            "bad.uff",
            "frf file",
            [("bad.uff", raw(b"    -1\n    58\n" + b"x" * 500))],
        )
    )

    # ---------------------------------------------------------------- logs (issue 26 accepted / internal)
    t = "track.csv"
    log_cmds = (("analyze track", "{f}"), ("log convert", "{f} -o c.csv"))
    log_bad = [
        ("dupcol.csv", header_edit(t, lambda c: c.__setitem__(6, "e2 [m]")), "e2"),
        ("dupcol2.csv", header_edit(t, lambda c: c.__setitem__(1, "u [V]")), "u"),
        ("ms.csv", edited(t, lambda s: _scale_time(s, 1000.0)), "ms.csv"),
        ("back.csv", frf_rows(t, lambda rows: rows.__setitem__(50, rows[10])), "back.csv"),
        ("nan.csv", frf_rows(t, set_cell(30, 7, "nan")), "nan.csv"),
        ("inf.csv", frf_rows(t, set_cell(30, 7, "-inf")), "inf.csv"),
        ("huge.csv", frf_rows(t, set_cell(30, 7, "1e999")), "huge.csv"),
        ("word.csv", frf_rows(t, set_cell(30, 7, "oops")), "word.csv"),
        ("short.csv", frf_rows(t, lambda rows: rows[30].pop()), "short.csv"),
        ("long.csv", frf_rows(t, lambda rows: rows[30].append("1")), "long.csv"),
        ("header.csv", text("t [s],u [V]\n"), "header.csv"),
        ("onerow.csv", text("t [s],u [V]\n0,1\n"), "onerow.csv"),
        ("bigline.csv", text("t,u\n0," + "1" * 200_000 + "\n0.1,2\n"), "bigline.csv"),
        ("tall.csv", text("t [s],u [V]\n" + "".join(f"{k * 1e-9:.12f},1\n" for k in range(200))), "tall.csv"),
        ("devzero.csv", sparse(1 << 20), "devzero.csv"),
        ("notime.csv", text("a,b\n" + "".join(f"{k},{k}\n" for k in range(100))), "notime.csv"),
    ]
    for name, maker, culprit in log_bad:
        for command, pattern in log_cmds:
            add(_c(command, pattern.replace("{f}", name), 1, culprit, "log file", [(name, maker)]))
    add(
        _c(
            "identify rigid",
            "sparse.csv --position x2 --input u",
            1,
            "sparse.csv",
            "budget",
            [("sparse.csv", sparse(20 << 30, b"t,x2,u\n0,1,2\n"))],
        )
    )
    add(
        _c(
            "log convert",
            "complex.mat -o c.csv",
            1,
            "complex.mat",
            "log file",
            [("complex.mat", mat_file(lambda: {"t": np.arange(100) / 1e3, "u": np.ones(100) * (1 + 1j)}))],
        )
    )
    add(
        _c(
            "log convert",
            "complex.mat -o c.csv --map v=u",
            1,
            "complex",
            "log file",
            [("complex.mat", mat_file(lambda: {"t": np.arange(100) / 1e3, "u": np.ones(100) * (1 + 1j)}))],
        )
    )
    add(
        _c(
            "log convert",
            "uneq.mat -o c.csv --map a=u --map b=x",
            1,
            "uneq.mat",
            "log file",
            [("uneq.mat", mat_file(lambda: {"t": np.arange(100) / 1e3, "u": np.ones(100), "x": np.ones(90)}))],
        )
    )
    add(
        _c(
            "log convert",
            "uneq.mat -o c.csv",
            1,
            "uneq.mat",
            "log file",
            [("uneq.mat", mat_file(lambda: {"t": np.arange(100) / 1e3, "u": np.ones(100), "x": np.ones(90)}))],
        )
    )
    add(
        _c(
            "analyze track",
            "big73.mat",
            1,
            "big73.mat",
            "budget",
            [
                (
                    "big73.mat",
                    mat73(lambda f: (_h5_double(f, "t", (1, 2_000_000_000)), _h5_double(f, "e2", (1, 2_000_000_000)))),
                )
            ],
        )
    )
    add(
        _c(
            "log convert",
            "scalar73.mat -o c.csv --map u=k",
            1,
            "scalar73.mat",
            "log file",
            [
                (
                    "scalar73.mat",
                    mat73(
                        lambda f: (
                            _h5_double(f, "t", None, np.arange(100.0)[None, :] / 1e3),
                            _h5_double(f, "k", None, [[3.0]]),
                        )
                    ),
                )
            ],
        )
    )
    add(_c("log convert", "cut.mf4 -o c.csv", 1, "cut.mf4", "log file", [("cut.mf4", mdf_cut(0.6))], slow=True))
    add(_c("analyze track", "trunc.mf4", 1, "trunc.mf4", "log file", [("trunc.mf4", mdf_cut(0.3))], slow=True))
    add(_c("log convert", f"{TRACK} -o c.csv --fs 1e12", 2, "--fs", "budget"))
    add(_c("log convert", f"{TRACK} -o c.csv --scale t=1e-300", 1, "t", "log file"))

    # ---------------------------------------------------------------- issue 27: what the file is, in the options' words
    add(_c("analyze gains", BS_MODEL, 1, "this is a model file", "wrong kind"))
    add(_c("export c", f"{G_MODEL} -o g.h", 1, "this is a model file", "wrong kind"))
    add(_c("design gantry", G_GAINS, 1, "this is a gains file", "wrong kind"))
    add(_c("identify ballscrew", "nofreq.mat", 1, "--mat-freq", "name", [("nofreq.mat", mat_file(
        lambda: {"H": np.ones(10) + 1j}))]))
    add(_c("identify ballscrew", "nochan.mat", 1, "--mat-channel", "name", [("nochan.mat", mat_file(
        lambda: {"freq_hz": np.arange(1.0, 11.0), "H": np.ones(10)}))]))
    add(_c("log convert", "log.mf4 -o c.csv --skip-rows 2", 2, "--skip-rows", "option", [("log.mf4", mdf_cut(1.0))],
           slow=True))
    add(_c("identify ballscrew", f"{FX}/bs_frf_m70.csv --band 1 5", 1, "--band", "frf file"))

    # ---------------------------------------------------------------- outputs (issue 26 (e), 4.)
    add(_c("simulate frf", "-o exists.csv", 2, "exists.csv", "output", [("exists.csv", text("keep\n"))]))
    add(
        _c("simulate frf", "-o s.csv --frf-out exists.csv", 2, "exists.csv", "output", [("exists.csv", text("keep\n"))])
    )
    add(_c("simulate frf", "-o s.csv", 2, "s_frf.csv", "output", [("s_frf.csv", text("keep\n"))]))
    add(_c("simulate frf", "-o f.csv --frf-out f.csv", 2, "f.csv", "output"))
    add(_c("simulate frf", "-o s.txt", 2, "s.txt", "output"))
    add(_c("simulate frf", "-o nodir/s.csv", 1, "nodir", "output"))
    add(_c("simulate frf", f"-o {L}.csv", 1, "ENAMETOOLONG", "output"))
    add(_c("simulate frf", "-o adir", 1, "adir", "output", [("adir", folder())]))
    add(_c("simulate frf", "-o pipe.csv --force", 1, "pipe.csv", "output", [("pipe.csv", fifo())]))
    add(_c("export c", f"{BS_GAINS} -o /dev/null --force", 1, "/dev/null", "output"))
    add(_c("export c", f"{BS_GAINS} -o /proc/version --force", 1, "/proc/version", "output"))
    add(_c("simulate frf", "-o /proc/sys/kernel/ft.csv", 1, "/proc/sys/kernel/ft.csv", "output"))
    add(
        _c(
            "simulate gantry frf",
            "-o exists.csv --period 0.1 --periods 2",
            2,
            "exists.csv",
            "output",
            [("exists.csv", text("keep\n"))],
        )
    )
    add(
        _c(
            "simulate gantry frf",
            "-o s.csv --period 0.1 --periods 2",
            2,
            "s_frf.csv",
            "output",
            [("s_frf.csv", text("keep\n"))],
        )
    )
    add(_c("design ppc", f"{BS_MODEL} -o exists.toml", 2, "exists.toml", "output", [("exists.toml", text("keep\n"))]))
    add(_c("design ppc", f"{BS_MODEL} -o g.toml", 2, "g.json", "output", [("g.json", text("keep\n"))]))
    add(_c("design ppc", f"{BS_MODEL} -o g.yaml", 2, "g.yaml", "output"))
    add(_c("design ppc", f"{BS_MODEL} -o {L}.toml", 1, "ENAMETOOLONG", "output"))
    add(_c("design gantry", f"{G_MODEL} -o exists.toml", 2, "exists.toml", "output", [("exists.toml", text("keep\n"))]))
    add(_c("design gantry", f"{G_MODEL} -o nodir/g.toml", 1, "nodir", "output"))
    add(_c("design pid", f"{G_MODEL} -o exists.toml", 2, "exists.toml", "output", [("exists.toml", text("keep\n"))]))
    add(
        _c(
            "design loopshape",
            f"{G_MODEL} --crossover-hz 100 --pm-deg 35 -o exists.toml",
            2,
            "exists.toml",
            "output",
            [("exists.toml", text("keep\n"))],
        )
    )
    add(_c("design ppi", f"{BS_MODEL} -o exists.toml", 2, "exists.toml", "output", [("exists.toml", text("keep\n"))]))
    add(
        _c(
            "tune",
            f"mcppc {BS_MODEL} --frf {BS_FRF} -o exists.toml",
            2,
            "exists.toml",
            "output",
            [("exists.toml", text("keep\n"))],
        )
    )
    add(
        _c(
            "tune",
            f"gantry {G_MODEL} --frf {G_FRF} --x 0 -o exists.toml",
            2,
            "exists.toml",
            "output",
            [("exists.toml", text("keep\n"))],
        )
    )
    add(
        _c(
            "identify ballscrew",
            f"{BS_FRF} -o exists.toml",
            2,
            "exists.toml",
            "output",
            [("exists.toml", text("keep\n"))],
        )
    )
    add(
        _c(
            "identify gantry",
            f"{G_FRF} --x 0 --span 1.484 -o exists.toml",
            2,
            "exists.toml",
            "output",
            [("exists.toml", text("keep\n"))],
        )
    )
    add(
        _c(
            "identify rigid",
            f"{REV} --position x2 --input u -o exists.toml",
            2,
            "exists.toml",
            "output",
            [("exists.toml", text("keep\n"))],
        )
    )
    add(
        _c(
            "identify friction",
            f"{REV} --position x2 --input u --model {BS_MODEL} -o exists.toml",
            2,
            "exists.toml",
            "output",
            [("exists.toml", text("keep\n"))],
        )
    )
    add(
        _c(
            "identify friction",
            f"{REV} --position x2 --input u --steady-state --curve-out exists.json",
            2,
            "exists.json",
            "output",
            [("exists.json", text("keep\n"))],
        )
    )
    add(
        _c(
            "identify mass",
            f"{TRACK} {RS} --x 0 --x 0.1 -o exists.toml",
            2,
            "exists.toml",
            "output",
            [("exists.toml", text("keep\n"))],
        )
    )
    add(
        _c(
            "prefilter",
            f"{TRACK} --gains {BS_GAINS} -o exists.toml",
            2,
            "exists.toml",
            "output",
            [("exists.toml", text("keep\n"))],
        )
    )
    add(
        _c(
            "frf",
            f"{FRFLOG} --input u --output x1 -o exists.csv",
            2,
            "exists.csv",
            "output",
            [("exists.csv", text("keep\n"))],
        )
    )
    add(_c("export c", f"{BS_GAINS} -o exists.h", 2, "exists.h", "output", [("exists.h", text("keep\n"))]))
    add(_c("export c", f"{BS_GAINS} -o pipe.h --force", 1, "pipe.h", "output", [("pipe.h", fifo())]))
    add(_c("export c", f"{BS_GAINS} -o {L}.h", 1, "ENAMETOOLONG", "output"))
    add(_c("report", f"{BS_GAINS} -o exists.html", 2, "exists.html", "output", [("exists.html", text("keep\n"))]))
    add(_c("report", f"{BS_GAINS} -o r.html --pdf", 2, "r.pdf", "output", [("r.pdf", text("keep\n"))]))
    add(_c("report", f"{BS_GAINS} -o {L}.html", 1, "ENAMETOOLONG", "output"))
    add(
        _c(
            "trajectory",
            "--distance 0.1 --v-max 0.2 --a-max 5 --j-max 500 -o exists.csv",
            2,
            "exists.csv",
            "output",
            [("exists.csv", text("keep\n"))],
        )
    )
    add(_c("log convert", f"{TRACK} -o exists.csv", 2, "exists.csv", "output", [("exists.csv", text("keep\n"))]))
    add(_c("log merge", f"{TRACK} {DAQ} -o exists.csv", 2, "exists.csv", "output", [("exists.csv", text("keep\n"))]))
    add(_c("log convert", f"{TRACK} -o pipe.csv --force", 1, "pipe.csv", "output", [("pipe.csv", fifo())]))
    add(
        _c(
            "simulate track",
            f"-g {BS_GAINS} --distance 0.05 -o exists.csv",
            2,
            "exists.csv",
            "output",
            [("exists.csv", text("keep\n"))],
        )
    )
    add(
        _c(
            "simulate ropesnap",
            f"-g {BS_GAINS} -o exists.csv",
            2,
            "exists.csv",
            "output",
            [("exists.csv", text("keep\n"))],
        )
    )
    add(_c("simulate cut", f"-g {BS_GAINS} -o exists.csv", 2, "exists.csv", "output", [("exists.csv", text("keep\n"))]))
    add(_c("simulate gantry mass", "-o exists.csv", 2, "exists.csv", "output", [("exists.csv", text("keep\n"))]))
    add(
        _c(
            "simulate gantry ropesnap",
            f"-g {G_GAINS} -o exists.csv",
            2,
            "exists.csv",
            "output",
            [("exists.csv", text("keep\n"))],
        )
    )
    add(
        _c(
            "simulate gantry track",
            f"-g {G_GAINS} -o exists.csv",
            2,
            "exists.csv",
            "output",
            [("exists.csv", text("keep\n"))],
        )
    )
    add(
        _c(
            "simulate gantry contour",
            f"-g {G_GAINS} --axis-gains {A_GAINS} -o exists.csv",
            2,
            "exists.csv",
            "output",
            [("exists.csv", text("keep\n"))],
        )
    )
    add(
        _c(
            "simulate gantry axis-frf",
            "-o exists.csv --period 0.1 --periods 2",
            2,
            "exists.csv",
            "output",
            [("exists.csv", text("keep\n"))],
        )
    )
    add(_c("demo", "--out full", 2, "full", "output", [("full", folder()), ("full/keep.txt", text("keep\n"))]))
    add(_c("demo", "--out afile", 1, "afile", "output", [("afile", text("keep\n"))]))
    add(_c("demo", "--out nodir/d", 1, "nodir", "output"))
    add(_c("demo", f"--out {L}", 1, "ENAMETOOLONG", "output"))
    add(_c("demo", "gantry --out full", 2, "full", "output", [("full", folder()), ("full/keep.txt", text("keep\n"))]))
    cases += later_command_cases()
    return cases


def later_command_cases() -> list[Case]:
    """The commands added after the corpus was first built: frf merge and info, identify resonances, log resample and
    the fleet's three."""
    cases: list[Case] = []
    add = cases.append
    # frf merge: pieces FILE:OUT/IN[,options]
    add(_c("frf merge", "-o m.csv", 2, "missing", "parser"))
    add(_c("frf merge", f"{FX}/motor_bode.csv:x1 -o m.csv", 2, "x1", "parser"))
    add(_c("frf merge", f"{FX}/nosuch.csv:x1/u {FX}/load_bode.csv:x2/u -o m.csv", 1, "nosuch.csv", "frf file"))
    add(_c("frf merge", f"{FX}/motor_bode.csv:x1/u,scale=nan {FX}/load_bode.csv:x2/u -o m.csv", 2, "scale",
           "non-finite option"))
    add(_c("frf merge", f"{FX}/motor_bode.csv:x1/u,scale=1e400 {FX}/load_bode.csv:x2/u -o m.csv", 2, "scale",
           "non-finite option"))
    add(_c("frf merge", f"{FX}/motor_bode.csv:x1/u,nosuch=1 {FX}/load_bode.csv:x2/u -o m.csv", 2, "nosuch"))
    add(_c("frf merge", f"{PIECES} -o m.xyz", 2, "m.xyz", "output"))
    add(_c("frf merge", f"{PIECES} -o m.xml", 2, "m.xml", "output"))
    add(_c("frf merge", f"{PIECES} -o exists.csv", 2, "exists.csv", "output", [("exists.csv", text("keep\n"))]))
    add(_c("frf merge", f"{PIECES} -o nodir/m.csv", 1, "nodir", "output"))
    add(_c("frf merge", f"{FX}/motor_bode.csv:x1/u {FX}/motor_bode.csv:x1/u -o m.csv", 1, "x1/u"))
    add(_c("frf merge", f"empty.csv:x1/u {FX}/load_bode.csv:x2/u -o m.csv", 1, "empty.csv", "frf file",
           [("empty.csv", text(""))]))
    add(_c("frf merge", f"bin.csv:x1/u {FX}/load_bode.csv:x2/u -o m.csv", 1, "bin.csv", "frf file",
           [("bin.csv", binary_without_nul())]))
    # frf info
    add(_c("frf info", "", 2, "missing", "parser"))
    add(_c("frf info", f"{FX}/nosuch.csv", 1, "nosuch.csv", "frf file"))
    add(_c("frf info", "f.xyz", 1, "f.xyz", "frf file", [("f.xyz", text("1,2\n"))]))
    add(_c("frf info", "empty.csv", 1, "empty.csv", "frf file", [("empty.csv", text(""))]))
    add(_c("frf info", "bin.csv", 1, "bin.csv", "frf file", [("bin.csv", binary_without_nul())]))
    add(_c("frf info", "big.csv", 1, "big.csv", "budget", [("big.csv", sparse(20 << 30))]))
    add(_c("frf info", "bad.xml", 1, "bad.xml", "frf file", [("bad.xml", text("<a><b></a>"))]))
    add(_c("frf info", "cut.xml", 1, "cut.xml", "frf file", [("cut.xml", cut("ast.xml", 0.5))]))
    add(_c("frf info", "fifo.csv", 1, "fifo.csv", "frf file", [("fifo.csv", fifo())]))
    # identify resonances: a magnitude-only PSD
    add(_c("identify resonances", "", 2, "missing", "parser"))
    add(_c("identify resonances", f"{FX}/nosuch.csv", 1, "nosuch.csv", "frf file"))
    add(_c("identify resonances", "empty.csv", 1, "empty.csv", "frf file", [("empty.csv", text(""))]))
    add(_c("identify resonances", "bin.csv", 1, "bin.csv", "frf file", [("bin.csv", binary_without_nul())]))
    add(_c("identify resonances", "big.csv", 1, "big.csv", "budget", [("big.csv", sparse(20 << 30))]))
    add(_c("identify resonances", "cut.csv", 1, "cut.csv", "frf file", [("cut.csv", cut("psd.csv", 0.002))]))
    add(_c("identify resonances", TRACK, 1, "track.csv", "wrong kind"))
    # log resample
    add(_c("log resample", "", 2, "missing", "parser"))
    add(_c("log resample", f"{REV} --fs 0 -o r.csv", 2, "--fs"))
    add(_c("log resample", f"{REV} --fs -5 -o r.csv", 2, "--fs"))
    add(_c("log resample", f"{REV} --fs 1e12 -o r.csv", 2, "--fs", "budget"))
    add(_c("log resample", f"{REV} --fs 1000 --max-gap 0 -o r.csv", 2, "--max-gap"))
    add(_c("log resample", f"{FX}/nosuch.csv --fs 1000 -o r.csv", 1, "nosuch.csv", "log file"))
    add(_c("log resample", f"{REV} --fs 1000 -o r.xyz", 2, "r.xyz", "output"))
    add(_c("log resample", f"{REV} --fs 1000 -o exists.csv", 2, "exists.csv", "output",
           [("exists.csv", text("keep\n"))]))
    add(_c("log resample", f"{REV} --fs 1000 -o nodir/r.csv", 1, "nodir", "output"))
    add(_c("log resample", "big.csv --fs 1000 -o r.csv", 1, "big.csv", "budget", [("big.csv", sparse(20 << 30))]))
    # drive parameter sets
    cg, ct = f"{FX}/c_gains.toml", f"{FX}/c.sinamics.txt"
    for command in ("export drive", "import drive"):
        add(_c(command, "", 2, "missing", "parser"))
        add(_c(command, f"robot {cg if command == 'export drive' else ct}", 2, "robot", "parser"))
    add(_c("export drive", f"sinamics {BS_GAINS} -o d.txt", 1, "bs_gains.toml", "wrong kind"))
    add(_c("export drive", f"sinamics {cg} -o d.txt", 2, "--torque-constant"))
    add(_c("export drive", f"sinamics {cg} -o d.txt --torque-constant -1", 2, "--torque-constant"))
    add(_c("export drive", f"sinamics {cg} -o d.txt --torque-constant 1 --position-fs 3000", 2, "--position-fs"))
    add(_c("export drive", f"linuxcnc-pid {cg} -o d.ini --machine-unit mm", 2, "--machine-unit"))
    add(_c("export drive", f"sinamics {cg} -o exists.txt --torque-constant 1", 2, "exists.txt", "output",
           [("exists.txt", text("keep\n"))]))
    add(_c("export drive", f"sinamics {FX}/nosuch.toml -o d.txt", 1, "nosuch.toml", "name"))
    add(_c("import drive", f"sinamics {FX}/nosuch.txt -o b.toml", 1, "nosuch.txt", "name"))
    add(_c("import drive", "p.txt -o b.toml", 2, "missing", "parser"))
    add(_c("import drive", "sinamics p.txt -o b.toml", 1, "p.txt", "schema", [("p.txt", text("p1460[0] 0.5\n"))]))
    add(_c("import drive", "sinamics p.txt -o b.toml", 1, "p1462", "schema",
           [("p.txt", text("; requires: speed controller cycle = 125 us\n; requires: position control cycle = 1000 us\n"
                           "p1460[0] = 0.5\n"))]))
    add(_c("import drive", "sinamics p.txt -o b.toml", 1, "p1460", "non-finite",
           [("p.txt", text("; requires: speed controller cycle = 125 us\n; requires: position control cycle = 1000 us\n"
                           "p1460[0] = nan\np1462[0] = 10\n"))]))
    add(_c("import drive", "odrive o.json -o b.toml", 1, "o.json", "schema", [("o.json", text("{\"axis0\": \n"))]))
    add(_c("import drive", "linuxcnc-pid p.ini -o b.toml", 1, "--command-unit", "schema",
           [("p.ini", text("[JOINT_0]\nP = 1\nD = 0.1\n"))]))
    add(_c("import drive", "linuxcnc-pid p.ini -o b.toml --command-unit A --machine-unit mm", 1, "no two real roots",
           "schema", [("p.ini", text("[JOINT_0]\nP = 1\nI = 100\nD = 0.1\n"))]))
    add(_c("import drive", "ax8000 a.xml -o b.toml", 1, "a.xml", "schema",
           [("a.xml", text('<!DOCTYPE x [<!ENTITY a "b">]><InitCmds/>'))]))
    add(_c("import drive", "ax8000 a.xml -o b.toml", 1, "0x3140:01", "schema",
           [("a.xml", text("<InitCmds><InitCmd><Index>#x3140</Index><SubIndex>1</SubIndex><Data>00</Data>"
                           "</InitCmd></InitCmds>"))]))
    add(_c("import drive", "ax8000 a.xml -o b.toml", 1, "a.xml", "schema", [("a.xml", text("<InitCmds>"))]))
    add(_c("export drive", f"yaskawa {cg} -o y.txt --torque-constant 1", 2, "--inertia"))
    add(_c("export drive", f"yaskawa {cg} -o y.txt --torque-constant 1 --inertia 0", 2, "--inertia"))
    add(_c("import drive", "yaskawa y.txt -o b.toml", 1, "--inertia", "schema",
           [("y.txt", text("Pn100 = 40\nPn101 = 2000\nPn102 = 40\n"))]))
    add(_c("import drive", "yaskawa y.txt -o b.toml --inertia 1e-4 --fs 8000 --position-fs 1000", 1, "Pn101",
           "schema", [("y.txt", text("Pn100 = 40\nPn101 = 2.5\nPn102 = 40\n"))]))
    add(_c("import drive", f"sinamics {ct} -o exists.toml", 2, "exists.toml", "output",
           [("exists.toml", text("keep\n"))]))
    # the fleet
    add(_c("fleet simulate", "", 2, "missing", "parser"))
    add(_c("fleet simulate", "fl --axes 0", 2, "--axes"))
    add(_c("fleet simulate", "fl --axes -2", 2, "--axes"))
    add(_c("fleet simulate", "fl --weeks 0", 2, "--weeks"))
    add(_c("fleet simulate", "fl --drift-share 2", 2, "--drift-share"))
    add(_c("fleet simulate", "fl --drift-share nan", 2, "--drift-share", "non-finite option"))
    add(_c("fleet simulate", "fl --axes 10000000 --weeks 1000000", 2, "axes", "budget"))
    add(_c("fleet simulate", "afile", 1, "afile", "output", [("afile", text("keep\n"))]))
    add(_c("fleet simulate", "full --axes 2 --weeks 2", 2, "full", "output",
           [("full", folder()), ("full/fleet.toml", text("keep\n"))]))
    add(_c("fleet run", "--history h.parquet", 2, "missing", "parser"))
    add(_c("fleet run", f"{FX}/nosuch.toml --history h.parquet", 1, "nosuch.toml", "name"))
    add(_c("fleet run", "m.toml --history h.parquet", 1, "m.toml", "nesting", [("m.toml", nested_toml_tables(5000))]))
    add(_c("fleet run", "m.toml --history h.parquet", 1, "m.toml", "parser", [("m.toml", text("schema = \n"))]))
    add(_c("fleet run", f"{BS_MODEL} --history h.parquet", 1, "bs_model.toml", "wrong kind"))
    add(_c("fleet run", "m.xyz --history h.parquet", 1, "m.xyz", "wrong kind", [("m.xyz", text("a\n"))]))
    add(_c("fleet run", f"{MANIFEST} --history h.parquet --jobs 0", 2, "--jobs"))
    add(_c("fleet run", f"{MANIFEST} --history h.parquet --horizon -1", 2, "--horizon"))
    add(_c("fleet run", f"{MANIFEST} --history afile", 1, "afile", "output", [("afile", text("keep\n"))]))
    add(_c("fleet report", f"{FX}/nosuch.toml --history h.parquet -o f.html", 1, "nosuch.toml", "name"))
    add(_c("fleet report", f"{MANIFEST} --history nohist -o f.html", 1, "nohist", "name"))
    add(_c("fleet report", f"{MANIFEST} --history h.parquet -o exists.html", 2, "exists.html", "output",
           [("exists.html", text("keep\n"))]))
    add(_c("fleet report", f"{MANIFEST} --history h.parquet -o f.xyz", 2, "f.xyz", "output"))
    add(_c("fleet report", "m.toml --history h.parquet -o f.html", 1, "m.toml", "nesting",
           [("m.toml", nested_toml_tables(5000))]))
    cases += project_cases()
    return cases


def project_cases() -> list[Case]:
    """The project file (feedtune.toml): ``project init``, and ``tune``/``analyze``/``report`` given one with
    ``--project`` (a bad project file is a data error naming the file and the key; a bad ``--project`` usage)."""
    cases: list[Case] = []
    add = cases.append
    head = 'schema = "feedtune.project/1"\n'
    add(_c("project init", f"--model {FX}/nosuch.toml", 2, "nosuch.toml", "name"))
    add(_c("project init", f"--model {BS_MODEL} --set tune.lfp=1", 2, "tune.lfp", "name"))
    add(_c("project init", "--set bogus", 2, "--set"))
    add(_c("project init", "--set tune.force=true", 2, "tune.force"))
    add(_c("project init", f"--model {BS_MODEL} --limits nosuch", 2, "--limits", "parser"))
    add(_c("project init", f"--model {BS_MODEL} -o p.txt", 2, "p.txt", "output"))
    add(_c("project init", f"--model {BS_MODEL} -o exists.toml", 2, "exists.toml", "output",
           [("exists.toml", text("keep\n"))]))
    add(_c("project init", f"--model {BS_MODEL} -o nodir/p.toml", 1, "nodir", "output"))
    add(_c("tune", "--project nosuch.toml", 2, "nosuch.toml", "name"))
    add(_c("tune", "--project", 2, "--project", "parser"))
    add(_c("tune", "--project p.toml", 1, "tune.lfp", "schema", [("p.toml", text(head + "[tune]\nlfp = 1\n"))]))
    add(_c("tune", "--project p.toml", 1, "tune.lpf", "schema",
           [("p.toml", text(head + "[tune]\nlpf = [1, 2]\n"))]))
    add(_c("tune", "--project p.toml", 1, "structure", "schema", [("p.toml", text(head))]))
    add(_c("analyze gains", "--project p.toml", 1, "axis.frf", "schema",
           [("p.toml", text(head + '[axis]\nfrf = "a.csv"\n'))]))
    add(_c("analyze gains", "--project p.toml", 1, "axis.frf[0]", "name",
           [("p.toml", text(head + '[axis]\nfrf = ["nosuch.csv"]\n'))]))
    add(_c("report", "--project p.toml", 1, "p.toml", "parser", [("p.toml", text(head + "[report\n"))]))
    add(_c("report", "--project p.toml", 1, "p.toml", "wrong kind",
           [("p.toml", text('schema = "feedtune.model/1"\n'))]))
    add(_c("report", "--project p.toml", 1, "p.toml", "nesting", [("p.toml", nested_toml_tables(5000))]))
    add(_c("report", "--project p.toml", 1, "limits.ms_max", "big number",
           [("p.toml", text(head + "[limits]\nms_max = 1e400\n"))]))
    add(_c("analyze track", f"{FX}/x.csv --project p.toml", 2, "--project"))
    return cases


def _scale_time(s: str, factor: float) -> str:
    """A log's text with its time column multiplied by ``factor`` (a time in ms under a header that says s)."""
    out = []
    for line in s.splitlines():
        if line and (line[0].isdigit() or line[0] == "-"):
            first, _, rest = line.partition(",")
            line = f"{float(first) * factor!r},{rest}"
        out.append(line)
    return "\n".join(out) + "\n"


def all_cases() -> list[Case]:
    """The whole corpus: the hand-written cases, then the generated option cases."""
    return hand_cases() + option_cases()


# ------------------------------------------------------------------------------------------ running
def _listing(folder: Path) -> dict[str, tuple[int, int]]:
    out = {}
    for p in sorted(folder.rglob("*")):
        try:
            st = p.lstat()
        except OSError:
            continue
        out[str(p.relative_to(folder))] = (st.st_size, st.st_mtime_ns)
    return out


class _Stop(BaseException):
    """The time limit of a case."""


def run_case(case: Case, fx: Path, folder: Path, time_limit: float = TIME_LIMIT_S) -> Outcome:
    """Run ``case`` in ``folder`` (created empty, its input files written first) through the command line's
    :func:`~feedtune.cli.main.main` in this process."""
    from feedtune.cli.main import main

    if folder.exists():
        shutil.rmtree(folder)
    folder.mkdir(parents=True)
    for name, make in case.files:
        path = folder / name
        path.parent.mkdir(parents=True, exist_ok=True)
        make(fx, path)
    before = _listing(folder)
    argv, cwd = sys.argv, os.getcwd()
    out, err = io.StringIO(), io.StringIO()
    code, escaped, hung = None, None, False

    def stop(*_):
        raise _Stop()

    previous = signal.signal(signal.SIGALRM, stop) if hasattr(signal, "SIGALRM") else None
    try:
        os.chdir(folder)
        sys.argv = ["feedtune", *case.argv(fx)]
        if previous is not None:
            signal.setitimer(signal.ITIMER_REAL, time_limit)
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                main()
                code = 0
            except SystemExit as exc:
                code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
            except _Stop:
                hung = True
            except BaseException as exc:  # what escaped is the finding
                escaped = "".join(traceback.format_exception_only(type(exc), exc)).strip()
    finally:
        if previous is not None:
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, previous)
        os.chdir(cwd)
        sys.argv = argv
    after = _listing(folder)
    left = sorted(k for k, v in after.items() if before.get(k) != v)
    return Outcome(code, out.getvalue(), err.getvalue(), escaped, left, hung)


def classify(case: Case, outcome: Outcome) -> str:
    """The class of an outcome (see the module docstring)."""
    lines = outcome.err.strip().splitlines()
    if outcome.hung:
        return "hang"
    if outcome.escaped is not None or "Traceback (most recent call last)" in outcome.err:
        return "traceback"
    if any("internal error" in line for line in lines):
        return "internal error"
    if outcome.code == 0:
        return "accepted bad"
    if outcome.code != case.code:
        return "wrong code"
    errors = [line for line in lines if line.startswith("feedtune: error: ")]
    others = [
        line for line in lines if not line.startswith(("feedtune: error: ", "feedtune: warning: ", "feedtune: note: "))
    ]
    if len(errors) != 1 or others or case.culprit.lower() not in errors[0].lower():
        return "unclear"
    if outcome.left:
        return "wrote"
    return "clean"


def describe(case: Case, outcome: Outcome) -> str:
    """One paragraph for a failure message."""
    return (
        f"feedtune {' '.join(case.argv(Path('FX')))}\n  expected exit {case.code} naming {case.culprit!r}; got "
        f"exit {outcome.code}, stderr: {outcome.err.strip()[:600]!r}"
        + (f", escaped: {outcome.escaped[:300]}" if outcome.escaped else "")
        + (f", left: {outcome.left}" if outcome.left else "")
    )
