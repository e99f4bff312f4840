"""Safe, vectorised formulas and conditions written by users in case files.

A formula such as ``"(x-x0)**2 + (y-y0)**2 - r2"`` is parsed with
``ast.parse(text, mode="eval")``; every node is checked against the whitelist
below and turned into a tree of Python closures that evaluates on NumPy
arrays.  The text never reaches ``eval``, ``exec`` or ``compile`` (``ast.parse``
only builds the syntax tree, no code object): whatever the user writes,
nothing but the whitelisted float64 arithmetic can run.

Grammar (anything else is refused with a one-line :class:`FormulaError`
``"{source}: {key}: {what is wrong}"``):

* numbers: int and float literals, all evaluated as float64;
* names: the variables (``x``, ``y`` by default), the named parameters of the
  case, the constants ``pi`` and ``e``;
* binary ``+ - * / **``, unary ``+ -``, parentheses (``^`` is refused: use ``**``);
* calls of the :data:`FUNCTIONS` by bare name, positional arguments only,
  with the number of arguments checked;
* in conditions only: comparisons ``< <= > >= == !=``, chained as in
  ``0 <= x <= 5``, and ``and``, ``or``, ``not``.

Limits: the length (:data:`MAX_LENGTH`) and the bracket nesting
(:data:`MAX_NESTING`) are checked before parsing, in linear time, so hostile
input is refused fast; the parsed tree is limited to :data:`MAX_NODES` nodes
and a depth of :data:`MAX_DEPTH`.  Evaluation ignores floating-point warnings
and refuses non-finite results (or comparison operands), naming the first
offending point.
"""
from __future__ import annotations

import ast
import difflib
import functools
import warnings
from typing import TYPE_CHECKING, Any, Callable, Iterable, Mapping, NoReturn, cast

import numpy as np

from xfemcontact.errors import FormulaError, where

if TYPE_CHECKING:
    from numpy.typing import ArrayLike, NDArray

    #: the variables' values during an evaluation, by name
    Env = dict[str, NDArray[np.float64]]
    #: what a compiled node gives: an array, or a NumPy scalar for constants
    Result = NDArray[Any] | np.float64 | np.bool_
    #: a compiled node
    Closure = Callable[[Env], Result]
    #: how a kind of node is compiled: (NUMBER or CONDITION, its closure)
    Compiled = tuple[str, Closure]

MAX_LENGTH = 2000
MAX_NESTING = 50
MAX_NODES = 500
MAX_DEPTH = 100


def _fold(ufunc: Callable[[Any, Any], Any]) -> Callable[..., Any]:
    return lambda *args: functools.reduce(ufunc, args)


#: name -> (NumPy function, least and most number of arguments; None: no limit)
FUNCTIONS: dict[str, tuple[Callable[..., Any], int, int | None]] = {
    "sqrt": (np.sqrt, 1, 1), "sin": (np.sin, 1, 1), "cos": (np.cos, 1, 1),
    "tan": (np.tan, 1, 1), "asin": (np.arcsin, 1, 1), "acos": (np.arccos, 1, 1),
    "atan": (np.arctan, 1, 1), "atan2": (np.arctan2, 2, 2), "sinh": (np.sinh, 1, 1),
    "cosh": (np.cosh, 1, 1), "tanh": (np.tanh, 1, 1), "exp": (np.exp, 1, 1),
    "log": (np.log, 1, 1), "log10": (np.log10, 1, 1), "abs": (np.abs, 1, 1),
    "min": (_fold(np.minimum), 2, None), "max": (_fold(np.maximum), 2, None),
    "sign": (np.sign, 1, 1), "floor": (np.floor, 1, 1), "ceil": (np.ceil, 1, 1),
    "hypot": (np.hypot, 2, 2),
}
CONSTANTS = {"pi": np.pi, "e": np.e}

_BINARY: dict[type[ast.operator], Callable[..., Any]] = {
    ast.Add: np.add, ast.Sub: np.subtract, ast.Mult: np.multiply,
    ast.Div: np.true_divide, ast.Pow: np.power}
_UNARY: dict[type[ast.unaryop], Callable[..., Any]] = {ast.UAdd: np.positive,
                                                       ast.USub: np.negative}
_COMPARE: dict[type[ast.cmpop], Callable[..., Any]] = {
    ast.Lt: np.less, ast.LtE: np.less_equal, ast.Gt: np.greater,
    ast.GtE: np.greater_equal, ast.Eq: np.equal, ast.NotEq: np.not_equal}
_SYMBOLS = {ast.Mod: "%", ast.FloorDiv: "//", ast.MatMult: "@", ast.LShift: "<<",
            ast.RShift: ">>", ast.BitOr: "|", ast.BitAnd: "&", ast.Invert: "~",
            ast.In: "in", ast.NotIn: "not in", ast.Is: "is", ast.IsNot: "is not"}
_REFUSED = {
    ast.Attribute: "attribute access is", ast.Subscript: "subscripts are",
    ast.Slice: "slices are", ast.Lambda: "lambda is", ast.ListComp: "comprehensions are",
    ast.SetComp: "comprehensions are", ast.DictComp: "comprehensions are",
    ast.GeneratorExp: "generator expressions are", ast.IfExp: "conditional expressions are",
    ast.NamedExpr: "assignment expressions (:=) are", ast.JoinedStr: "f-strings are",
    ast.FormattedValue: "f-strings are", ast.List: "lists are", ast.Tuple: "tuples are",
    ast.Dict: "dicts are", ast.Set: "sets are", ast.Starred: "starred arguments are",
    ast.Await: "'await' is", ast.Yield: "'yield' is", ast.YieldFrom: "'yield' is",
}
_LITERALS = {complex: "complex numbers are", str: "strings are", bytes: "bytes are"}
_TRIVIAL = (ast.expr_context, ast.operator, ast.unaryop, ast.cmpop, ast.boolop)
NUMBER, CONDITION = "a number", "a condition"


class _NonFinite(Exception):
    """Raised during evaluation with the mask of the non-finite values."""


def _fail(prefix: str, message: str) -> NoReturn:
    raise FormulaError(f"{prefix}: {message}")


def _finite(value: Result) -> Result:
    bad = ~np.isfinite(value)
    if np.any(bad):
        raise _NonFinite(bad)
    return value


def _shorten(text: str, limit: int = 40) -> str:
    return text if len(text) <= limit else text[:limit - 3] + "..."


def _snippet(node: ast.AST) -> str:
    return _shorten(ast.unparse(node))


def _hint(name: str, known: list[str]) -> str:
    close = difflib.get_close_matches(name, known, n=1)
    return f"(did you mean '{close[0]}'?)" if close else f"(known: {', '.join(known)})"


def _describe(value: object) -> str:
    """How a refused TOML value is named in messages."""
    if isinstance(value, bool):
        return "true" if value else "false"
    kinds = {str: "a string", list: "an array", tuple: "an array", dict: "a table",
             type(None): "nothing"}
    return kinds.get(type(value), f"a {type(value).__name__}")


def _is_number(value: object) -> bool:
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool)


def _as_float(value: Any) -> np.float64:
    """``value`` as a float64, inf when a Python int is too large."""
    try:
        return np.float64(value)
    except OverflowError:
        return np.float64(np.inf)


class _Compiler:
    """Checks an AST against the whitelist and builds closures ``env -> array``."""

    used: set[str]                     # the variables met

    def __init__(self, variables: tuple[str, ...], params: dict[str, np.float64], prefix: str,
                 conditions: bool) -> None:
        self.variables, self.params, self.prefix = variables, params, prefix
        self.conditions, self.used = conditions, set()
        self.rules: dict[type[ast.AST], Callable[[Any], Compiled]] = {
            ast.Constant: self._constant, ast.Name: self._name,
            ast.BinOp: self._binop, ast.UnaryOp: self._unaryop, ast.Call: self._call,
            ast.Compare: self._compare, ast.BoolOp: self._boolop}

    def fail(self, message: str) -> NoReturn:
        _fail(self.prefix, message)

    def build(self, node: ast.AST, kind: str) -> Closure:
        """Closure of ``node``, which must evaluate to ``kind``."""
        rule = self.rules.get(type(node))
        if rule is None:
            what = _REFUSED.get(type(node), f"'{type(node).__name__}' is")
            self.fail(f"{what} not allowed ('{_snippet(node)}')")
        got, function = rule(node)
        if got != kind:
            self.fail(f"expected {kind}, got {got} ('{_snippet(node)}')")
        return function

    def _constant(self, node: ast.Constant) -> Compiled:
        value = node.value
        if not _is_number(value):
            what = _LITERALS.get(type(value), f"'{_snippet(node)}' is")
            self.fail(f"{what} not allowed, expected a number")
        number = _as_float(value)
        if not np.isfinite(number):
            self.fail(f"number out of range ('{_snippet(node)}')")
        return NUMBER, lambda env: number

    def _name(self, node: ast.Name) -> Compiled:
        name = node.id
        if name.startswith("_"):
            self.fail(f"names starting with '_' are not allowed ('{name}')")
        if name in self.variables:
            self.used.add(name)
            return NUMBER, lambda env: env[name]
        if name in self.params or name in CONSTANTS:
            value = np.float64(self.params.get(name, CONSTANTS.get(name)))
            return NUMBER, lambda env: value
        if name in FUNCTIONS:
            self.fail(f"function '{name}' needs arguments: {name}(...)")
        known = [*self.variables, *self.params, *CONSTANTS]
        self.fail(f"unknown name '{name}' {_hint(name, known)}")

    def _binop(self, node: ast.BinOp) -> Compiled:
        if isinstance(node.op, ast.BitXor):
            self.fail("'^' is not allowed (use ** for powers)")
        if type(node.op) not in _BINARY:
            self.fail(f"operator '{_SYMBOLS[type(node.op)]}' is not allowed")
        ufunc = _BINARY[type(node.op)]
        left, right = self.build(node.left, NUMBER), self.build(node.right, NUMBER)
        return NUMBER, lambda env: ufunc(left(env), right(env))

    def _unaryop(self, node: ast.UnaryOp) -> Compiled:
        if isinstance(node.op, ast.Not):
            if not self.conditions:
                self.fail("'not' is only allowed in conditions")
            operand = self.build(node.operand, CONDITION)
            return CONDITION, lambda env: np.logical_not(operand(env))
        if type(node.op) not in _UNARY:
            self.fail(f"operator '{_SYMBOLS[type(node.op)]}' is not allowed")
        ufunc, operand = _UNARY[type(node.op)], self.build(node.operand, NUMBER)
        return NUMBER, lambda env: ufunc(operand(env))

    def _call(self, node: ast.Call) -> Compiled:
        if not isinstance(node.func, ast.Name):
            self.build(node.func, NUMBER)  # refuses attribute access and the like
            self.fail(f"only the known functions can be called ('{_snippet(node)}')")
        name = node.func.id
        if name not in FUNCTIONS:
            self.fail(f"unknown function '{name}' {_hint(name, list(FUNCTIONS))}")
        if node.keywords:
            self.fail(f"keyword arguments are not allowed ('{_snippet(node)}')")
        if any(isinstance(arg, ast.Starred) for arg in node.args):
            self.fail(f"starred arguments are not allowed ('{_snippet(node)}')")
        args = [self.build(arg, NUMBER) for arg in node.args]
        ufunc, least, most = FUNCTIONS[name]
        if not least <= len(args) <= (most or len(args)):
            plural = "s" if least > 1 else ""
            expected = f"{'at least ' if most is None else ''}{least} argument{plural}"
            self.fail(f"{name}() takes {expected}, got {len(args)}")
        return NUMBER, lambda env: ufunc(*[arg(env) for arg in args])

    def _compare(self, node: ast.Compare) -> Compiled:
        if not self.conditions:
            self.fail(f"comparisons are only allowed in conditions ('{_snippet(node)}')")
        for op in node.ops:
            if type(op) not in _COMPARE:
                self.fail(f"operator '{_SYMBOLS[type(op)]}' is not allowed")
        ufuncs = [_COMPARE[type(op)] for op in node.ops]
        operands = [self.build(item, NUMBER) for item in [node.left, *node.comparators]]

        def compare(env: Env) -> Result:
            values = [_finite(operand(env)) for operand in operands]
            tests = [ufunc(a, b) for ufunc, a, b in zip(ufuncs, values, values[1:])]
            return functools.reduce(np.logical_and, tests)
        return CONDITION, compare

    def _boolop(self, node: ast.BoolOp) -> Compiled:
        word = "and" if isinstance(node.op, ast.And) else "or"
        if not self.conditions:
            self.fail(f"'{word}' is only allowed in conditions")
        ufunc = np.logical_and if word == "and" else np.logical_or
        values = [self.build(value, CONDITION) for value in node.values]
        return CONDITION, lambda env: functools.reduce(ufunc, [value(env) for value in values])


def _parse(text: str, fail: Callable[[str], NoReturn]) -> ast.expr:
    """The AST of ``text``, refused fast when too long, too nested or too big."""
    _check_text(text, fail)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", SyntaxWarning)  # such as "1if": refused
            tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError as exc:
        line = f"line {exc.lineno}, " if (exc.lineno or 1) > 1 else ""
        place = f"{line}column {exc.offset}" if exc.offset else "the end"
        fail(f"syntax error at {place}: {exc.msg}")
    except (RecursionError, MemoryError, ValueError) as exc:
        fail(f"syntax error: {str(exc) or type(exc).__name__}")
    _check_tree(tree.body, fail)
    return tree.body


def _check_text(text: str, fail: Callable[[str], NoReturn]) -> None:
    """Linear-time limits checked before the parser sees ``text``."""
    if len(text) > MAX_LENGTH:
        fail(f"formula too long ({len(text)} characters, limit {MAX_LENGTH})")
    depth = 0
    for char in text:
        depth += (char in "([{") - (char in ")]}")
        if depth > MAX_NESTING:
            fail(f"formula nested too deeply (more than {MAX_NESTING} levels of brackets)")
    if not text.strip():
        fail("empty formula")


def _check_tree(root: ast.AST, fail: Callable[[str], NoReturn]) -> None:
    """Limits on the size and depth of the tree, checked without recursion."""
    count, stack = 0, [(root, 1)]
    while stack:
        node, depth = stack.pop()
        count += not isinstance(node, _TRIVIAL)
        if count > MAX_NODES:
            fail(f"formula too complex (more than {MAX_NODES} terms)")
        if depth > MAX_DEPTH:
            fail(f"formula nested too deeply (depth more than {MAX_DEPTH})")
        stack.extend((child, depth + 1) for child in ast.iter_child_nodes(node))


class _Expression:
    """What formulas and conditions share: names, evaluation, error points."""

    _dtype: type[np.generic] = np.float64

    def __init__(self, text: str, function: Closure, names: Iterable[str],
                 variables: Iterable[str], prefix: str) -> None:
        self.text, self.names, self.is_constant = text, frozenset(names), not names
        self._function, self._variables, self._prefix = function, tuple(variables), prefix
        if self.is_constant:
            self._constant = self._evaluate({})

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.text!r})"

    def __call__(self, **variables: ArrayLike) -> NDArray[Any]:
        unexpected = sorted(set(variables) - set(self._variables))
        missing = sorted(self.names - set(variables))
        if unexpected or missing:
            raise TypeError(f"{self!r}: unexpected variables {unexpected}, missing {missing}")
        env = {name: np.asarray(value, dtype=np.float64) for name, value in variables.items()}
        shape = np.broadcast_shapes(*[array.shape for array in env.values()])
        result = self._constant if self.is_constant else self._evaluate(env, shape)
        out = np.empty(shape, dtype=self._dtype)
        out[...] = result
        return out

    def _evaluate(self, env: Env, shape: tuple[int, ...] = ()) -> Result:
        try:
            with np.errstate(all="ignore"):
                return self._function(env)
        except _NonFinite as exc:
            mask = np.broadcast_to(exc.args[0], shape)
            if not env:
                raise FormulaError(f"{self._prefix}: division by zero, overflow or "
                                   f"invalid value in '{_shorten(self.text)}'") from None
            index = np.unravel_index(int(np.argmax(mask)), shape)
            point = ", ".join(f"{name}={np.broadcast_to(env[name], shape)[index]:.10g}"
                              for name in self._variables if name in env)
            # at the points of one process: the other processes may not fail
            raise FormulaError(f"{self._prefix}: division by zero or invalid value "
                               f"at {point}", collective=False) from None


class Formula(_Expression):
    """A compiled formula: ``f(x=..., y=...)`` gives a float64 array.

    Attributes: ``text`` (as written), ``names`` (the variables it uses) and
    ``is_constant`` (it uses none).  Calling it broadcasts the variables passed
    (all must be among the allowed ones; those used are required, else
    TypeError) and raises :class:`FormulaError` naming the first point where
    the result is NaN or inf.  A constant formula is evaluated (and its errors
    raised) at compile time.
    """

    def value(self) -> float:
        """The value of a constant formula; :class:`FormulaError` otherwise."""
        if not self.is_constant:
            raise FormulaError(f"{self._prefix}: expected a constant, '{_shorten(self.text)}' "
                               f"depends on {', '.join(sorted(self.names))}")
        return float(self._constant)


class Condition(_Expression):
    """A compiled condition: ``c(x=..., y=...)`` gives a bool array.

    Like :class:`Formula`; a NaN or inf operand of a comparison is an error.
    """

    _dtype = np.bool_


def _compile(text: str, params: Mapping[str, float] | None, variables: tuple[str, ...],
             prefix: str, conditions: bool) -> Formula | Condition:
    fail = functools.partial(_fail, prefix)
    compiler = _Compiler(variables, _check_params(params, variables, fail), prefix, conditions)
    node = _parse(text, fail)
    if conditions:
        return Condition(text, compiler.build(node, CONDITION), compiler.used, variables, prefix)
    inner = compiler.build(node, NUMBER)
    return Formula(text, lambda env: _finite(inner(env)), compiler.used, variables, prefix)


def _check_params(params: Mapping[str, float] | None, variables: tuple[str, ...],
                  fail: Callable[[str], NoReturn]) -> dict[str, np.float64]:
    """The parameters as floats, after checking their names and values."""
    params = dict(params or {})
    for name, value in params.items():
        if not isinstance(name, str) or not name.isidentifier() or name.startswith("_"):
            fail(f"parameter name {name!r} is not allowed (letters, digits and '_', "
                 f"not starting with '_')")
        for kind, names in (("variable", variables), ("function", FUNCTIONS),
                            ("constant", CONSTANTS)):
            if name in names:
                fail(f"parameter '{name}' shadows the {kind} '{name}'")
        if not _is_number(value):
            fail(f"parameter '{name}' must be a number, got {_describe(value)}")
        if not np.isfinite(_as_float(value)):
            fail(f"parameter '{name}' must be finite, got {str(value)[:20]}")
    return {name: _as_float(value) for name, value in params.items()}


def compile_formula(text_or_number: str | float, params: Mapping[str, float] | None = None,
                    variables: Iterable[str] = ("x", "y"), source: str = "<case>",
                    key: str = "<formula>") -> Formula:
    """Compile a formula string (or take a number) into a :class:`Formula`.

    ``params`` maps the names of the case parameters to numbers; ``variables``
    are the names given at call time; ``source`` and ``key`` (the case file and
    the dotted TOML key) prefix every error message.  Raises
    :class:`FormulaError` for anything outside the grammar of this module.
    """
    prefix, variables = where(source, key), tuple(variables)
    if isinstance(text_or_number, str):
        return cast(Formula, _compile(text_or_number, params, variables, prefix, conditions=False))
    if not _is_number(text_or_number):
        _fail(prefix, f"expected a number or a formula string, got {_describe(text_or_number)}")
    _check_params(params, variables, functools.partial(_fail, prefix))
    number = _as_float(text_or_number)
    if not np.isfinite(number):
        _fail(prefix, f"expected a finite number, got {str(text_or_number)[:20]}")
    return Formula(str(text_or_number), lambda env: number, (), variables, prefix)


def compile_condition(text: str, params: Mapping[str, float] | None = None,
                      variables: Iterable[str] = ("x", "y"), source: str = "<case>",
                      key: str = "<condition>") -> Condition:
    """Compile a condition string into a :class:`Condition` (bool-valued).

    Same grammar as :func:`compile_formula` plus comparisons (chainable, as in
    ``0 <= x <= 5``) and ``and``, ``or``, ``not``.
    """
    if not isinstance(text, str):
        _fail(where(source, key), f"expected a condition string, got {_describe(text)}")
    return cast(Condition, _compile(text, params, tuple(variables), where(source, key), conditions=True))
