"""The package import graph: no cycles, and every package imports only what docs/architecture.md allows.

Counts every import statement in the source, eager or lazy (inside functions), so a lazy import cannot hide a
cycle. The allowed table is the one in docs/architecture.md; changing it is a design decision, made there first.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1] / "feedtune"

# Value-type modules at the bottom: everything may import them (numpy only below them).
BASE = {
    "errors", "frf", "log", "lti", "quantity", "frf_sampling", "frf_quality", "spectrum", "blas", "display", "progress",
    "parallel", "structures", "__init__", "__main__", "budget", "_kernel_cache",
}
# Facades above every package: they register their functions in display (display.facade), through which the value
# types' .plot() and .to_control() reach them; only the package root imports them, so nothing below has an edge up.
FACADES = {"plotting", "interop_control"}

ALLOWED = {
    "cli": "*",
    "workflows": {"analysis", "control", "design", "identify", "io", "machines", "models", "report", "sim", "tune"},
    "fleet": {"analysis", "control", "design", "identify", "io", "machines", "models", "report", "sim", "tune",
              "workflows"},
    "report": {"analysis", "control", "io", "machines", "models", "sim"},
    "export": {"control", "io", "machines"},
    "tune": {"analysis", "control", "design", "models"},
    # documented deviations: experiments estimate FRFs (identify), score runs (analysis.metrics) and the ball screw's
    # FRF run holds the drive with a weak P-PI designed from the twin's inertia (design)
    "machines": {"analysis", "control", "design", "identify", "io", "models", "sim"},
    # documented deviation: contour paths use analysis.metrics' polyline distance
    "sim": {"analysis", "control", "models"},
    "design": {"control", "models"},
    "analysis": {"control", "models"},
    "identify": {"models"},
    # documented deviation: the friction feedforward evaluates the Stribeck law of models.friction
    "control": {"models"},
    "models": set(),
    "io": {"control", "models"},
}


def _imports() -> dict[tuple[str, str], list[str]]:
    """``{(package, imported package): ["file:line -> module", ...]}`` over every import statement."""
    edges: dict[tuple[str, str], list[str]] = {}
    for path in ROOT.rglob("*.py"):
        rel = path.relative_to(ROOT)
        src = rel.parts[0][:-3] if len(rel.parts) == 1 else rel.parts[0]
        mod = ["feedtune", *rel.with_suffix("").parts]
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    base = mod[: len(mod) - node.level]
                    names = [".".join(base + ([node.module] if node.module else []))]
                else:
                    names = [node.module or ""]
            else:
                continue
            for name in names:
                parts = name.split(".")
                if len(parts) > 1 and parts[0] == "feedtune" and parts[1] != src:
                    edges.setdefault((src, parts[1]), []).append(f"{rel}:{node.lineno} -> {name}")
    return edges


EDGES = _imports()


def _graph() -> dict[str, set[str]]:
    g: dict[str, set[str]] = {}
    for a, b in EDGES:
        g.setdefault(a, set()).add(b)
    return g


def test_no_import_cycle_between_packages():
    g = _graph()

    def reaches(a: str, b: str, seen: frozenset = frozenset()) -> bool:
        return any(x == b or (x not in seen and reaches(x, b, seen | {x})) for x in g.get(a, ()))

    cycles = sorted({" <-> ".join(sorted((a, b))) for a, b in EDGES if reaches(b, a)})
    assert not cycles, cycles


@pytest.mark.parametrize("package", sorted(ALLOWED))
def test_package_imports_only_what_the_architecture_allows(package):
    allowed = ALLOWED[package]
    bad = {b: where for (a, b), where in EDGES.items()
           if a == package and b not in BASE and allowed != "*" and b not in allowed}
    assert not bad, f"{package} imports {sorted(bad)}: {[w[0] for w in bad.values()]}"


def test_the_acceptance_rules_hold():
    pairs = set(EDGES)
    assert ("analysis", "design") not in pairs, EDGES.get(("analysis", "design"))
    assert ("sim", "identify") not in pairs, EDGES.get(("sim", "identify"))
    assert ("io", "design") not in pairs, EDGES.get(("io", "design"))


def test_io_takes_only_value_types_from_models():
    """io reads and writes models; it imports classes and constants from models, never physics functions."""
    offenders = []
    for path in (ROOT / "io").rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("models"):
                for alias in node.names:
                    name = alias.name
                    value_type = name[:1].isupper()  # a class (CapWords) or a CONSTANT
                    if not value_type and name != "param_units":  # param_units: the unit table of a model kind
                        offenders.append(f"{path.name}:{node.lineno} {node.module}.{name}")
    assert not offenders, offenders


def test_every_package_is_in_the_table():
    packages = {p.name for p in ROOT.iterdir() if p.is_dir() and (p / "__init__.py").exists()}
    assert packages <= set(ALLOWED), sorted(packages - set(ALLOWED))


def test_only_the_package_root_imports_the_facades():
    """plotting and interop_control are imported by feedtune/__init__.py only, eager or lazy; everything else reaches
    their functions through display.facade(), so no package below has an edge up to them."""
    offenders = []
    for path in ROOT.rglob("*.py"):
        rel = path.relative_to(ROOT)
        if rel == Path("__init__.py"):
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                names = [node.module or ""] + [a.name for a in node.names]  # also `from . import plotting`
            else:
                continue
            if any(part in FACADES for n in names for part in n.split(".")):
                offenders.append(f"{rel}:{node.lineno}")
    assert not offenders, offenders
    up = sorted((a, b) for a, b in EDGES if b in FACADES and a != "__init__")
    assert not up, up


def test_the_package_root_imports_the_facades():
    """The root imports both facades (in ``_load_facades``, which ``display.facade`` calls on first use: ``import
    feedtune`` stays cheap), so their functions are registered before any value type needs one."""
    tree = ast.parse((ROOT / "__init__.py").read_text(encoding="utf-8"))
    imported = {a.name for node in ast.walk(tree) if isinstance(node, ast.ImportFrom) and node.level == 1
                and node.module is None for a in node.names}
    assert FACADES <= imported, sorted(FACADES - imported)
    display = (ROOT / "display.py").read_text(encoding="utf-8")
    assert "_load_facades()" in display


# The one delivery exit (docs/architecture.md): a gains document is built from a design, certified and given its
# [certificate] in workflows/deliver.py only; every command, demo and library user goes through deliver().
DELIVERY_ONLY = {
    "gains_document": {"workflows/deliver.py",
                       # the ball screw's FRF run holds the drive with a weak P-PI: a runtime, never written
                       "machines/ballscrew/experiments.py"},
    "gantry_gains_document": {"workflows/deliver.py"},
    "axis_gains_document": {"workflows/deliver.py"},
    "cascade_gains_document": {"workflows/deliver.py"},
    "certificate_section": {"workflows/deliver.py"},
}


def test_one_delivery_exit():
    """Counts the places outside the delivery exit that build a gains document from a design or a certificate
    section: zero (a new controller structure adds one entry to feedtune.structures.CONTROLLERS, not a new path)."""
    offenders = []
    for path in ROOT.rglob("*.py"):
        rel = path.relative_to(ROOT).as_posix()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if not isinstance(node, ast.Call):
                continue
            f = node.func
            name = f.id if isinstance(f, ast.Name) else f.attr if isinstance(f, ast.Attribute) else None
            if name in DELIVERY_ONLY and rel not in DELIVERY_ONLY[name]:
                offenders.append(f"{rel}:{node.lineno} {name}()")
    assert not offenders, offenders
