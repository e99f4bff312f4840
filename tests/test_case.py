"""Tests of xfemcontact.case.load: valid cases, one-line refusals, fuzzing."""
import copy
import dataclasses
import datetime
import math
import re
import tempfile
import tomllib
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from xfemcontact.case import Case, load_case, schema
from xfemcontact.case.formula import Condition, FormulaError
from xfemcontact.case.functions import TimeFormula
from xfemcontact.case.load import Material
from xfemcontact.errors import CaseError, XfcError
from conftest import SHARED_MESHES

CASES = Path(__file__).parent / "data" / "cases"
MESH = SHARED_MESHES / "ssnv509a.mmed"
DELETE = object()


# --- a minimal TOML writer (inline tables and arrays only) ----------------------------------

_BARE = re.compile(r"[A-Za-z0-9_-]+")


def _toml_string(text):
    out = []
    for char in text:
        if char in '"\\':
            out.append("\\" + char)
        elif ord(char) < 0x20 or char == "\x7f":
            out.append(f"\\u{ord(char):04x}")
        else:
            out.append(char)
    return '"' + "".join(out) + '"'


def _toml_key(key):
    return key if _BARE.fullmatch(key) else _toml_string(key)


def _toml_value(value):
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, str):
        return _toml_string(value)
    if isinstance(value, (datetime.date, datetime.time)):
        return value.isoformat()
    if isinstance(value, list):
        return "[" + ", ".join(_toml_value(item) for item in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{_toml_key(k)} = {_toml_value(v)}"
                               for k, v in value.items()) + "}"
    raise TypeError(type(value))


def dumps(doc):
    """TOML text of ``doc``: every top-level key as ``key = <inline value>``."""
    return "".join(f"{_toml_key(key)} = {_toml_value(value)}\n" for key, value in doc.items())


# --- helpers --------------------------------------------------------------------------------

def read(name):
    with open(CASES / f"{name}.toml", "rb") as file:
        return tomllib.load(file)


def edit(doc, dotted, value):
    """Set (or delete, with DELETE) ``doc[dotted]``; ``dotted`` like ``"test[1].point"``."""
    parts = re.findall(r"[^.\[\]]+|\[\d+\]", dotted)
    steps = [int(p[1:-1]) if p.startswith("[") else p for p in parts]
    node = doc
    for step in steps[:-1]:
        node = node[step]
    if value is DELETE:
        del node[steps[-1]]
    else:
        node[steps[-1]] = value


def write_case(folder, doc, name="case.toml"):
    path = Path(folder) / name
    path.write_text(dumps(doc), encoding="utf-8")
    return path


def refusal(exc_type=XfcError, source="case.toml"):
    """Load ./case.toml, expect ``exc_type``; return its one-line message."""
    with pytest.raises(exc_type) as info:
        load_case(source)
    message = str(info.value)
    assert "\n" not in message and message.startswith(f"{source}: ")
    return message


@pytest.fixture
def here(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    return tmp_path


# --- valid cases ----------------------------------------------------------------------------

def test_elastic_rectangle():
    case = load_case(CASES / "elastic_rectangle.toml")
    assert isinstance(case, Case)
    assert case.name == "elastic_rectangle" and case.title.startswith("Elastic 4x4")
    assert case.source == str(CASES / "elastic_rectangle.toml")
    assert case.path == (CASES / "elastic_rectangle.toml").resolve()
    assert case.mesh.file is None and case.mesh.refine == 0
    assert case.mesh.rectangle == {"nx": 4, "ny": 4, "x": (0.0, 10.0), "y": (0.0, 10.0),
                                   "cell": "QUAD8", "diagonal": "alternate"}
    assert case.material == Material(E=2.0e11, nu=0.3, model="C_PLAN")
    assert [d.groups for d in case.dirichlet] == [("LIG1",), ("P1",)]
    assert list(case.dirichlet[0].components) == ["DY"]
    assert list(case.dirichlet[1].components) == ["DX"]
    assert case.dirichlet[1].key == "dirichlet[1]"
    (traction,) = case.traction
    assert traction.pressure is None and traction.key == "traction[0]"
    assert traction.force["FX"].value() == 0.0 and traction.force["FY"].value() == 1.0e6
    assert case.body_force is None and case.interface is None and case.params == {}
    assert case.contact.friction is False and case.contact.contact_init is True
    assert (case.contact.coef_cont, case.contact.coef_frot, case.contact.coulomb) == \
        (None, None, 0.0)
    assert case.contact.integration == "NOEUD"
    assert (case.contact.iter_cont_maxi, case.contact.iter_frot_maxi, case.contact.ordre_int,
            case.contact.resi_frot, case.contact.seuil_init) == (30, 10, None, 1e-4, None)
    assert (case.newton.resi_glob_rela, case.newton.iter_glob_maxi) == (1e-6, 20)
    assert case.output.formats == ("xdmf",) and case.output.plots is True
    assert float(case.reference["DY"](x=0.0, y=10.0)) == pytest.approx(5e-5)
    names = [(t.name, t.field, t.kind, t.type, t.criterion) for t in case.tests]
    assert names == [("MAX DY", "DY", "node", "MAX", "RELATIF"),
                     ("DX everywhere", "DX", "node", "MAX_ERROR", "ABSOLU"),
                     ("VALUE SIYY", "SIYY", "cell", "VALUE", "RELATIF")]
    assert case.tests[1].reference == 0.0 and case.tests[2].point == (5.0, 5.0)
    assert case.tests[0].where is None and case.tests[0].point is None


def test_interface_case():
    case = load_case(CASES / "ssnv509_interface.toml")
    assert case.params == {"x0": 5.0, "y0": 11.77, "r2": 64.27, "p": 0.1}
    assert (case.mesh.rectangle["cell"], case.mesh.rectangle["diagonal"]) == ("TRIA6", "alternate")
    assert case.material.model == "D_PLAN" and case.material.nu == 0.0
    assert case.dirichlet[1].groups == ("LIG3", "P4")
    dy = case.dirichlet[1].components["DY"]
    assert isinstance(dy, TimeFormula) and float(dy(x=0.0, y=10.0)) == pytest.approx(-1e-6)
    pres, side = case.traction
    assert pres.force is None and pres.pressure.value() == pytest.approx(100.0)
    assert side.pressure is None and side.force["FX"].value() == 0.0
    assert float(side.force["FY"](x=0.0, y=10.0)) == pytest.approx(-1e3)
    assert case.body_force.FX.value() == 0.0 and case.body_force.FY.value() == -1.0e3
    interface = case.interface
    assert (interface.type, interface.law, interface.level_set_field) == \
        ("INTERFACE", "contact", None)
    assert float(interface.level_set(x=5.0, y=11.77)) == pytest.approx(-64.27)
    contact = case.contact
    assert contact.friction is True and contact.coulomb == 2.0
    assert contact.contact_init == "interpenetrated" and contact.seuil_init == -5.0
    assert (contact.iter_cont_maxi, contact.iter_frot_maxi, contact.ordre_int) == (4, 6, 4)
    assert case.newton.resi_glob_rela == 1e-9 and case.newton.iter_glob_maxi == 20
    assert set(case.reference) == {"LAGS_C"}
    lags = case.reference["LAGS_C"](x=np.array([5.0]), y=np.array([0.0]))
    assert lags[0] == pytest.approx(-0.1)
    first, error, value, somm = case.tests
    assert isinstance(first.where, Condition)
    assert list(first.where(x=[4.0, 6.0, 4.0], y=0.0, LAGS_C=[-1.0, -1.0, 0.0],
                            LAGS_F1=0.0, gap=0.0, slip=0.0)) == [True, False, False]
    assert (first.name, first.reference, first.tolerance, first.criterion) == \
        ("min LAGS_C", -0.1, 1e-3, "ABSOLU")
    assert (error.name, error.field, error.kind, error.reference) == \
        ("MAX_ERROR LAGS_C", "LAGS_C", "interface", 0.0)
    assert value.point == (0.0, 5.0) and value.criterion == "RELATIF"
    assert (somm.type, somm.kind) == ("SOMM_ABS", "cell")
    assert case.output.formats == ("xdmf", "vtu") and case.output.plots is False


def test_mesh_file_case():
    if not MESH.is_file():
        pytest.skip(f"{MESH} not available")
    case = load_case(CASES / "ssnv509a_mesh.toml")
    assert case.mesh.file == MESH.resolve() and case.mesh.rectangle is None
    assert case.mesh.refine == 1 and case.mesh.key_file == "mesh.file"
    assert case.title == "ssnv509a_mesh"
    assert case.interface.law == "bonded" and case.contact.contact_init is False
    case.check_groups(["LIG1", "LIG2", "LIG3", "LIG4", "SURF"])
    bad = dataclasses.replace(case, dirichlet=(dataclasses.replace(case.dirichlet[0],
                                                                   groups=("LIG11",)),))
    with pytest.raises(CaseError) as info:
        bad.check_groups(["LIG2", "LIG1", "SURF"])
    assert str(info.value) == (f"{case.source}: dirichlet[0].group: no group 'LIG11' in "
                               "ssnv509a.mmed (did you mean 'LIG1'? groups: LIG1, LIG2, SURF)")


def test_minimal_case_defaults(here):
    write_case(here, {"mesh": {"rectangle": {"nx": 1, "ny": 2}},
                      "material": {"E": 1, "nu": 0}})
    case = load_case("case.toml")
    assert case.source == "case.toml" and case.title == "case" and case.name == "case"
    assert isinstance(case.material.E, float) and case.material.model == "C_PLAN"
    assert case.dirichlet == () and case.traction == () and case.tests == ()
    assert case.reference == {} and case.interface is None and case.body_force is None
    assert case.contact == load_case(CASES / "elastic_rectangle.toml").contact
    with pytest.raises(dataclasses.FrozenInstanceError):
        case.title = "x"


def test_check_groups_rectangle(here):
    doc = read("ssnv509_interface")
    write_case(here, doc)
    case = load_case("case.toml")
    case.check_groups(["LIG1", "LIG2", "LIG3", "LIG4", "P4"])
    with pytest.raises(CaseError) as info:
        case.check_groups(["LIG1", "LIG2", "LIG3", "LIG4"])
    assert str(info.value) == ("case.toml: dirichlet[1].group: no group 'P4' in rectangle "
                               "(groups: LIG1, LIG2, LIG3, LIG4)")
    with pytest.raises(CaseError, match=r"traction\[1\]\.group: no group 'LIG4'"):
        case.check_groups(["LIG1", "LIG2", "LIG3", "P4"])


def test_schema_reference_lists_every_key():
    text = "\n".join(schema.reference())
    for table_name, key in schema.CASE.keys.items():
        assert table_name in text
        for name in (key.table.keys if key.table else {}):
            assert re.search(rf"^\[?{table_name}\.{name}[ \]]", text, re.M)


# --- refusals -------------------------------------------------------------------------------

BAD = [
    # unknown keys, with suggestions, at several depths
    ({"contacts": {}}, "contacts: unknown key (did you mean 'contact'?)"),
    ({"dirichlet[1].DXX": 0.0}, "dirichlet[1].DXX: unknown key (did you mean 'DX'?)"),
    ({"mesh.rectangle.nz": 3}, "mesh.rectangle.nz: unknown key (did you mean 'nx'?)"),
    ({"contact.COEF_CONT": 1.0}, "contact.COEF_CONT: unknown key (did you mean 'coef_cont'?)"),
    ({"test[2].tolerence": 1.0}, "test[2].tolerence: unknown key (did you mean 'tolerance'?)"),
    ({"material.zzz": 1}, "material.zzz: unknown key (known: E, nu, model)"),
    ({"reference.DZ": "x"}, 'reference.DZ: a 3-D component (set material.model = "3D" with a 3-D mesh)'),
    # wrong types
    ({"material.E": "abc"}, 'material.E: expected a number, got "abc"'),
    ({"material.nu": True}, "material.nu: expected a number, got true"),
    ({"material.E": math.inf}, "material.E: expected a finite number, got inf"),
    ({"contact.ordre_int": 2.5}, "contact.ordre_int: expected an integer, got 2.5"),
    ({"title": 3}, "title: expected a string, got 3"),
    ({"material": 5}, "material: expected a table, got 5"),
    ({"dirichlet": {"group": "LIG1", "DX": 0}},
     "dirichlet: expected an array of tables ([[dirichlet]]), got a table"),
    ({"dirichlet[0].group": []},
     "dirichlet[0].group: expected a group name or a non-empty array of names, got []"),
    ({"test[2].point": [1.0]},
     "test[2].point: expected an array of two numbers [x, y], got [1.0]"),
    ({"output.plots": 1}, "output.plots: expected true, false or one of OUI, NON, got 1"),
    ({"material.model": "C_PLN"},
     'material.model: unknown value "C_PLN" (did you mean "C_PLAN"? expected one of C_PLAN, '
     'D_PLAN, 3D)'),
    ({"output.formats[1]": "pdf"},
     'output.formats[1]: unknown value "pdf" (expected one of xdmf, vtu, med)'),
    ({"contact.contact_init": "maybe"},
     'contact.contact_init: unknown value "maybe" (expected one of OUI, NON, INTERPENETRE)'),
    # out of range
    ({"contact.coef_cont": -1}, "contact.coef_cont: must be > 0, got -1"),
    ({"contact.coef_frot": 0.0}, "contact.coef_frot: must be > 0, got 0.0"),
    ({"contact.coulomb": -0.1}, "contact.coulomb: must be >= 0, got -0.1"),
    ({"material.E": 0}, "material.E: must be > 0, got 0"),
    ({"material.nu": 0.5}, "material.nu: must be > -1 and < 0.5, got 0.5"),
    ({"material.nu": -1}, "material.nu: must be > -1 and < 0.5, got -1"),
    ({"contact.ordre_int": 9}, "contact.ordre_int: must be >= 1 and <= 8, got 9"),
    ({"contact.iter_cont_maxi": 0}, "contact.iter_cont_maxi: must be >= 1 and <= 1000000, got 0"),
    ({"contact.iter_frot_maxi": -3}, "contact.iter_frot_maxi: must be >= 1 and <= 1000000, got -3"),
    ({"newton.iter_glob_maxi": 0}, "newton.iter_glob_maxi: must be >= 1 and <= 1000000, got 0"),
    ({"newton.resi_glob_rela": 0}, "newton.resi_glob_rela: must be > 0, got 0"),
    ({"mesh.refine": 7}, "mesh.refine: must be >= 0 and <= 6, got 7"),
    ({"mesh.rectangle.nx": 0}, "mesh.rectangle.nx: must be >= 1 and <= 10000, got 0"),
    ({"mesh.rectangle.x": [10.0, 0.0]},
     "mesh.rectangle.x: must be increasing [min, max], got [10.0, 0.0]"),
    # missing or conflicting keys
    ({"mesh.file": "m.mmed"}, "mesh: give exactly one of 'file', 'rectangle' or 'box'"),
    ({"mesh.rectangle": DELETE}, "mesh: give exactly one of 'file', 'rectangle' or 'box'"),
    ({"material": DELETE},
     "material: missing required table [material] (E, nu, model: the elastic material)"),
    ({"material.E": DELETE}, "material.E: missing required key (Young's modulus in Pa)"),
    ({"test[0].tolerance": DELETE}, "test[0].tolerance: missing required key (tolerance)"),
    ({"dirichlet[0].DX": DELETE, "dirichlet[0].DY": DELETE},
     "dirichlet[0]: give at least one of 'DX' or 'DY'"),
    ({"traction[1].PRES": 1.0}, "traction[1]: give either 'FX'/'FY' or 'PRES', not both"),
    ({"interface.level_set_field": "LSN"},
     "interface: give exactly one of 'level_set' or 'level_set_field'"),
    ({"interface.type": "fissure"},
     "interface.type: crack tips are not supported (TYPE_DISCONTINUITE='INTERFACE' only)"),
    ({"test[0].type": "VALUE"}, 'test[0].point: required when type = "VALUE" (point = [x, y])'),
    ({"test[2].type": "MAX"},
     'test[2].point: not allowed when type = "MAX" (point is for type = "VALUE" only)'),
    ({"test[1].reference": 0.5},
     'test[1].reference: not allowed when type = "MAX_ERROR" (the error to reference.<field> '
     'is compared to 0)'),
    ({"test[2].reference": DELETE},
     'test[2].reference: required when type = "VALUE" (reference = <number>)'),
    ({"reference.LAGS_C": DELETE},
     'test[1].field: type = "MAX_ERROR" needs the formula reference.LAGS_C (add it to '
     '[reference])'),
    ({"interface": DELETE},
     "test[0].field: LAGS_C is an interface field but the case has no [interface] (add one, "
     "or test DX DY SIXX SIYY SIXY)"),
    ({"test[3].criterion": "relatif"},
     'test[3].criterion: RELATIF needs a non-zero reference (use criterion = "ABSOLU")'),
    ({"interface.level_set": DELETE, "interface.level_set_field": "LSN"},
     'interface.level_set_field: needs a mesh file with point data (a rectangle mesh has '
     'none: use level_set = "<formula>")'),
    ({"contact.coulomb": DELETE},
     'contact.coulomb: required when frottement = "COULOMB" (give the friction coefficient, '
     '0 for none)'),
    ({"title": datetime.date(1979, 5, 27)},
     "title: expected a string, got a date/time (1979-05-27)"),
    # parameters
    ({"parameters.x": 1.0}, "parameters.x: 'x' is a formula variable (choose another name)"),
    ({"parameters.LAGS_C": 1.0},
     "parameters.LAGS_C: 'LAGS_C' is a field name usable in test conditions (choose another "
     "name)"),
    ({"parameters.r2": "64"}, 'parameters.r2: expected a number, got "64"'),
    ({"parameters.a b": 1.0},
     "parameters.\"a b\": not a valid name (ASCII letters, digits and '_', starting with a "
     "letter)"),
    # formulas and conditions (FormulaError, same shape)
    ({"dirichlet[1].DY": "-1e-7*"}, "dirichlet[1].DY: syntax error at "),
    ({"interface.level_set": "(x-x0)**2 + (y-z0)**2 - r2"},
     "interface.level_set: unknown name 'z0' (known: x, y, x0, y0, r2, p, pi, e)"),
    ({"test[0].where": "x <= 5 and DX != 0"}, "test[0].where: unknown name 'DX' "),
    ({"test[2].where": "LAGS_C < 0"}, "test[2].where: unknown name 'LAGS_C' "),
    ({"traction[0].PRES": True},
     "traction[0].PRES: expected a number or a formula string, got true"),
    ({"body_force.FY": "1/0"},
     "body_force.FY: division by zero, overflow or invalid value in '1/0'"),
    ({"reference.LAGS_C": "(1/\n0)"},      # a multi-line formula: still one line
     "reference.LAGS_C: division by zero, overflow or invalid value in '(1/\\n0)'"),
]


@pytest.mark.parametrize("edits, expected", BAD, ids=[f"{i}:{next(iter(e))}"
                                                      for i, (e, _) in enumerate(BAD)])
def test_refused(here, edits, expected):
    doc = read("ssnv509_interface")
    for dotted, value in edits.items():
        edit(doc, dotted, value)
    write_case(here, doc)
    message = refusal()
    assert message.startswith(f"case.toml: {expected}"), message
    if not expected.endswith(" "):
        assert message == f"case.toml: {expected}"


def test_formula_errors_are_formula_errors(here):
    doc = read("ssnv509_interface")
    edit(doc, "dirichlet[1].DY", "-1e-7*")
    write_case(here, doc)
    refusal(FormulaError)
    edit(doc, "dirichlet[1].DY", 0.0)
    edit(doc, "material.E", -1.0)
    write_case(here, doc)
    refusal(CaseError)


def test_missing_mesh_file(here):
    doc = read("ssnv509_interface")
    edit(doc, "mesh", {"file": "../meshes/nowhere.mmed"})
    write_case(here, doc)
    missing = (here.parent / "meshes" / "nowhere.mmed").resolve()
    expected = (f"case.toml: mesh.file: mesh file not found: {missing} "
                "(paths are relative to the case file's folder)")
    assert refusal(CaseError) == expected


def test_mesh_file_relative_to_case_folder(here):
    (here / "sub").mkdir()
    (here / "meshes").mkdir()
    (here / "meshes" / "m.mmed").write_bytes(b"")
    doc = read("ssnv509_interface")
    edit(doc, "mesh", {"file": "../meshes/m.mmed"})
    write_case(here / "sub", doc)
    assert load_case("sub/case.toml").mesh.file == here / "meshes" / "m.mmed"
    edit(doc, "mesh", {"file": "meshes"})         # a folder is not a mesh file
    write_case(here, doc)
    assert "mesh.file: " in refusal(CaseError) and ": a folder, not a mesh file" in refusal(CaseError)


def test_toml_syntax_error(here):
    (here / "case.toml").write_text('title = "x"\n[mesh]\nrectangle = { nx = 4,, }\n')
    assert refusal(CaseError) == "case.toml: line 3: Invalid initial character for a key part " \
                                 "(column 22)"
    (here / "case.toml").write_text('title = "x\n')
    assert refusal(CaseError).startswith("case.toml: line 1: ")
    (here / "case.toml").write_text('[mesh]\n[mesh]\n')
    assert refusal(CaseError).startswith("case.toml: line 2: ")


def test_deeply_nested_toml(here):
    (here / "case.toml").write_text("title = " + "[" * 3000 + "]" * 3000 + "\n")
    assert refusal(CaseError) == "case.toml: arrays or tables nested too deeply"


def test_unreadable_files(here):
    assert refusal(CaseError, "nope.toml") == \
        "nope.toml: case file not found (give the path of a TOML case file)"
    (here / "folder.toml").mkdir()
    assert "is a folder" in refusal(CaseError, "folder.toml")
    (here / "latin1.toml").write_bytes('title = "\n\ncontrainte é"\n'.encode("latin-1"))
    assert refusal(CaseError, "latin1.toml") == \
        "latin1.toml: line 3: not UTF-8 text (save the case file as UTF-8)"


def test_messages_stay_on_one_line(here):
    doc = read("ssnv509_interface")
    edit(doc, "material.model", "C_PLAN\n\u2028")
    write_case(here, doc)
    assert refusal(CaseError) == ('case.toml: material.model: unknown value '
                                  '"C_PLAN\\n\\u2028" (did you mean "C_PLAN"? '
                                  'expected one of C_PLAN, D_PLAN, 3D)')
    edit(doc, "material.model", "C_PLAN")
    edit(doc, "contact.bad\tkey", 1)
    write_case(here, doc)
    assert refusal(CaseError).startswith('case.toml: contact."bad\\tkey": unknown key (known: ')


# --- fuzzing --------------------------------------------------------------------------------

KNOWN_NAMES = sorted({name for key in schema.CASE.keys.values() if key.table
                      for name in key.table.keys} | set(schema.CASE.keys)
                     | set(schema.RECTANGLE.keys))
WORDS = ["VALUE", "MAX_ERROR", "MIN", "COULOMB", "SANS", "OUI", "NON", "INTERPENETRE",
         "FISSURE", "crack", "xdmf", "vtu", "QUAD8", "TRIA6", "left", "LAGS_C", "gap", "slip",
         "DX", "SIXY", "contact", "bonded", "free", "D_PLAN", "LIG1", "x+y", "1/0", "x <= 5",
         "LAGS_C != 0", "(x-x0)**2", "sqrt(-1)", "__import__('os')", "x0", "", " ", "1e400",
         "nan", "ssnv509a.mmed", "../../../../shared/meshes/ssnv509a.mmed", "."]
scalars = (st.booleans() | st.integers(-(2 ** 63), 2 ** 63 - 1) | st.integers(-3, 12)
           | st.floats(allow_nan=True, allow_infinity=True) | st.sampled_from([0.0, 0.5, -1.0])
           | st.text(max_size=12) | st.sampled_from(WORDS))
keys = st.sampled_from(KNOWN_NAMES) | st.text(min_size=1, max_size=8)
toml_values = st.recursive(scalars, lambda inner: st.lists(inner, max_size=3)
                           | st.dictionaries(keys, inner, max_size=3), max_leaves=6)


def _slots(node, out):
    """Every (container, key) pair of ``node``, depth first."""
    items = node.items() if isinstance(node, dict) else enumerate(node)
    for key, value in list(items):
        out.append((node, key))
        if isinstance(value, (dict, list)):
            _slots(value, out)
    return out


def mutate(doc, data):
    slots = _slots(doc, [])
    tables = [doc] + [c[k] for c, k in slots if isinstance(c[k], dict)]
    op = data.draw(st.sampled_from(["drop", "rename", "replace", "insert"]))
    if op == "insert" or not slots:
        table = data.draw(st.sampled_from(tables))
        table[data.draw(keys)] = data.draw(toml_values)
        return
    container, key = data.draw(st.sampled_from(slots))
    if op == "drop":
        del container[key]
    elif op == "rename" and isinstance(container, dict):
        container[data.draw(keys)] = container.pop(key)
    else:
        container[key] = data.draw(toml_values)


VALID = {name: read(name) for name in ("elastic_rectangle", "ssnv509_interface", "ssnv509a_mesh")}
VALID["ssnv509a_mesh"]["mesh"]["file"] = str(MESH)      # absolute: written anywhere


@pytest.mark.parametrize("name", sorted(VALID))
def test_writer_round_trip(name):
    assert tomllib.loads(dumps(VALID[name])) == VALID[name]


@settings(max_examples=200, deadline=None, database=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(name=st.sampled_from(sorted(VALID)), data=st.data())
def test_fuzz_loads_or_refuses_in_one_line(name, data):
    doc = copy.deepcopy(VALID[name])
    for _ in range(data.draw(st.integers(1, 3))):
        mutate(doc, data)
    with tempfile.TemporaryDirectory() as folder:
        path = write_case(folder, doc)
        try:
            case = load_case(path)
        except XfcError as exc:
            message = str(exc)
            assert message.startswith(f"{path}: ") and "\n" not in message
            assert message.isprintable(), message
        else:
            assert isinstance(case, Case)


def test_case_tables_hold_the_schema_keys():
    """The typed tables of a Case hold exactly the keys of their schema table (described
    there, once), apart from what is derived (Contact.friction from frottement)."""
    import dataclasses

    from xfemcontact.case import load

    pairs = [(load.Material, schema.MATERIAL, set()), (load.Newton, schema.NEWTON, set()),
             (load.Output, schema.OUTPUT, set()), (load.Interface, schema.INTERFACE, set()),
             (load.Contact, schema.CONTACT, {"friction", "frottement"})]
    for cls, table, derived in pairs:
        fields = {f.name for f in dataclasses.fields(cls)}
        assert fields ^ set(table.keys) <= derived, (cls.__name__, fields ^ set(table.keys))
