"""The package's public API is typed: every public function, method and class
(name not starting with ``_``, plus ``__init__``) carries annotations on its
parameters and its return value.

The walk covers the whole package and lists what is missing (``python
tests/test_typing.py``); the assertion is on the files in TYPED: every file.
``make lint`` runs mypy on the package (mypy.ini) and pyflakes."""
import ast

from conftest import ROOT

PACKAGE = ROOT / "xfemcontact"

# files (relative to the package) whose public API must be fully annotated: all of them
TYPED = ["**/*.py"]


def _public(name):
    return not name.startswith("_") or name == "__init__"


def _missing_in_function(node):
    """What ``node`` (a def) lacks: its unannotated parameters and its return."""
    args = node.args
    params = args.posonlyargs + args.args + args.kwonlyargs
    if params and params[0].arg in ("self", "cls"):
        params = params[1:]
    missing = [a.arg for a in params if a.annotation is None]
    missing += [f"*{a.arg}" for a in (args.vararg, args.kwarg)
                if a is not None and a.annotation is None]
    if node.returns is None:
        missing.append("return")
    return missing


def unannotated(path):
    """``(line, qualified name, missing)`` for the public defs of ``path`` lacking
    annotations. Only module-level functions, classes and the methods of public
    classes count; functions nested in functions are private by nature."""
    out = []

    def visit(body, prefix):
        for node in body:
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                if _public(node.name):
                    missing = _missing_in_function(node)
                    if missing:
                        out.append((node.lineno, prefix + node.name, missing))
            elif isinstance(node, ast.ClassDef) and _public(node.name):
                visit(node.body, prefix + node.name + ".")
            elif isinstance(node, ast.If):          # e.g. TYPE_CHECKING blocks
                visit(node.body + node.orelse, prefix)

    visit(ast.parse(path.read_text()).body, "")
    return out


def report():
    """Every public def of the package without full annotations, by file."""
    found = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        items = unannotated(path)
        if items:
            found[path.relative_to(PACKAGE).as_posix()] = items
    return found


def typed_files():
    return {p.relative_to(PACKAGE).as_posix()
            for pattern in TYPED for p in PACKAGE.glob(pattern)}


def test_typed_files_exist():
    for pattern in TYPED:
        assert list(PACKAGE.glob(pattern)), pattern


def test_public_api_annotated():
    typed = typed_files()
    missing = {f: items for f, items in report().items() if f in typed}
    lines = [f"{f}:{line}: {name} lacks {', '.join(what)}"
             for f, items in sorted(missing.items()) for line, name, what in items]
    assert not lines, "unannotated public API:\n" + "\n".join(lines)


def test_walk_finds_unannotated(tmp_path):
    src = tmp_path / "m.py"
    src.write_text(
        "def f(a, b: int) -> int: ...\n"
        "def g(a: int): ...\n"
        "def _h(a): ...\n"
        "class C:\n"
        "    def __init__(self, x): ...\n"
        "    def m(self, *args: int, **kw) -> None: ...\n"
        "    def _p(self, y): ...\n"
        "    def ok(self, z: float) -> float: ...\n"
        "class _D:\n"
        "    def m(self, q): ...\n")
    assert [(name, what) for _, name, what in unannotated(src)] == [
        ("f", ["a"]), ("g", ["return"]), ("C.__init__", ["x", "return"]),
        ("C.m", ["*kw"])]


if __name__ == "__main__":
    for f, items in report().items():
        for line, name, what in items:
            print(f"{f}:{line}: {name} lacks {', '.join(what)}")
