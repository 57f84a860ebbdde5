"""The registry of plant structures, gains formats and controller structures: every decision by kind goes through it.

A **plant structure** is the physics a measurement is fitted to, whichever machine it was measured on:

* ``rigid``: one inertia or mass, in rad or m (a direct-drive rotary table, a servo motor, a linear-motor axis);
  above the band a measured FRF proves, the analysis continues it with the roll-off and delay it identifies there
  (:mod:`feedtune.models.rolloff`, :mod:`feedtune.analysis.band_edge`);
* ``two_mass``: a motor and a load coupled by a spring (a ball screw, a rack and pinion, a belt axis; its model
  file's kind is ``ballscrew``, the thesis' name);
* ``gantry``: two parallel drives and a yawing cross-beam.

A **gains format** is a gains document's ``kind``: the runtime that executes it per sample, the analysis ``feedtune
analyze`` prints of it, the C emitter of ``feedtune export c`` and the builder of the document from a design.

A **controller structure** is a control law with its design and its tuner (``mcppc``, ``ppi``, ``mimo``, ``pid``,
``loopshape``); it names the plant structures it fits and the gains format it is delivered in.

Machines (a twin, its experiments and its demo) are not here: :mod:`feedtune.machines.registry`; a machine names
the plant structure of its twin.

Each entry names where each layer's part lives as ``"package.module:attribute"`` (the form of Python's entry points)
and the layer that owns a part imports it when first used (:func:`resolve`), so this module imports nothing of
feedtune beyond its errors and sits with the value types at the bottom of the layering: every layer may ask it.
``tests/test_structures.py`` checks that every part resolves, lies in the package of its role, and is resolved only
from packages the layering table lets import that package; and it counts the places outside this registry and the
modules of each structure that decide by kind (zero). Adding a structure is its modules, one per layer, and one
entry here (docs/architecture.md, "Adding a plant structure").

Examples
--------
>>> plant("two_mass").model_kind, [c.name for c in controllers_of("two_mass")]
('ballscrew', ['mcppc', 'ppi', 'cascade'])
>>> controller("mimo").command, gains_format(controller("mimo").gains_kind).title
('gantry', 'gantry MIMO or PID')
"""

from __future__ import annotations

import importlib
from collections.abc import Iterable
from dataclasses import dataclass

from .errors import DataError, UsageError

Ref = str
"""``"package.module:attribute"``: where a part lives; :func:`resolve` imports it."""


@dataclass(frozen=True)
class PlantStructure:
    """A plant structure (module docstring).

    Attributes
    ----------
    name : str
        ``rigid``, ``two_mass``, ``gantry``.
    title : str
        What it is, for messages and docs.
    noun : str
        Its models in a phrase (``a NOUN model``).
    model_kind : str
        The ``kind`` of its model file (``feedtune.model/1``).
    models : tuple of Ref
        Its model classes (the first is the one its model file holds; the others are views of it, e.g. a gantry
        model at a table position).
    reader, writer : Ref
        The model-file codec (io): ``reader(doc, where) -> model``, ``writer(model) -> dict`` (the body).
    identify : str
        The command that identifies it (``feedtune identify ...``), named in messages.
    positions : bool
        Its FRFs are measured at table positions (``--x``, ``x_m``).
    axial_mode : bool
        It has an axial mode whose compliance a tuner can cap (``compliance_max``).
    to_control, from_control : Ref, optional
        Its python-control conversions (the ``interop_control`` facade).
    report : Ref, optional
        ``report(model_input, name, inputs, names, limits, warnings) -> (Section or None, FRF names drawn)``: the
        report's section of its model files (report).
    modules : tuple of str
        Its modules beyond those its parts name (paths under ``feedtune/``): they may name its kinds.
    """

    name: str
    title: str
    noun: str
    model_kind: str
    models: tuple[Ref, ...]
    reader: Ref
    writer: Ref
    identify: str
    positions: bool = False
    axial_mode: bool = False
    to_control: Ref | None = None
    from_control: Ref | None = None
    report: Ref | None = None
    modules: tuple[str, ...] = ()

    @property
    def model(self) -> Ref:
        """The class its model file holds."""
        return self.models[0]


@dataclass(frozen=True)
class GainsFormat:
    """A gains document's ``kind`` (module docstring).

    Attributes
    ----------
    kind : str
        ``ballscrew``, ``gantry``, ``axis``.
    title : str
        What its files hold, for messages and docs.
    document : Ref
        ``document(design) -> dict``: the gains document of a design (io).
    runtime : Ref
        The class executing a document per sample (machines): ``runtime.from_document(doc, where)``.
    analysis : Ref
        ``analysis(doc, where, frf) -> GainsAnalysis``: every analysis case of a document (machines).
    emitter : Ref
        ``emitter(doc, runtime, options, where) -> str``: its C header (export).
    report : Ref, optional
        ``report(inputs, names, limits, data, warnings, colors) -> (subsections, designs)``: the report's subsections
        of its gains files and their analysed designs (report; :func:`feedtune.report.design.design_section` calls each
        once, in this registry's order); without one the report lists its files only.
    loop : str
        What the analysis' crossovers are of, when not of the position loop (``CoM`` for a gantry).
    legend : str
        What ``feedtune analyze`` prints under its table, when not the SISO legend (how a MIMO loop is judged).
    modules : tuple of str
        Its modules beyond those its parts name (paths under ``feedtune/``).
    """

    kind: str
    title: str
    document: Ref
    runtime: Ref
    analysis: Ref
    emitter: Ref
    report: Ref | None = None
    loop: str = ""
    legend: str = ""
    modules: tuple[str, ...] = ()


@dataclass(frozen=True)
class ControllerStructure:
    """A controller structure (module docstring).

    Attributes
    ----------
    name : str
        The controller its gains file records (``controller``): ``mcppc``, ``ppi``, ``mimo``, ``pid``, ``loopshape``.
    title : str
        Its display name (MC-PPC, P-PI ...): one vocabulary for the command line, the report and the docs.
    plants : tuple of str
        The plant structures it fits.
    gains_kind : str
        The gains format it is delivered in.
    design : Ref
        Its design class (the tuner returns one too).
    tuner : Ref
        ``tuner(model, *, limits, filters, fs, delay_samples, frf, filter_choice, objective, ...)`` (tune).
    command : str
        Its name on ``feedtune tune STRUCTURE`` (default: ``name``).
    tune_command : Ref
        The command line's tuning of it (cli): ``tune_command(entry, request)``.
    default_fs_hz : float
        Sample rate [Hz] of a design without ``fs`` and without a rate recorded in an FRF.
    lpf_order : int
        Default order of its filter pack's low-pass.
    lead_stages : bool
        Its filter pack may hold lead stages.
    baseline : bool
        An industry baseline the report measures the improvements of the others against (P-PI, PID).
    objective : str
        Its tuner's objective unless told otherwise (empty: the tuners' default, :mod:`feedtune.tune.search`).
    options : tuple of str
        The options of ``feedtune tune`` that only it takes (``--position-fs`` ...); another structure refuses them.
    modules : tuple of str
        Its modules beyond those its parts name (paths under ``feedtune/``).
    """

    name: str
    title: str
    plants: tuple[str, ...]
    gains_kind: str
    design: Ref
    tuner: Ref
    tune_command: Ref
    command: str = ""
    default_fs_hz: float = 20000.0
    lpf_order: int = 1
    lead_stages: bool = False
    baseline: bool = False
    objective: str = ""
    options: tuple[str, ...] = ()
    modules: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "command", self.command or self.name)


# ------------------------------------------------------------------------------------------ the registry
PLANTS: tuple[PlantStructure, ...] = (
    PlantStructure(
        "rigid", "rigid axis (one inertia or mass, rad or m)", "rigid-body", "rigid",
        ("feedtune.models.rigid:RigidBodyModel",),
        "feedtune.io.rigid_model:rigid_from_doc", "feedtune.io.rigid_model:rigid_to_doc", "feedtune identify rigid",
        to_control="feedtune.interop_control:rigid_to_control",
        report="feedtune.report.identification:rigid_model_section",
        modules=("identify/rigid.py",)),
    PlantStructure(
        "two_mass", "two-mass drive (a ball screw, a rack and pinion, a belt axis)", "ball-screw", "ballscrew",
        ("feedtune.models.ballscrew:BallScrewModel",), "feedtune.io.ballscrew_model:ballscrew_from_doc",
        "feedtune.io.ballscrew_model:ballscrew_to_doc", "feedtune identify ballscrew", axial_mode=True,
        to_control="feedtune.interop_control:ballscrew_to_control",
        from_control="feedtune.interop_control:ballscrew_from_control",
        report="feedtune.report.identification:ballscrew_model_section",
        modules=("identify/ballscrew.py", "analysis/ballscrew.py", "cli/simulate_cmd.py", "fleet/")),
    PlantStructure(
        "gantry", "T-gantry (two parallel drives, a yawing cross-beam)", "gantry", "gantry",
        ("feedtune.models.gantry:GantryModel", "feedtune.models.gantry:GantryModelAtX"),
        "feedtune.io.gantry_model:gantry_model_from_doc", "feedtune.io.gantry_model:gantry_model_to_doc",
        "feedtune identify gantry", positions=True,
        to_control="feedtune.interop_control:gantry_to_control",
        from_control="feedtune.interop_control:gantry_from_control",
        report="feedtune.report.identification:gantry_model_section",
        modules=("identify/gantry.py", "identify/mass.py", "analysis/gantry.py", "cli/identify_gantry_cmd.py")),
)
"""Every plant structure."""

GAINS: tuple[GainsFormat, ...] = (
    GainsFormat(
        "ballscrew", "two-mass MC-PPC or P-PI", "feedtune.io.gains:gains_document",
        "feedtune.machines.ballscrew.runtime:GainsRuntime",
        "feedtune.machines.ballscrew.gains_analysis:analyze_document", "feedtune.export.c_ballscrew:ballscrew_header",
        report="feedtune.report.design:ballscrew_subsections",
        modules=("control/ballscrew_law.py", "machines/ballscrew/law.py")),
    GainsFormat(
        "gantry", "gantry MIMO or PID", "feedtune.io.gantry_gains:gantry_gains_document",
        "feedtune.machines.gantry.runtime:GantryRuntime",
        "feedtune.machines.gantry.gains_analysis:analyze_gantry_document", "feedtune.export.c_gantry:gantry_header",
        report="feedtune.report.gantry_design:machine_subsections", loop="CoM",
        legend="Ms = max sigma_max(S); stability by the MIMO Nyquist criterion on det(I + L); crossovers and "
               "margins of the CoM loop alpha^T L [1 1]^T; disk = balanced disk margin",
        modules=("control/gantry.py", "machines/gantry/law.py")),
    GainsFormat(
        "axis", "loop-shaped axis", "feedtune.io.gantry_gains:axis_gains_document",
        "feedtune.machines.gantry.runtime:AxisRuntime",
        "feedtune.machines.gantry.gains_analysis:analyze_axis_document", "feedtune.export.c_gantry:axis_header",
        report="feedtune.report.gantry_design:machine_subsections",
        modules=("control/axis.py", "machines/gantry/law.py")),
    GainsFormat(
        "cascade", "drive speed/position cascade", "feedtune.io.cascade_gains:cascade_gains_document",
        "feedtune.machines.cascade.runtime:CascadeRuntime",
        "feedtune.machines.cascade.gains_analysis:analyze_document", "feedtune.export.c_cascade:cascade_header",
        report="feedtune.report.cascade_design:cascade_subsections",
        modules=("control/cascade.py", "machines/cascade/law.py", "machines/cascade/twin.py",
                 "models/cascade_plant.py", "analysis/cascade.py", "export/drives/")),
)
"""Every gains format."""

CONTROLLERS: tuple[ControllerStructure, ...] = (
    ControllerStructure(
        "mcppc", "MC-PPC", ("two_mass",), "ballscrew", "feedtune.design.mcppc:McppcDesign",
        "feedtune.tune.mcppc:tune_mcppc", "feedtune.cli.design_cmd:tune_two_mass",
        modules=("cli/design_cmd.py",)),
    ControllerStructure(
        "ppi", "P-PI", ("two_mass",), "ballscrew", "feedtune.design.ppi:PpiDesign", "feedtune.tune.ppi:tune_ppi",
        "feedtune.cli.design_cmd:tune_two_mass", baseline=True, modules=("cli/design_cmd.py",)),
    ControllerStructure(
        "mimo", "MIMO", ("gantry",), "gantry", "feedtune.design.gantry_mimo:GantryMimoDesign",
        "feedtune.tune.gantry:tune_gantry_mimo", "feedtune.cli.design_gantry_cmd:tune_gantry", command="gantry",
        default_fs_hz=15000.0, lpf_order=2, lead_stages=True, modules=("cli/design_gantry_cmd.py",)),
    ControllerStructure(
        "pid", "PID", ("gantry",), "gantry", "feedtune.design.gantry_pid:GantryPidDesign",
        "feedtune.tune.pid:tune_gantry_pid", "feedtune.cli.design_gantry_cmd:tune_gantry", default_fs_hz=15000.0,
        lpf_order=2, lead_stages=True, baseline=True, modules=("cli/design_gantry_cmd.py",)),
    ControllerStructure(
        "loopshape", "x-axis loop shaping", ("rigid",), "axis", "feedtune.design.loopshape:LoopShapeDesign",
        "feedtune.tune.loopshape:tune_loopshape", "feedtune.cli.design_loopshape_cmd:tune_axis",
        default_fs_hz=15000.0, lead_stages=True),
    ControllerStructure(
        "cascade", "drive cascade", ("rigid", "two_mass"), "cascade", "feedtune.design.cascade:CascadeDesign",
        "feedtune.tune.cascade:tune_cascade", "feedtune.cli.cascade_cmd:tune_command", default_fs_hz=8000.0,
        lpf_order=2, objective="bandwidth",
        options=("--filter", "--position-fs", "--current-loop-hz", "--position-encoder", "--match-margins")),
)
"""Every controller structure."""


# ------------------------------------------------------------------------------------------ look-ups
def _known(kind: str, names: Iterable[str]) -> str:
    return f"known {kind}: {', '.join(names)}"


def plants() -> tuple[PlantStructure, ...]:
    """Every plant structure."""
    return PLANTS


def plant(name: str) -> PlantStructure:
    """The plant structure called ``name``; UsageError listing the known ones otherwise."""
    for p in PLANTS:
        if p.name == name:
            return p
    raise UsageError(f"unknown plant structure {name!r}; {_known('plant structures', (p.name for p in PLANTS))}")


def plant_of_model_kind(kind: str) -> PlantStructure | None:
    """The plant structure whose model files have ``kind`` (None for another kind, e.g. ``friction``)."""
    return next((p for p in PLANTS if p.model_kind == kind), None)


def gains_formats() -> tuple[GainsFormat, ...]:
    """Every gains format."""
    return GAINS


def gains_format(kind: object, where: str | None = None) -> GainsFormat:
    """The gains format of a document's ``kind``: DataError naming ``where`` when given (a file's kind), UsageError
    otherwise."""
    for g in GAINS:
        if g.kind == kind:
            return g
    known = ", ".join(repr(g.kind) for g in GAINS)
    if where is not None:
        raise DataError(f"{where}: gains file kind {kind!r} unknown; expected one of {known}")
    raise UsageError(f"unknown gains kind {kind!r}; expected one of {known}")


def controllers() -> tuple[ControllerStructure, ...]:
    """Every controller structure."""
    return CONTROLLERS


def controller(name: str) -> ControllerStructure:
    """The controller structure called ``name`` (the gains file's ``controller``); UsageError otherwise."""
    for c in CONTROLLERS:
        if c.name == name:
            return c
    raise UsageError(f"unknown controller structure {name!r}; "
                     f"{_known('controller structures', (c.name for c in CONTROLLERS))}")


def controller_by_command(command: str) -> ControllerStructure:
    """The controller structure of ``feedtune tune STRUCTURE``; UsageError naming the known ones otherwise."""
    for c in CONTROLLERS:
        if c.command == command:
            return c
    raise UsageError(f"STRUCTURE must be one of {', '.join(c.command for c in CONTROLLERS)}, got {command!r}")


def controllers_of(plant_name: str) -> tuple[ControllerStructure, ...]:
    """The controller structures that fit a plant structure."""
    return tuple(c for c in CONTROLLERS if plant_name in c.plants)


def controller_title(name: str | None) -> str:
    """``"mcppc"`` -> ``"MC-PPC"``; an unknown name as given; empty or None -> ``"controller"``."""
    if not name:
        return "controller"
    key = str(name).strip()
    return next((c.title for c in CONTROLLERS if c.name == key.lower()), key)


# ------------------------------------------------------------------------------------------ values by class
def class_refs(value: object) -> tuple[Ref, ...]:
    """``"module:qualname"`` of the class of ``value`` and of each of its bases (nearest first)."""
    return tuple(f"{c.__module__}:{c.__qualname__}" for c in type(value).__mro__)


def plant_of(model: object) -> PlantStructure | None:
    """The plant structure of a model value (one of its :attr:`~PlantStructure.models` or a subclass), or None."""
    for ref in class_refs(model):
        for p in PLANTS:
            if ref in p.models:
                return p
    return None


def controller_of(design: object) -> ControllerStructure | None:
    """The controller structure of a design value (its :attr:`~ControllerStructure.design` or a subclass)."""
    for ref in class_refs(design):
        for c in CONTROLLERS:
            if ref == c.design:
                return c
    return None


def require_plant(model: object, allowed: Iterable[str], where: str) -> PlantStructure:
    """The plant structure of ``model``, which must be one of ``allowed``; DataError naming ``where``, what it is and
    what is needed (and the command that makes it) otherwise."""
    allowed = tuple(allowed)
    found = plant_of(model)
    if found is not None and found.name in allowed:
        return found
    wanted = [plant(n) for n in allowed]
    nouns = " or ".join(p.noun for p in wanted)
    kinds = " or ".join(f'"{p.model_kind}"' for p in wanted)
    made = " or ".join(f"'{p.identify}'" for p in wanted)
    raise DataError(f"{where}: a {nouns} model is needed (kind = {kinds}, from {made}), got a {type(model).__name__}")


# ------------------------------------------------------------------------------------------ parts
def resolve(ref: Ref) -> object:
    """The object a :data:`Ref` names (a module where it names no attribute), its module imported on first use."""
    module, _, attr = ref.partition(":")
    obj: object = importlib.import_module(module)
    for part in filter(None, attr.split(".")):
        obj = getattr(obj, part)
    return obj


def kind_names() -> frozenset[str]:
    """Every name this registry gives (plant structures, model kinds, gains kinds, controller structures and their
    command names): the vocabulary of a decision by kind."""
    return frozenset({p.name for p in PLANTS} | {p.model_kind for p in PLANTS} | {g.kind for g in GAINS}
                     | {c.name for c in CONTROLLERS} | {c.command for c in CONTROLLERS})


__all__ = [
    "CONTROLLERS", "GAINS", "PLANTS", "ControllerStructure", "GainsFormat", "PlantStructure", "Ref", "class_refs",
    "controller", "controller_by_command", "controller_of", "controller_title", "controllers", "controllers_of",
    "gains_format", "gains_formats", "kind_names", "plant", "plant_of", "plant_of_model_kind", "plants",
    "require_plant", "resolve",
]
