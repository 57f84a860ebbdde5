"""Hand feedtune's models, controllers and FRFs to python-control, and take them back.

=========================================  =======================================================================
feedtune                                   python-control
=========================================  =======================================================================
:class:`~feedtune.frf.Frf`                 ``FrequencyResponseData`` (``omega`` in rad/s, channel labels kept)
``BallScrewModel``                         ``StateSpace`` of eq. 3.3 (inputs ``u, d1, d2``, outputs ``x1, x2``)
                                           or ``TransferFunction`` (``form="tf"``)
``GantryModel`` at ``x``, ``GantryModelAtX``  ``StateSpace`` (inputs ``u1, u2``, outputs ``y1, y2``)
``RigidBodyModel``                         ``TransferFunction`` ``1 / (m s^2 + b s)`` (the linear part)
``BallScrewLaw``                           1x2 ``TransferFunction`` ``[K1 K2]`` from ``(e1, e2)`` to ``u``;
                                           ``discrete=True``: ``[K1d K2d] z^-delay`` with ``dt = 1/fs``
:class:`~feedtune.lti.Zpk`                 SISO ``TransferFunction`` (continuous, or discrete with ``dt``)
=========================================  =======================================================================

Back: :func:`frf_from_control` (a ``FrequencyResponseData``, or any LTI system evaluated on a grid),
:func:`ballscrew_from_control` and :func:`gantry_from_control` (the physical parameters from any realization, by
linear least squares on the equations of motion at frequencies up to its highest mode, checked to reproduce
it), :func:`zpk_from_control`. :func:`to_control` and :func:`from_control` dispatch on the type.

Accuracy (the thesis law at 20 kHz against ``feedtune analyze``'s loops, ``tests/test_interop_control.py``): the
continuous law times the model, as transfer functions or state space, agrees to 3e-13; the law times the FRF to
1e-12. In discrete time a transfer function evaluates polynomials whose roots crowd ``z = 1`` (integrators, slow
filters at a high sample rate): ``law_to_control(discrete=True)`` is good to about 1e-8 at 0.5 Hz, while
``form="ss"``, a cascade of first- and second-order sections, is good to 1e-12. Evaluate discrete systems one by
one and multiply the responses (2e-12); python-control's series connection of two state spaces is good to 3e-11
near ``z = 1``, and a MIMO ``TransferFunction`` times a ``StateSpace`` without slycot goes through polynomials
and loses everything there. python-control is imported when a function runs (``pip install "feedtune[control]"``).

Examples
--------
>>> from feedtune.models import THESIS_TABLE_3_1
>>> sys = to_control(THESIS_TABLE_3_1)
>>> sys.input_labels, sys.output_labels
(['u', 'd1', 'd2'], ['x1', 'x2'])
>>> back = ballscrew_from_control(sys)
>>> abs(back.k / THESIS_TABLE_3_1.k - 1) < 1e-12
True
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .display import register_facade
from .errors import DataError, UsageError
from .frf import Frf
from .lti import Zpk
from .structures import plant_of, plant_of_model_kind, plants, resolve

FORMS = ("ss", "tf")
"""Realizations :func:`to_control` builds: state space or transfer function."""


def _control():
    try:
        import control
    except ImportError:  # pragma: no cover - depends on the environment
        raise ImportError("python-control is needed for this: pip install \"feedtune[control]\" "
                          "(or pip install control)") from None
    return control


def _check_form(form: str) -> str:
    if form not in FORMS:
        raise UsageError(f"form must be one of {', '.join(FORMS)}, got {form!r}", parameter="form")
    return form


def _dt(sys) -> float | None:
    """feedtune's sample time [s] of a python-control system: None for continuous, else a number."""
    dt = sys.dt
    if dt is None or dt is False or (not isinstance(dt, bool) and dt == 0):
        return None
    if dt is True:
        raise UsageError("the python-control system is discrete with an unspecified sample time (dt=True); give "
                         "it a numeric dt", parameter="dt")
    return float(dt)


def _name(text: str) -> str:
    """A python-control system name (no ``.`` allowed there): dots become ``_``."""
    return str(text).replace(".", "_")


def _response(sys, freq_hz) -> np.ndarray:
    """``(n_out, n_in, n_freq)`` complex response of an LTI system on a grid [Hz]."""
    f = np.asarray(freq_hz, float)
    dt = _dt(sys)
    x = 2j * np.pi * f if dt is None else np.exp(2j * np.pi * f * dt)
    h = np.asarray(sys(x, squeeze=False), complex)
    return h.reshape(sys.noutputs, sys.ninputs, f.size)


# ------------------------------------------------------------------------------------------ FRFs
def frf_to_control(frf: Frf):
    """An :class:`~feedtune.frf.Frf` as a python-control ``FrequencyResponseData``.

    Frequencies become ``omega = 2 pi f`` [rad/s]; the channel names become the input and output labels and the
    source the system name. Coherence and units are not carried (python-control has no place for them).
    """
    ct = _control()
    return ct.frd(frf.response, 2 * np.pi * frf.freq_hz, inputs=list(frf.inputs), outputs=list(frf.outputs),
                  name=_name(frf.source))


def frf_from_control(sys, freq_hz=None, *, outputs: Sequence[str] | None = None,
                     inputs: Sequence[str] | None = None, quantity: str = "position", input_unit: str = "V",
                     output_unit: str = "rad", source: str | None = None) -> Frf:
    """An :class:`~feedtune.frf.Frf` from a python-control system.

    Parameters
    ----------
    sys : FrequencyResponseData, StateSpace or TransferFunction
        A ``FrequencyResponseData`` is taken on its own grid (or interpolated by python-control onto ``freq_hz``);
        an LTI system is evaluated on ``freq_hz`` (``s = j 2 pi f``, or ``z = exp(j 2 pi f dt)`` when discrete).
    freq_hz : array_like, optional
        Grid [Hz]; required for an LTI system.
    outputs, inputs : sequence of str, optional
        Channel names (default the system's labels).
    quantity, input_unit, output_unit : str
        What the outputs measure and the units (python-control does not record them).
    source : str, optional
        ``meta["source"]`` (default the system's name).
    """
    ct = _control()
    if isinstance(sys, ct.FrequencyResponseData):
        if freq_hz is None:
            f = np.asarray(sys.omega, float) / (2 * np.pi)
            h = np.asarray(sys.frdata if hasattr(sys, "frdata") else sys.fresp, complex)
        else:
            f = np.asarray(freq_hz, float)
            h = np.asarray(sys.eval(2 * np.pi * f, squeeze=False), complex)
    elif isinstance(sys, ct.LTI):
        if freq_hz is None:
            raise UsageError("freq_hz is needed to evaluate a state-space or transfer-function system on a grid",
                             parameter="freq_hz")
        f = np.asarray(freq_hz, float)
        h = _response(sys, f)
    else:
        raise UsageError(f"expected a python-control system, got {type(sys).__name__}")
    h = h.reshape(sys.noutputs, sys.ninputs, f.size)
    outs = tuple(outputs) if outputs is not None else tuple(sys.output_labels)
    ins = tuple(inputs) if inputs is not None else tuple(sys.input_labels)
    name = source or getattr(sys, "name", None) or "python-control system"
    return Frf(f, h, outs, ins, quantity, None, input_unit, output_unit, {"source": str(name)})


# ------------------------------------------------------------------------------------------ models
def ballscrew_to_control(model, form: str = "ss"):
    """A ball-screw model as a python-control system: the state space of eq. 3.3 (states ``x1, x2, v1, v2`` [rad,
    rad/s], inputs ``u, d1, d2`` [command unit], outputs ``x1, x2`` [rad]) or, with ``form="tf"``, the 2x3
    transfer functions ``G11 .. G23`` with the common denominator of eq. 3.4."""
    ct = _control()
    name = "ball-screw model"
    if _check_form(form) == "ss":
        A, B, C = model.state_space()
        return ct.ss(A, B, C, np.zeros((2, 3)), inputs=["u", "d1", "d2"], outputs=["x1", "x2"],
                     states=["x1", "x2", "v1", "v2"], name=name)
    nums, den = model.numerators(), model.denominator()
    rows = [[nums["G11"], nums["G11"], nums["G13"]], [nums["G21"], nums["G21"], nums["G23"]]]
    return ct.tf(rows, [[den] * 3] * 2, inputs=["u", "d1", "d2"], outputs=["x1", "x2"], name=name)


def gantry_to_control(model, x: float | None = None):
    """A gantry model at table position ``x`` [m] (a ``GantryModel``; a ``GantryModelAtX`` has its own) as a
    python-control ``StateSpace``: states ``y1, y2, y1', y2'`` [m, m/s], inputs ``u1, u2``, outputs ``y1, y2`` [m]."""
    ct = _control()
    at = model.at(0.0 if x is None else x) if hasattr(model, "at") else model
    A, B, C = at.state_space()
    return ct.ss(A, B, C, np.zeros((2, 2)), inputs=["u1", "u2"], outputs=["y1", "y2"],
                 states=["y1", "y2", "v1", "v2"], name=_name(f"gantry model at x = {at.x:g} m"))


def rigid_to_control(model):
    """The linear part of a rigid-body model, ``x / F = 1 / (m s^2 + b s)`` [position unit/command unit] with the
    viscous coefficient of ``v > 0``; Coulomb friction and the offset are not linear and are left out."""
    ct = _control()
    return ct.tf([1.0], [model.mass, model.viscous, 0.0], inputs=["u"], outputs=["x"], name="rigid-body model")


def _probe_frequencies(sys, n: int = 30) -> np.ndarray:
    """Frequencies [Hz] from 1/100 to 3 times the largest finite pole of a continuous system (its highest mode)."""
    p = np.abs(np.asarray(sys.poles(), complex))
    p = p[np.isfinite(p) & (p > 0)]
    hi = float(p.max()) if p.size else 2 * np.pi * 100.0
    return np.logspace(np.log10(hi / 100), np.log10(hi * 3), n) / (2 * np.pi)


def _continuous_response(sys, freq_hz):
    if isinstance(sys, _control().FrequencyResponseData):
        return np.asarray(sys.eval(2 * np.pi * np.asarray(freq_hz, float), squeeze=False), complex)
    if _dt(sys) is not None:
        raise UsageError(f"a physical model is continuous; this system is discrete (dt = {sys.dt} s); convert it "
                         "to continuous time first")
    return _response(sys, freq_hz)


def _lstsq(rows: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """Real least squares of complex equations, each equation and each unknown scaled to unit norm."""
    w = 1.0 / np.linalg.norm(np.column_stack([rows, rhs]), axis=1)
    rows, rhs = rows * w[:, None], rhs * w
    a = np.vstack([rows.real, rows.imag])
    b = np.concatenate([rhs.real, rhs.imag])
    scale = np.linalg.norm(a, axis=0)
    scale[scale == 0] = 1.0
    return np.linalg.lstsq(a / scale, b, rcond=None)[0] / scale


def ballscrew_from_control(sys, freq_hz=None, *, lead_m_per_rad: float | None = None, input_unit: str = "V"):
    """The ball-screw model (eq. 3.1) of a python-control system whose input 0 is ``u`` and outputs 0, 1 are ``x1,
    x2`` (any realization: state space, transfer functions, or a ``FrequencyResponseData`` with ``freq_hz``).

    ``m1, m2, b1, b2, k, c`` solve the equations of motion at ``freq_hz`` (default: 1/100 to 3 times the axial
    mode) in least squares (a realization of a model comes back to about 1e-13 relative)::

        (m1 s^2 + (b1 + c) s + k) G11 - (c s + k) G21 = 1
        (m2 s^2 + (b2 + c) s + k) G21 - (c s + k) G11 = 0

    Raises
    ------
    DataError
        The system is not a 2-mass ball-screw model (the parameters do not reproduce it to 1e-8, or are negative).
    """
    from .models.ballscrew import BallScrewModel

    if sys.noutputs < 2 or sys.ninputs < 1:
        raise DataError(f"a ball-screw system has outputs x1, x2 and input u; this one has {sys.noutputs} output(s) "
                        f"and {sys.ninputs} input(s)")
    f = np.asarray(freq_hz, float) if freq_hz is not None else _probe_frequencies(sys)
    h = _continuous_response(sys, f)
    g11, g21 = h[0, 0], h[1, 0]
    s = 2j * np.pi * f
    zero = np.zeros_like(s)
    # unknowns m1, m2, b1, b2, k, c
    eq1 = np.stack([s * s * g11, zero, s * g11, zero, g11 - g21, s * (g11 - g21)], axis=1)
    eq2 = np.stack([zero, s * s * g21, zero, s * g21, g21 - g11, s * (g21 - g11)], axis=1)
    rows = np.vstack([eq1, eq2])
    rhs = np.concatenate([np.ones_like(s), zero])
    p = _lstsq(rows, rhs)
    tiny = 1e-9 * np.abs(p).max()
    p = np.where((p < 0) & (p > -tiny), 0.0, p)
    if np.any(p < 0):
        raise DataError("the system is not a 2-mass ball-screw model: the fitted parameters "
                        f"{dict(zip(('m1', 'm2', 'b1', 'b2', 'k', 'c'), np.round(p, 12).tolist(), strict=True))} "
                        "include negative values")
    kw = {} if lead_m_per_rad is None else {"lead_m_per_rad": float(lead_m_per_rad)}
    model = BallScrewModel(*map(float, p), input_unit=input_unit, lead_given=lead_m_per_rad is not None, **kw)
    back = model.frequency_response(f, ("G11", "G21"))
    err = max(float(np.max(np.abs(back["G11"] - g11) / np.abs(g11))),
              float(np.max(np.abs(back["G21"] - g21) / np.abs(g21))))
    if not err < 1e-8:
        raise DataError(f"the system is not a 2-mass ball-screw model: the best one misses it by {err:.2g} "
                        "(relative) at the probe frequencies")
    return model


def gantry_from_control(sys, *, L: float, x: float = 0.0, freq_hz=None, input_unit: str = "V"):
    """A ``GantryModelAtX`` (matrices ``M, C, K`` of eq. 4.3 at table position ``x`` [m]) from a 2x2 python-control
    system ``(u1, u2) -> (y1, y2)`` [m]: ``G(s)^-1 = K + C s + M s^2`` solved in least squares at ``freq_hz``
    (default: 1/100 to 3 times the yaw mode). ``L`` is the span between the actuators [m]."""
    from .models.gantry import GantryModelAtX

    if sys.noutputs != 2 or sys.ninputs != 2:
        raise DataError(f"a gantry system is 2x2; this one is {sys.noutputs}x{sys.ninputs}")
    f = np.asarray(freq_hz, float) if freq_hz is not None else _probe_frequencies(sys)
    h = _continuous_response(sys, f)
    s = 2j * np.pi * f
    det = h[0, 0] * h[1, 1] - h[0, 1] * h[1, 0]
    Z = np.array([[h[1, 1], -h[0, 1]], [-h[1, 0], h[0, 0]]]) / det
    basis = np.stack([np.ones_like(s), s, s * s], axis=1)
    K, C, M = (np.empty((2, 2)) for _ in range(3))
    for i in range(2):
        for j in range(2):
            K[i, j], C[i, j], M[i, j] = _lstsq(basis, Z[i, j])
    model = GantryModelAtX(x=x, M=M, C=C, K=K, L=L, input_unit=input_unit)
    back = model.frequency_response(f)
    err = float(np.max(np.abs(back - h)) / np.max(np.abs(h)))
    if not err < 1e-8:
        raise DataError(f"the system is not a 2-DOF mass-spring-damper gantry model: the best one misses it by "
                        f"{err:.2g} (relative) at the probe frequencies")
    return model


# ------------------------------------------------------------------------------------------ controllers
def _real_factors(roots: np.ndarray) -> list[np.ndarray]:
    """Real polynomial factors of degree 1 or 2 of a set of conjugate-closed roots, real roots paired."""
    r = np.asarray(roots, complex)
    tol = 1e-9 * np.maximum(1.0, np.abs(r))
    real = np.sort(r[np.abs(r.imag) <= tol].real)
    upper = r[r.imag > tol]
    factors = [np.array([1.0, -2 * z.real, abs(z) ** 2]) for z in upper]
    for k in range(0, real.size - 1, 2):
        factors.append(np.array([1.0, -(real[k] + real[k + 1]), real[k] * real[k + 1]]))
    if real.size % 2:
        factors.append(np.array([1.0, -real[-1]]))
    return factors


def zpk_sections(zpk: Zpk) -> list[tuple[np.ndarray, np.ndarray]]:
    """``[(num, den), ...]``: a proper transfer function as a cascade of real sections of order <= 2 (the gain in
    the first), each numerator of degree <= its denominator's.

    Raises
    ------
    UsageError
        More zeros than poles (improper; no state-space realization).
    """
    if zpk.zeros.size > zpk.poles.size:
        raise UsageError(f"the transfer function has {zpk.zeros.size} zeros and {zpk.poles.size} poles: improper, "
                         "no state-space realization (use form='tf')", parameter="form")
    dens = sorted(_real_factors(zpk.poles), key=len, reverse=True)
    nums = sorted(_real_factors(zpk.zeros), key=len, reverse=True)
    sections = [[np.array([1.0]), d] for d in dens]
    free = list(range(len(sections)))
    for n in nums:  # degree-2 numerators first, into degree-2 denominators
        k = next(i for i in free if len(sections[i][1]) >= len(n))
        sections[k][0] = n
        free.remove(k)
    if not sections:
        return [(np.array([zpk.gain]), np.array([1.0]))]
    sections[0][0] = sections[0][0] * zpk.gain
    return [(n, d) for n, d in sections]


def zpk_to_control(zpk: Zpk, form: str = "tf", *, delay_samples: int = 0, name: str | None = None,
                   inputs: Sequence[str] | None = None, outputs: Sequence[str] | None = None):
    """A :class:`~feedtune.lti.Zpk` as a python-control system: ``TransferFunction`` (``form="tf"``) or a cascade
    of sections as ``StateSpace`` (``form="ss"``, accurate near ``z = 1``); ``delay_samples`` multiplies a discrete
    one by ``z^-delay_samples``."""
    ct = _control()
    _check_form(form)
    if delay_samples:
        if zpk.dt is None:
            raise UsageError("delay_samples needs a discrete transfer function", parameter="delay_samples")
        zpk = zpk * Zpk([], np.zeros(int(delay_samples)), 1.0, zpk.dt)
    dt = 0 if zpk.dt is None else zpk.dt
    labels = {"inputs": list(inputs or ["e"]), "outputs": list(outputs or ["u"])}
    if name:
        labels["name"] = _name(name)
    if form == "tf":
        num, den = zpk.to_tf()
        return ct.tf(num, den, dt, **labels)
    if zpk.gain == 0:
        return ct.ss([], [], [], [[0.0]], dt, **labels)
    parts = [ct.ss(ct.tf(n, d, dt)) for n, d in zpk_sections(zpk)]
    sys = parts[0]
    for p in parts[1:]:
        sys = ct.series(sys, p)
    return ct.ss(sys.A, sys.B, sys.C, sys.D, dt, **labels)


def zpk_from_control(sys) -> Zpk:
    """A SISO python-control ``TransferFunction`` or ``StateSpace`` as a :class:`~feedtune.lti.Zpk` (``dt`` kept)."""
    ct = _control()
    if sys.ninputs != 1 or sys.noutputs != 1:
        raise UsageError(f"a Zpk is single-input single-output; this system is {sys.noutputs}x{sys.ninputs}")
    tf = sys if isinstance(sys, ct.TransferFunction) else ct.tf(sys)
    num, den = np.asarray(tf.num[0][0], float), np.asarray(tf.den[0][0], float)
    return Zpk.from_tf(num, den, _dt(sys))


def law_to_control(law, *, discrete: bool = False, delay: bool | None = None, form: str = "tf"):
    """A ball-screw law's feedback as the 1x2 python-control system ``u = [K1 K2] [e1; e2]`` (inputs ``e1, e2``
    [rad], output ``u`` [command unit]).

    Parameters
    ----------
    law : BallScrewLaw
    discrete : bool
        The discrete paths ``K1d, K2d`` (``dt = 1/fs``) instead of the continuous ``K1, K2``.
    delay : bool, optional
        Include the computational delay ``z^-delay_samples`` (default: with ``discrete``).
    form : str
        ``"tf"`` (``TransferFunction``) or ``"ss"`` (cascade realization; accurate near ``z = 1``).
    """
    ct = _control()
    _check_form(form)
    delay = discrete if delay is None else delay
    if delay and not discrete:
        raise UsageError("delay needs discrete=True (the computational delay is z^-delay_samples)",
                         parameter="delay")
    paths = (law.K1d(), law.K2d()) if discrete else (law.K1(), law.K2())
    d = int(law.delay_samples) if delay else 0
    parts = [zpk_to_control(k, form, delay_samples=d) for k in paths]
    dt = 0 if not discrete else 1.0 / law.fs
    labels = {"inputs": ["e1", "e2"], "outputs": ["u"], "name": "ball-screw law" + (" (discrete)" if discrete else "")}
    if form == "tf":
        return ct.tf([[p.num[0][0] for p in parts]], [[p.den[0][0] for p in parts]], dt, **labels)
    from scipy.linalg import block_diag

    A = block_diag(*[p.A for p in parts])
    B = block_diag(*[p.B for p in parts])
    return ct.ss(A, B, np.hstack([p.C for p in parts]), np.hstack([p.D for p in parts]), dt, **labels)


# ------------------------------------------------------------------------------------------ dispatch
def to_control(obj, **kwargs):
    """A feedtune value as a python-control object (table in the module docstring); ``kwargs`` go to the
    converter (``form``, ``discrete``, ``delay``, ``x``)."""
    from .control.ballscrew_law import BallScrewLaw

    if isinstance(obj, Frf):
        return frf_to_control(obj, **kwargs)
    plant = plant_of(obj)  # a model of a plant structure: its conversion (feedtune.structures)
    if plant is not None and plant.to_control:
        return resolve(plant.to_control)(obj, **kwargs)
    if isinstance(obj, BallScrewLaw):
        return law_to_control(obj, **kwargs)
    if isinstance(obj, Zpk):
        return zpk_to_control(obj, **kwargs)
    if hasattr(obj, "law") and callable(obj.law):  # a ball-screw design: its law
        return law_to_control(obj.law(), **kwargs)
    raise UsageError(f"no python-control form for a {type(obj).__name__}; feedtune converts Frf, BallScrewModel, "
                     "GantryModel, GantryModelAtX, RigidBodyModel, BallScrewLaw, designs and Zpk")


FROM_KINDS = ("frf", *(p.model_kind for p in plants() if p.from_control), "zpk")
"""What :func:`from_control` builds: an FRF, a model of each plant structure that has a conversion (by its model
kind, :attr:`feedtune.structures.PlantStructure.from_control`), a zero-pole-gain system."""


def from_control(sys, kind: str | None = None, **kwargs):
    """A feedtune value from a python-control object: ``kind`` ``"frf"`` (default for a ``FrequencyResponseData``),
    ``"ballscrew"``, ``"gantry"`` or ``"zpk"`` (default for a SISO system); ``kwargs`` go to
    :func:`frf_from_control`, :func:`ballscrew_from_control`, :func:`gantry_from_control` or
    :func:`zpk_from_control`."""
    ct = _control()
    if kind is None:
        if isinstance(sys, ct.FrequencyResponseData):
            kind = "frf"
        elif sys.ninputs == 1 and sys.noutputs == 1:
            kind = "zpk"
        else:
            raise UsageError(f"kind is needed for a MIMO system: {', '.join(FROM_KINDS[:-1])}", parameter="kind")
    if kind not in FROM_KINDS:
        raise UsageError(f"kind must be one of {', '.join(FROM_KINDS)}, got {kind!r}", parameter="kind")
    plant = plant_of_model_kind(kind)
    convert = {"frf": frf_from_control, "zpk": zpk_from_control}.get(kind) or resolve(plant.from_control)
    return convert(sys, **kwargs)


# the value types' .plot()/.to_control()/.from_control() reach these through display.facade()
for _fn in (
    frf_to_control, frf_from_control, ballscrew_to_control, ballscrew_from_control, gantry_to_control,
    gantry_from_control, rigid_to_control, zpk_to_control, zpk_from_control, law_to_control, to_control,
    from_control,
):
    register_facade(_fn.__name__, _fn)
del _fn
