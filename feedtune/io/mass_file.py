"""The gantry mass document (``schema = "feedtune.mass/1"``, ``kind = "gantry_mass"``): its one writer and reader.

Written by ``feedtune identify mass`` and the gantry demo, read by ``feedtune design gantry --mass``.
"""

from __future__ import annotations

from ..errors import DataError
from ..models.gantry_mass import MassFit
from ..quantity import quantity, value_of
from .document import read_document, require_schema
from .model_schema import validate_mass
from .schema_common import check_finite

# ------------------------------------------------------------------------------------------ mass document
MASS_SCHEMA = "feedtune.mass"
MASS_KIND = "gantry_mass"


def mass_document(fit, m_x: float | None, input_unit: str = "V") -> dict:
    """The mass document written by ``feedtune identify mass`` (``schema = "feedtune.mass/1"``).

    Parameters
    ----------
    fit : MassFit
        From :func:`~feedtune.identify.mass.fit_mass_distribution`.
    m_x : float or None
        Table mass [V/(m/s^2)] from :func:`~feedtune.identify.mass.fit_axis_mass`.
    input_unit : str
        Command unit.

    Returns
    -------
    dict
        ``m`` [V/(m/s^2)], ``alpha1_0`` [-], ``dalpha1_dx`` [1/m], ``alpha1_rms_residual`` [-], ``m_x`` and the
        per-position fits, numbers as ``{value, unit}``.
    """
    u = input_unit
    doc = {
        "schema": f"{MASS_SCHEMA}/1",
        "kind": MASS_KIND,
        "input_unit": u,
        "m": quantity(fit.m, f"{u}/(m/s^2)"),
        "alpha1_0": quantity(fit.alpha1_0, "-"),
        "dalpha1_dx": quantity(fit.dalpha1_dx, "1/m"),
        "alpha1_rms_residual": quantity(fit.alpha1_rms_residual, "-"),
        "positions": [p.to_dict() for p in fit.positions],
    }
    if m_x is not None:
        doc["m_x"] = quantity(m_x, f"{u}/(m/s^2)")
    return doc


def read_mass_document(path):
    """``(MassFit, m_x or None)`` from a mass document (:func:`mass_document`) at ``path``.

    The returned :class:`~feedtune.identify.mass.MassFit` carries the total mass and the ``alpha1(x)`` line
    (its ``side_masses(x)`` is the constraint of eq. 4.13); the per-position fits are not read back.

    Raises
    ------
    DataError
        Unreadable file, another schema or kind, a missing entry or a unit other than the one written.
    """
    where = str(path)
    doc = read_document(path)
    require_schema(doc, MASS_SCHEMA, where)
    if doc.get("kind") != MASS_KIND:
        raise DataError(f"{where}: kind must be {MASS_KIND!r}, got {doc.get('kind')!r}")
    u = doc.get("input_unit", "V")
    for key in ("m", "alpha1_0", "dalpha1_dx"):
        if key not in doc:
            raise DataError(f"{where}: entry {key!r} is missing")
    for key in ("m", "alpha1_0", "dalpha1_dx", "alpha1_rms_residual", "m_x"):
        check_finite(doc.get(key), [key], where)
    validate_mass(doc, where)
    fit = MassFit(positions=(), m=value_of(doc["m"], f"{u}/(m/s^2)", f"{where}: m"),
                  alpha1_0=value_of(doc["alpha1_0"], "-", f"{where}: alpha1_0"),
                  dalpha1_dx=value_of(doc["dalpha1_dx"], "1/m", f"{where}: dalpha1_dx"),
                  alpha1_rms_residual=value_of(doc.get("alpha1_rms_residual", 0.0), "-", where))
    m_x = value_of(doc["m_x"], f"{u}/(m/s^2)", f"{where}: m_x") if "m_x" in doc else None
    if not fit.m > 0 or (m_x is not None and not m_x > 0):
        raise DataError(f"{where}: the masses m and m_x must be > 0 {u}/(m/s^2), got {fit.m:g} and {m_x}")
    return fit, m_x
