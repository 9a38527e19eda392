"""The import layering, read from the sources with ``ast`` (nothing is imported).

The rules, from the bottom up:

1. **The engine** (every module of ``reference/``) imports neither the application
   (``flexmbs``, ``crosscheck``) nor the derivations, nor any of matplotlib, vtk, exudyn
   or dask — anywhere in a module, function-local imports included.  (The ParaView
   output, ``reference/io/vtk.py``, writes VTKHDF with h5py: no exception is needed.)
2. **Engine core → io**: the core (``reference/`` outside ``reference/io/``) imports of
   ``reference.io`` only ``reference.io.results`` — the results file and the ``Results``
   object are the engine's output contract, which the solution loop writes and ``solve``
   returns — anywhere, function-local imports included.  The deck reader
   (``reference.io.deck`` …) builds a Domain; the Domain knows no deck.
3. **No import cycle among the modules of** ``reference/`` **and of** ``flexmbs/``, counting
   function-local imports too (a module that imports another only when called still depends
   on it: the two could not be read, tested or moved apart).  ``from P import N`` is an edge
   to the module ``P.N`` if there is one, else to ``P``.  The exceptions are the edges of
   :data:`CYCLE_EXCEPTIONS`, each with its reason (none left).
4. **No back-arrow between the engine's folders**: with each sub-package of ``reference/``
   (``reference.algorithms``, ``reference.joints``, ``reference.io`` …) taken as one unit —
   but for the results contract of rule 2, a unit of its own — and each top-level module as
   one, the units' imports form no cycle either (e.g. a top-level module that an algorithm
   imports does not import an algorithm).
5. **The Domain** (``reference.domain``) imports neither the deck reader (``reference.io.deck`` and the
   ``reference.io.deck_*`` modules) nor the solution loop (``reference.solution``), function-local imports
   included: the deck reader builds a Domain and the loop takes one, so either can be read and changed apart
   from the Domain (``Domain.solve`` runs the loop it names, :attr:`reference.domain.Domain.solution_loop`).
6. **The application** keeps its order: ``crosscheck`` does not import ``flexmbs`` (the
   command line uses the cross-check, not the reverse); ``derivations`` imports none of
   ``reference``, ``crosscheck``, ``flexmbs`` (its output is text).
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("reference", "crosscheck", "flexmbs", "derivations")
FORBIDDEN_IN_ENGINE = ("flexmbs", "crosscheck", "derivations", "matplotlib", "vtk", "exudyn", "dask")
CORE_TO_IO = {"reference.io.results"}
"""The io modules the engine core may import anywhere."""
CYCLE_EXCEPTIONS: dict[tuple[str, str], str] = {}
"""(importer, imported) edges left out of the cycle check, each with the reason it remains."""


def modules() -> dict[str, Path]:
    """Dotted module name → source file, for every module of the four packages."""
    out = {}
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            parts = path.relative_to(ROOT).with_suffix("").parts
            out[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return out


MODULES = modules()


def imports(name: str) -> list[tuple[str, int, bool]]:
    """The imports of module ``name``: (imported module, line, made at module level)."""
    path = MODULES[name]
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = []

    def visit(node, top: bool):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.Import):
                found.extend((alias.name, child.lineno, top) for alias in child.names)
            elif isinstance(child, ast.ImportFrom):
                base = child.module or ""
                if child.level:
                    parent = package.split(".")[: len(package.split(".")) - child.level + 1]
                    base = ".".join(parent + ([base] if base else []))
                for alias in child.names:
                    sub = f"{base}.{alias.name}"
                    found.append((sub if sub in MODULES else base, child.lineno, top))
            elif isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
                visit(child, False)
            elif isinstance(child, ast.If) and _type_checking(child.test):
                continue  # not executed
            else:
                visit(child, top)

    visit(tree, True)
    return found


def _type_checking(test) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


def _within(module: str, package: str) -> bool:
    return module == package or module.startswith(package + ".")


def _engine() -> list[str]:
    return [m for m in MODULES if _within(m, "reference")]


def test_the_modules_are_found():
    assert {"reference.domain", "reference.io.results", "reference.io.deck", "crosscheck.harness",
            "flexmbs.cli", "derivations"} <= set(MODULES)


def test_the_engine_imports_no_application_and_no_heavy_optional_package():
    bad = [f"{MODULES[m].relative_to(ROOT)}:{line} imports {target}"
           for m in _engine() for target, line, _ in imports(m)
           if any(_within(target, f) for f in FORBIDDEN_IN_ENGINE)]
    assert not bad, "; ".join(bad)


def test_the_engine_core_imports_of_io_only_the_results_contract():
    bad = []
    for m in _engine():
        if _within(m, "reference.io"):
            continue
        for target, line, top in imports(m):
            if _within(target, "reference.io") and target not in CORE_TO_IO:
                bad.append(f"{MODULES[m].relative_to(ROOT)}:{line} imports {target}")
    assert not bad, "; ".join(bad)


def cycle(graph: dict[str, set]) -> list[str]:
    """One cycle of ``graph`` (module → the modules it imports) as a path ``[a, b, …, a]``; [] if none."""
    state, stack = {}, []

    def visit(node):
        state[node] = "open"
        stack.append(node)
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == "open":
                return stack[stack.index(nxt):] + [nxt]
            if nxt not in state:
                found = visit(nxt)
                if found:
                    return found
        state[node] = "done"
        stack.pop()
        return []

    for node in sorted(graph):
        if node not in state:
            found = visit(node)
            if found:
                return found
    return []


def test_cycle_detection_names_the_cycle():
    assert cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == ["a", "b", "c", "a"]
    assert cycle({"a": {"b"}, "b": set(), "c": {"a", "b"}}) == []


def _graph(package: str, unit=lambda m: m) -> dict[str, set]:
    """The imports among the modules of ``package`` (function-local ones included, less
    :data:`CYCLE_EXCEPTIONS`), as edges between the ``unit`` of each."""
    graph: dict[str, set] = {}
    for m in MODULES:
        if _within(m, package):
            graph.setdefault(unit(m), set()).update(
                unit(t) for t, _, _ in imports(m)
                if t in MODULES and _within(t, package) and unit(t) != unit(m) and (m, t) not in CYCLE_EXCEPTIONS)
    return graph


@pytest.mark.parametrize("package", ["reference", "flexmbs"])
def test_no_import_cycle_among_the_modules(package):
    found = cycle(_graph(package))
    assert not found, "import cycle: " + " → ".join(found)


def _folder(module: str) -> str:
    """The unit of rule 4: a sub-package of ``reference`` for its modules (the results contract apart),
    else the module itself."""
    parts = module.split(".")
    return module if module in CORE_TO_IO or len(parts) < 3 else ".".join(parts[:2])


def test_no_back_arrow_between_the_engine_folders():
    found = cycle(_graph("reference", _folder))
    assert not found, "import cycle between folders: " + " → ".join(found)


def _forbidden_to_the_domain(target: str) -> bool:
    return _within(target, "reference.solution") or _within(target, "reference.io.deck") or target.startswith(
        "reference.io.deck_")


def test_the_rule_of_the_domain_names_the_deck_reader_and_the_loop():
    assert _forbidden_to_the_domain("reference.io.deck") and _forbidden_to_the_domain("reference.io.deck_solution")
    assert _forbidden_to_the_domain("reference.solution")
    assert not _forbidden_to_the_domain("reference.io.results") and not _forbidden_to_the_domain("reference.errors")
    assert {"reference.io.deck_connectors", "reference.io.deck_solution"} <= set(MODULES)  # the names still exist


def test_the_domain_imports_neither_the_deck_reader_nor_the_solution_loop():
    bad = [f"reference/domain.py:{line} imports {target}" for target, line, _ in imports("reference.domain")
           if _forbidden_to_the_domain(target)]
    assert not bad, "; ".join(bad)


def test_every_cycle_exception_is_an_import_that_exists():
    """An exception whose import is gone is stale: remove it."""
    present = {(m, t) for m in MODULES for t, _, _ in imports(m)}
    assert set(CYCLE_EXCEPTIONS) <= present, set(CYCLE_EXCEPTIONS) - present


@pytest.mark.parametrize("package, forbidden", [("crosscheck", ("flexmbs",)),
                                                ("derivations", ("reference", "crosscheck", "flexmbs"))])
def test_the_application_keeps_its_order(package, forbidden):
    bad = [f"{MODULES[m].relative_to(ROOT)}:{line} imports {target}"
           for m in MODULES if _within(m, package) for target, line, _ in imports(m)
           if any(_within(target, f) for f in forbidden)]
    assert not bad, "; ".join(bad)
