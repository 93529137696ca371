"""No import loop among the modules of a package: each module's imports of the package's other
modules (at any depth in the module, function bodies included, sub-packages too) form a graph
without cycles; and validation's sub-packages import one way, the CLI on top and common/ at
the bottom. No module is over MAX_MODULE_LINES lines."""

import ast
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("dr", "fem_reference", "scenes", "results", "validation")


def modules(package: str) -> dict[str, Path]:
    """The modules of ``package`` by dotted name inside it ('report.plan'; a sub-package by its
    own name, from its ``__init__``)."""
    found = {}
    for path in (ROOT / package).rglob("*.py"):
        parts = path.relative_to(ROOT / package).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        if name:
            found[name] = path
    return found


def package_imports(package: str, path: Path, names: set[str]) -> set[str]:
    """The modules of ``package`` (dotted names in ``names``) that the module at ``path`` imports."""
    inside = list(path.relative_to(ROOT / package).parent.parts)
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text())):
        targets: list[list[str]] = []
        if isinstance(node, ast.ImportFrom):
            module = (node.module or "").split(".") if node.module else []
            if node.level:
                base = inside[:len(inside) - (node.level - 1)] + module
            elif module and module[0] == package:
                base = module[1:]
            else:
                continue
            targets = [base + [a.name] for a in node.names]
        elif isinstance(node, ast.Import):
            targets = [a.name.split(".")[1:] for a in node.names if a.name.startswith(package + ".")]
        for target in targets:
            # the longest prefix that is a module: 'from .plan import Run' names plan, 'from . import plan' plan
            for n in range(len(target), 0, -1):
                if ".".join(target[:n]) in names:
                    found.add(".".join(target[:n]))
                    break
    return found


def import_graph(package: str) -> dict[str, set[str]]:
    files = modules(package)
    return {name: package_imports(package, path, set(files)) - {name} for name, path in files.items()}


def cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One cycle of ``graph`` (its modules in order), or None."""
    state: dict[str, int] = {}  # 1: on the current path, 2: done

    def visit(node: str, path: list[str]) -> list[str] | None:
        state[node] = 1
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                return path[path.index(nxt):] + [nxt]
            if nxt not in state and (found := visit(nxt, path + [nxt])):
                return found
        state[node] = 2
        return None

    for start in sorted(graph):
        if start not in state and (found := visit(start, [start])):
            return found
    return None


@pytest.mark.parametrize("package", PACKAGES)
def test_no_import_cycle_among_a_packages_modules(package):
    graph = import_graph(package)
    assert cycle(graph) is None, f"import loop in {package}: {' -> '.join(cycle(graph))}"


def test_validation_sub_packages_import_one_way():
    """At least four sub-packages; between them no loop; the CLI's top-level modules imported by
    none of them; ``common`` importing no other."""
    graph = import_graph("validation")
    sub_packages = {name for name in graph if "." not in name and (ROOT / "validation" / name).is_dir()}
    assert len(sub_packages - {"common"}) >= 4, sub_packages

    def home(module: str) -> str:
        top = module.split(".")[0]
        return top if top in sub_packages else "cli"

    layers: dict[str, set[str]] = {}
    for module, imported in graph.items():
        layers.setdefault(home(module), set()).update(home(m) for m in imported if home(m) != home(module))
    assert cycle(layers) is None, f"sub-packages import in a loop: {' -> '.join(cycle(layers))}"
    assert not [p for p, imported in layers.items() if "cli" in imported], layers
    assert layers.get("common", set()) == set(), layers["common"]


def test_the_check_finds_a_cycle():
    assert cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert cycle({"a": {"b"}, "b": set()}) is None


def test_the_graph_resolves_relative_imports_across_sub_packages(tmp_path, monkeypatch):
    """'from ..common.tables import x' in report/plan.py is an edge report.plan -> common.tables,
    'from . import plan' in report/validate.py one to report.plan."""
    pkg = tmp_path / "pkg"
    for rel, text in {"__init__.py": "", "common/__init__.py": "", "common/tables.py": "",
                      "report/__init__.py": "", "report/plan.py": "from ..common.tables import x\n",
                      "report/validate.py": "from . import plan\nimport pkg.common.tables\n"}.items():
        (pkg / rel).parent.mkdir(parents=True, exist_ok=True)
        (pkg / rel).write_text(text)
    monkeypatch.setattr(sys.modules[__name__], "ROOT", tmp_path)
    graph = import_graph("pkg")
    assert graph["report.plan"] == {"common.tables"}
    assert graph["report.validate"] == {"report.plan", "common.tables"}


MAX_MODULE_LINES = 500
"""Longest module of the five packages: a module past it holds more than one job."""


@pytest.mark.parametrize("package", PACKAGES)
def test_no_module_is_over_the_line_limit(package):
    long = {name: n for name, path in modules(package).items()
            if (n := len(path.read_text().splitlines())) > MAX_MODULE_LINES}
    assert not long, f"modules over {MAX_MODULE_LINES} lines (split them along their jobs): {long}"
