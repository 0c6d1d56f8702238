"""Architecture rule: the data flows one way, and stages meet only through plain data.

    core -> surfaces -> flatten -> plan -> mapping -> psd (readers) -> dwell -> smooth -> schedule
         -> export / simulate / report
         -> config -> pipeline -> paper -> cli

Every module and package under ``src/polishpath`` is a unit of one of these
layers, and the rule below covers every unit, with no exception:

* the **core** (types, errors, meshops, pathops, progress, fileio, runfolder, _numba_cache,
  provenance, defaults, resources, _version) imports only the core;
* a **stage** imports the core and stages upstream of it (earlier in ORDER),
  never one downstream: a stage that needs a later stage's result is wrong
  about where it sits in the flow (the planner and the flattening do not use
  each other at all);
* the **wiring**: ``config`` (the job's options) imports only the core;
  ``pipeline`` (the one place stages are wired together) imports stages and config;
* on top: ``paper`` (the reproduction, built on the pipeline), ``cli`` (the
  command line), ``__main__`` and the package ``__init__``.

No two units import each other (no import circle), no two modules import each
other either, inside a package or across (a circle of modules, even through an
import inside a function, works only by the order the modules happen to load
in), and no module reaches outside the package for files (``Path(__file__).parents[...]`` into the
checkout): data folders come in as arguments.

How to fix a failure: move the shared code into polishpath/meshops.py (mesh
maths), polishpath/pathops.py (path maths) or polishpath/types.py (data), or
pass the data in from the polishpath/pipeline package; a new module or package gets its
place in ORDER (or CORE) here. A circle of modules inside a package: move what they share
down into a module of its own that both import (smooth/kernels.py, simulate/profile.py).
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "polishpath"
CORE = {"types", "errors", "meshops", "pathops", "progress", "fileio", "runfolder", "provenance", "defaults", "resources",
        "_version", "axes", "_numba_cache"}
# every other unit, upstream first; psd (measurement readers, PSD maths: core imports only) sits before
# dwell (figuring), which reads error maps with it
ORDER = ["surfaces", "flatten", "plan", "mapping", "psd", "dwell", "smooth", "schedule", "export", "simulate", "report",
         "config", "pipeline", "paper", "cli", "__main__", "__init__"]
# pairs (unit, upstream unit) that may not meet although the order would allow it
INDEPENDENT = {("plan", "flatten"), ("flatten", "surfaces"), ("plan", "surfaces")}
# the job's options need only the core: no stage is loaded to read a config
INDEPENDENT |= {("config", u) for u in ORDER[:ORDER.index("config")]}
ALLOWED = {st: {u for u in ORDER[:i] if (st, u) not in INDEPENDENT} for i, st in enumerate(ORDER)}


def stage_of(path: Path) -> str:
    rel = path.relative_to(SRC)
    return rel.parts[0].removesuffix(".py")


def imported_stages(path: Path) -> set[tuple[str, int]]:
    tree = ast.parse(path.read_text(), filename=str(path))
    pkg_depth = len(path.relative_to(SRC).parts) - 1  # 0 for polishpath/x.py
    out = set()
    for node in ast.walk(tree):
        names = []
        if isinstance(node, ast.ImportFrom):
            if node.level == 0:
                if node.module and node.module.startswith("polishpath"):
                    parts = node.module.split(".")[1:]
                    names.append(parts[0] if parts else None)
                    if not parts:
                        names.extend(a.name for a in node.names)
            else:
                up = node.level - 1  # levels above the current package
                if up > pkg_depth:
                    continue
                if up == pkg_depth:  # relative to polishpath/
                    if node.module:
                        names.append(node.module.split(".")[0])
                    else:
                        names.extend(a.name for a in node.names)
        elif isinstance(node, ast.Import):
            for a in node.names:
                if a.name.startswith("polishpath."):
                    names.append(a.name.split(".")[1])
        for n in names:
            if n:
                out.add((n, node.lineno))
    return out


def unit_files():
    for p in sorted(SRC.rglob("*.py")):
        if stage_of(p) not in CORE:
            yield p


@pytest.mark.parametrize("path", list(unit_files()), ids=lambda p: str(p.relative_to(SRC)))
def test_imports_follow_the_data_flow(path):
    st = stage_of(path)
    assert st in ALLOWED, f"{path.relative_to(SRC)} belongs to no layer: give {st!r} its place in ORDER or CORE"
    for name, line in imported_stages(path):
        if name == st or name in CORE:
            continue
        assert name in ALLOWED[st], (
            f"{path.relative_to(SRC)}:{line} imports polishpath.{name}, but {st} may only use "
            f"the core ({', '.join(sorted(CORE))}) and {sorted(ALLOWED[st]) or 'no other unit'}. "
            "Take the data as an argument (a polishpath.types dataclass) and wire the stages in "
            "the polishpath/pipeline package, or move shared maths into polishpath/meshops.py / pathops.py."
        )


def test_core_imports_only_the_core():
    for name in CORE:
        p = SRC / f"{name}.py"
        assert p.is_file(), f"core module {name}.py is listed in CORE but does not exist"
        for imp, line in imported_stages(p):
            assert imp in CORE, f"core module {name}.py:{line} imports {imp}; the core must not depend on stages."


def test_every_unit_has_a_layer():
    units = {p.name.removesuffix(".py") for p in SRC.iterdir()
             if (p.is_dir() and (p / "__init__.py").exists()) or p.suffix == ".py"}
    missing = units - set(ALLOWED) - CORE
    assert not missing, f"new unit(s) {sorted(missing)}: add them to ORDER (or CORE) in tests/test_architecture.py"
    assert not set(ALLOWED) & CORE


def test_no_import_circle():
    graph: dict[str, set[str]] = {}
    for p in SRC.rglob("*.py"):
        st = stage_of(p)
        graph.setdefault(st, set()).update(n for n, _ in imported_stages(p) if n != st)

    def visit(u, trail):
        for v in sorted(graph.get(u, ())):
            assert v not in trail, f"import circle: {' -> '.join([*trail, v])}"
            visit(v, [*trail, v])

    for u in sorted(graph):
        visit(u, [u])


def module_name(path: Path, root: Path = SRC) -> str:
    """Dotted name of a module file under ``root`` (a package's ``__init__.py`` is the package)."""
    parts = list(path.relative_to(root.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def module_imports(path: Path, modules: set[str], root: Path = SRC) -> set[tuple[str, int]]:
    """``(module, line)`` of every module of the package that ``path`` imports, anywhere in the file
    (an import inside a function closes a circle as surely as one at the top, only later).

    ``from .x import name`` is an import of module ``x`` (or of submodule ``x.name`` when there is one);
    ``from . import name`` of the submodule ``name``, else of the package's ``__init__``.
    """
    me = module_name(path, root)
    package = me if path.name == "__init__.py" else me.rpartition(".")[0]
    top = root.name
    out = set()
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        targets = []
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            targets = [f"{target}.{a.name}" if f"{target}.{a.name}" in modules else target for a in node.names]
        elif isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        out.update((t, node.lineno) for t in targets if t in modules and t != me and t.split(".")[0] == top)
    return out


def module_circles(root: Path = SRC) -> list[list[str]]:
    """The import circles between the modules under ``root``: the shortest circle through each module (its
    modules in import order, the first repeated at the end) that no circle found before passes through."""
    files = {module_name(p, root): p for p in sorted(root.rglob("*.py"))}
    graph = {m: {t for t, _ in module_imports(p, set(files), root)} for m, p in files.items()}
    circles, seen = [], set()
    for start in sorted(graph):
        if start in seen:
            continue
        # breadth-first from start: the shortest way back to it, if any
        prev, queue = {start: None}, [start]
        back = None
        while queue and back is None:
            nxt = []
            for u in queue:
                for v in sorted(graph[u]):
                    if v == start:
                        back = u
                        break
                    if v not in prev:
                        prev[v] = u
                        nxt.append(v)
                if back is not None:
                    break
            queue = nxt
        if back is None:
            continue
        trail = [back]
        while prev[trail[-1]] is not None:
            trail.append(prev[trail[-1]])
        circle = [*reversed(trail), start]
        seen.update(circle)
        circles.append(circle)
    return circles


def test_no_import_circle_between_modules():
    circles = module_circles()
    assert not circles, "import circle(s) between modules: " + "; ".join(" -> ".join(c) for c in circles) + (
        ". Move what the modules of a circle share down into a module of its own that each of them imports "
        "(as smooth/kernels.py holds the integrator kernels for smooth/interpolate.py and smooth/samples.py), "
        "or pass it in as an argument; an import moved into a function hides the circle, it does not remove it.")


def test_the_circle_rule_catches_a_circle_through_a_function(tmp_path):
    # the rule itself: a -> b at the top, b -> a inside a function, in a subpackage; c alone is no circle
    pkg = tmp_path / "polishpath" / "stage"
    pkg.mkdir(parents=True)
    (tmp_path / "polishpath" / "__init__.py").write_text("")
    (pkg / "__init__.py").write_text("from .a import f\n")
    (pkg / "a.py").write_text("from .b import g\nfrom .. import stage\n")
    (pkg / "b.py").write_text("def g():\n    from . import a\n    return a\n")
    (pkg / "c.py").write_text("from .a import f\nfrom polishpath.stage import b\n")
    root = tmp_path / "polishpath"
    assert module_imports(pkg / "c.py", {"polishpath.stage.a", "polishpath.stage.b"}, root) == {
        ("polishpath.stage.a", 1), ("polishpath.stage.b", 2)}
    assert module_circles(root) == [["polishpath.stage", "polishpath.stage.a", "polishpath.stage"],
                                    ["polishpath.stage.b", "polishpath.stage.a", "polishpath.stage.b"]]
    (pkg / "b.py").write_text("def g():\n    return 1\n")
    (pkg / "a.py").write_text("from .b import g\n")
    assert module_circles(root) == []


#: what stages pass on in typed fields (ToolPath.sample_pieces / piece_params, PlanarPath.lattice /
#: dwell_points_only), never as ``stats`` keys; runfolder.py, the format, alone names them as keys (run.npz
#: arrays, and the figures of a format 0-2 summary.json it still reads)
TYPED_KEYS = {"sample_pieces", "piece_params", "on_grid"}
#: dict methods that change a dict in place
MUTATING = {"update", "setdefault", "pop", "popitem", "clear", "__setitem__", "__delitem__"}


def stats_misuse(tree: ast.AST, module: str) -> list[tuple[int, str]]:
    """``(line, what)`` for each read or write of a :data:`TYPED_KEYS` key as a dict key, and each in-place
    change of an object's ``stats`` (``obj.stats[k] = v``, ``obj.stats.update(...)``; a local dict is free)."""
    out = []

    def key(node) -> str | None:
        typed = isinstance(node, ast.Constant) and node.value in TYPED_KEYS and module != "runfolder.py"
        return node.value if typed else None

    for node in ast.walk(tree):
        if isinstance(node, ast.Subscript) and key(node.slice):
            out.append((node.lineno, f"[{key(node.slice)!r}]"))
        elif isinstance(node, ast.Dict):
            out.extend((node.lineno, f"{{{key(k)!r}: ...}}") for k in node.keys if key(k))
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute):
            name = node.func.attr
            if name in ("get", "pop", "setdefault") and node.args and key(node.args[0]):
                out.append((node.lineno, f".{name}({key(node.args[0])!r})"))
            if name in ("update", "setdefault"):
                out.extend((node.lineno, f".{name}({kw.arg}=...)") for kw in node.keywords if key(ast.Constant(kw.arg)))
            owner = node.func.value
            if name in MUTATING and isinstance(owner, ast.Attribute) and owner.attr == "stats":
                out.append((node.lineno, f"<object>.stats.{name}(...)"))
        elif isinstance(node, (ast.Assign, ast.AugAssign, ast.Delete)):
            for t in node.targets if isinstance(node, (ast.Assign, ast.Delete)) else [node.target]:
                if isinstance(t, ast.Subscript) and isinstance(t.value, ast.Attribute) and t.value.attr == "stats":
                    out.append((node.lineno, "<object>.stats[...] = ..."))
    return out


@pytest.mark.parametrize("path", sorted(SRC.rglob("*.py")), ids=lambda p: str(p.relative_to(SRC)))
def test_stages_pass_data_in_typed_fields_and_change_no_stats(path):
    found = stats_misuse(ast.parse(path.read_text(), filename=str(path)), str(path.relative_to(SRC)))
    assert not found, (
        f"{path.relative_to(SRC)}: " + ", ".join(f"line {n}: {w}" for n, w in found) + ". What a later stage "
        "needs is a typed field (ToolPath.sample_pieces / piece_params, PlanarPath.lattice / dwell_points_only), "
        "not a stats key a reader could miss and fall back from; and a frozen object's stats is not changed "
        "after it is made: build a new one (dataclasses.replace(obj, stats={**obj.stats, ...})).")


def test_the_stats_rule_catches_keys_and_changes():
    bad = ast.parse("a = tp.stats.get('sample_pieces', [0, 1])\nb = st['piece_params']\n"
                    "s.update(on_grid=True)\nmapped.stats.update(x=1)\ntool.stats['y'] = 2\nd = {'on_grid': 1}")
    assert sorted(n for n, _ in stats_misuse(bad, "x.py")) == [1, 2, 3, 4, 5, 6]
    good = ast.parse("stats = {}\nstats['x'] = 1\nstats.update(y=2)\nn = tp.sample_pieces\n"
                     "new = replace(tp, stats={**tp.stats, 'z': 3})")
    assert stats_misuse(good, "x.py") == []
    assert stats_misuse(ast.parse("st.pop('sample_pieces', None)\na = {'piece_params': 1}"), "runfolder.py") == []
    assert len(stats_misuse(ast.parse("run.stats.update(x=1)"), "runfolder.py")) == 1


def _climbs_out(node: ast.AST, depth: int) -> int | None:
    """How far above polishpath/ a ``Path(__file__)`` expression climbs (None: it does not)."""
    # count .parent steps and the index of .parents[k] above a __file__ name
    steps, cur = 0, node
    while True:
        if isinstance(cur, ast.Attribute) and cur.attr == "parent":
            steps, cur = steps + 1, cur.value
        elif (isinstance(cur, ast.Subscript) and isinstance(cur.value, ast.Attribute) and cur.value.attr == "parents"
              and isinstance(cur.slice, ast.Constant) and isinstance(cur.slice.value, int)):
            steps, cur = steps + cur.slice.value + 1, cur.value.value
        elif isinstance(cur, (ast.Call, ast.Attribute)):
            cur = cur.func if isinstance(cur, ast.Call) else cur.value
        else:
            break
    uses_file = any(isinstance(n, ast.Name) and n.id == "__file__" for n in ast.walk(node))
    # from polishpath/a/b.py, depth 1: one step is a/, two are polishpath/, three leave the package
    return steps - depth - 1 if uses_file and steps > depth + 1 else None


@pytest.mark.parametrize("path", sorted(SRC.rglob("*.py")), ids=lambda p: str(p.relative_to(SRC)))
def test_no_module_reads_paths_outside_the_package(path):
    depth = len(path.relative_to(SRC).parts) - 1
    tree = ast.parse(path.read_text(), filename=str(path))
    for node in ast.walk(tree):
        if isinstance(node, (ast.Attribute, ast.Subscript)):
            out = _climbs_out(node, depth)
            assert out is None, (
                f"{path.relative_to(SRC)}:{node.lineno} climbs {out} folder(s) above the polishpath package from "
                "__file__ (into a checkout that a user's install does not have). Take the folder as an argument."
            )
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and node.value.startswith(("../", "/work/")):
            raise AssertionError(f"{path.relative_to(SRC)}:{node.lineno} names a path outside the package: {node.value!r}")


def test_the_path_rule_catches_a_climb(tmp_path):
    # the rule itself: parents[2] from polishpath/x.py leaves the package, parent of the file does not
    bad = ast.parse("Path(__file__).resolve().parents[2] / 'benchmarks'", mode="eval").body
    good = ast.parse("Path(__file__).resolve().parent / 'data'", mode="eval").body
    deep = ast.parse("Path(__file__).parent.parent.parent", mode="eval").body
    assert _climbs_out(bad.left, 0) == 2 and _climbs_out(good.left, 0) is None
    assert _climbs_out(deep, 1) == 1 and _climbs_out(deep, 2) is None
