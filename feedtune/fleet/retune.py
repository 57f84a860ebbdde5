"""A proposed re-tune of an axis whose installed gains fail, drift or are forecast to fail: the same controller
structure and filter pack, tuned on the newest identified model under the axis' limits on the newest measured FRFs
(:func:`feedtune.tune.ppi.tune_ppi`, :func:`feedtune.tune.mcppc.tune_mcppc`), then certified on those FRFs as
written (:func:`feedtune.machines.certificate.certify`). A design that fails its certificate is not proposed.

The worker returns the gains document; the process running the fleet writes it into the history's ``_proposals/``
folder (``<machine>_<axis>-<key>.toml`` with its JSON twin, ``key`` the first 12 digits of the measurement's key),
so a re-run proposes for a measurement once.
"""

from __future__ import annotations

from dataclasses import dataclass

from .snapshot import Snapshot, model_of


@dataclass(frozen=True)
class Proposal:
    """A certified re-tune: the gains document (with its ``[certificate]``) and a summary."""

    axis_id: str
    key: str
    doc: dict
    summary: dict


def retune_axis(task: Snapshot) -> Proposal:
    """Tune and certify (module docstring); DesignError when no design of the structure meets the limits."""
    from ..control.filters import FilterPack
    from ..errors import DesignError
    from ..io import read_document
    from ..io.gains import read_sampling
    from ..tune.mcppc import tune_mcppc
    from ..tune.ppi import tune_ppi
    from ..workflows.deliver import deliver

    installed = read_document(task.gains)
    kind = installed.get("controller")
    tuners = {"ppi": tune_ppi, "mcppc": tune_mcppc}
    if kind not in tuners:
        raise DesignError(f"{task.gains_name}: controller {kind!r} is not re-tuned by a fleet run; expected "
                          f"{' or '.join(tuners)}")
    pack = FilterPack.from_dict(installed.get("filters", {}).get("continuous", {}), f"{task.gains_name}: filters")
    fs, delay, _ = read_sampling(installed, task.gains_name)
    from dataclasses import replace

    model = replace(model_of(task.fit), lead_given="lead_m_per_rad" in installed.get("model", {}))
    frfs = task.read_frfs()
    design = tuners[kind](model, limits=task.limits, filters=pack, fs=fs, delay_samples=delay, frf=frfs,
                          filter_choice="identical")
    delivery = deliver(design, list(zip(task.frf_names, frfs, strict=True)), task.limits, where="proposed gains")
    if not delivery.ok:
        raise DesignError("the re-tuned design fails its certificate: " + "; ".join(delivery.violations()))
    doc, worst = delivery.document, delivery.certificate.worst()
    gains = {**design.gains, **getattr(design, "ppi_gains", {})}
    summary = {"controller": kind, "measured_at": task.date.isoformat(), "key": task.key,
               "first_crossover_hz": worst["first_crossover_hz"], "ms": worst["ms"], "pm_deg": worst["pm_deg"],
               "gm_db": worst["gm_db"], "disk_margin": worst["disk_margin"],
               "active_limit": (worst.get("active_limit") or {}).get("name"), "gains": gains}
    return Proposal(task.axis_id, task.key, doc, summary)


def run_retune(task: Snapshot):
    """:func:`retune_axis` under the worker settings; a failure is returned as its message (one line)."""
    from .task import _one_line, worker_settings

    with worker_settings():
        try:
            return retune_axis(task)
        except Exception as exc:  # one axis' re-tune never stops the fleet
            return f"re-tune: {_one_line(exc)}"
