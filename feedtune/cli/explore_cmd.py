"""``feedtune explore``: an interactive page (one self-contained HTML file, no server) where the gain, the notches
and the low-pass pole of a ball-screw gains file are moved on its measured FRF and the Bode plot, the Nyquist plot,
``|S|`` and the verdict follow (:mod:`feedtune.report.explore`)."""

from __future__ import annotations

from pathlib import Path

import typer

from .common import FORCE_OPTION
from .design_cmd import QUANTITY_OPTION
from .frf_options import (
    FRF_CHANNEL_OPTION,
    FRF_INPUT_UNIT_OPTION,
    FRF_MAP_OPTION,
    FRF_SCALE_OPTION,
    FRF_SKIP_ROWS_OPTION,
)
from .limits_options import (
    DM_MIN_OPTION,
    GM_LOW_MIN_OPTION,
    GM_MIN_OPTION,
    LIMITS_OPTION,
    MS_MAX_OPTION,
    PM_MIN_OPTION,
    limits_from_options,
)
from .progress_display import QUIET_OPTION, show_progress
from .report_cmd import HTML_SUFFIXES
from .sampling_options import FS_OVERRIDE_OPTION


def explore(
    gains_file: Path = typer.Argument(..., metavar="GAINS",
                                      help="Ball-screw gains file (.toml or .json) from 'feedtune design' or 'tune'."),
    frf: Path = typer.Option(..., "--frf", metavar="FRF", help="Measured FRF with x1/u and x2/u."),
    out: Path = typer.Option(..., "--out", "-o", metavar="FILE", help="HTML page to write (.html)."),
    quantity: str = QUANTITY_OPTION,
    frf_map: list[str] = FRF_MAP_OPTION,
    frf_skip_rows: int = FRF_SKIP_ROWS_OPTION,
    frf_scale: list[str] = FRF_SCALE_OPTION,
    frf_channel: str = FRF_CHANNEL_OPTION,
    frf_input_unit: str = FRF_INPUT_UNIT_OPTION,
    limits: str = LIMITS_OPTION,
    ms_max: float = MS_MAX_OPTION,
    pm_min: float = PM_MIN_OPTION,
    gm_min: float = GM_MIN_OPTION,
    gm_low_min: float = GM_LOW_MIN_OPTION,
    dm_min: float = DM_MIN_OPTION,
    fs_override: bool = FS_OVERRIDE_OPTION,
    force: bool = FORCE_OPTION,
    quiet: bool = QUIET_OPTION,
) -> None:
    """Interactive page: move the gain and filters of a gains file, see the margins.

    One self-contained HTML file (no server, nothing loaded from the network): sliders for the overall gain, each
    notch's frequency and dampings and the low-pass pole; the Bode plot, the Nyquist plot, |S|, Ms, the margins
    and the verdict under the limits follow on the measured FRF (discrete controller, ZOH, computational delay, as
    'feedtune analyze GAINS --frf FRF' computes them). A button downloads the gains file shown, without a
    certificate: certify it with 'feedtune analyze FILE --frf FRF'."""
    show_progress(quiet)
    from ..errors import UsageError
    from ..io import ensure_writable, read_document
    from ..report.explore import write_explore_page
    from .delivery import read_sources
    from .frf_options import FrfReadOptions
    from .sampling_options import gains_sampling

    policy = limits_from_options(limits, ms_max, pm_min, gm_min, dm_min, gm_low_min)
    if out.suffix.lower() not in HTML_SUFFIXES:
        raise UsageError(f"--out {out}: the page is an HTML file; give a name ending in .html")
    ensure_writable(out, force)
    frf_options = FrfReadOptions.from_cli(frf_map, frf_skip_rows, frf_scale, frf_channel, frf_input_unit)
    doc = read_document(gains_file)
    source = read_sources([frf], quantity, frf_options)[0]
    rate = gains_sampling(doc, str(gains_file), [(source.name, source.frf)], override=fs_override)
    if rate is not None:
        rate.report(False)
    written = write_explore_page(doc, str(gains_file), source.frf, str(frf), out, limits=policy, force=force)
    typer.echo(f"wrote {written} ({written.stat().st_size / 1e6:.2f} MB)")
