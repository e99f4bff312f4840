"""Tests of xfemcontact.case.formula: correctness, refusals, evaluation errors, fuzzing."""
import ast
import functools
import inspect

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from xfemcontact.case import formula as formula_module
from xfemcontact.case.formula import Condition, Formula, compile_condition, compile_formula
from xfemcontact.errors import FormulaError, XfcError

X = np.linspace(-4.0, 6.0, 11)[:, None]
Y = np.linspace(0.0, 12.0, 7)[None, :]
PARAMS = {"x0": 5.0, "y0": 11.77, "r2": 64.27}
FUZZ = settings(max_examples=300, deadline=None, database=None,
                suppress_health_check=[HealthCheck.too_slow])
GRAMMAR_FUZZ = settings(FUZZ, max_examples=150)


def refused(text, fragment, **kwargs):
    """Compile ``text``, expect a one-line FormulaError containing ``fragment``."""
    with pytest.raises(FormulaError) as info:
        compile_formula(text, **kwargs)
    message = str(info.value)
    assert fragment in message
    assert "\n" not in message


# --- correctness ---------------------------------------------------------------------------

CASES = [
    ("(x-5)**2 + (y-11.77)**2 - 64.27", lambda x, y: (x - 5) ** 2 + (y - 11.77) ** 2 - 64.27),
    ("2*x - 3*y + 1", lambda x, y: 2 * x - 3 * y + 1),
    ("-x**2", lambda x, y: -(x**2)),
    ("2**3**2 + 0*x", lambda x, y: 512.0 + 0 * x),
    ("2**-1 * x", lambda x, y: 0.5 * x),
    ("1 - 2 - 3 + 8 / 2 / 2 + x", lambda x, y: -2.0 + x),
    ("+x - -y", lambda x, y: x + y),
    ("atan2(y, x)", lambda x, y: np.arctan2(y, x)),
    ("min(x, y, 3)", lambda x, y: np.minimum(np.minimum(x, y), 3)),
    ("max(x, 2*y)", lambda x, y: np.maximum(x, 2 * y)),
    ("sqrt(x**2 + y**2) - hypot(x, y)", lambda x, y: np.sqrt(x**2 + y**2) - np.hypot(x, y)),
    ("exp(-((x-1)**2 + y**2) / 4)", lambda x, y: np.exp(-((x - 1) ** 2 + y**2) / 4)),
    ("sin(pi*x/10) * cos(y)", lambda x, y: np.sin(np.pi * x / 10) * np.cos(y)),
    ("log(1 + x**2) + log10(1 + y)", lambda x, y: np.log(1 + x**2) + np.log10(1 + y)),
    ("abs(x) + sign(x - 1)", lambda x, y: np.abs(x) + np.sign(x - 1)),
    ("floor(x / 3) + ceil(y / 5)", lambda x, y: np.floor(x / 3) + np.ceil(y / 5)),
    ("tanh(x) + sinh(x/4) + cosh(y/6)", lambda x, y: np.tanh(x) + np.sinh(x / 4) + np.cosh(y / 6)),
    ("tan(x/10) + atan(y) + asin(x/10) + acos(y/12)",
     lambda x, y: np.tan(x / 10) + np.arctan(y) + np.arcsin(x / 10) + np.arccos(y / 12)),
    ("sqrt(sqrt(abs(sin(x)) + 1)) * max(min(x, y), -1)",
     lambda x, y: np.sqrt(np.sqrt(np.abs(np.sin(x)) + 1)) * np.maximum(np.minimum(x, y), -1)),
    ("e**x + 1_000 * 1e-3 * y", lambda x, y: np.e**x + y),
    ("(x\n - 1) * y  # a comment", lambda x, y: (x - 1) * y),
]


@pytest.mark.parametrize("text, reference", CASES, ids=[case[0] for case in CASES])
def test_formula_matches_numpy(text, reference):
    f = compile_formula(text)
    result = f(x=X, y=Y)
    assert result.dtype == np.float64 and result.shape == (11, 7)
    np.testing.assert_allclose(result, np.broadcast_to(reference(X, Y), (11, 7)),
                               rtol=1e-13, atol=1e-13)


def test_params_level_set_equals_literal_one():
    with_params = compile_formula("(x-x0)**2 + (y-y0)**2 - r2", PARAMS)
    literal = compile_formula("(x-5)**2 + (y-11.77)**2 - 64.27")
    np.testing.assert_array_equal(with_params(x=X, y=Y), literal(x=X, y=Y))
    assert with_params.names == {"x", "y"} and not with_params.is_constant


def test_broadcasting_array_and_scalar():
    f = compile_formula("x + 10*y")
    result = f(x=np.arange(5.0), y=2)
    np.testing.assert_array_equal(result, np.arange(5.0) + 20)
    assert f(x=1, y=2).shape == ()


def test_names_and_constants():
    f = compile_formula("2*x + 1")
    assert isinstance(f, Formula) and f.text == "2*x + 1" and f.names == {"x"}
    c = compile_formula("2*pi*e")
    assert c.is_constant and c.names == frozenset()
    assert c.value() == pytest.approx(2 * np.pi * np.e)
    full = c(x=np.zeros((3, 4)), y=0)
    assert full.shape == (3, 4) and np.all(full == c.value())
    full[0, 0] = 0.0  # a writable array of its own
    assert compile_formula(3).value() == 3.0
    assert compile_formula(2.5)(x=[1, 2]).tolist() == [2.5] * 2
    assert compile_formula("1 + 1")().shape == ()
    with pytest.raises(FormulaError, match="expected a constant"):
        f.value()


def test_other_variables():
    f = compile_formula("2*t + s", variables=("s", "t"))
    assert f(s=1.0, t=np.array([1.0, 2.0])).tolist() == [3.0, 5.0]
    with pytest.raises(FormulaError, match="unknown name 'x'"):
        compile_formula("x", variables=("s", "t"))


def test_wrong_call_arguments_are_programming_errors():
    f = compile_formula("x + y")
    with pytest.raises(TypeError):
        f(x=1.0)
    with pytest.raises(TypeError):
        f(x=1.0, y=2.0, z=3.0)


# --- conditions ----------------------------------------------------------------------------

@pytest.mark.parametrize("text, reference", [
    ("x <= 5", lambda x, y: x <= 5),
    ("0 <= x <= 5", lambda x, y: (0 <= x) & (x <= 5)),
    ("x < 2 or y > 3", lambda x, y: (x < 2) | (y > 3)),
    ("not (x > 1)", lambda x, y: ~(x > 1)),
    ("x >= 0 and y != 4 and not x == 2", lambda x, y: (x >= 0) & (y != 4) & (x != 2)),
    ("(x-x0)**2 + (y-y0)**2 < r2", lambda x, y: (x - 5) ** 2 + (y - 11.77) ** 2 < 64.27),
])
def test_condition_matches_numpy(text, reference):
    c = compile_condition(text, PARAMS)
    assert isinstance(c, Condition)
    result = c(x=X, y=Y)
    assert result.dtype == np.bool_ and result.shape == (11, 7)
    np.testing.assert_array_equal(result, np.broadcast_to(reference(X, Y), (11, 7)))


def test_constant_condition_broadcasts():
    c = compile_condition("1 < 2")
    assert c.is_constant and c(x=np.zeros(4), y=0).tolist() == [True] * 4


@pytest.mark.parametrize("text, fragment", [
    ("x + 1", "expected a condition, got a number"),
    ("(x > 1) + 1", "expected a number, got a condition"),
    ("x in y", "operator 'in' is not allowed"),
    ("x is y", "operator 'is' is not allowed"),
    ("x < 1 < z", "unknown name 'z'"),
])
def test_condition_refusals(text, fragment):
    with pytest.raises(FormulaError, match=fragment):
        compile_condition(text)


def test_condition_with_invalid_operand_names_the_point():
    c = compile_condition("sqrt(x) > 1", source="case.toml", key="contact.where")
    with pytest.raises(FormulaError) as info:
        c(x=np.array([4.0, -1.0]), y=0.0)
    assert str(info.value) == ("case.toml: contact.where: "
                               "division by zero or invalid value at x=-1, y=0")


@pytest.mark.parametrize("text, fragment", [
    ("x < 1", "comparisons are only allowed in conditions"),
    ("x and y", "'and' is only allowed in conditions"),
    ("not x", "'not' is only allowed in conditions"),
])
def test_conditions_only_in_conditions(text, fragment):
    refused(text, fragment)


# --- refusals ------------------------------------------------------------------------------

REFUSALS = [
    ("__import__('os')", "unknown function '__import__'"),
    ("__import__('os').system('true')", "attribute access is not allowed"),
    ("().__class__.__bases__", "attribute access is not allowed"),
    ("x.real", "attribute access is not allowed ('x.real')"),
    ("x[0]", "subscripts are not allowed"),
    ("lambda: 1", "lambda is not allowed"),
    ("[i for i in (1,2)]", "comprehensions are not allowed"),
    ("sum(i for i in x)", "unknown function 'sum'"),
    ("min(i for i in x)", "generator expressions are not allowed"),
    ("'a'", "strings are not allowed"),
    ("b'a'", "bytes are not allowed"),
    ("x if y else 1", "conditional expressions are not allowed"),
    ("(a := 1)", "assignment expressions (:=) are not allowed"),
    ("f'{x}'", "f-strings are not allowed"),
    ("1j", "complex numbers are not allowed"),
    ("True", "'True' is not allowed"),
    ("None", "'None' is not allowed"),
    ("[x, y]", "lists are not allowed"),
    ("(x, y)", "tuples are not allowed"),
    ("{x: y}", "dicts are not allowed"),
    ("{x}", "sets are not allowed"),
    ("x ^ 2", "'^' is not allowed (use ** for powers)"),
    ("x % 2", "operator '%' is not allowed"),
    ("x // 2", "operator '//' is not allowed"),
    ("~x", "operator '~' is not allowed"),
    ("sin(x=1)", "keyword arguments are not allowed"),
    ("sqrt(*x)", "starred arguments are not allowed"),
    ("min(x)", "min() takes at least 2 arguments, got 1"),
    ("sqrt(x, y)", "sqrt() takes 1 argument, got 2"),
    ("atan2(y)", "atan2() takes 2 arguments, got 1"),
    ("sin", "function 'sin' needs arguments"),
    ("x(1)", "unknown function 'x'"),
    ("(x+1)(2)", "only the known functions can be called"),
    ("z", "unknown name 'z' (known: x, y, pi, e)"),
    ("sine(x)", "unknown function 'sine' (did you mean 'sin'?)"),
    ("_x", "names starting with '_' are not allowed"),
    ("x +", "syntax error at the end"),
    ("x + )", "syntax error at column 5"),
    ("x\n+ 1", "syntax error at line 2"),
    ("x\0", "syntax error"),
    ("   ", "empty formula"),
    ("9" * 400, "number out of range"),
    ("1e999", "number out of range"),
    ("10**10**10", "division by zero, overflow or invalid value"),
    ("1/0", "division by zero, overflow or invalid value"),
]


@pytest.mark.parametrize("text, fragment", REFUSALS, ids=[r[0][:30] for r in REFUSALS])
def test_refusals(text, fragment):
    refused(text, fragment)


def test_message_names_source_key_and_known_names():
    with pytest.raises(FormulaError) as info:
        compile_formula("(x-x0)**2 + z", PARAMS, source="case.toml", key="interface.level_set")
    assert str(info.value) == ("case.toml: interface.level_set: unknown name 'z' "
                               "(known: x, y, x0, y0, r2, pi, e)")
    assert isinstance(info.value, XfcError)
    refused("x0 + xx0", "unknown name 'xx0' (did you mean 'x0'?)", params=PARAMS)


HOSTILE = {
    "parentheses 100000": ("(" * 100000 + "x" + ")" * 100000,
                           "formula too long (200001 characters, limit 2000)"),
    "x+ 600000": ("x+" * 600000 + "x", "formula too long"),
    "minus 10000": ("-" * 10000 + "x", "formula too long"),
    "parentheses 51": ("(" * 51 + "x" + ")" * 51, "formula nested too deeply"),
    "brackets 51": ("[" * 51 + "x" + "]" * 51, "formula nested too deeply"),
    "minus 1999": ("-" * 1999 + "x", "formula nested too deeply"),
    "powers 600": ("2**" * 600 + "2", "formula nested too deeply"),
    "x+ 900": ("x+" * 900 + "x", "formula nested too deeply"),
    "min of 600": ("min(" + ",".join(["x"] * 600) + ")", "formula too complex"),
}


@pytest.mark.parametrize("text, fragment", HOSTILE.values(), ids=HOSTILE.keys())
def test_hostile_input_is_refused_fast(text, fragment, monkeypatch):
    """Refused with bounded work (no wall-clock test): text over the length limit
    never reaches Python's parser; shorter text is parsed at most once."""
    import ast

    from xfemcontact.case import formula as fm

    calls = []
    real = ast.parse
    monkeypatch.setattr(fm.ast, "parse", lambda *a, **k: (calls.append(1), real(*a, **k))[1])
    refused(text, fragment)
    if len(text) > fm.MAX_LENGTH:
        assert not calls
    else:
        assert len(calls) <= 1


@pytest.mark.parametrize("value, fragment", [
    (True, "expected a number or a formula string, got true"),
    (False, "got false"),
    ([1, 2], "got an array"),
    ({"a": 1}, "got a table"),
    (None, "got nothing"),
    (float("nan"), "expected a finite number, got nan"),
    (float("inf"), "expected a finite number"),
    (10**400, "expected a finite number"),
])
def test_refused_values(value, fragment):
    refused(value, fragment, source="case.toml", key="material.E")
    with pytest.raises(FormulaError, match="expected a condition string"):
        compile_condition(value)


@pytest.mark.parametrize("params, fragment", [
    ({"x": 1.0}, "parameter 'x' shadows the variable 'x'"),
    ({"sin": 1.0}, "parameter 'sin' shadows the function 'sin'"),
    ({"pi": 3.0}, "parameter 'pi' shadows the constant 'pi'"),
    ({"e": 3.0}, "parameter 'e' shadows the constant 'e'"),
    ({"_a": 1.0}, "parameter name '_a' is not allowed"),
    ({"a b": 1.0}, "parameter name 'a b' is not allowed"),
    ({"a": True}, "parameter 'a' must be a number, got true"),
    ({"a": "1"}, "parameter 'a' must be a number, got a string"),
    ({"a": float("inf")}, "parameter 'a' must be finite"),
    ({"a": 10**400}, "parameter 'a' must be finite"),
])
def test_refused_params(params, fragment):
    refused("1", fragment, params=params)
    refused(1.0, fragment, params=params)


def test_no_eval_exec_or_compile_in_module():
    tree = ast.parse(inspect.getsource(formula_module))
    called = {node.func.id for node in ast.walk(tree)
              if isinstance(node, ast.Call) and isinstance(node.func, ast.Name)}
    assert not called & {"eval", "exec", "compile", "__import__", "getattr"}


# --- evaluation errors ---------------------------------------------------------------------

@pytest.mark.parametrize("text, variables, point", [
    ("1/x", {"x": np.array([1.0, 0.0, 2.0]), "y": 5.0}, "at x=0, y=5"),
    ("sqrt(x)", {"x": np.array([[4.0], [-1.0]]), "y": np.array([2.0, 3.0])}, "at x=-1, y=2"),
    ("log(0*x)", {"x": np.array([3.0, 4.0]), "y": 1.5}, "at x=3, y=1.5"),
    ("x**10**10", {"x": np.array([0.5, 1.0, 2.0]), "y": 0.0}, "at x=2, y=0"),
    ("exp(1000*x)", {"x": np.array([-1.0, 1.0]), "y": 0.0}, "at x=1, y=0"),
])
def test_evaluation_errors_name_the_first_point(text, variables, point):
    f = compile_formula(text, source="case.toml", key="dirichlet[1].DY")
    with pytest.raises(FormulaError) as info:
        f(**variables)
    prefix = "case.toml: dirichlet[1].DY: "
    assert str(info.value) == f"{prefix}division by zero or invalid value {point}"


def test_evaluation_ignores_global_error_settings():
    old = np.seterr(all="raise")
    try:
        with pytest.raises(FormulaError, match="at x=0"):
            compile_formula("1/x")(x=np.array([0.0]), y=0.0)
    finally:
        np.seterr(**old)


# --- fuzzing -------------------------------------------------------------------------------

TOKENS = ["x", "y", "a", "1", "2.5", "0", "1e308", "9" * 30, "(", ")", "[", "]", "+", "-", "*",
          "/", "**", "^", "%", ",", ".", ":", "=", "<", "<=", "==", " ", "'", "j", "_", "\n",
          "sin", "sqrt", "min", "max", "atan2", "log", "exp", "pi", "e", "lambda", "if", "else",
          "and", "or", "not", "for", "in", "__class__", "__import__", "real", "*x", "x=", ":="]
TOKEN_TEXT = st.lists(st.sampled_from(TOKENS), max_size=40).map("".join)


def only_formula_errors(compile_function, text):
    try:
        expression = compile_function(text, {"a": 2.0})
    except FormulaError:
        return
    try:
        result = expression(x=X, y=Y)
    except FormulaError:
        return
    assert result.shape == (11, 7)


@FUZZ
@given(st.one_of(st.text(max_size=80), TOKEN_TEXT))
def test_fuzz_only_formula_errors_escape(text):
    only_formula_errors(compile_formula, text)
    only_formula_errors(compile_condition, text)


# A random expression is a triple (text, reference function of (x, y), variable names used),
# the reference being built with NumPy calls independently of the module.
REFERENCE_FUNCTIONS = {
    "sqrt": (np.sqrt, 1), "sin": (np.sin, 1), "cos": (np.cos, 1), "tan": (np.tan, 1),
    "asin": (np.arcsin, 1), "acos": (np.arccos, 1), "atan": (np.arctan, 1),
    "atan2": (np.arctan2, 2), "sinh": (np.sinh, 1), "cosh": (np.cosh, 1), "tanh": (np.tanh, 1),
    "exp": (np.exp, 1), "log": (np.log, 1), "log10": (np.log10, 1), "abs": (np.abs, 1),
    "sign": (np.sign, 1), "floor": (np.floor, 1), "ceil": (np.ceil, 1), "hypot": (np.hypot, 2),
    "min": (lambda *a: functools.reduce(np.minimum, a), 3),
    "max": (lambda *a: functools.reduce(np.maximum, a), 2),
}
REFERENCE_BINARY = {"+": np.add, "-": np.subtract, "*": np.multiply, "/": np.divide, "**": np.power}


def leaf(value):
    if isinstance(value, str):
        constants = {"pi": np.float64(np.pi), "e": np.float64(np.e)}
        if value in constants:
            return value, lambda x, y: constants[value], frozenset()
        return value, (lambda x, y: x) if value == "x" else (lambda x, y: y), frozenset(value)
    return repr(value), lambda x, y: np.float64(value), frozenset()


def binary(op, left, right):
    return (f"({left[0]} {op} {right[0]})",
            lambda x, y: REFERENCE_BINARY[op](left[1](x, y), right[1](x, y)), left[2] | right[2])


def call(name, args):
    function = REFERENCE_FUNCTIONS[name][0]
    return (f"{name}({', '.join(a[0] for a in args)})",
            lambda x, y: function(*[a[1](x, y) for a in args]),
            frozenset().union(*[a[2] for a in args]))


def extend(children):
    binaries = st.builds(binary, st.sampled_from(sorted(REFERENCE_BINARY)), children, children)
    negations = children.map(lambda c: (f"(-{c[0]})", lambda x, y: np.negative(c[1](x, y)), c[2]))
    calls = st.sampled_from(sorted(REFERENCE_FUNCTIONS)).flatmap(
        lambda name: st.builds(call, st.just(name), st.lists(
            children, min_size=REFERENCE_FUNCTIONS[name][1],
            max_size=REFERENCE_FUNCTIONS[name][1])))
    return st.one_of(binaries, negations, calls)


LEAVES = st.one_of(st.sampled_from(["x", "y", "pi", "e"]), st.integers(0, 20),
                   st.floats(0.0, 10.0)).map(leaf)
EXPRESSIONS = st.recursive(LEAVES, extend, max_leaves=12)


def expected_outcome(reference):
    with np.errstate(all="ignore"):
        values = np.broadcast_to(np.asarray(reference(X, Y), dtype=np.float64), (11, 7))
    return values, ~np.isfinite(values)


@GRAMMAR_FUZZ
@given(EXPRESSIONS)
def test_grammar_fuzz_matches_reference(expression):
    text, reference, names = expression
    values, bad = expected_outcome(reference)
    if not bad.any():
        f = compile_formula(text)
        assert f.names == names
        np.testing.assert_allclose(f(x=X, y=Y), values, rtol=1e-12, atol=0)
        return
    with pytest.raises(FormulaError) as info:
        compile_formula(text)(x=X, y=Y)
    if names:  # the first offending point is named
        i, j = np.unravel_index(int(np.argmax(bad)), bad.shape)
        assert str(info.value).endswith(f"at x={X[i, 0]:.10g}, y={Y[0, j]:.10g}")


@settings(GRAMMAR_FUZZ, max_examples=60)
@given(EXPRESSIONS, EXPRESSIONS, st.sampled_from(["<", "<=", ">", ">=", "==", "!="]),
       st.sampled_from(["and", "or", "and not"]))
def test_grammar_fuzz_conditions(left, right, op, word):
    compare = {"<": np.less, "<=": np.less_equal, ">": np.greater, ">=": np.greater_equal,
               "==": np.equal, "!=": np.not_equal}[op]
    text = f"{left[0]} {op} {right[0]} {word} x > 1"
    (a, bad_a), (b, bad_b) = expected_outcome(left[1]), expected_outcome(right[1])
    if bad_a.any() or bad_b.any():
        with pytest.raises(FormulaError):
            compile_condition(text)(x=X, y=Y)
        return
    second = X > 1 if word != "and not" else ~(X > 1)
    combine = np.logical_or if word == "or" else np.logical_and
    expected = combine(compare(a, b), second)
    np.testing.assert_array_equal(compile_condition(text)(x=X, y=Y), expected)
