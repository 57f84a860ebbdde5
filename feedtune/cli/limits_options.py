"""The limits-policy options shared by ``design``, ``tune``, ``analyze``, ``report`` and the demos.

``--limits PROFILE`` picks a named profile of :mod:`feedtune.analysis.limits`; ``--ms-max``, ``--pm-min``,
``--gm-min``, ``--gm-low-min`` and ``--dm-min`` override single limits of it (``--gm-min 0`` switches the
gain-increase margin limit off, ``--gm-low-min 0`` the gain-reduction one).
"""

from __future__ import annotations

import math

import typer

from .help_text import LIMITS_PROFILES, choice

LIMITS_OPTION = typer.Option(
    "textbook", "--limits", **choice(LIMITS_PROFILES),
    help="Limits profile: textbook (Ms <= 2.5, PM >= 30 deg, GM >= 6 dB both ways) or thesis (Ms <= 3.25, PM >= 30 "
         "deg, the thesis' own acceptance); single limits are overridden by --ms-max, --pm-min, --gm-min, "
         "--gm-low-min, --dm-min.")
MS_MAX_OPTION = typer.Option(None, "--ms-max", metavar="MS", help="Largest peak sensitivity max|S| [-] "
                                                                  "(overrides the profile's).")
PM_MIN_OPTION = typer.Option(None, "--pm-min", metavar="DEG", help="Smallest |phase margin| at any crossover [deg] "
                                                                   "(overrides the profile's; 0: none).")
GM_MIN_OPTION = typer.Option(None, "--gm-min", metavar="DB", help="Smallest gain-increase margin (|L| < 1 at a phase "
                                                                  "crossover) [dB] (overrides the profile's; 0: none).")
GM_LOW_MIN_OPTION = typer.Option(
    None, "--gm-low-min", metavar="DB",
    help="Smallest gain-reduction margin of a conditionally stable loop (|L| > 1 at a phase crossover: how far the "
         "gain may fall, e.g. under actuator saturation) [dB] (overrides the profile's: textbook 6, thesis none; 0: "
         "none).")
DM_MIN_OPTION = typer.Option(None, "--dm-min", metavar="ALPHA", help="Smallest balanced disk margin alpha [-] "
                                                                     "(0: none).")


OPTION_NAMES = {"ms": "--ms-max", "pm_deg": "--pm-min", "gm_db": "--gm-min", "gm_low_db": "--gm-low-min",
                "disk_margin": "--dm-min"}
"""The option that sets each limit, for messages."""


def limits_from_options(profile: str = "textbook", ms_max: float | None = None, pm_min: float | None = None,
                        gm_min: float | None = None, dm_min: float | None = None, gm_low_min: float | None = None):
    """The :class:`~feedtune.analysis.limits.Limits` of the options; bad values are usage errors naming the option."""
    from ..analysis.limits import limits_profile
    from ..errors import UsageError

    base = limits_profile(profile)
    checks = (("--ms-max", ms_max, lambda v: v > 1, "a number > 1"),
              ("--pm-min", pm_min, lambda v: 0 <= v < 180, "an angle in [0, 180) deg"),
              ("--gm-min", gm_min, lambda v: v >= 0, "a number >= 0 dB"),
              ("--gm-low-min", gm_low_min, lambda v: v >= 0, "a number >= 0 dB"),
              ("--dm-min", dm_min, lambda v: 0 <= v < 2, "a number in [0, 2)"))
    for name, value, ok, expected in checks:
        if value is not None and not (math.isfinite(value) and ok(value)):
            raise UsageError(f"{name} must be {expected}, got {value:g}")
    return base.override(ms_max=ms_max, pm_min_deg=pm_min, gm_min_db=gm_min, disk_margin_min=dm_min,
                         gm_low_min_db=gm_low_min)


def print_check(check: dict) -> None:
    """One line with the verdict of a limit check (``LimitCheck.to_dict()``, optionally with ``checked_case``)."""
    from ..analysis.limits import Limits

    text = Limits.from_dict(check["limits"]).describe()
    where = f" in the {check['checked_case']} case" if check.get("checked_case") else ""
    if check["ok"]:
        typer.echo(f"check passed ({text}){where}; stable in every case")
    else:
        typer.echo(f"check FAILED ({text}){where}:")
        for v in check["violations"]:
            typer.echo(f"  {v}")


def finish_analysis(result: dict, verdict, as_json: bool, strict: bool, gains_kind: str | None = None) -> None:
    """Add a gains file's verdict (:func:`feedtune.machines.certificate.gains_verdict`: a certificate made anew on the
    FRFs given, the file's own certificate, or the design model) to ``result`` as ``check`` and ``verdict``,
    print the summary (or the JSON envelope, with ``gains_kind`` the gains file's kind) and, with ``strict``, raise
    DesignError when the verdict fails."""
    from ..errors import DesignError
    from .delivery import print_verdict
    from .envelope import collect, design_result, emit
    from .summary import print_design_summary

    result = design_result(result, gains_kind)
    result["check"] = verdict.certificate.check_dict(OPTION_NAMES)
    result["verdict"] = verdict.to_dict(OPTION_NAMES)
    if as_json:
        collect(*(n for n in verdict.notes if n == verdict.stored.problem()))
        emit(result)
    else:
        print_design_summary(result)
        if verdict.basis == "certificate":
            typer.echo("(the table: the design model alone; the verdict rests on the file's certificate)")
        print_verdict(verdict, command="analyze")
        print_check(result["check"])
    if strict and not verdict.ok:
        raise DesignError("; ".join(result["check"]["violations"]))
