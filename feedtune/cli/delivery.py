"""The command line's side of the one delivery exit (:mod:`feedtune.workflows.deliver`) and of a gains file's verdict
(:func:`feedtune.machines.certificate.gains_verdict`): FRF files read as certification sources, the certificate
printed, a failed design refused with the limit that fails (by its option)."""

from __future__ import annotations

from pathlib import Path

import typer

from .common import fmt
from .limits_options import OPTION_NAMES


def read_sources(paths, quantity: str | None = None, options=None, *, warn: bool = True) -> list:
    """:class:`~feedtune.machines.certificate.FrfSource` of each FRF file (read with the shared FRF options, each
    identified by the SHA-256 of its bytes); an empty list without paths."""
    from ..machines.certificate import FrfSource
    from .frf_options import read_optional_frf

    out = []
    for p in [p for p in (paths if isinstance(paths, (list, tuple)) else [paths]) if p is not None]:
        out.append(FrfSource.from_file(p, read_optional_frf(p, quantity, warn=warn, options=options)))
    return out


def print_certificate(cert: dict, title: str | None = None) -> None:
    """One line per FRF (its digest, figures, verdict) and the worst case with the active limit and, for a
    conditionally stable loop, the saturation headroom."""
    typer.echo(title or f"certificate ({cert['limits']['profile']} limits; every FRF):")
    for c in cert["frfs"]:
        first = c["crossovers_hz"][0] if c.get("crossovers_hz") else None
        verdict = "ok" if c["ok"] else "FAILS: " + "; ".join(c["violations"])
        digest = f" (sha256 {c['sha256'][:12]})" if c.get("sha256") else ""
        gm_low = c.get("gm_reduction_db")
        low = f", gain-reduction GM {fmt(gm_low, 'dB')}" if gm_low is not None else ""
        typer.echo(f"  {c['frf']}{digest}, {c['checked_case']} case: first crossover {fmt(first, 'Hz')}, Ms "
                   f"{c['ms']:.3g} at {fmt(c['ms_freq_hz'], 'Hz')}, PM {fmt(c.get('pm_deg'), 'deg')}, GM "
                   f"{fmt(c.get('gm_increase_db'), 'dB')}{low}, DM {fmt(c.get('disk_margin'), '', 3)}, "
                   f"{'stable' if c['stable'] else 'UNSTABLE'}: {verdict}")
        for note in band_notes(c):
            typer.echo(f"    {note}")
    w = cert["worst"]
    act = w["active_limit"]
    active = "none" if act is None else f"{act['name']} = {act['value']:.4g} (limit {act['limit']:g}) on {act['frf']}"
    typer.echo(f"  worst: first crossover {fmt(w['first_crossover_hz'], 'Hz')} ({w['first_crossover_hz_frf']}), "
               f"Ms {w['ms']:.3g} ({w['ms_frf']}); active limit: {active}")
    sat = [c["saturation"] for c in cert["frfs"] if c.get("saturation")]
    if sat:
        worst = min(sat, key=lambda s: s["overdrive_ratio"])
        typer.echo(f"  conditionally stable: {worst['text']}")


def band_notes(figures: dict) -> list[str]:
    """What a measured case's figures rest on beyond its proved band (its ``band_edge``): where a channel's lines are
    noise, and, when the loop there is not small, the ``valid to ... assumes ...`` line."""
    out = []
    for ch in (figures.get("band_edge") or {}).get("channels", []):
        where = []
        if ch.get("noise_below_hz"):
            where.append(f"up to {fmt(ch['noise_below_hz'], 'Hz')}")
        if ch.get("noise_from_hz"):
            where.append(f"from {fmt(ch['noise_from_hz'], 'Hz')} up")
        if where:
            out.append(f"{ch['channel']}: lines are noise {' and '.join(where)}; judged on the model there")
    return out + list(figures.get("assumes") or [])


def refuse_failed(delivery, what: str, *, allow_unstable: bool | None) -> str | None:
    """Raise DesignError naming the failing limits by their options when the delivery fails (``allow_unstable``
    None: no way to write it anyway; False: say which option writes it); with ``allow_unstable`` True return the
    warning to print after writing (None when it passes)."""
    from ..errors import DesignError

    if delivery.ok:
        return None
    msg = "; ".join(delivery.violations(OPTION_NAMES))
    if allow_unstable is None:
        raise DesignError(f"the {what} fails its certificate: {msg}")
    if not allow_unstable:
        raise DesignError(f"{msg}; no gains file written (use --allow-unstable to write it anyway)")
    return f"{msg} (written because of --allow-unstable)"


def write_delivery(delivery, out: Path | None, force: bool, allow_unstable: bool | None, what: str) -> str | None:
    """Refuse a failed delivery (:func:`refuse_failed`) or write it to ``out``; the warning to print, if any."""
    warning = refuse_failed(delivery, what, allow_unstable=allow_unstable)
    if out is not None:
        delivery.write(out, force=force, allow_failed=True)
    return warning


def print_verdict(verdict, *, command: str) -> None:
    """What a gains file's verdict rests on (the file's certificate, FRFs given now, or the model alone), its notes
    (an edited certificate ignored, FRFs compared by digest) and, uncertified, what would certify it."""
    from ..machines.certificate import UNCERTIFIED_HINT
    from .envelope import warn

    for note in verdict.notes:
        if verdict.stored.status in ("edited", "undigested") and note == verdict.stored.problem():
            warn(note)
        else:
            typer.echo(f"note: {note}")
    typer.echo(f"verdict on {verdict.basis_text()}")
    if verdict.basis != "model":
        print_certificate(verdict.certificate.to_dict(OPTION_NAMES))
    else:
        typer.echo(f"  to certify it on measured FRFs: {UNCERTIFIED_HINT.format(command=command)}")


def finish_design(delivery, result: dict, *, out: Path | None, force: bool, allow_unstable: bool,
                  as_json: bool) -> None:
    """The end of every ``design`` command: the delivery's check (and, on FRFs, its certificate) into ``result``,
    the gains file written unless the design fails (``--allow-unstable`` writes it with a warning), the summary or
    the ``--json`` envelope printed; DesignError (exit 1) naming the failing limits by their options otherwise."""
    from .envelope import collect, design_result, emit
    from .limits_options import print_check
    from .summary import print_design_summary

    doc = delivery.document
    result = {**result, "check": delivery.check_dict(OPTION_NAMES)}
    if "friction_feedforward" in doc:
        result["friction_feedforward"] = {k: v for k, v in doc["friction_feedforward"].items() if k != "source"}
    if delivery.certified:
        result["certificate"] = delivery.certificate.to_dict(OPTION_NAMES)
    warning = write_delivery(delivery, out, force, allow_unstable, "design")
    if out is not None:
        result["out"] = str(out)
    if warning:
        collect(warning)
    result = design_result(result, doc.get("kind"))
    if as_json:
        emit(result)
    else:
        print_design_summary(result)
        print_check(result["check"])
        if delivery.certified:
            print_certificate(result["certificate"])
        else:
            typer.echo("not certified on a measured FRF (checked on the design model): pass --frf to certify it and "
                       "write the certificate into the gains file")
        if "friction_feedforward" in result:
            print_friction(result["friction_feedforward"])
        if out is not None:
            typer.echo(f"wrote {out}")
    if warning:
        typer.echo(f"feedtune: warning: {warning}", err=True)


def print_friction(ff: dict) -> None:
    """One line on the friction feedforward a gains file holds (the law, its levels, Stribeck velocities and viscous
    terms, the linear band)."""
    levels = ", ".join(f"{k} {fmt(ff[k]['value'], ff[k]['unit'])}" for k in ("dc_pos", "ds_pos", "dc_neg", "ds_neg")
                       if k in ff)
    vu = ff["v_band"].get("unit", "rad/s")  # rad/s (ball screw) or m/s (a linear axis)
    omega = (f", Omega {fmt(ff['omega_pos']['value'], vu)} / {fmt(ff['omega_neg']['value'], vu)}"
             if "omega_pos" in ff else "")
    viscous = (f", viscous {fmt(ff['viscous_pos']['value'], ff['viscous_pos']['unit'])} / "
               f"{fmt(ff['viscous_neg']['value'], ff['viscous_neg']['unit'])}" if "viscous_pos" in ff else "")
    law = "eq. 2.1" if ff.get("model", "stribeck") == "stribeck" else ff["model"]
    band = fmt(ff["v_band"]["value"], vu)
    typer.echo(f"friction feedforward ({law}): {levels}{omega}{viscous}, linear band +-{band}")
