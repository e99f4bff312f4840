"""The package's layout: every module imports, and the imports between modules form
no circle (module-level and deferred imports alike), so that each room of the
package depends only on rooms below it (ARCHITECTURE.md)."""
import ast
import importlib
import pathlib

import pytest

from conftest import ROOT

PACKAGE = ROOT / "xfemcontact"


def modules():
    """Dotted names of every module of the package."""
    out = []
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(ROOT).with_suffix("").parts
        out.append(".".join(parts[:-1] if parts[-1] == "__init__" else parts))
    return out


def imports(name):
    """The package modules ``name`` imports, at module level or inside functions."""
    path = ROOT / pathlib.Path(*name.split("."))
    path = path / "__init__.py" if path.is_dir() else path.with_suffix(".py")
    known = set(modules())
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            subs = {f"{node.module}.{a.name}" for a in node.names}
            found.update(subs & known)
            if subs - known:            # names defined by the module (or package) itself
                found.add(node.module)
    return {m for m in found if m in known and m != name}


@pytest.mark.parametrize("name", [m for m in modules() if not m.endswith("__main__")])
def test_every_module_imports(name):
    importlib.import_module(name)


def test_no_import_circles():
    graph = {m: imports(m) for m in modules()}
    # a package's __init__ is imported with any of its modules: an edge to the
    # package itself is an edge to what its __init__ imports
    circles, index, low, stack, on, counter = [], {}, {}, [], set(), [0]

    def visit(v):                                  # Tarjan's strongly connected components
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                circles.append(sorted(component))

    for v in graph:
        if v not in index:
            visit(v)
    assert not circles, circles


def test_no_law_is_named_outside_its_module():
    """Laws are asked what they do (zero_jump, separate_bodies, multipliers), never
    compared by name."""
    for path in PACKAGE.rglob("*.py"):
        text = path.read_text()
        assert "law ==" not in text and "law !=" not in text, path
