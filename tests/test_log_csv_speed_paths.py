"""The fast paths of the CSV log writer and reader (issue 11), checked against independent references: the compiled
float formatter against Python's ``repr`` and ``float`` (CPython's own dtoa), the chunked and threaded writers
against rows joined from ``repr``, the reader that parses straight from the file against ``numpy.loadtxt`` and
against :func:`parse_table` on the whole text (same table, same error message)."""

from __future__ import annotations

import random

import numpy as np
import pytest

import feedtune.io._table as table_mod
import feedtune.io.csv_text as text_mod
from feedtune.errors import DataError
from feedtune.io import read_log, write_log_csv
from feedtune.io._table import parse_table, read_table_data, read_table_file
from feedtune.io.csv_text import csv_row_chunks, csv_rows, format_float_rows
from feedtune.io.log_csv import log_to_csv_text
from feedtune.log import Log


def _repr_cell(x: float) -> str:
    return "" if x != x else repr(x)


def _reference_rows(columns) -> str:
    """Rows built one number at a time with ``repr`` (NaN as an empty field)."""
    rows = zip(*(c.tolist() for c in columns), strict=True)
    return "".join(",".join(_repr_cell(x) for x in row) + "\n" for row in rows)


def _special_values() -> np.ndarray:
    pow2 = np.ldexp(1.0, np.arange(-1074, 1024))
    pow10 = np.array([float(f"{m}e{e}") for e in range(-323, 309) for m in (1, 2, 5, 9, 123, 4999)])
    edges = np.array([0.0, -0.0, 1e-300, -1e300, 1e300, 5e-324, -5e-324, 2.2250738585072014e-308,
                      2.225073858507201e-308, 1.7976931348623157e308, 1e16, 9999999999999998.0, 1e15, 1e-4, 1e-5,
                      0.00011, 9.999999999999999e-5, 123456789012345678.0, 0.1, 0.2, 0.3, 1 / 3, 2.0 ** 53,
                      2.0 ** 53 + 2, 2.0 ** 63, 12345.0, -7.0, np.inf, -np.inf, np.nan])
    base = np.concatenate([pow2, pow10, edges])
    with np.errstate(over="ignore"):
        return np.concatenate([base, np.nextafter(base, np.inf), np.nextafter(base, -np.inf), -base])


def _random_doubles(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    bits = rng.integers(0, 2 ** 64, n, dtype=np.uint64, endpoint=False).view(np.float64)  # every class of double
    subnormal = rng.integers(1, 2 ** 52, n // 4, dtype=np.uint64).view(np.float64)
    integers = rng.integers(-2 ** 60, 2 ** 60, n // 4).astype(float)
    scaled = rng.normal(size=n) * 10.0 ** rng.integers(-30, 30, n)
    decimals = np.round(rng.normal(size=n // 4) * 1e6) / 1e3
    return np.concatenate([bits, subnormal, integers, scaled, decimals, np.arange(n // 4) / 20000.0])


@pytest.mark.parametrize("seed", [0, 1])
def test_compiled_formatter_writes_the_repr_of_every_double(seed):
    x = np.concatenate([_special_values(), _random_doubles(100_000, seed)])
    lines = format_float_rows(x.reshape(-1, 1)).decode("ascii").split("\n")
    assert lines[-1] == "" and len(lines) == x.size + 1
    ref = [_repr_cell(v) for v in x.tolist()]
    bad = [(got, want) for got, want in zip(lines[:-1], ref, strict=True) if got != want]
    assert not bad, bad[:10]
    finite = np.isfinite(x)
    back = np.array([float(s) for s, f in zip(lines[:-1], finite, strict=True) if f])
    assert np.array_equal(back.view(np.uint64), x[finite].view(np.uint64))  # bit-exact, -0.0 included


def test_compiled_formatter_rows_and_columns():
    block = np.array([[0.0, -0.0, np.nan], [1e-300, 1e300, 3.0], [np.nan, np.nan, np.nan]])
    assert format_float_rows(block) == b"0.0,-0.0,\n1e-300,1e+300,3.0\n,,\n"
    assert format_float_rows(np.empty((0, 3))) == b""


@pytest.mark.parametrize("threshold", [0, 10 ** 12])
def test_row_chunks_compiled_and_percent_paths_match_repr(monkeypatch, threshold):
    """Both writer paths, over several chunks (formatted on two threads in the compiled path), against rows joined
    from ``repr``; the numbers read back with numpy.loadtxt are the same doubles."""
    monkeypatch.setattr(text_mod, "COMPILED_MIN_CELLS", threshold)
    rng = np.random.default_rng(3)
    n = 2500
    cols = [np.arange(n) / 20000.0, rng.normal(size=n) * 1e-7, _random_doubles(n, 4)[:n],
            np.where(rng.random(n) < 0.01, -0.0, rng.integers(-5, 5, n).astype(float))]
    chunks = list(csv_row_chunks(cols, chunk_rows=300))
    assert len(chunks) == 9
    text = b"".join(chunks).decode("utf-8")
    assert text == _reference_rows(cols)
    assert csv_rows(cols) == text
    finite = [c for c in cols if np.isfinite(c).all()]
    text_finite = csv_rows(finite)
    back = np.loadtxt(text_finite.splitlines(), delimiter=",", ndmin=2)
    assert np.array_equal(back.view(np.uint64), np.column_stack(finite).view(np.uint64))


def test_row_chunks_take_other_dtypes_the_percent_way(monkeypatch):
    monkeypatch.setattr(text_mod, "COMPILED_MIN_CELLS", 0)
    cols = [np.arange(3), np.array([0.5, np.nan, 2.0], dtype=np.float32), np.array([1.5, 2.5, -0.0])]
    assert csv_rows(cols) == "0,0.5,1.5\n1,,2.5\n2,2.0,-0.0\n"
    with pytest.raises(ValueError, match="different lengths"):
        csv_rows([np.arange(3.0), np.arange(4.0)])


def _log(n: int, seed: int = 0) -> Log:
    rng = np.random.default_rng(seed)
    t = np.arange(n) / 20000.0
    wild = _random_doubles(3 * n, seed + 1)
    sig = {"x1": np.cumsum(rng.normal(size=n)) * 1e-5, "u": rng.normal(size=n) * 3.0,
           "e": rng.permutation(wild[np.isfinite(wild)])[:n],
           "z": np.where(rng.random(n) < 0.05, -0.0, rng.normal(size=n) * 1e-300)}
    return Log(t, sig, {"x1": "rad", "u": "V", "e": "m"}, {"source": "twin run 3", "axis": "x"})


def test_written_file_is_the_text_and_reads_back_to_the_bit(tmp_path, monkeypatch):
    monkeypatch.setattr(text_mod, "CSV_CHUNK_ROWS", 700)
    monkeypatch.setattr(text_mod, "COMPILED_MIN_CELLS", 0)
    log = _log(5000)
    path = tmp_path / "run.csv"
    write_log_csv(log, path)
    raw = path.read_bytes()
    header = "# feedtune log\n# source: twin run 3\n# axis: x\nt [s],x1 [rad],u [V],e [m],z\n"
    assert raw.decode("utf-8") == header + _reference_rows([log.t, *log.signals.values()])
    assert raw.decode("utf-8") == log_to_csv_text(log)
    ref = np.loadtxt(path, delimiter=",", comments="#", skiprows=4)
    back = read_log(path)
    assert np.array_equal(back.t.view(np.uint64), ref[:, 0].view(np.uint64))
    assert np.array_equal(back.t.view(np.uint64), log.t.view(np.uint64))
    for j, (k, v) in enumerate(log.signals.items(), start=1):
        assert np.array_equal(back.signals[k].view(np.uint64), v.view(np.uint64)), k
        assert np.array_equal(ref[:, j].view(np.uint64), v.view(np.uint64)), k


# ---------------------------------------------------------------------------------------------------------- reader
def _same_outcome(path, **kwargs):
    """read_table_file and parse_table on the whole text: the same table or the same DataError."""
    def outcome(fn):
        try:
            return fn()
        except DataError as exc:
            return str(exc)

    fast = outcome(lambda: read_table_file(path, "CSV", **kwargs))
    slow = outcome(lambda: parse_table(*read_table_data(path, "CSV"), **kwargs))
    if isinstance(slow, str) or isinstance(fast, str):
        assert fast == slow
        return fast
    assert fast.name == slow.name and fast.columns == slow.columns and fast.metadata == slow.metadata
    assert fast.comments == slow.comments and fast.has_header == slow.has_header
    assert fast.first_data_index == slow.first_data_index
    assert fast.data.shape == slow.data.shape and fast.data.flags.f_contiguous
    assert np.array_equal(fast.data.view(np.uint64), slow.data.view(np.uint64))
    return fast


def _rows(n: int, k: int = 3, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.column_stack([np.arange(n) / 1000.0] + [rng.normal(size=n) * 10.0 ** rng.integers(-8, 8, n)
                                                       for _ in range(k - 1)])


def _body(values: np.ndarray, sep: str = ",") -> str:
    return "".join(sep.join(repr(x) for x in row) + "\n" for row in values.tolist())


@pytest.fixture(params=[False, True], ids=["one part", "two parts"])
def parts(request, monkeypatch):
    """The reader with one part, and with any body over 1 kB parsed in two parts on two threads."""
    monkeypatch.setattr(table_mod, "READ_PARTS_MIN_BYTES", 1000 if request.param else 1 << 60)
    monkeypatch.setattr(table_mod, "_idle_cores", lambda: 2.0)  # a loaded machine would take one part
    return request.param


def test_reader_parses_the_numbers_from_the_file(tmp_path, parts):
    values = _rows(4000)
    text = ("# feedtune log\n# source: bench\n# note\n\nt [s],x [mm],y\n" + _body(values[:1300])
            + "# a comment line\n\n" + _body(values[1300:2900]) + "\n" + _body(values[2900:]))
    path = tmp_path / "a.csv"
    path.write_text(text)
    table = _same_outcome(path, require_header=False)
    assert table.text == b"" and table.path == str(path)  # the fast path: the file was not read whole
    assert np.array_equal(table.data.view(np.uint64), values.view(np.uint64))
    ref = np.loadtxt(path, delimiter=",", comments="#", skiprows=5)
    assert np.array_equal(table.data.view(np.uint64), ref.view(np.uint64))
    assert table.columns == ["t [s]", "x [mm]", "y"] and table.metadata == {"source": ["bench"]}
    vectors = [table.column_vector(j) for j in range(3)]
    for j, v in enumerate(vectors):  # one writable vector per column, not views of each other
        assert v.dtype == np.float64 and v.flags.c_contiguous and v.flags.writeable
        assert np.array_equal(v, values[:, j])
        assert not any(np.shares_memory(v, w) for w in vectors[j + 1:])
    assert table.line_number(2500) == 2500 + 8  # header on line 5, two lines before row 1300
    log = read_log(path)
    assert np.array_equal(log.signals["x"], values[:, 1]) and log.units["x"] == "mm"


@pytest.mark.parametrize(
    ("name", "make"),
    [
        ("bom crlf", lambda body: b"\xef\xbb\xbf" + ("t [s],x,y\n" + body).replace("\n", "\r\n").encode()),
        ("latin-1 unit", lambda body: ("t [s],x [\xb5m],y\n" + body).encode("latin-1")),
        ("late latin-1", lambda body: ("t [s],x,y\n" + body + "# \xb5m\n").encode("latin-1")),
        ("no header", lambda body: body.encode()),
        ("semicolons", lambda body: ("t;x;y\n" + body.replace(",", ";")).encode()),
        ("decimal commas", lambda body: ("t;x;y\n" + body.replace(",", ";").replace(".", ",")).encode()),
        ("tabs and trailing comments", lambda body: ("t\tx\ty\n" + body.replace(",", "\t").replace(
            "\n", " # c\n", 100)).encode()),
        ("old mac", lambda body: ("t,x,y\n" + body).replace("\n", "\r").encode()),
        ("long preamble", lambda body: ("".join(f"# line {i}\n" for i in range(9000)) + "t,x,y\n" + body).encode()),
        ("ints", lambda body: ("t,x,y\n" + "".join(f"{i},{-i},{i * 7}\n" for i in range(8000))).encode()),
    ],
)
def test_reader_layouts_give_the_whole_text_result(tmp_path, parts, name, make):
    values = _rows(3000)
    path = tmp_path / "b.csv"
    path.write_bytes(make(_body(values)))
    table = _same_outcome(path, require_header=False)
    if name == "ints":
        assert np.array_equal(table.data[:, 2], np.arange(8000) * 7.0)
    else:
        assert np.array_equal(table.data.view(np.uint64), values.view(np.uint64)), name


def test_reader_with_skip_rows(tmp_path, parts):
    values = _rows(3000)
    path = tmp_path / "vendor.csv"
    path.write_text("Vendor DAQ export\nrate: 1000 Hz\n\nt,x,y\n" + _body(values))
    table = _same_outcome(path, skip_rows=3)
    assert np.array_equal(table.data, values)
    _same_outcome(path, skip_rows=0)  # the preamble read as a header: refused the same way
    _same_outcome(path, skip_rows=-1)


@pytest.mark.parametrize(
    ("cell", "fragment"),
    [("abc", "'abc' is not a number"), ("nan", "empty or NaN cell"), ("", "empty or NaN cell"),
     ("NA", "empty or NaN cell"), ("null", "empty or NaN cell"), ("-nan", "empty or NaN cell"),
     ("#N/A", "empty or NaN cell"), ("inf", "infinite value"), ("-Infinity", "infinite value"),
     ("1.5,7", "4 fields, but the header has 3 columns"), ("1e999", "infinite value")],
)
def test_reader_errors_name_the_line(tmp_path, parts, cell, fragment):
    values = _rows(3000)
    lines = _body(values).splitlines(keepends=True)
    lines[2790] = f"2.79,{cell},3.0\n"
    path = tmp_path / "bad.csv"
    path.write_text("t,x,y\n" + "".join(lines))
    message = _same_outcome(path)
    assert isinstance(message, str) and fragment in message, message
    if "fields" not in fragment:
        assert "line 2792" in message


def test_reader_two_parts_do_not_accept_a_row_the_whole_file_refuses(tmp_path, monkeypatch):
    """pandas takes a wider first row of a stream (drops its extra field): a second part never starts on one."""
    monkeypatch.setattr(table_mod, "READ_PARTS_MIN_BYTES", 1000)
    monkeypatch.setattr(table_mod, "_idle_cores", lambda: 2.0)
    values = _rows(3000)
    body = _body(values).splitlines(keepends=True)
    wide = body[:1500] + [line.replace("\n", ",7\n") for line in body[1500:]]
    path = tmp_path / "wide.csv"
    path.write_text("t,x,y\n" + "".join(wide))
    message = _same_outcome(path)
    assert isinstance(message, str) and "4 fields, but the header has 3 columns" in message
    trailing = body[:1500] + [line.replace("\n", ",\n") for line in body[1500:]]
    path.write_text("t,x,y\n" + "".join(trailing))
    _same_outcome(path)


@pytest.mark.parametrize("seed", range(3))
def test_reader_mutated_files_match_the_whole_text_parser(tmp_path, parts, seed):
    """Random byte-level damage to a 200 kB log: the fast reader gives what parse_table gives (table or message)."""
    rnd = random.Random(seed)
    base = ("# feedtune log\n# source: x\nt [s],x [mm],y [V]\n" + _body(_rows(3000, seed=seed))).encode()
    harmless = [b"5", b"0", b"-", b"\n", b"\r\n", b"#", b" ", b"\n\n", b"# c\n", b"e"]
    harmful = [b",", b";", b'"', b"\r", b"nan", b"\xb5", b"\xc3", b"1e999", b"x", b"\t", b"."]
    tables = 0
    for case in range(60):
        data = bytearray(base)
        for _ in range(rnd.randint(1, 4)):
            at = rnd.randrange(len(data))
            if case % 2:  # at a line start: comments, blank lines, line ends kept readable
                at = data.index(b"\n", at) + 1 if b"\n" in data[at:] else len(data)
            op = rnd.random()
            if op < 0.5:
                data[at:at] = rnd.choice(harmless)
            elif op < 0.7:
                data[at:at] = rnd.choice(harmful)
            elif op < 0.85:
                del data[at:at + rnd.randint(1, 3)]
            else:
                data[at] = rnd.randrange(32, 127)
        path = tmp_path / f"m{case}.csv"
        path.write_bytes(bytes(data))
        tables += not isinstance(_same_outcome(path, require_header=False), str)
    assert tables >= 5  # some damage leaves a readable table: compared number by number


def test_column_vectors_are_stacked_on_demand(tmp_path):
    path = tmp_path / "ints.csv"
    path.write_text("t,n,x\n" + "".join(f"{i / 100!r},{i},{i * 0.5!r}\n" for i in range(9000)))
    table = read_table_file(path)
    assert isinstance(table.numbers, tuple)
    n = table.column_vector(1)  # an integer column: converted to float
    assert n.dtype == np.float64 and np.array_equal(n, np.arange(9000.0))
    data = table.data
    assert data.shape == (9000, 3) and data.flags.f_contiguous and not isinstance(table.numbers, tuple)
    assert np.array_equal(data[:, 2], np.arange(9000) * 0.5) and np.array_equal(table.column("n"), n)


def test_a_read_only_column_becomes_the_tables_own():
    array = np.arange(5.0)
    lent = array[:]
    lent.flags.writeable = False  # how pandas hands out its own array
    owned = table_mod._own_float_vector(lent)
    assert owned.flags.writeable and np.shares_memory(owned, array)  # no copy
    frozen = np.arange(5.0)
    frozen.flags.writeable = False
    copied = table_mod._own_float_vector(frozen[:])
    assert copied.flags.writeable and not np.shares_memory(copied, frozen)
    ints = table_mod._own_float_vector(np.arange(3))
    assert ints.dtype == np.float64 and ints.flags.writeable


def test_table_lines_are_read_from_the_file(tmp_path):
    path = tmp_path / "c.csv"
    path.write_text("t,x\n" + _body(_rows(5000, 2)))
    table = read_table_file(path)
    assert table.text == b""
    assert table.lines[0] == "t,x" and len(table.lines) == 5001
