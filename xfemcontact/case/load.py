"""Read a TOML case file, check all of it against :data:`schema.CASE`, return a :class:`Case`.

Nothing heavy happens here: the mesh file is only checked to exist, formulas
are compiled (not evaluated on a mesh).  Every refusal is one line,
``"{file}: {dotted.key[i]}: {what is wrong} ({what would be right})"``:
a :class:`CaseError`, or the :class:`FormulaError` of a formula or condition
(same shape).
"""
from __future__ import annotations

import difflib
import json
import math
import os
import re
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Iterable, NoReturn

from xfemcontact.case import schema
from xfemcontact.contact import laws
from xfemcontact.case.formula import (Condition, Formula, FormulaError, compile_condition,
                                      compile_formula)
from xfemcontact.case.functions import Function, TimeFormula
from xfemcontact.errors import CaseError, where

__all__ = ["load_case", "Case", "MeshSpec", "Material", "Dirichlet", "Traction", "BodyForce",
           "Interface", "Contact", "Newton", "TestSpec", "Output", "Instants"]


# --- what a case is ------------------------------------------------------------------------

@dataclass(frozen=True)
class MeshSpec:
    file: Path | None                 # resolved; None for a rectangle or a box
    rectangle: dict[str, Any] | None  # keyword arguments of mesh.generate.rectangle
    refine: int
    key_file: str = "mesh.file"
    box: dict[str, Any] | None = None     # keyword arguments of mesh.generate.box

    @property
    def key(self) -> str:
        """The case key of the mesh: ``mesh.file``, ``mesh.rectangle`` or ``mesh.box``."""
        return "mesh.file" if self.file is not None else \
            "mesh.rectangle" if self.rectangle is not None else "mesh.box"

    @property
    def name(self) -> str:
        """The mesh in messages: the file's name, "rectangle" or "box"."""
        return self.file.name if self.file is not None else \
            "rectangle" if self.rectangle is not None else "box"


# The tables below hold the keys of their schema table (xfemcontact.case.schema, where
# each key is described, once); tests/test_case.py checks that they match.

@dataclass(frozen=True)
class Material:
    """``[material]``: E in Pa, nu, C_PLAN, D_PLAN or 3D."""
    E: float
    nu: float
    model: str


@dataclass(frozen=True)
class Dirichlet:
    """One ``[[dirichlet]]``: imposed displacements (m) on groups."""

    groups: tuple[str, ...]
    components: dict[str, TimeFormula]  # {"DX": TimeFormula, "DY": ..., "DZ": ...}, those given only
    key: str                          # "dirichlet[0]"
    fonc_mult: str | None = None      # name of the [functions] table multiplying it


@dataclass(frozen=True)
class Traction:
    """One ``[[traction]]``: a force per unit length (N/m) or a pressure (Pa) on edge groups;
    in 3-D a force per unit area (Pa) or a pressure on face groups."""

    groups: tuple[str, ...]
    force: dict[str, TimeFormula] | None  # {"FX": ..., "FY": ..., ["FZ": ...]} (missing one = 0)
    pressure: TimeFormula | None
    key: str                          # "traction[0]"
    fonc_mult: str | None = None


@dataclass(frozen=True)
class BodyForce:
    """``[body_force]``: force per unit volume, N/m^3 (FZ: 3-D cases, None in 2-D)."""
    FX: TimeFormula
    FY: TimeFormula
    fonc_mult: str | None = None
    FZ: TimeFormula | None = None

    @property
    def components(self) -> tuple[TimeFormula, ...]:
        """FX, FY and, in 3-D, FZ."""
        return (self.FX, self.FY) if self.FZ is None else (self.FX, self.FY, self.FZ)


@dataclass(frozen=True)
class Instants:
    """The instants computed (DEFI_LIST_INST) and what to do when a step fails (ECHEC).

    ``values``: increasing, ``values[0]`` the initial (unloaded) state, one solve
    per later instant; ``given``: the case has ``[instants]`` (without, one step
    0 -> 1 and no cutting, ``action = "ARRET"``)."""

    values: tuple[float, ...]
    given: bool
    action: str = "ARRET"             # "DECOUPE" | "ARRET"
    subd_pas: int = 4
    subd_niveau: int = 3

    @property
    def last(self) -> float:
        return self.values[-1]

    def match(self, t: float) -> float | None:
        """The instant of ``values`` equal to ``t`` to round-off, or None."""
        span = max(abs(self.values[-1] - self.values[0]), abs(self.values[-1]), 1e-300)
        for v in self.values:
            if abs(v - t) <= 1e-9 * span:
                return v
        return None


@dataclass(frozen=True)
class Interface:
    """``[interface]``: the level set and the interface law."""
    type: str
    level_set: Formula | None
    level_set_field: str | None
    law: str
    max_offset: float = 0.5


@dataclass(frozen=True)
class Contact:
    """``[contact]``: contact and friction settings."""
    friction: bool                    # derived: frottement == "COULOMB" and coulomb > 0
    coulomb: float
    coef_cont: float | None
    coef_frot: float | None
    contact_init: bool | str
    seuil_init: float | None
    iter_cont_maxi: int
    iter_frot_maxi: int
    resi_frot: float
    ordre_int: int | None
    algo_lagr: str = "AUTO"
    integration: str = "NOEUD"
    friction_unknown: str = "LAGS_F1"


@dataclass(frozen=True)
class Newton:
    """``[newton]``: Newton's tolerance and iterations."""
    resi_glob_rela: float
    iter_glob_maxi: int


@dataclass(frozen=True)
class TestSpec:
    """One ``[[test]]`` of the test table."""
    __test__ = False                  # not a pytest test class

    name: str
    field: str
    kind: str                         # "interface" | "node" | "cell"
    type: str                         # MIN | MAX | VALUE | SOMM_ABS | MAX_ERROR
    where: Condition | None
    point: tuple[float, float] | None
    reference: float                  # 0 for MAX_ERROR
    tolerance: float
    criterion: str                    # "ABSOLU" | "RELATIF"
    key: str                          # "test[0]"
    inst: float = 1.0                 # the instant tested (one of case.instants.values)


@dataclass(frozen=True)
class Output:
    """``[output]``: result formats and plots."""

    formats: tuple[str, ...]
    plots: bool
    profile_point: tuple[float, ...] | None = None     # 3-D: plot_profiles.png's planes go through it
    profile_normal: tuple[float, ...] | None = None    # 3-D: the normal of its one plane


@dataclass(frozen=True)
class Case:
    """A checked case file, its formulas compiled."""
    path: Path                        # resolved path of the case file
    source: str                       # the path as the user gave it, for messages
    name: str                         # file stem
    title: str
    params: dict[str, float]
    mesh: MeshSpec
    material: Material
    dirichlet: tuple[Dirichlet, ...]
    traction: tuple[Traction, ...]
    body_force: BodyForce | None
    interface: Interface | None
    contact: Contact
    newton: Newton
    reference: dict[str, TimeFormula]  # field -> TimeFormula (at the last instant)
    tests: tuple[TestSpec, ...]
    output: Output
    instants: Instants = Instants((0.0, 1.0), False)
    functions: dict[str, Function] | None = None   # name -> Function (DEFI_FONCTION)

    @property
    def dim(self) -> int:
        """Space dimension: 3 for ``material.model = "3D"``, else 2."""
        return 3 if self.material.model == "3D" else 2

    @property
    def components(self) -> tuple[str, ...]:
        """The displacement components: DX, DY (and DZ in 3-D)."""
        return ("DX", "DY", "DZ")[:self.dim]

    def reference_at(self, t: float) -> dict[str, TimeFormula]:
        """The reference formulas at instant ``t``."""
        return {name: f.at(t) for name, f in self.reference.items()}

    def check_groups(self, available: Iterable[str]) -> None:
        """Raise :class:`CaseError` for the first load group not in ``available``."""
        available = sorted(set(available))
        mesh = self.mesh.name
        loads: tuple[Dirichlet | Traction, ...] = (*self.dirichlet, *self.traction)
        for load in loads:
            for group in load.groups:
                if group not in available:
                    close = _closest(group, available, cutoff=0.6)
                    hint = f"did you mean '{close}'? " if close else ""
                    listed = ", ".join(available[:30]) + (", ..." if len(available) > 30 else "")
                    raise CaseError(f"{self.source}: {load.key}.group: no group "
                                    f"'{_printable(group)}' in {mesh} "
                                    f"({hint}groups: {listed or 'none'})")


# --- loading -------------------------------------------------------------------------------

def load_case(path: str | os.PathLike[str]) -> Case:
    """Read, check and compile the case file ``path``; :class:`CaseError` if anything is wrong."""
    source = _printable(os.fsdecode(path))
    path = Path(path)
    raw = _read_toml(path, source)
    walker = _Walker(source, path.parent)
    walker.dim = _dimension(raw)
    # parameters first: every formula of the case may use them
    walker.params = walker.value(schema.CASE.keys["parameters"], raw.get("parameters", {}),
                                 "parameters", {})
    values = walker.table(schema.CASE, raw, "")
    case = _build(values, path, source, walker.params, walker.fail)
    _check_case(case, walker.fail)
    return case


def _dimension(raw: dict[str, Any]) -> int:
    """3 when the raw case is 3-D (``material.model = "3D"``, or a ``mesh.box`` without a
    model), else 2: the formulas of a 3-D case are of x, y and z."""
    material, mesh = raw.get("material"), raw.get("mesh")
    model = material.get("model") if isinstance(material, dict) else None
    if isinstance(model, str):
        return 3 if model.casefold() == "3d" else 2
    return 3 if isinstance(mesh, dict) and "box" in mesh else 2


def _read_toml(path: Path, source: str) -> dict[str, Any]:
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        raise CaseError(f"{source}: case file not found (give the path of a TOML case file)") \
            from None
    except IsADirectoryError:
        raise CaseError(f"{source}: is a folder, not a case file (give a TOML case file)") \
            from None
    except (OSError, ValueError) as exc:
        reason = _printable(getattr(exc, "strerror", None) or str(exc))
        raise CaseError(f"{source}: cannot read the case file: {reason}") from None
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line: int | str = data[:exc.start].count(b"\n") + 1
        raise CaseError(f"{source}: line {line}: not UTF-8 text (save the case file as "
                        f"UTF-8)") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        message = str(exc)
        found = re.search(r"\(at line (\d+), column (\d+)\)$", message)
        if found:
            line = found.group(1)
            message = f"{message[:found.start()].rstrip()} (column {found.group(2)})"
        else:
            line = text.count("\n") + 1
            message = re.sub(r"\s*\(at end of document\)$", " (at the end of the file)",
                             message)
        raise CaseError(f"{source}: line {line}: {_printable(message)}") from None
    except RecursionError:
        raise CaseError(f"{source}: arrays or tables nested too deeply") from None


class _Walker:
    """Checks raw TOML values against the schema and converts them."""

    params: dict[str, float]           # the case's parameters, once checked
    dim: int = 2                       # space dimension: 3 adds z to the formulas' variables

    def __init__(self, source: str, folder: Path) -> None:
        self.source, self.folder, self.params = source, folder, {}
        self.convert: dict[str, Callable[[schema.Key, Any, str, dict[str, Any]], Any]] = {
            "float": self._float, "int": self._int, "str": self._str,
            "choice": self._choice, "choices": self._choices, "formula": self._formula,
            "tformula": self._tformula, "numbers": self._numbers,
            "condition": self._condition, "names": self._names, "point": self._point,
            "interval": self._interval, "file": self._file, "table": self._table,
            "tables": self._tables}

    def fail(self, at: str, message: str) -> NoReturn:
        raise CaseError(f"{where(self.source, at)}: {message}")

    def table(self, spec: schema.Table, raw: Any, at: str) -> dict[str, Any]:
        """The checked values of table ``raw``: every key of ``spec``, in order."""
        if not isinstance(raw, dict):
            self.fail(at, f"expected a table, got {_show(raw)}")
        for name in raw:
            if name not in spec.keys:
                if spec.extra is None:
                    self.fail(_join(at, name), f"unknown key {_suggest(name, spec.keys)}")
                self._check_name(name, at)
        rule: schema.Rule
        presence = [rule for rule in spec.rules if not isinstance(rule, schema.When)]
        for rule in presence:              # which keys are given, before their values
            self._rule(rule, raw, {}, at)
        out: dict[str, Any] = {}
        for name, key in spec.keys.items():
            here = _join(at, name)
            if name in raw:
                out[name] = self.value(key, raw[name], here, out)
            elif key.required:
                if key.type == "table":
                    self.fail(here, f"missing required table [{here}] ({key.doc})")
                self.fail(here, f"missing required key ({key.doc})")
            else:
                out[name] = None if key.default is None else self.value(key, key.default,
                                                                        here, out)
        for name in raw:
            if name not in spec.keys:
                assert spec.extra is not None          # else refused above
                out[name] = self.value(spec.extra, raw[name], _join(at, name), out)
        for rule in spec.rules:
            if isinstance(rule, schema.When):
                self._rule(rule, raw, out, at)
        return out

    def value(self, key: schema.Key, raw: Any, at: str, siblings: dict[str, Any]) -> Any:
        return self.convert[key.type](key, raw, at, siblings)

    def _check_name(self, name: str, at: str) -> None:
        if not re.fullmatch(schema.PARAMETER_NAME, name):
            self.fail(_join(at, name), "not a valid name (ASCII letters, digits and '_', "
                                       "starting with a letter)")
        if name in schema.RESERVED_NAMES:
            self.fail(_join(at, name), f"'{name}' is {schema.RESERVED_NAMES[name]} "
                                       f"(choose another name)")

    # rules

    def _rule(self, rule: schema.Rule, raw: dict[str, Any], out: dict[str, Any], at: str) -> None:
        if self.dim == 2 and not isinstance(rule, schema.When):      # 2-D: no DZ, FZ in the rules
            rule = _planar(rule)
        if isinstance(rule, schema.ExactlyOne):
            if sum(name in raw for name in rule.keys) != 1:
                self.fail(at, f"give exactly one of {_either(rule.keys)}")
        elif isinstance(rule, schema.AtLeastOne):
            if not any(name in raw for name in rule.keys):
                self.fail(at, f"give at least one of {_either(rule.keys)}")
        elif isinstance(rule, schema.NotBoth):
            if any(n in raw for n in rule.first) and any(n in raw for n in rule.second):
                self.fail(at, f"give either {_group(rule.first)} or {_group(rule.second)}, "
                              f"not both")
        elif isinstance(rule, schema.When):
            if out.get(rule.key) not in rule.values:
                return
            condition = f"{rule.key} = {_show(out[rule.key])}"
            hint = f" ({rule.hint})" if rule.hint else ""
            for name in rule.require:
                if name not in raw:
                    self.fail(_join(at, name), f"required when {condition}{hint}")
            for name in rule.forbid:
                if name in raw:
                    self.fail(_join(at, name), f"not allowed when {condition}{hint}")
        else:  # pragma: no cover - a schema mistake
            raise TypeError(f"unknown rule {rule!r}")

    # value types

    def _number(self, raw: Any, at: str, what: str = "a number") -> int | float:
        if isinstance(raw, bool) or not isinstance(raw, (int, float)):
            self.fail(at, f"expected {what}, got {_show(raw)}")
        if not math.isfinite(raw):
            self.fail(at, f"expected a finite number, got {_show(raw)}")
        return raw

    def _bounded(self, key: schema.Key, raw: Any, at: str) -> Any:
        value = raw
        if ((key.gt is not None and not value > key.gt) or (key.ge is not None and value < key.ge)
                or (key.lt is not None and not value < key.lt)
                or (key.le is not None and value > key.le)):
            self.fail(at, f"must be {schema.bounds(key)}, got {_show(raw)}")
        return value

    def _float(self, key: schema.Key, raw: Any, at: str, siblings: dict[str, Any]) -> float:
        if isinstance(raw, str):
            hint = _unit_hint(raw, key.doc)
            if hint:
                self.fail(at, f"expected a number, got {_show(raw)} ({hint})")
        return float(self._bounded(key, self._number(raw, at), at))

    def _int(self, key: schema.Key, raw: Any, at: str, siblings: dict[str, Any]) -> int:
        if isinstance(raw, bool) or not isinstance(raw, int):
            self.fail(at, f"expected an integer, got {_show(raw)}")
        return self._bounded(key, raw, at)

    def _str(self, key: schema.Key, raw: Any, at: str, siblings: dict[str, Any]) -> str:
        if not isinstance(raw, str):
            self.fail(at, f"expected a string, got {_show(raw)}")
        bad = next((i for i, c in enumerate(raw) if not c.isprintable()), None)
        if bad is not None:
            self.fail(at, f"control character U+{ord(raw[bad]):04X} at position {bad + 1} "
                          f"(one line of printable text)")
        if len(raw) > key.max_length:
            self.fail(at, f"too long ({len(raw)} characters, at most {key.max_length})")
        return raw

    def _choice(self, key: schema.Key, raw: Any, at: str, siblings: dict[str, Any]) -> Any:
        listed = ", ".join(key.choices)
        if key.booleans and isinstance(raw, bool):
            raw = "OUI" if raw else "NON"
        if not isinstance(raw, str):
            what = f"true, false or one of {listed}" if key.booleans else \
                f"a string (one of {listed})"
            self.fail(at, f"expected {what}, got {_show(raw)}")
        folded = {choice.casefold(): choice for choice in key.choices}
        canonical = folded.get(raw.casefold())
        if canonical is None:
            refused = {k.casefold(): v for k, v in key.refused.items()}.get(raw.casefold())
            if refused:
                self.fail(at, refused)
            close = _closest(raw.casefold(), list(folded), cutoff=0.6)
            hint = f"did you mean {_show(folded[close])}? " if close else ""
            self.fail(at, f"unknown value {_show(raw)} ({hint}expected one of {listed})")
        return canonical if key.values is None else key.values[canonical]

    def _choices(self, key: schema.Key, raw: Any, at: str,
                 siblings: dict[str, Any]) -> tuple[Any, ...]:
        if not isinstance(raw, list):
            self.fail(at, f"expected an array of strings (among {', '.join(key.choices)}), "
                          f"got {_show(raw)}")
        items = [self._choice(key, item, f"{at}[{i}]", siblings) for i, item in enumerate(raw)]
        return tuple(dict.fromkeys(items))

    def _formula(self, key: schema.Key, raw: Any, at: str, siblings: dict[str, Any],
                 variables: tuple[str, ...] = ("x", "y")) -> Formula:
        if self.dim == 3:
            variables = ("x", "y", "z") + variables[2:]
        try:
            return _single_line(compile_formula, raw, self.params, source=self.source, key=at,
                                variables=variables)
        except FormulaError as exc:
            hint = _unit_hint(raw, key.doc, strict=True) if isinstance(raw, str) else None
            if hint:
                raise FormulaError(f"{where(self.source, at)}: expected a number or a formula, "
                                   f"got {_show(raw)} ({hint})") from None
            raise exc from None

    def _tformula(self, key: schema.Key, raw: Any, at: str, siblings: dict[str, Any]) -> Formula:
        """A formula of x, y and t (bound to an instant when the case is built)."""
        return self._formula(key, raw, at, siblings, variables=("x", "y", "t"))

    def _numbers(self, key: schema.Key, raw: Any, at: str,
                 siblings: dict[str, Any]) -> tuple[float, ...]:
        if not isinstance(raw, list) or not raw:
            self.fail(at, f"expected a non-empty array of numbers, got {_show(raw)}")
        return tuple(float(self._number(item, f"{at}[{i}]")) for i, item in enumerate(raw))

    def _condition(self, key: schema.Key, raw: Any, at: str,
                   siblings: dict[str, Any]) -> Condition:
        assert key.variables is not None and key.context is not None    # condition keys have both
        variables = key.variables[siblings[key.context]]
        if self.dim == 3 and key.variables is schema.CONDITION_VARIABLES:
            variables = schema.CONDITION_VARIABLES_3D[siblings[key.context]]
        return _single_line(compile_condition, raw, self.params, variables=variables,
                            source=self.source, key=at)

    def _names(self, key: schema.Key, raw: Any, at: str,
               siblings: dict[str, Any]) -> tuple[str, ...]:
        items = [raw] if isinstance(raw, str) else raw
        if not isinstance(items, list) or not items:
            self.fail(at, f"expected a group name or a non-empty array of names, "
                          f"got {_show(raw)}")
        for i, item in enumerate(items):
            here = at if isinstance(raw, str) else f"{at}[{i}]"
            if not isinstance(item, str) or not item.strip():
                self.fail(here, f"expected a group name, got {_show(item)}")
        return tuple(dict.fromkeys(items))

    def _pair(self, raw: Any, at: str, what: str, count: int = 2) -> tuple[float, ...]:
        if not isinstance(raw, list) or len(raw) != count:
            self.fail(at, f"expected an array of {('two', 'three')[count - 2]} numbers {what}, "
                          f"got {_show(raw)}")
        return tuple(float(self._number(item, f"{at}[{i}]")) for i, item in enumerate(raw))

    def _point(self, key: schema.Key, raw: Any, at: str,
               siblings: dict[str, Any]) -> tuple[float, ...]:
        if self.dim == 3:
            return self._pair(raw, at, "[x, y, z]", 3)
        return self._pair(raw, at, "[x, y]")

    def _interval(self, key: schema.Key, raw: Any, at: str,
                  siblings: dict[str, Any]) -> tuple[float, float]:
        low, high = self._pair(raw, at, "[min, max]")
        if not low < high:
            self.fail(at, f"must be increasing [min, max], got {_show(raw)}")
        return low, high

    def _file(self, key: schema.Key, raw: Any, at: str, siblings: dict[str, Any]) -> Path:
        if not isinstance(raw, str):
            self.fail(at, f"expected a string, got {_show(raw)}")
        name = raw
        try:
            path = (self.folder / name).resolve()
            found = path.exists()
            regular = path.is_file()
        except (OSError, ValueError, RuntimeError):
            path, found, regular = self.folder / name, False, False
        if not found:
            self.fail(at, f"mesh file not found: {_printable(str(path))} (paths are relative "
                          f"to the case file's folder)")
        if not regular:
            self.fail(at, f"{_printable(str(path))}: {_kind(path)}, not a mesh file (give a "
                          f"regular file)")
        return path

    def _table(self, key: schema.Key, raw: Any, at: str, siblings: dict[str, Any]) -> dict[str, Any]:
        assert key.table is not None                                      # table keys have it
        return self.table(key.table, raw, at)

    def _tables(self, key: schema.Key, raw: Any, at: str,
                siblings: dict[str, Any]) -> tuple[dict[str, Any], ...]:
        assert key.table is not None
        if not isinstance(raw, list):
            self.fail(at, f"expected an array of tables ([[{at}]]), got {_show(raw)}")
        table = key.table
        return tuple(self.table(table, item, f"{at}[{i}]") for i, item in enumerate(raw))


def _planar(rule: schema.Rule) -> schema.Rule:
    """``rule`` without the keys of 3-D components (:data:`schema.KEYS_3D`)."""
    def keep(keys: tuple[str, ...]) -> tuple[str, ...]:
        return tuple(k for k in keys if k not in schema.KEYS_3D)

    if isinstance(rule, schema.NotBoth):
        return schema.NotBoth(keep(rule.first), keep(rule.second))
    if isinstance(rule, (schema.ExactlyOne, schema.AtLeastOne)):
        return type(rule)(keep(rule.keys))
    return rule


def _single_line(compile_: Callable[..., Any], raw: Any, params: dict[str, float],
                 **kwargs: Any) -> Any:
    """Compile; a FormulaError goes through, its message made printable on one line."""
    try:
        return compile_(raw, params, **kwargs)
    except FormulaError as exc:
        message = str(exc)
        if _printable(message) != message:
            raise FormulaError(_printable(message)) from None
        raise


#: SI prefixes understood in unit hints
_PREFIXES = {"": 1.0, "T": 1e12, "G": 1e9, "M": 1e6, "k": 1e3, "h": 1e2, "c": 1e-2,
             "m": 1e-3, "u": 1e-6, "\u00b5": 1e-6, "\u03bc": 1e-6, "n": 1e-9}
_WITH_UNIT = re.compile(r"\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)"   # a number
                        r"\s*([^\d\s.,+*/()-][^\s]*)\s*")                     # a unit


def _unit_hint(text: str, doc: str, strict: bool = False) -> str | None:
    """What to write instead of a number with a unit (``"210 GPa"``), or None.

    The key's unit is read from its documentation (``"... in Pa"``); a unit
    made of an SI prefix and it gives the value to write.  With ``strict``
    (formulas, where ``"2 x"`` is a different mistake) only such units count.
    """
    found = _WITH_UNIT.fullmatch(text[:100])
    if not found:
        return None
    number, unit = found.group(1), found.group(2)
    unit_doc = re.search(r"\bin ([A-Za-z][A-Za-z/^0-9]*)", doc)
    si = unit_doc.group(1) if unit_doc else None
    if si and unit.endswith(si) and unit[:len(unit) - len(si)] in _PREFIXES:
        value = float(number) * _PREFIXES[unit[:len(unit) - len(si)]]
        return f"write numbers without units, in {si}: {value:g}"
    if strict:
        return None
    return f"write numbers without units, in {si}" if si else "write numbers without units"


# --- building the case ---------------------------------------------------------------------

def _build(v: dict[str, Any], path: Path, source: str, params: dict[str, float],
           fail: Callable[[str, str], NoReturn]) -> Case:
    mesh, contact, test_specs = v["mesh"], v["contact"], []
    instants = _instants(v["instants"], fail)
    functions = _functions(v["functions"], fail)
    last = instants.last

    def mult_of(table, at):
        name = table.get("fonc_mult")
        if name is None:
            return None
        if name not in functions:
            known = ", ".join(sorted(functions)) or "none"
            fail(f"{at}.fonc_mult", f"no function {_show(name)} in [functions] (functions: {known})")
        function = functions[name]
        outside = function.outside(instants.values)
        if outside is not None:
            fail(f"{at}.fonc_mult", f"function {_show(name)} has no value at instant {outside:g} "
                                    f"(its abscissae are {function.t[0]:g} .. {function.t[-1]:g}; "
                                    f"set prol_gauche / prol_droite to CONSTANT or LINEAIRE, or "
                                    f"extend vale)")
        return function

    def bound(formula, mult):
        return TimeFormula(formula, mult, last)

    dim = _dimension_of(v)
    space = ("x", "y", "z")[:dim]
    forces = ("FX", "FY", "FZ")[:dim]
    zero = {name: compile_formula(0.0, params, source=source, key=name, variables=space + ("t",))
            for name in forces}
    for i, t in enumerate(v["test"]):
        inst = last
        if t["inst"] is not None:
            inst = instants.match(t["inst"])
            if inst is None:
                fail(f"test[{i}].inst", f"{t['inst']:g} is not an instant of the case "
                                        f"(instants: {_list_instants(instants.values)})")
        test_specs.append(TestSpec(
            name=t["name"] if t["name"] is not None else f"{t['type']} {t['field']}",
            field=t["field"], kind=schema.FIELD_KIND[t["field"]], type=t["type"],
            where=t["where"], point=t["point"],
            reference=t["reference"] if t["reference"] is not None else 0.0,
            tolerance=t["tolerance"], criterion=t["criterion"], key=f"test[{i}]", inst=inst))
    if dim == 2:
        for at, table in [(f"traction[{i}]", t) for i, t in enumerate(v["traction"])] + \
                [("body_force", v["body_force"] or {})]:
            if table.get("FZ") is not None:
                fail(f"{at}.FZ", "a 3-D component (set material.model = \"3D\" with a 3-D mesh)")
    tractions = []
    for i, t in enumerate(v["traction"]):
        mult = mult_of(t, f"traction[{i}]")
        force = pressure = None
        if t["PRES"] is None:
            force = {name: bound(t[name] if t[name] is not None else zero[name], mult)
                     for name in forces}
        else:
            pressure = bound(t["PRES"], mult)
        tractions.append(Traction(groups=t["group"], force=force, pressure=pressure,
                                  key=f"traction[{i}]", fonc_mult=t["fonc_mult"]))
    dirichlet = []
    for i, d in enumerate(v["dirichlet"]):
        mult = mult_of(d, f"dirichlet[{i}]")
        dirichlet.append(Dirichlet(
            groups=d["group"], key=f"dirichlet[{i}]", fonc_mult=d["fonc_mult"],
            components={c: bound(d[c], mult) for c in ("DX", "DY", "DZ") if d[c] is not None}))
    body = v["body_force"]
    body_force = None
    if body is not None:
        mult = mult_of(body, "body_force")
        body_force = BodyForce(**{name: bound(body[name] if body[name] is not None else zero[name],
                                              mult) for name in forces},
                               fonc_mult=body["fonc_mult"])
    interface = v["interface"]
    return Case(
        path=path.resolve(), source=source, name=path.stem,
        title=v["title"] if v["title"] is not None else path.stem,
        params=dict(params),
        mesh=MeshSpec(file=mesh["file"], rectangle=mesh["rectangle"], refine=mesh["refine"],
                      box=mesh["box"]),
        material=Material(**dict(v["material"], model=_model(v))),
        dirichlet=tuple(dirichlet),
        traction=tuple(tractions),
        body_force=body_force,
        interface=None if interface is None else Interface(**interface),
        contact=Contact(
            friction=contact["frottement"] == "COULOMB" and contact["coulomb"] > 0,
            **{name: value for name, value in contact.items() if name != "frottement"}),
        newton=Newton(**v["newton"]),
        reference={name: bound(f, None) for name, f in v["reference"].items() if f is not None},
        tests=tuple(test_specs),
        output=Output(**v["output"]),
        instants=instants,
        functions=functions)


def _model(v: dict[str, Any]) -> str:
    """``material.model`` as given, else 3D for a box and C_PLAN otherwise."""
    model = v["material"]["model"]
    if model is not None:
        return model
    return "3D" if v["mesh"]["box"] is not None else "C_PLAN"


def _dimension_of(v: dict[str, Any]) -> int:
    """Space dimension of the checked values ``v`` of a case."""
    return 3 if _model(v) == "3D" else 2


def _list_instants(values, limit=8):
    shown = ", ".join(f"{t:g}" for t in values[:limit])
    return shown + (f", ... ({len(values)} in all)" if len(values) > limit else "")


def _instants(table, fail):
    """The :class:`Instants` of ``[instants]`` (one step 0 -> 1 without it)."""
    if table is None:
        return Instants((0.0, 1.0), False)
    points = []
    if table["values"] is not None:
        values = table["values"]
        for i in range(1, len(values)):
            if not values[i] > values[i - 1]:
                fail(f"instants.values[{i}]", f"instants must increase, got {values[i]:g} after "
                                              f"{values[i - 1]:g}")
        points += list(values)
    for i, r in enumerate(table["ranges"] or ()):
        if not r["end"] > r["start"]:
            fail(f"instants.ranges[{i}].end", f"must be > start ({r['start']:g}), got {r['end']:g}")
        n = r["steps"]
        points += [r["start"] + (r["end"] - r["start"]) * k / n for k in range(n)] + [r["end"]]
    points = sorted(points)
    span = max(points[-1] - points[0], abs(points[-1]), 1e-300)
    merged = [points[0]]
    for t in points[1:]:
        if t - merged[-1] > 1e-9 * span:
            merged.append(t)
    if len(merged) > schema.MAX_INSTANTS:
        fail("instants", f"too many instants ({len(merged)}, at most {schema.MAX_INSTANTS})")
    if len(merged) < 2:
        fail("instants", f"give at least two instants: the initial state and one computed "
                         f"(got {_list_instants(merged)})")
    echec = table["echec"]
    return Instants(tuple(merged), True, echec["action"], echec["subd_pas"], echec["subd_niveau"])


def _functions(table, fail):
    """{name: :class:`Function`} of ``[functions]``."""
    out = {}
    for name, f in (table or {}).items():
        at = f"functions.{name}"
        if f["vale"] is not None:
            vale = f["vale"]
            if len(vale) % 2:
                fail(f"{at}.vale", f"expected pairs t0, f0, t1, f1, ... (an even count of numbers), "
                                   f"got {len(vale)} numbers")
            ts, fs = vale[0::2], vale[1::2]
            key = f"{at}.vale"
        else:
            if f["vale_fonc"] is None:
                fail(f"{at}.vale_fonc", "required with vale_para (the values at its abscissae)")
            ts, fs = f["vale_para"], f["vale_fonc"]
            if len(ts) != len(fs):
                fail(f"{at}.vale_fonc", f"expected as many values as vale_para ({len(ts)}), "
                                        f"got {len(fs)}")
            key = f"{at}.vale_para"
        for i in range(1, len(ts)):
            if not ts[i] > ts[i - 1]:
                fail(key, f"the abscissae must increase, got {ts[i]:g} after {ts[i - 1]:g}")
        out[name] = Function(name, tuple(ts), tuple(fs), f["prol_gauche"], f["prol_droite"])
    return out


def _kind(path: Path) -> str:
    """What a path that is not a regular file is, in words."""
    import stat

    try:
        mode = path.stat().st_mode
    except OSError:
        return "cannot be read"
    for test, what in ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a named pipe (FIFO)"),
                       (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
                       (stat.S_ISSOCK, "a socket")):
        if test(mode):
            return what
    return "not a regular file"


def _check_case(case: Case, fail: Callable[[str, str], NoReturn]) -> None:
    """The checks that involve several tables."""
    names: dict[str, str] = {}
    for test in case.tests:
        if test.name in names:
            fail(f"{test.key}.name", f"duplicate test name {_show(test.name)} (also "
                                     f"{names[test.name]}): give each [[test]] its own name")
        names[test.name] = test.key
    if (case.interface is not None and case.interface.level_set_field is not None
            and case.mesh.file is None):
        fail("interface.level_set_field", f"needs a mesh file with point data (a {case.mesh.name} "
                                          f"mesh has none: use level_set = \"<formula>\")")
    _check_dimension(case, fail)
    law = laws.get(case.interface.law) if case.interface is not None else None
    if law is not None and "contact" in law.case_tables and case.contact.friction and not law.frictional:
        fail("contact.frottement", f"law = {_show(law.name)} is frictionless "
                                   f"({law.doc}): use frottement = \"SANS\"")
    for test in case.tests:
        if test.kind == "interface" and case.interface is None:
            fail(f"{test.key}.field", f"{test.field} is an interface field but the case has "
                                      f"no [interface] (add one, or test DX DY SIXX SIYY SIXY)")
        if test.type == "MAX_ERROR" and test.field not in case.reference:
            fail(f"{test.key}.field", f"type = \"MAX_ERROR\" needs the formula "
                                      f"reference.{test.field} (add it to [reference])")
        if test.type != "MAX_ERROR" and test.criterion == "RELATIF" and test.reference == 0:
            fail(f"{test.key}.criterion", "RELATIF needs a non-zero reference "
                                          "(use criterion = \"ABSOLU\")")


def _check_dimension(case: Case, fail: Callable[[str, str], NoReturn]) -> None:
    """The keys of a case agree with its dimension (``material.model``)."""
    three = case.dim == 3
    if case.mesh.box is not None and not three:
        fail("material.model", f"mesh.box is a 3-D mesh: use model = \"3D\" (or leave it out), "
                               f"got {_show(case.material.model)}")
    if case.mesh.rectangle is not None and three:
        fail("material.model", "model = \"3D\" needs a 3-D mesh (mesh.box, or a mesh file of "
                               "HEXA20 or TETRA10 cells); mesh.rectangle is 2-D")
    if three and case.mesh.refine:
        fail("mesh.refine", "uniform refinement is for 2-D meshes only (for now): generate or "
                            "mesh the finer box instead")
    normal = case.output.profile_normal
    if three and normal is not None and not any(normal):
        fail("output.profile_normal", "must not be the zero vector")
    if three:
        return
    for name in ("profile_point", "profile_normal"):
        if getattr(case.output, name) is not None:
            fail(f"output.{name}", "a 3-D key (the planes of plot_profiles.png, drawn in 3-D)")
    hint = "a 3-D component (set material.model = \"3D\" with a 3-D mesh)"
    for d in case.dirichlet:
        if "DZ" in d.components:
            fail(f"{d.key}.DZ", hint)
    for test in case.tests:
        if test.field in schema.FIELDS_3D_ONLY:
            fail(f"{test.key}.field", f"{test.field} is {hint[2:]}")
    for name in case.reference:
        if name in schema.FIELDS_3D_ONLY:
            fail(f"reference.{name}", hint)


# --- messages ------------------------------------------------------------------------------

_BARE = re.compile(r"[A-Za-z0-9_-]+")


def _join(at: str, name: str) -> str:
    name = name if _BARE.fullmatch(name) else _show(name)
    return f"{at}.{name}" if at else name


def _printable(text: str) -> str:
    """``text`` with every non-printable character escaped: always one line."""
    return "".join(c if c.isprintable() else c.encode("unicode_escape").decode("ascii")
                   for c in text)


def _shorten(text: str, limit: int = 60) -> str:
    return text if len(text) <= limit else text[:limit - 3] + "..."


def _show(value: object, depth: int = 0) -> str:
    """A TOML value as written in messages: ``"abc"``, ``true``, ``-1``, ``[0, 1]``."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return _printable(json.dumps(_shorten(value, 50), ensure_ascii=False))
    if isinstance(value, (int, float)):
        return _shorten(repr(value), 30)
    if isinstance(value, dict):
        return "a table"
    if isinstance(value, list):
        if depth > 2:
            return "[...]"
        return _shorten("[" + ", ".join(_show(item, depth + 1) for item in value[:5])
                        + (", ..." if len(value) > 5 else "") + "]")
    if hasattr(value, "isoformat"):
        return f"a date/time ({value.isoformat()})"
    return _shorten(_printable(repr(value)))


def _suggest(name: str, known: Iterable[str]) -> str:
    """``(did you mean 'x'?)`` for the closest known name, else the list of known names."""
    known = list(known)
    folded = {k.casefold(): k for k in known}
    close = folded.get(name.casefold())
    if close is None:
        match = _closest(name.casefold(), list(folded))
        close = folded[match] if match else None
    if close is not None:
        return f"(did you mean '{close}'?)"
    return f"(known: {', '.join(known)})"


def _closest(name: str, known: Iterable[str], cutoff: float = 0.5) -> str | None:
    """The most similar of ``known`` (the first one on ties), None if none is close."""
    best, best_ratio = None, cutoff
    for candidate in known:
        ratio = difflib.SequenceMatcher(None, name[:100], candidate).ratio()
        if ratio > best_ratio or (ratio == best_ratio and best is None):
            best, best_ratio = candidate, ratio
    return best


def _group(keys: Iterable[str]) -> str:
    return "/".join(f"'{k}'" for k in keys)


def _either(keys: Iterable[str]) -> str:
    quoted = [f"'{k}'" for k in keys]
    return quoted[0] if len(quoted) == 1 else f"{', '.join(quoted[:-1])} or {quoted[-1]}"
