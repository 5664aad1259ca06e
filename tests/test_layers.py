"""Imports point down the floors only, and the report reads what runs stored.

Every import statement of the source tree (those inside functions too) is read with :mod:`ast`,
resolved to the module it names, and checked against :data:`LAYERS`: a module may import its own
floor and those below it, never one above. Within a floor, modules may import each other (the
structure check keeps them free of cycles).
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent

#: The import package's folders (pyproject.toml's package-dir, top-level packages only).
FOLDERS = {"rockbench.reference_solver": "reference_solver", "rockbench.engines": "engines",
           "rockbench.benchmark": "benchmark"}

#: The floors, lowest first: ``(what the floor holds, module prefixes)``. A module's floor is that
#: of the longest prefix naming it (``rockbench.benchmark.suites.runner`` beats
#: ``rockbench.benchmark.suites``).
LAYERS = [
    ("the problem: blocks, pulses, restitution, the classifier, the reference solver",
     ["rockbench.reference_solver"]),
    ("the engine contract: what an adapter exchanges, what it reads from its state, its hooks, the engines' "
     "versions", ["rockbench.engines", "rockbench.engines.contract", "rockbench.engines.motion",
                  "rockbench.engines.hooks", "rockbench.engines.support"]),
    ("the calibration's rules: knobs, search, pick, η reader, price, time-step rule, held-out block, cache, the "
     "one routine", ["rockbench.engines.calibration"]),
    ("the contact engines' base and its loop", ["rockbench.engines.contact", "rockbench.engines.loop"]),
    ("one adapter per engine", ["rockbench.engines.adapters"]),
    ("the registry and the conformance checker", ["rockbench.engines.registry", "rockbench.engines.checker"]),
    ("block presets, experimental data, facts about the installed engines and the benchmark's errors",
     ["rockbench.benchmark.blocks", "rockbench.benchmark.engine_info", "rockbench.benchmark.errors"]),
    ("maps: the case or map a user asks for, grids, cells, executors, the run folders they are stored in, and the "
     "sweep that computes a map into its folder",
     ["rockbench.benchmark.request", "rockbench.benchmark.maps", "rockbench.benchmark.store",
      "rockbench.benchmark.sweep"]),
    ("scores of stored maps", ["rockbench.benchmark.scoring"]),
    ("suite files: what a benchmark run computes, and computing its maps", ["rockbench.benchmark.suites"]),
    ("the report: pages and pictures of what runs stored", ["rockbench.benchmark.report"]),
    ("front doors: the command line, the notebook API, one simulated case, the θ(t) curves a run stores, "
     "a suite's whole job (maps, scores, report) and the paper's figures",
     ["rockbench.benchmark", "rockbench.benchmark.cli", "rockbench.benchmark.api",
      "rockbench.benchmark.simulation", "rockbench.benchmark.trajectories", "rockbench.benchmark.suites.runner",
      "rockbench.benchmark.figures"]),
]

#: Modules the report may not import: the report draws what runs stored and simulates nothing.
SIMULATES = ["rockbench.engines.registry", "rockbench.reference_solver.solver", "rockbench.benchmark.sweep",
             "rockbench.benchmark.maps.executors", "rockbench.benchmark.maps.worker", "rockbench.benchmark.simulation"]


def _module_name(path: Path) -> tuple[str, bool]:
    """``(dotted name, is a package's __init__)`` of a source file."""
    for pkg, folder in sorted(FOLDERS.items(), key=lambda kv: -len(kv[1])):
        try:
            rel = path.relative_to(ROOT / folder)
        except ValueError:
            continue
        parts = list(rel.with_suffix("").parts)
        is_pkg = parts[-1] == "__init__"
        return ".".join([pkg] + (parts[:-1] if is_pkg else parts)), is_pkg
    raise ValueError(path)


def _sources() -> list[Path]:
    return sorted(p for folder in FOLDERS.values() for p in (ROOT / folder).rglob("*.py"))


def _imports(path: Path) -> list[tuple[int, str]]:
    """``(line, imported module)`` for every import of the project's own modules in ``path``; ``from
    X import Y`` counts as ``X.Y`` (Y may be a module or a name in X)."""
    mod, is_pkg = _module_name(path)
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
        if isinstance(node, ast.Import):
            out += [(node.lineno, a.name) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = mod.split(".")[: len(mod.split(".")) - node.level + (1 if is_pkg else 0)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            out += [(node.lineno, f"{target}.{a.name}") for a in node.names]
    return [(line, t) for line, t in out if t == "rockbench" or t.startswith("rockbench.")]


def _floor(module: str) -> int:
    """The floor of a module (or of a name in one): the floor of its longest matching prefix."""
    best, floor = -1, None
    for i, (_, prefixes) in enumerate(LAYERS):
        for p in prefixes:
            if (module == p or module.startswith(p + ".")) and len(p) > best:
                best, floor = len(p), i
    assert floor is not None, f"{module} is on no floor of LAYERS"
    return floor


def _all_imports():
    return [(path, line, _module_name(path)[0], target) for path in _sources() for line, target in _imports(path)]


def test_every_module_is_on_a_floor():
    for path in _sources():
        _floor(_module_name(path)[0])


def test_imports_point_down_only():
    upward = [f"{path.relative_to(ROOT)}:{line}: {mod} (floor {_floor(mod) + 1}) imports {target} "
              f"(floor {_floor(target) + 1}: {LAYERS[_floor(target)][0]})"
              for path, line, mod, target in _all_imports() if _floor(target) > _floor(mod)]
    assert not upward, "imports that point up a floor:\n" + "\n".join(upward)


def _subpackage(dotted: str) -> str | None:
    """The subpackage of a floor that holds a module (or a name in one): ``rockbench.benchmark.maps`` for
    ``rockbench.benchmark.maps.grid.MapSpec``; None for a module directly in a floor's folder."""
    for pkg, folder in FOLDERS.items():
        if dotted.startswith(pkg + "."):
            sub = dotted[len(pkg) + 1:].split(".")[0]
            return f"{pkg}.{sub}" if (ROOT / folder / sub / "__init__.py").is_file() else None
    return None


def _cycle(edges: dict[str, set[str]]) -> list[str] | None:
    """One cycle of a directed graph (its nodes in order, the first repeated at the end), None if none."""
    state: dict[str, int] = {}   # 1: on the path, 2: done
    path: list[str] = []

    def visit(n: str) -> list[str] | None:
        state[n] = 1
        path.append(n)
        for m in sorted(edges.get(n, ())):
            if state.get(m) == 1:
                return path[path.index(m):] + [m]
            if m not in state and (found := visit(m)):
                return found
        state[n] = 2
        path.pop()
        return None

    return next((c for n in sorted(edges) if n not in state and (c := visit(n))), None)


def test_subpackages_import_one_way():
    """No two subpackages of a floor import each other, directly or round a longer loop (``benchmark/store``
    reads and writes what ``benchmark/maps`` computes; ``maps`` never imports ``store``)."""
    edges: dict[str, set[str]] = {}
    where: dict[tuple[str, str], str] = {}
    for path, line, mod, target in _all_imports():
        a, b = _subpackage(mod), _subpackage(target)
        if a and b and a != b:
            edges.setdefault(a, set()).add(b)
            where.setdefault((a, b), f"{path.relative_to(ROOT)}:{line} imports {target}")
    cycle = _cycle(edges)
    assert cycle is None, "subpackages that import each other: " + " → ".join(cycle) + "\n" + "\n".join(
        where[(a, b)] for a, b in zip(cycle, cycle[1:]))


def test_imports_are_absolute():
    """Every import of the project's own modules names its full path (``rockbench.engines.contract``), never
    a relative one: a module's imports read the same wherever it moves, and none climbs out of its folder."""
    found = [f"{path.relative_to(ROOT)}:{node.lineno}: from {'.' * node.level}{node.module or ''} import ..."
             for path in _sources() for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path)))
             if isinstance(node, ast.ImportFrom) and node.level]
    assert not found, "relative imports (write rockbench.<floor>...):\n" + "\n".join(found)


def test_report_simulates_nothing():
    found = [f"{path.relative_to(ROOT)}:{line}: imports {target}" for path, line, mod, target in _all_imports()
             if mod.startswith("rockbench.benchmark.report")
             and any(target == s or target.startswith(s + ".") for s in SIMULATES)]
    assert not found, "the report reads what runs stored; these imports simulate:\n" + "\n".join(found)


def _is_module(dotted: str) -> bool:
    """Whether a dotted name is one of the project's modules or packages (not a name inside one)."""
    for pkg, folder in sorted(FOLDERS.items(), key=lambda kv: -len(kv[0])):
        if dotted == pkg or dotted.startswith(pkg + "."):
            base = ROOT / folder / Path(*dotted[len(pkg) + 1:].split(".")) if dotted != pkg else ROOT / folder
            return base.with_suffix(".py").is_file() or (base / "__init__.py").is_file()
    return False


def test_no_private_name_crosses_a_module():
    """A name with a leading underscore stays in its module: one that another module needs is public
    (or lives where it is needed). A package's private module is its siblings' to import."""
    found = [f"{path.relative_to(ROOT)}:{line}: imports {target}" for path, line, mod, target in _all_imports()
             if target.rsplit(".", 1)[-1].startswith("_") and not target.endswith("__")
             and not _is_module(target)]
    assert not found, "private names imported across modules:\n" + "\n".join(found)


#: The folders whose imports inside functions must each say why (the engines' adapters import their
#: engine's library on first use, as the engine contract says).
REASONED = ("reference_solver", "benchmark")


def test_imports_inside_functions_say_why():
    """An import sits inside a function only for an optional dependency or start-up time, and says so
    in a comment on its line or just above it (or above the group of imports it belongs to)."""
    found = []
    for path in _sources():
        if path.relative_to(ROOT).parts[0] not in REASONED:
            continue
        lines = path.read_text(encoding="utf-8").split("\n")
        tree = ast.parse("\n".join(lines), str(path))
        parents = {c: n for n in ast.walk(tree) for c in ast.iter_child_nodes(n)}
        for node in ast.walk(tree):
            if not isinstance(node, (ast.Import, ast.ImportFrom)):
                continue
            up = parents.get(node)
            while up is not None and not isinstance(up, (ast.FunctionDef, ast.AsyncFunctionDef)):
                up = parents.get(up)
            if up is None:
                continue
            k = node.lineno - 1
            own = lines[node.end_lineno - 1].split("#", 1)
            said = len(own) > 1 and not own[1].strip().startswith("noqa")
            while not said and k > 0 and lines[k - 1].strip().startswith(("import ", "from ", "#")):
                k -= 1
                said = lines[k].strip().startswith("#") and not lines[k].strip().startswith("# noqa")
            if not said:
                found.append(f"{path.relative_to(ROOT)}:{node.lineno}: {lines[node.lineno - 1].strip()}")
    assert not found, "imports inside functions without a reason:\n" + "\n".join(found)


@pytest.mark.parametrize("source, target, floor_ok", [
    ("rockbench.benchmark.sweep", "rockbench.benchmark.report.plots.picture.MapPicture", False),
    ("rockbench.engines.calibration.routine", "rockbench.engines.adapters.mujoco.MujocoAdapter", False),
    ("rockbench.engines.adapters.mujoco", "rockbench.engines.contact.ContactEngine", True),
    ("rockbench.engines.contract", "rockbench.engines.calibration.step_rule", False),
    ("rockbench.engines.checker", "rockbench.engines.registry.get_adapter", True),
    ("rockbench.benchmark.report.build", "rockbench.benchmark.maps.grid.MapSpec", True),
    ("rockbench.benchmark.suites.runner", "rockbench.benchmark.report.build.build_report", True),
    ("rockbench.engines.contract", "rockbench.benchmark.store.files", False),
])
def test_the_rule_itself(source, target, floor_ok):
    """The floor comparison the test relies on says what the declared layers mean."""
    assert (_floor(target) <= _floor(source)) is floor_ok


def test_each_floor_s_errors_live_on_it_and_users_catch_them_at_the_front_door():
    """docs/architecture.md, "Errors": the root and bad input on floor 1, the engines' errors on floor 2,
    the benchmark's on floor 3, every one a RockbenchError and importable from ``rockbench.benchmark``."""
    import rockbench.benchmark as rb

    floors = {"RockbenchError": 0, "ConfigError": 0, "EngineUnavailableError": 1, "EngineError": 1,
              "IncomparableError": 2}
    assert set(rb.ERRORS) == set(floors)
    for name, floor in floors.items():
        cls = getattr(rb, name)
        assert issubclass(cls, rb.RockbenchError) and cls.__name__ == name
        assert cls.__module__.split(".")[1] == list(FOLDERS)[floor].split(".")[1], cls.__module__
