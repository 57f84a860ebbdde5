"""The CSV row writer (issue 11: >= 50 MB/s instead of ``DataFrame.to_csv``): the same text as pandas, bit-exact
round trips."""

from __future__ import annotations

import numpy as np
import pandas as pd

from feedtune.io import read_log, write_log_csv
from feedtune.io.csv_text import CSV_CHUNK_ROWS, csv_rows
from feedtune.log import Log


def _columns(n: int):
    rng = np.random.default_rng(0)
    wild = rng.normal(size=n) * 10.0 ** rng.integers(-300, 300, n)
    special = np.r_[np.inf, -np.inf, -0.0, 0.0, 1e-320, 5e-324, np.nan, rng.normal(size=n - 7)]
    return [wild, special, np.arange(n), rng.normal(size=n).astype(np.float32), np.arange(n) % 3 == 0]


def test_rows_are_the_text_pandas_writes():
    cols = _columns(CSV_CHUNK_ROWS + 123)  # more than one chunk
    expected = pd.DataFrame(dict(enumerate(cols))).to_csv(index=False, header=False, lineterminator="\n")
    assert csv_rows(cols) == expected
    assert csv_rows([np.array([])]) == ""


def test_a_log_reads_back_to_the_bit(tmp_path):
    rng = np.random.default_rng(1)
    n = 5000
    t = np.arange(n) / 20000.0
    sig = {"x1": rng.normal(size=n) * 1e-7, "u": rng.normal(size=n) * 3.0, "e": rng.normal(size=n) * 1e300}
    log = Log(t, sig, {"x1": "rad", "u": "V", "e": "m"}, {"source": "twin"})
    write_log_csv(log, tmp_path / "a.csv")
    back = read_log(tmp_path / "a.csv")
    assert np.array_equal(back.t, t)
    for k, v in sig.items():
        assert np.array_equal(back.signals[k], v, equal_nan=True), k


def test_reader_takes_bytes_with_bom_crlf_and_latin_1(tmp_path):
    """Files are parsed from their bytes: a UTF-8 BOM, Windows line ends and a Latin-1 unit (beyond the sample the
    encoding is guessed from) read the same as the plain file."""
    n = 30000
    rows = "".join(f"{k / 1000!r},{float(np.sin(k))!r}\n" for k in range(n))
    plain = "t [s],x [mm]\n" + rows
    (tmp_path / "plain.csv").write_bytes(plain.encode())
    (tmp_path / "bom.csv").write_bytes(b"\xef\xbb\xbf" + plain.replace("\n", "\r\n").encode())
    late = "t [s],x [mm]\n" + rows + "# tail comment \xb5m\n"
    (tmp_path / "latin.csv").write_bytes(late.encode("latin-1"))
    ref = read_log(tmp_path / "plain.csv")
    for name in ("bom.csv", "latin.csv"):
        got = read_log(tmp_path / name)
        assert np.array_equal(got.t, ref.t) and np.array_equal(got.signals["x"], ref.signals["x"]), name
        assert got.units == ref.units, name
