"""The package reads top-down: a layer imports only layers below it (and itself).

Every ``import``/``from … import`` in every module counts, function-level ones included —
a deferred import that dodges a cycle is still an arrow back up."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PKG = Path(__file__).resolve().parents[1] / "daebench"

# bottom to top; a module may import its own layer and any layer listed before it
LAYERS = ["core", "stepping", "models", "integrators", "driver", "harness", "workflows", "peers", "studies", "api",
          "cli"]
RANK = {name: i for i, name in enumerate(LAYERS)}


def layer_of(module: str) -> str | None:
    parts = module.split(".")
    if parts[0] != "daebench" or len(parts) < 2:
        return None
    return parts[1] if parts[1] in RANK else None


def imports_of(path: Path, root: Path = PKG) -> list[tuple[int, str]]:
    rel = path.relative_to(root.parent).with_suffix("")
    here = ".".join(rel.parts)
    found = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found += [(node.lineno, a.name) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:  # relative: resolve against this module's package
                base = here.split(".")[: -node.level]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            found.append((node.lineno, mod))
            if mod == "daebench":  # `from daebench import x`: x is a layer or an API name
                found += [(node.lineno, f"daebench.{a.name}") for a in node.names]
    return found


def upward_imports(root: Path = PKG) -> list[str]:
    bad = []
    for path in sorted(root.rglob("*.py")):
        own = layer_of(".".join(path.relative_to(root.parent).with_suffix("").parts))
        if own is None:
            continue
        for line, mod in imports_of(path, root):
            target = layer_of(mod)
            if target is not None and RANK[target] > RANK[own]:
                bad.append(f"{path.relative_to(root.parent)}:{line} ({own}) imports {mod} ({target})")
    return bad


def test_every_module_belongs_to_a_layer():
    top = sorted(p.name for p in PKG.iterdir() if p.suffix == ".py" or (p.is_dir() and (p / "__init__.py").exists()))
    stray = [n for n in top if n.removesuffix(".py") not in RANK and n != "__init__.py"]
    assert stray == [], f"top-level modules outside the layers: {stray}"
    assert len([n for n in top if n.endswith(".py")]) <= 10


def test_no_import_reaches_up_a_layer():
    assert upward_imports() == []


def test_the_check_catches_an_upward_import(tmp_path):
    fake = tmp_path / "daebench"
    (fake / "core").mkdir(parents=True)
    (fake / "core" / "bad.py").write_text("def f():\n    from daebench.harness import runner\n")
    (fake / "harness").mkdir()
    (fake / "harness" / "ok.py").write_text("from daebench.core import bad\n")
    assert upward_imports(fake) == ["daebench/core/bad.py:2 (core) imports daebench.harness (harness)"]


@pytest.mark.parametrize("pkg", [p for p in LAYERS if p != "api"])
def test_each_layer_says_what_lives_there(pkg):
    doc = ast.get_docstring(ast.parse((PKG / pkg / "__init__.py").read_text()))
    assert doc and "import" in doc, f"daebench/{pkg}/__init__.py should say what lives there and what it may import"


def module_graph(root: Path = PKG) -> dict[str, set[str]]:
    """module → the daebench modules it imports (``from pkg import mod`` counts as ``pkg.mod``)."""
    names = {".".join(p.relative_to(root.parent).with_suffix("").parts).removesuffix(".__init__")
             for p in root.rglob("*.py")}
    graph: dict[str, set[str]] = {}
    for path in root.rglob("*.py"):
        here = ".".join(path.relative_to(root.parent).with_suffix("").parts).removesuffix(".__init__")
        edges = set()
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            mods = []
            if isinstance(node, ast.Import):
                mods = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and not node.level and node.module:
                mods = [node.module] + [f"{node.module}.{a.name}" for a in node.names]
            for m in mods:
                while m and m not in names:
                    m = m.rpartition(".")[0]
                if m and m != here and not here.startswith(m + ".") and m.count(".") > 0:
                    edges.add(m)
        graph[here] = {e for e in edges if not e.endswith("daebench")}
    return graph


def import_cycles(root: Path = PKG) -> list[list[str]]:
    """The strongly connected groups of more than one module (Tarjan)."""
    graph, index, low, stack, on, out = module_graph(root), {}, {}, [], set(), []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            group = []
            while True:
                w = stack.pop()
                on.discard(w)
                group.append(w)
                if w == v:
                    break
            if len(group) > 1:
                out.append(sorted(group))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def test_no_import_circle_between_modules():
    assert import_cycles() == []


def test_the_circle_check_catches_a_circle(tmp_path):
    fake = tmp_path / "daebench" / "harness"
    fake.mkdir(parents=True)
    (fake / "a.py").write_text("from daebench.harness import b\n")
    (fake / "b.py").write_text("def f():\n    from daebench.harness.a import x\n")
    (fake / "c.py").write_text("from daebench.harness import a\n")
    assert import_cycles(tmp_path / "daebench") == [["daebench.harness.a", "daebench.harness.b"]]


# ---- the API is the only door; imports inside functions are documented lazy loads ------------------
#: the floors whose imports inside functions are checked (the lower ones import at the top, and the
#: command line may defer its imports so that `daebench --help` stays quick)
UPPER = ("harness", "workflows", "studies", "api")
LAZY = "lazy:"


def cli_imports(root: Path = PKG) -> list[str]:
    """Every import in ``cli/`` of a daebench module other than :mod:`daebench.api`, the
    command line's own modules and the package top (for its version)."""
    bad = []
    for path in sorted((root / "cli").rglob("*.py")):
        for line, mod in imports_of(path, root):
            if mod.startswith("daebench") and mod != "daebench" and not mod.startswith(("daebench.api",
                                                                                       "daebench.cli")):
                bad.append(f"{path.relative_to(root.parent)}:{line} imports {mod}")
    return bad


def test_the_command_line_calls_only_the_api():
    assert cli_imports() == []


def test_the_cli_check_catches_a_harness_import(tmp_path):
    fake = tmp_path / "daebench" / "cli"
    fake.mkdir(parents=True)
    (fake / "cmd.py").write_text("def f():\n    from daebench import api\n    from daebench.harness import x\n"
                                 "    from daebench.studies.perf import suite\n")
    assert cli_imports(tmp_path / "daebench") == ["daebench/cli/cmd.py:3 imports daebench.harness",
                                                  "daebench/cli/cmd.py:4 imports daebench.studies.perf"]


def undocumented_inner_imports(root: Path = PKG, floors: tuple[str, ...] = UPPER) -> list[str]:
    """Imports inside a function of the upper floors and the package's own ``__init__``
    without a ``lazy:`` comment on their line saying what is loaded lazily (each once)."""
    bad = []
    paths = [root / "__init__.py"] + [p for f in floors for p in sorted((root / f).rglob("*.py"))]
    for path in paths:
        if not path.exists():
            continue
        text = path.read_text()
        lines = text.splitlines()
        for top in ast.walk(ast.parse(text, str(path))):
            if not isinstance(top, (ast.FunctionDef, ast.AsyncFunctionDef)):
                continue
            for node in ast.walk(top):
                if isinstance(node, (ast.Import, ast.ImportFrom)) and LAZY not in lines[node.lineno - 1]:
                    bad.append(f"{path.relative_to(root.parent)}:{node.lineno}: {lines[node.lineno - 1].strip()}")
    return sorted(set(bad))


def test_imports_inside_functions_are_documented_lazy_loads():
    assert undocumented_inner_imports() == []


def test_the_lazy_check_catches_an_undocumented_one(tmp_path):
    fake = tmp_path / "daebench" / "harness"
    fake.mkdir(parents=True)
    (fake / "m.py").write_text("import os\n\ndef f():\n    import json\n    import rich  # lazy: a terminal's bar\n")
    assert undocumented_inner_imports(tmp_path / "daebench", ("harness",)) == ["daebench/harness/m.py:4: import json"]


def test_param_error_is_importable_from_the_package():
    from daebench import ParamError
    from daebench.core.params import ParamError as Core

    assert ParamError is Core
