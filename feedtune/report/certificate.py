"""The report's certificate of each design on every measured FRF (positions, loads), for every machine kind."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from functools import partial

import numpy as np

from .content import Cell, FigureBlock, Table, text_cell
from .figures import PALETTE, Curve, sensitivity_figure
from .sections import ReportLimits
from .trust import trusted_mask


def _s_magnitude(S: np.ndarray) -> np.ndarray:
    """``|S|`` of a SISO loop, ``sigma_max(S)`` of a 2x2 one."""
    if S.ndim == 1:
        return np.abs(S)
    from ..analysis.mimo import singular_values

    return singular_values(S)[0]


def certificate_blocks(designs: Sequence, frfs: Sequence[tuple[str, object]], docs: Mapping[str, Mapping],
                       limits: ReportLimits, store: dict, analysed_on: Mapping[str, object] | None = None) -> list:
    """With two or more measured FRFs (positions, loads): each design's certificate on every one
    (:func:`feedtune.machines.certificate.certify`, the analysis of ``feedtune analyze GAINS --frf F``; a gantry FRF
    at the table position it records), as a table and the discrete ``|S|`` (``sigma_max(S)`` for a gantry) on each
    FRF with the Ms limit; ``store[name]["certificate"]`` gets its dictionary.

    Parameters
    ----------
    designs : sequence
        The analysed designs (``name``, ``label``).
    frfs : sequence of (str, Frf)
        The measured FRFs of the machine and their names.
    docs : mapping
        The gains document of each design by name.
    limits : ReportLimits
    store : dict
        The report's data, by design name.
    analysed_on : mapping, optional
        ``{design name: Frf}``: the FRF (one of ``frfs``, the same object) whose ``analyze_gains`` analysis the
        design already holds as ``analysis``; the certificate uses it instead of analysing that FRF again.
    """
    if len(frfs) < 2:
        return []
    from ..machines.certificate import certify

    blocks: list = []
    for d in designs:
        title = d.label if d.name in d.label else f"{d.label} ({d.name})"
        on = (analysed_on or {}).get(d.name)
        cert = certify(docs[d.name], d.name, frfs, limits.policy, known=[(on, d.analysis)] if on is not None else ())
        store[d.name]["certificate"] = cert.to_dict()
        rows = []
        for c, row in zip(cert.frfs, cert.to_dict()["frfs"], strict=True):
            first = row["crossovers_hz"][0] if row["crossovers_hz"] else None
            act = row["active_limit"]
            rows.append([text_cell(c.name), text_cell("yes" if row["stable"] else "NO"), Cell(first, "Hz"),
                         Cell(row["ms"], ""), Cell(row["ms_freq_hz"], "Hz"), Cell(row["pm_deg"], "deg"),
                         Cell(row["gm_db"], "dB"), Cell(row["disk_margin"], ""),
                         text_cell("-" if act is None else act["name"]),
                         text_cell("ok" if row["ok"] else "; ".join(row["violations"]))])
        w = cert.worst()
        rows.append([text_cell("worst"), text_cell("yes" if w["stable"] else "NO"), Cell(w["first_crossover_hz"], "Hz"),
                     Cell(w["ms"], ""), text_cell(str(w["ms_frf"])), Cell(w["pm_deg"], "deg"), Cell(w["gm_db"], "dB"),
                     Cell(w["disk_margin"], ""),
                     text_cell("-" if w["active_limit"] is None else
                               f"{w['active_limit']['name']} on {w['active_limit']['frf']}"),
                     text_cell("ok" if w["ok"] else "fails")])
        blocks.append(Table(f"Certificate of {title} on every measured FRF, discrete case, "
                            f"{limits.policy.describe()}",
                            ["FRF", "stable", "first crossover", "Ms", "Ms at", "PM", "GM", "disk margin",
                             "active limit", "verdict"], rows,
                            "Each row is feedtune analyze GAINS --frf FRF; the last row is the worst over the FRFs "
                            "(lowest first crossover, highest Ms, smallest margins)."))
        by_name = dict(frfs)
        curves, masked = [], 0
        for k, c in enumerate(cert.frfs):
            case = c.analysis.cases[c.checked_case]
            frf = by_name.get(c.name)
            mask = trusted_mask(frf, tuple(frf.channels), case.freq_hz, limits.coherence_trust) \
                if frf is not None else None
            masked += 0 if mask is None else int(np.count_nonzero(~mask))
            curves.append(Curve(case.freq_hz, _s_magnitude(case.S), c.name, PALETTE[k % len(PALETTE)], mask=mask))
        peaks = {c.name: (float(c.metrics.ms_freq_hz), float(c.metrics.ms)) for c in cert.frfs}
        note = (f" Lines whose coherence (lowest over the FRF's channels) is below {limits.coherence_trust:g} are "
                "not drawn; Ms is the analysis' peak over every line." if masked else "")
        blocks.append(FigureBlock(f"design-certificate-{d.name}", f"|S| of {title} on every measured "
                                  "FRF (discrete case; sigma_max(S) for a gantry) with the Ms limit." + note,
                                  partial(sensitivity_figure, curves, peaks, limits.ms_max,
                                          title=f"|S| of {title} on every FRF")))
    return blocks
