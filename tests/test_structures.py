"""The registry of structures (feedtune.structures) and of machines (feedtune.machines.registry) is the one place
that decides by kind: every part it names resolves and lies in the package of its role, the per-kind tables agree
with it, and the places outside it (and outside each structure's own modules) that decide by kind are counted."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from feedtune import structures as st
from feedtune.machines.registry import machines

ROOT = Path(__file__).resolve().parents[1] / "feedtune"

# The package each part of an entry lives in (docs/architecture.md, "Adding a plant structure").
ROLES = {
    "models": "models", "reader": "io", "writer": "io", "to_control": "interop_control",
    "from_control": "interop_control", "document": "io", "runtime": "machines", "analysis": "machines",
    "emitter": "export", "report": "report", "design": "design", "tuner": "tune", "tune_command": "cli",
}


def _refs(entry) -> list[tuple[str, str]]:
    out = []
    for role in ROLES:
        value = getattr(entry, role, None)
        for ref in (value if isinstance(value, tuple) else (value,)):
            if ref:
                out.append((role, ref))
    return out


@pytest.mark.parametrize("entry", [*st.PLANTS, *st.GAINS, *st.CONTROLLERS],
                         ids=lambda e: getattr(e, "name", getattr(e, "kind", "?")))
def test_every_part_resolves_in_the_package_of_its_role(entry):
    for role, ref in _refs(entry):
        assert ref.startswith(f"feedtune.{ROLES[role]}"), (role, ref)
        assert st.resolve(ref) is not None, ref
    for module in getattr(entry, "modules", ()):
        assert (ROOT / module).exists(), module


def test_the_entries_name_each_other():
    plants = {p.name for p in st.PLANTS}
    gains = {g.kind for g in st.GAINS}
    for c in st.CONTROLLERS:
        assert set(c.plants) <= plants and c.gains_kind in gains, c.name
    assert {c.gains_kind for c in st.CONTROLLERS} == gains  # every format is delivered by some structure
    for m in machines():
        assert {m.plant, *m.axes} <= plants, m.name
        assert st.resolve(m.experiments) is not None and st.resolve(m.params) is not None
        assert m.demo is None or callable(st.resolve(m.demo))
    names = [c.command for c in st.CONTROLLERS]
    assert len(set(names)) == len(names)


def test_value_lookups_agree_with_the_registry():
    from feedtune.design.ppi import PpiDesign
    from feedtune.models.ballscrew import THESIS_TABLE_3_1
    from feedtune.models.rigid import RigidBodyModel

    assert st.plant_of(THESIS_TABLE_3_1) is st.plant("two_mass") and st.plant_of(object()) is None
    assert st.class_refs(PpiDesign.__new__(PpiDesign))[0] == st.controller("ppi").design
    assert st.plant("rigid").model == f"{RigidBodyModel.__module__}:{RigidBodyModel.__qualname__}"
    with pytest.raises(ValueError, match="a ball-screw model is needed"):
        st.require_plant(object(), ("two_mass",), "m.toml")


def test_per_kind_tables_are_the_registrys():
    """Every table keyed by kind elsewhere holds exactly the registry's kinds (a new structure cannot be forgotten)."""
    from feedtune.cli.tune_cmd import TITLES
    from feedtune.control.names import CONTROLLER_NAMES
    from feedtune.io.gains_schema import SCHEMAS
    from feedtune.io.model_file import model_kinds
    from feedtune.io.model_schema import MODEL_SCHEMAS

    model_kinds_ = {p.model_kind for p in st.PLANTS}
    assert set(SCHEMAS) == {g.kind for g in st.GAINS}
    assert set(MODEL_SCHEMAS) - {"friction"} == model_kinds_
    assert set(model_kinds()) - {"friction"} == model_kinds_
    assert CONTROLLER_NAMES == {c.name: c.title for c in st.CONTROLLERS}
    assert TITLES == {c.command: c.title for c in st.CONTROLLERS}


def test_feature_tables_name_only_registered_kinds():
    """Tables of a feature that some kinds have (LinuxCNC pins, a shaper's twin move, the kernels a machine's twin
    compiles) name only registered kinds; a kind without an entry is refused by name where the feature is asked for."""
    from feedtune.export.linuxcnc import PINS
    from feedtune.machines.registry import machine_names
    from feedtune.workflows.shaper_twin import DEFAULT_MOVES, MOVERS, PREFILTER_SECTION
    from feedtune.workflows.warmup import MACHINE_KERNELS

    gains = {g.kind for g in st.GAINS}
    for table in (PINS, DEFAULT_MOVES, MOVERS, PREFILTER_SECTION):
        assert set(table) <= gains, set(table) - gains
    assert set(MACHINE_KERNELS) <= set(machine_names())


# ------------------------------------------------------------------------------------------ decisions by kind
def _owned() -> dict[str, set[str]]:
    """``{module path (file or folder/) under feedtune/: the kind names it may use}``: each structure's and each
    machine's own modules name their own kinds (and those of the structures they are delivered with)."""
    owned: dict[str, set[str]] = {}

    def own(path: str, names: set[str]) -> None:
        owned.setdefault(path, set()).update(names)

    def path_of(ref: str) -> str:
        return ref.partition(":")[0].removeprefix("feedtune.").replace(".", "/") + ".py"

    def plant_names(p) -> set[str]:
        return {p.name, p.model_kind}

    def controller_names(c) -> set[str]:
        return {c.name, c.command, c.gains_kind}.union(*(plant_names(st.plant(n)) for n in c.plants))

    for p in st.PLANTS:
        names = plant_names(p).union(*(controller_names(c) for c in st.controllers_of(p.name)))
        for ref in (*p.models, p.reader, p.writer, p.report):
            if ref:
                own(path_of(ref), names)
        for module in p.modules:
            own(module, names)
    for g in st.GAINS:
        names = {g.kind}.union(*(controller_names(c) for c in st.CONTROLLERS if c.gains_kind == g.kind))
        for ref in (g.document, g.runtime, g.analysis, g.emitter, g.report):
            if ref:
                own(path_of(ref), names)
        for module in g.modules:
            own(module, names)
    for c in st.CONTROLLERS:
        for ref in (c.design, c.tuner, c.tune_command):
            own(path_of(ref), controller_names(c))
        for module in c.modules:
            own(module, controller_names(c))
    for m in machines():
        names = {m.name}
        for p in map(st.plant, (m.plant, *m.axes)):
            names |= plant_names(p).union(*(controller_names(c) for c in st.controllers_of(p.name)))
        for module in m.modules:
            own(module, names)
        own(path_of(m.experiments), names)
    return owned


def _strings(node) -> set[str] | None:
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        return {node.value}
    if isinstance(node, (ast.Tuple, ast.List, ast.Set)):
        parts = [_strings(e) for e in node.elts]
        return None if any(p is None for p in parts) else set().union(*parts)
    return None


def decisions_by_kind() -> list[str]:
    """Every comparison with a kind name (``kind == "gantry"``, ``x in ("mcppc", "ppi")``) and every table keyed by
    two kind names or more, outside the registries and outside the modules of the structures the names belong to."""
    names = st.kind_names()
    owned = _owned()
    skip = {"structures.py", "machines/registry.py"}
    found = []
    for path in sorted(ROOT.rglob("*.py")):
        rel = path.relative_to(ROOT).as_posix()
        if rel in skip:
            continue
        mine = set().union(*(v for k, v in owned.items() if rel == k or (k.endswith("/") and rel.startswith(k))))
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            used: set[str] = set()
            if isinstance(node, ast.Compare):
                for side in (node.left, *node.comparators):
                    used |= _strings(side) or set()
            elif isinstance(node, ast.Dict):
                keys = {k.value for k in node.keys if isinstance(k, ast.Constant) and isinstance(k.value, str)}
                used = keys if len(keys & names) >= 2 else set()
            foreign = (used & names) - mine
            if foreign:
                found.append(f"{rel}:{node.lineno} {', '.join(sorted(foreign))}")
    return found


HELD = {"io/gains_schema.py", "io/model_schema.py", "export/linuxcnc.py", "workflows/shaper_twin.py",
        "workflows/warmup.py"}
"""Modules whose per-kind tables :func:`test_per_kind_tables_are_the_registrys` and
:func:`test_feature_tables_name_only_registered_kinds` hold to the registry."""


def test_decisions_by_kind_live_in_the_registry():
    """Zero places outside the registries and the structures' own modules decide by kind."""
    found = [f for f in decisions_by_kind() if f.split(":")[0] not in HELD]
    assert not found, found
