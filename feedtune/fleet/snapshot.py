"""An axis at its newest measurement: what a forecast and a re-tune start from (picklable, for the engine)."""

from __future__ import annotations

import datetime as _dt
from dataclasses import dataclass

import numpy as np

MODEL_PARAMETERS = ("m1", "m2", "b1", "b2", "k", "c")
"""The 2-mass model's parameters as the history's columns name them."""


@dataclass(frozen=True)
class Snapshot:
    """The installed gains and limits of an axis with its newest measurement's FRFs and fit.

    Attributes
    ----------
    axis_id, key : str
        The axis and the history key of the measurement.
    date : datetime.datetime
        When it was measured.
    gains, gains_name : str
        The installed gains file (absolute) and its name as the manifest writes it.
    limits : Limits
    frfs, frf_names : tuple of str
        The measurement's FRF files (absolute) and their names.
    frf_options : dict
        Reader settings (``read_frf`` keyword arguments).
    fit : dict
        The 2-mass fit: ``m1 ... c``, ``lead_m_per_rad`` and ``input_unit`` as in the history (:func:`fit_of`).
    """

    axis_id: str
    key: str
    date: _dt.datetime
    gains: str
    gains_name: str
    limits: object
    frfs: tuple[str, ...]
    frf_names: tuple[str, ...]
    frf_options: dict
    fit: dict

    def read_frfs(self, paths=None) -> list:
        """The measurement's FRFs (or those of ``paths``, read with the same settings)."""
        from ..io import read_frf

        return [read_frf(p, **self.frf_options) for p in (self.frfs if paths is None else paths)]


def finite(value) -> bool:
    """A number, not NaN or infinite (history cells are None where a fit failed)."""
    return isinstance(value, (int, float)) and bool(np.isfinite(value))


def has_fit(row: dict) -> bool:
    """The row holds a whole 2-mass fit (every parameter finite)."""
    return all(finite(row.get(n)) for n in MODEL_PARAMETERS)


def fit_of(row: dict) -> dict:
    """The 2-mass fit of a history row (:attr:`Snapshot.fit`)."""
    return {**{n: float(row[n]) for n in MODEL_PARAMETERS}, "lead_m_per_rad": row.get("lead_m_per_rad"),
            "input_unit": row.get("input_unit")}


def model_of(fit: dict, values: dict | None = None):
    """The :class:`~feedtune.models.ballscrew.BallScrewModel` of a fit, with ``values`` replacing some parameters."""
    from ..models.ballscrew import BallScrewModel

    params = {k: float((values or {}).get(k, fit[k])) for k in MODEL_PARAMETERS}
    return BallScrewModel(**params, lead_m_per_rad=float(fit.get("lead_m_per_rad") or 0.02 / (2 * np.pi)),
                          input_unit=str(fit.get("input_unit") or "V"))


def snapshot(entry, manifest, row: dict, measurement) -> Snapshot:
    """The snapshot of a manifest axis at the history row of one of its measurements."""
    return Snapshot(entry.id, row["key"], row["measured_at"], str(entry.gains), manifest.relative(entry.gains),
                    entry.limits, tuple(str(p) for p in measurement.frfs),
                    tuple(manifest.relative(p) for p in measurement.frfs), dict(entry.frf_options), fit_of(row))
