"""Architecture rule: the data flows one way, and stages meet only through plain data.

surface -> flatten -> plan -> map -> smooth -> export / simulate / report -> paper

Each stage may import the core (types, errors, meshops, pathops, progress, _version) and
stages upstream of it (earlier in ORDER), never a stage downstream: a stage
that needs a later stage's result is wrong about where it sits in the flow.
Stages exchange plain data (the dataclasses of polishpath.types).

How to fix a failure: move the shared code into polishpath/meshops.py (mesh
maths), polishpath/pathops.py (path maths) or polishpath/types.py (data), or pass the data in from
polishpath/pipeline.py, which is the one place allowed to wire stages together.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "polishpath"
CORE = {"types", "errors", "meshops", "pathops", "progress", "fileio", "runfolder", "provenance", "defaults", "_version"}
# the wiring (config: the job's options, pipeline: the one place stages meet) sits above every stage;
# the paper reproduction above it
ORDER = ["surfaces", "flatten", "plan", "mapping", "smooth", "export", "psd", "simulate", "report", "config", "pipeline", "paper"]
# the planner and flattening do not need each other's code either way: both take plain data
INDEPENDENT = {("plan", "flatten"), ("flatten", "surfaces"), ("plan", "surfaces")}
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


def stage_files():
    for p in sorted(SRC.rglob("*.py")):
        st = stage_of(p)
        if st in ALLOWED:
            yield p


@pytest.mark.parametrize("path", list(stage_files()), ids=lambda p: str(p.relative_to(SRC)))
def test_stage_imports_follow_the_data_flow(path):
    st = stage_of(path)
    for name, line in imported_stages(path):
        if name == st or name in CORE:
            continue
        assert name in ALLOWED[st], (
            f"{path.relative_to(SRC)}:{line} imports polishpath.{name}, but the {st} stage may only use "
            f"the core ({', '.join(sorted(CORE))}) and {sorted(ALLOWED[st]) or 'no other stage'}. "
            "Take the data as an argument (a polishpath.types dataclass) and wire the stages in "
            "polishpath/pipeline.py, or move shared maths into polishpath/meshops.py."
        )


def test_core_imports_no_stage():
    for name in CORE:
        p = SRC / f"{name}.py"
        for imp, line in imported_stages(p):
            assert imp in CORE, f"core module {name}.py:{line} imports stage {imp}; the core must not depend on stages."


def test_every_stage_is_covered_by_the_rule():
    stages = {p.name for p in SRC.iterdir() if p.is_dir() and not p.name.startswith("__")}
    missing = stages - set(ALLOWED)
    assert not missing, f"new stage(s) {missing}: add them to ALLOWED in tests/test_architecture.py with their allowed imports"
