"""End-to-end fuzzing of what a user writes (issue 7, item 5).

Whole TOML texts, mutated at the character, token and line level, go through
``load_case`` and then, when they load and their mesh is small, through the
checks made before any heavy work (``preflight.build_mesh`` + ``preflight.preflight``):
nothing may escape but our documented :class:`XfcError` with a one-line,
printable message naming the case file.  Formulas (hostile ones included) are
fuzzed in place in a case file the same way.  tests/test_case.py fuzzes the
parsed documents and tests/test_formula.py the formula compiler alone.

Budget: ``max_examples = 200`` per test, no deadline, no example database.
"""
import re
import tempfile
from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from xfemcontact import preflight
from xfemcontact.case import Case, load_case
from xfemcontact.errors import XfcError
from conftest import SHARED_MESHES

DATA = Path(__file__).parent / "data" / "cases"
TEXTS = {p.stem: p.read_text() for p in sorted(DATA.glob("*.toml"))}
# the mesh file of ssnv509a_mesh.toml, absolute so that the case can be written anywhere
TEXTS["ssnv509a_mesh"] = re.sub(r'file = "[^"]*"', f'file = "{SHARED_MESHES / "ssnv509a.mmed"}"',
                                TEXTS["ssnv509a_mesh"])

FUZZ = settings(max_examples=200, deadline=None, database=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                       HealthCheck.filter_too_much])

TOKENS = ["=", "[", "]", "[[", "]]", "{", "}", ",", '"', "'", "'''", '"""', "#", "\n", ".",
          "-", "+", "0", "1e400", "nan", "inf", "-inf", "true", "false", "1979-05-27",
          "0x1F", "1_000", "\\", "\\u0000", "\u2028", "\x00", "\t", " ", "é", "mesh", "material",
          "dirichlet", "interface", "contact", "test", "E", "nu", "DX", "DY", "group",
          "level_set", "law", "free", "bonded", "LIG1", "P1", "SURF", "nx", "ny", "refine",
          "x", "y", "1/0", "(", ")", "**", "__import__('os')", "x.__class__", "lambda: 0"]
FORMULAS = ["x", "y", "x+y", "1/(x-5)", "sqrt(x-5)", "log(y)", "(y-5)**2", "-(y-5)**2",
            "x*y-20", "sign(x-5)*(y-5)", "max(x,y)-5", "min(x-5,0)", "1e308*1e308", "0",
            "__import__('os')", "x.real", "y[0]", "(lambda: 1)()", "[x for x in y]",
            "(" * 60 + "x" + ")" * 60, "x+" * 1200 + "x", "9**9**9", "pi*e", "atan2(y,x)-1",
            "exp(x)", "hypot(x-5,y-5)-3", "x if y else 0", "x @ y", "x ^ y", "not x", "x < y",
            "", " ", "1e-320*x", "-0.0", "floor(x)-ceil(y)", "abs(x-5)-abs(y-5)"]


def _check(path, text_loaded):
    """load_case(path), then the pre-run checks when the mesh is small; XfcError only."""
    try:
        case = load_case(path)
        assert isinstance(case, Case)
        rect = case.mesh.rectangle
        small = (case.mesh.file is None and rect["nx"] * rect["ny"] <= 400
                 and case.mesh.refine <= 1)
        if small:
            raw = preflight.build_mesh(case)
            pre = preflight.preflight(case, raw)
            assert all("\n" not in w for w in pre.warnings)
    except XfcError as exc:
        message = str(exc)
        assert message.startswith(f"{path}: "), message
        assert "\n" not in message and message.isprintable(), message


def _mutate(text, data):
    """One random edit of ``text``: characters, tokens or whole lines."""
    op = data.draw(st.sampled_from(["delete", "insert", "replace", "line-drop", "line-dup",
                                    "line-swap", "number"]), label="op")
    lines = text.split("\n")
    if op.startswith("line") and len(lines) > 1:
        i = data.draw(st.integers(0, len(lines) - 1), label="line")
        if op == "line-drop":
            del lines[i]
        elif op == "line-dup":
            lines.insert(i, lines[i])
        else:
            j = data.draw(st.integers(0, len(lines) - 1), label="other line")
            lines[i], lines[j] = lines[j], lines[i]
        return "\n".join(lines)
    if op == "number":
        numbers = list(re.finditer(r"-?\d+(\.\d+)?([eE][-+]?\d+)?", text))
        if numbers:
            m = data.draw(st.sampled_from(numbers), label="number")
            new = data.draw(st.sampled_from(["0", "-1", "1e400", "0.5", "-0.0", "2.5", "12",
                                             "10001", "1e-300", '"1"', "nan", "true"]))
            return text[:m.start()] + new + text[m.end():]
    at = data.draw(st.integers(0, len(text)), label="at")
    if op == "delete":
        return text[:at] + text[at + data.draw(st.integers(1, 20), label="length"):]
    piece = data.draw(st.sampled_from(TOKENS) | st.text(max_size=6), label="piece")
    if op == "insert":
        return text[:at] + piece + text[at:]
    return text[:at] + piece + text[at + len(piece):]


@FUZZ
@given(name=st.sampled_from(sorted(TEXTS)), data=st.data())
def test_fuzz_case_texts(name, data):
    text = TEXTS[name]
    for _ in range(data.draw(st.integers(1, 4), label="edits")):
        text = _mutate(text, data)
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "case.toml"
        path.write_text(text, encoding="utf-8", errors="surrogatepass")
        _check(path, text)


@FUZZ
@given(data=st.data())
def test_fuzz_random_bytes(data):
    raw = data.draw(st.binary(max_size=300) | st.text(max_size=300).map(
        lambda t: t.encode("utf-8", "surrogatepass")))
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "case.toml"
        path.write_bytes(raw)
        _check(path, raw)


@FUZZ
@given(name=st.sampled_from(["elastic_rectangle", "ssnv509_interface"]),
       key=st.sampled_from(["level_set", "DX", "DY", "FY", "PRES", "where"]),
       formula=st.sampled_from(FORMULAS) | st.text(max_size=40)
       | st.lists(st.sampled_from(["x", "y", "1", "0", "+", "-", "*", "/", "**", "(", ")",
                                   "sqrt(", "log(", ",", "e", "pi", "x0", "<", "and"]),
                  max_size=12).map("".join))
def test_fuzz_formulas_in_case_files(name, key, formula):
    """A formula put in place of every formula-valued key of a case, then checked at the nodes."""
    text = TEXTS[name]
    quoted = '"' + formula.replace("\\", "\\\\").replace('"', '\\"') + '"'
    quoted = "".join(c if c.isprintable() or c == " " else f"\\u{ord(c):04x}" for c in quoted)
    pattern = rf'^({key} = )(".*"|[-0-9.e]+)$'
    text, count = re.subn(pattern, lambda m: m.group(1) + quoted, text, flags=re.M)
    if key == "level_set" and count == 0:
        text += f"\n[interface]\nlevel_set = {quoted}\nlaw = \"free\"\n"
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "case.toml"
        path.write_text(text, encoding="utf-8")
        _check(path, text)
