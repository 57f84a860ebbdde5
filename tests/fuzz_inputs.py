"""Mutated input files for the reader fuzz tests (tests/test_fuzz_readers.py, a few hundred examples each) and the
longer run of benchmarks/fuzz_readers.py (thousands each).

Every reader and document loader gets byte-level mutations of a valid file of its format (bit flips, truncation,
deleted, repeated and inserted spans, a cell replaced by a special token) and must either read it or raise one of
feedtune's own errors (:class:`~feedtune.errors.FeedtuneError`): any other exception is a crash of our code.
"""

from __future__ import annotations

import json
import random
from collections.abc import Callable
from pathlib import Path

TOKENS = [b"nan", b"inf", b"-inf", b"1e999", b"-1", b"0", b"", b"\x00", b"\xff\xfe", b"\r", b"\r\n", b",,,,", b";",
          b'"', b"#", b"[", b"{", b"}", b"]", b"=", b"9" * 400, b"x" * 1000, "\u00e9".encode(), b"true",
          b"[[1, 2]]",
          # what the hostile run found: nesting bombs, integers beyond the float range, dotted-key depth
          b"[" * 5000 + b"]" * 5000, b'{"a": ' * 3000 + b"1" + b"}" * 3000, b"{a = " * 3000 + b"1" + b"}" * 3000,
          b"9" * 5001, b"-" + b"9" * 320, b"." .join([b"a"] * 500), b"1e308", b"1.8e308", b"4.9e-324"]


def mutate(data: bytes, rng: random.Random) -> bytes:
    """One to three random mutations of ``data``."""
    out = bytearray(data)
    for _ in range(rng.randint(1, 3)):
        if not out:
            out += rng.choice(TOKENS)
            continue
        kind = rng.randrange(6)
        i = rng.randrange(len(out))
        if kind == 0:  # bit flips
            for _ in range(rng.randint(1, 8)):
                j = rng.randrange(len(out))
                out[j] ^= 1 << rng.randrange(8)
        elif kind == 1:  # truncation
            del out[i:]
        elif kind == 2:  # a deleted span
            del out[i:i + rng.randint(1, 200)]
        elif kind == 3:  # a repeated span
            j = min(len(out), i + rng.randint(1, 200))
            out[j:j] = out[i:j] * rng.randint(1, 3)
        elif kind == 4:  # a token inserted
            out[i:i] = rng.choice(TOKENS)
        else:  # a token replacing a short span
            out[i:i + rng.randint(1, 12)] = rng.choice(TOKENS)
    return bytes(out)


def _gains_doc(path: Path):
    from feedtune.io import read_document
    from feedtune.machines import load_runtime

    return load_runtime(read_document(path), str(path))


def _analysis(path: Path):
    from feedtune.io import read_document
    from feedtune.machines import analyze_gains

    return analyze_gains(read_document(path), str(path))


def readers(examples: Path, tmp: Path) -> dict[str, tuple[str, bytes, Callable[[Path], object]]]:
    """``{name: (suffix, valid bytes, read)}`` for every reader and loader, the valid files written into ``tmp``."""
    from feedtune.control.filters import FilterPack, Notch
    from feedtune.design.mcppc import design_mcppc
    from feedtune.io import read_frf, read_log, save_model, write_document, write_frf
    from feedtune.io.gains import gains_document
    from feedtune.io.mass_file import read_mass_document
    from feedtune.io.model_file import load_model
    from feedtune.models import THESIS_TABLE_3_1
    from feedtune.models.gantry import THESIS_GANTRY

    frf = read_frf(examples / "ballscrew_frf.csv").select(1.0, 300.0)
    write_frf(frf, tmp / "f.csv", force=True)
    write_frf(frf, tmp / "f.uff", force=True)
    write_frf(frf, tmp / "f.mat", force=True)
    save_model(tmp / "bs.toml", THESIS_TABLE_3_1, force=True)
    save_model(tmp / "g.json", THESIS_GANTRY, force=True)
    write_document(tmp / "gains.toml", gains_document(design_mcppc(THESIS_TABLE_3_1, filters=FilterPack(
        [Notch(420.0, 0.55, 0.7)], 2000.0))), force=True)
    log = "t,u,x1,x2\n" + "".join(f"{k / 1000:.3f},{(k % 7) / 7:.4f},{k * 1e-4:.6f},{k * 1.1e-4:.6f}\n"
                                  for k in range(300))
    (tmp / "log.csv").write_text("# unit: u = V\n# unit: x1 = rad\n# unit: x2 = rad\n" + log)
    import numpy as np
    import scipy.io

    t = np.arange(300) / 1000.0
    scipy.io.savemat(tmp / "log.mat", {"t": t[:, None], "u": np.sin(40 * t)[:, None], "x1": (1e-3 * t)[:, None]})
    formats_extra = {"log mat": (".mat", (tmp / "log.mat").read_bytes(), read_log)}
    try:
        import asammdf

        mdf = asammdf.MDF()
        mdf.append([asammdf.Signal(np.sin(40 * t), t, name="u", unit="V"),
                    asammdf.Signal(1e-3 * t, t, name="x1", unit="rad")])
        mdf.save(tmp / "log.mf4", overwrite=True)
        formats_extra["log mdf"] = (".mf4", (tmp / "log.mf4").read_bytes(), read_log)
    except ImportError:  # the optional extra
        pass
    mass = {"schema": "feedtune.mass/1", "kind": "gantry_mass", "input_unit": "V",
            "m": {"value": 2.7, "unit": "V/(m/s^2)"}, "alpha1_0": {"value": 0.5, "unit": "-"},
            "dalpha1_dx": {"value": -0.17, "unit": "1/m"}, "m_x": {"value": 0.7, "unit": "V/(m/s^2)"}}
    (tmp / "mass.json").write_text(json.dumps(mass))
    return {
        "frf csv": (".csv", (tmp / "f.csv").read_bytes(), read_frf),
        "frf uff": (".uff", (tmp / "f.uff").read_bytes(), read_frf),
        "frf mat": (".mat", (tmp / "f.mat").read_bytes(), read_frf),
        "log csv": (".csv", (tmp / "log.csv").read_bytes(), read_log),
        "model toml": (".toml", (tmp / "bs.toml").read_bytes(), load_model),
        "model json": (".json", (tmp / "g.json").read_bytes(), load_model),
        "gains runtime": (".toml", (tmp / "gains.toml").read_bytes(), _gains_doc),
        "gains analysis": (".toml", (tmp / "gains.toml").read_bytes(), _analysis),
        "mass": (".json", (tmp / "mass.json").read_bytes(), lambda p: read_mass_document(p)),
        **formats_extra,
    }


def run_one(read: Callable[[Path], object], path: Path) -> str | None:
    """Read ``path``; None when it is read or refused with feedtune's own error, else the crash signature."""
    import warnings

    from feedtune.errors import FeedtuneError

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            read(path)
    except FeedtuneError:
        return None
    except Exception as exc:  # a crash of our code
        return f"{type(exc).__name__}: {str(exc)[:120]}"
    return None
