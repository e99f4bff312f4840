"""The case-file format, as data: every key with its type, default, range and meaning.

:data:`CASE` describes a whole TOML case file.  It is a :class:`Table` of
:class:`Key` entries; the loader (:mod:`xfemcontact.case.load`) walks it
generically: unknown keys are refused (with a close name suggested), missing
required keys reported, every value checked against its type and range and
turned into its canonical form, then the :class:`Table` rules (exactly one
of, at least one of, not both, required/forbidden when) are checked.

Defaults are written as they would be in TOML and converted like a given value
(``"OUI"`` becomes ``True``, ``[0, 10]`` a tuple ...); a default of ``None``
means "absent" and is kept as ``None``.  A table key with the default ``{}``
is always present, filled with the defaults of its keys.

Value types (``Key.type``):

* ``float``: an int or float (never a bool), finite, within the bounds
  ``gt``/``ge``/``lt``/``le``; stored as float.
* ``int``: an int only (``2.0`` is refused), within the bounds.
* ``str``: one line of printable text (no control characters), at most
  ``max_length`` characters.
* ``choice``: a string matched case-insensitively against ``choices``, stored
  in the spelling of ``choices`` (or mapped through ``values``); with
  ``booleans``, TOML ``true``/``false`` are accepted as ``"OUI"``/``"NON"``;
  ``refused`` maps values that are known but not supported to the message.
* ``choices``: an array of ``choice`` values, stored as a tuple (repeats dropped).
* ``formula``: a number or a formula string of ``x``, ``y`` (``z`` in a 3-D case) and
  the parameters, compiled at load time into a :class:`~xfemcontact.case.formula.Formula`.
* ``tformula``: the same with the instant ``t`` too (loads and references), stored as a
  :class:`~xfemcontact.case.functions.TimeFormula` (bound to the last instant, with
  the ``fonc_mult`` function of its table when it has one).
* ``numbers``: a non-empty array of finite numbers, stored as a tuple of floats.
* ``condition``: a condition string, compiled into a
  :class:`~xfemcontact.case.formula.Condition`; its variables are
  ``variables[siblings[context]]`` (they depend on a key validated before it).
* ``names``: a non-empty string or a non-empty array of them, stored as a tuple.
* ``point``: an array of two numbers (three in a 3-D case), stored as a tuple of floats.
* ``interval``: an array of two increasing numbers, stored as a tuple of floats.
* ``file``: a path relative to the case file's folder, stored resolved; the
  file must exist.
* ``table``: a sub-table, described by ``table``.
* ``tables``: an array of tables (``[[name]]``), stored as a tuple.
"""
from __future__ import annotations

import json
import keyword
from dataclasses import dataclass, field
from typing import Any

from xfemcontact.case.formula import CONSTANTS
from xfemcontact.case.formula import FUNCTIONS as FORMULA_FUNCTIONS
from xfemcontact.contact import laws

NODE_FIELDS = ("DX", "DY")
CELL_FIELDS = ("SIXX", "SIYY", "SIXY")
INTERFACE_FIELDS = ("LAGS_C", "LAGS_F1", "gap", "slip")
#: the fields of 3-D cases (code_aster's Voigt order of the stresses; LAGS_F2: the second
#: friction semi-multiplier, along t2 of the tangent basis)
NODE_FIELDS_3D = ("DX", "DY", "DZ")
CELL_FIELDS_3D = ("SIXX", "SIYY", "SIZZ", "SIXY", "SIXZ", "SIYZ")
INTERFACE_FIELDS_3D = INTERFACE_FIELDS + ("LAGS_F2",)
#: the keys of 3-D components (imposed DZ, forces FZ): left out of the rules of 2-D cases
KEYS_3D = ("DZ", "FZ")
#: fields of 3-D cases only
FIELDS_3D_ONLY = tuple(f for f in NODE_FIELDS_3D + CELL_FIELDS_3D + INTERFACE_FIELDS_3D
                       if f not in NODE_FIELDS + CELL_FIELDS + INTERFACE_FIELDS)
#: field name -> where it lives: "node", "cell" or "interface"
FIELD_KIND = {**dict.fromkeys(NODE_FIELDS_3D, "node"), **dict.fromkeys(CELL_FIELDS_3D, "cell"),
              **dict.fromkeys(INTERFACE_FIELDS_3D, "interface")}
FIELDS = tuple(FIELD_KIND)
#: field name -> the variables of a test's ``where`` condition on that field (2-D cases)
CONDITION_VARIABLES = {
    name: ("x", "y") + {"node": NODE_FIELDS, "cell": CELL_FIELDS,
                        "interface": INTERFACE_FIELDS}[kind]
    for name, kind in FIELD_KIND.items()}
#: the same in 3-D cases
CONDITION_VARIABLES_3D = {
    name: ("x", "y", "z") + {"node": NODE_FIELDS_3D, "cell": CELL_FIELDS_3D,
                             "interface": INTERFACE_FIELDS_3D}[kind]
    for name, kind in FIELD_KIND.items()}

MESH_CELLS = ("QUAD8", "TRIA6")
BOX_CELLS = ("HEXA20", "TETRA10")
DIAGONALS = ("right", "left", "alternate")
MODELS = ("C_PLAN", "D_PLAN", "3D")
LAWS = laws.NAMES
TEST_TYPES = ("MIN", "MAX", "VALUE", "SOMM_ABS", "MAX_ERROR")
CRITERIA = ("ABSOLU", "RELATIF")
OUTPUT_FORMATS = ("xdmf", "vtu", "med")
MAX_REFINE = 6
#: most instants of a case (after the ranges are expanded) and most subdivision levels
MAX_INSTANTS = 100000
MAX_SUBD = 20
MAX_CELLS_PER_SIDE = 10000
MAX_CELLS_PER_SIDE_3D = 1000
#: most iterations of any loop (ITER_GLOB_MAXI, ITER_CONT_MAXI, ITER_FROT_MAXI and the
#: options overriding them): far beyond any useful count, far below PETSc's integers
MAX_ITERATIONS = 1000000

#: names a parameter may not take, with what they already are
RESERVED_NAMES = {
    **dict.fromkeys(("x", "y"), "a formula variable"),
    "z": "a formula variable (3-D cases)",
    "t": "a formula variable (the instant)",
    **dict.fromkeys(FIELDS, "a field name usable in test conditions"),
    **dict.fromkeys(CONSTANTS, "a constant"),
    **dict.fromkeys(FORMULA_FUNCTIONS, "a function"),
    **{word: "a Python keyword" for word in keyword.kwlist},
}
#: parameter names: ASCII letters, digits and '_', starting with a letter
PARAMETER_NAME = r"[A-Za-z][A-Za-z0-9_]*"

_CRACK = "crack tips are not supported (TYPE_DISCONTINUITE='INTERFACE' only)"
BOOLEAN = {"OUI": True, "NON": False}


@dataclass(frozen=True)
class Key:
    """One key of a table: its type, whether required, its default, bounds and meaning."""

    type: str
    doc: str
    required: bool = False
    default: object = None            # as written in TOML
    gt: float | None = None
    ge: float | None = None
    lt: float | None = None
    le: float | None = None
    choices: tuple[str, ...] = ()
    values: dict[str, Any] | None = None
    booleans: bool = False
    refused: dict[str, str] = field(default_factory=dict)
    table: Table | None = None
    context: str | None = None
    variables: dict[str, tuple[str, ...]] | None = None
    max_length: int = 200


@dataclass(frozen=True)
class ExactlyOne:
    """Exactly one of ``keys`` must be given."""

    keys: tuple[str, ...]


@dataclass(frozen=True)
class AtLeastOne:
    """At least one of ``keys`` must be given."""

    keys: tuple[str, ...]


@dataclass(frozen=True)
class NotBoth:
    """Keys of group ``first`` and of group ``second`` cannot be given together."""

    first: tuple[str, ...]
    second: tuple[str, ...]


@dataclass(frozen=True)
class When:
    """When the (checked) value of ``key`` is in ``values``: ``require`` / ``forbid`` keys."""

    key: str
    values: tuple[object, ...]
    require: tuple[str, ...] = ()
    forbid: tuple[str, ...] = ()
    hint: str = ""


#: a rule of a :class:`Table`
Rule = ExactlyOne | AtLeastOne | NotBoth | When


@dataclass(frozen=True)
class Table:
    """A TOML table: its keys in checking order, its rules, and what its free keys are."""

    keys: dict[str, Key]
    doc: str = ""
    rules: tuple[Rule, ...] = ()
    extra: Key | None = None          # type of the keys not listed (free names)


def flag(doc: str, default: object) -> Key:
    """A boolean key: true/false or "OUI"/"NON"."""
    return Key("choice", doc, default=default, choices=tuple(BOOLEAN), values=BOOLEAN,
               booleans=True)


def formula(doc: str, **kwargs: Any) -> Key:
    """A formula key (a number or a formula of x, y (z in 3-D) and the parameters)."""
    return Key("formula", doc, **kwargs)


def tformula(doc: str, **kwargs: Any) -> Key:
    """A number or a formula of x, y and the instant t (loads, references)."""
    return Key("tformula", doc, **kwargs)


def fonc_mult() -> Key:
    return Key("str", "name of a [functions] table multiplying this load's values at each "
               "instant (FONC_MULT)", max_length=100)


RECTANGLE = Table({
    "nx": Key("int", "number of cells along x", required=True, ge=1, le=MAX_CELLS_PER_SIDE),
    "ny": Key("int", "number of cells along y", required=True, ge=1, le=MAX_CELLS_PER_SIDE),
    "x": Key("interval", "[xmin, xmax] in m", default=[0.0, 10.0]),
    "y": Key("interval", "[ymin, ymax] in m", default=[0.0, 10.0]),
    "cell": Key("choice", "cell type", default="QUAD8", choices=MESH_CELLS),
    "diagonal": Key("choice", "how TRIA6 split the squares", default="alternate",
                    choices=DIAGONALS),
}, doc="structured mesh of a rectangle")

BOX = Table({
    "nx": Key("int", "number of cells along x", required=True, ge=1, le=MAX_CELLS_PER_SIDE_3D),
    "ny": Key("int", "number of cells along y", required=True, ge=1, le=MAX_CELLS_PER_SIDE_3D),
    "nz": Key("int", "number of cells along z", required=True, ge=1, le=MAX_CELLS_PER_SIDE_3D),
    "x": Key("interval", "[xmin, xmax] in m", default=[0.0, 1.0]),
    "y": Key("interval", "[ymin, ymax] in m", default=[0.0, 1.0]),
    "z": Key("interval", "[zmin, zmax] in m", default=[0.0, 1.0]),
    "cell": Key("choice", "cell type (TETRA10: 6 a hexahedron)", default="HEXA20", choices=BOX_CELLS),
}, doc="structured mesh of a box (3-D)")

MESH = Table({
    "file": Key("file", "mesh file (MED, Gmsh, XDMF, VTU), relative to the case file's folder"),
    "rectangle": Key("table", "structured rectangle mesh: nx, ny, x, y, cell, diagonal",
                     table=RECTANGLE),
    "box": Key("table", "structured box mesh (3-D): nx, ny, nz, x, y, z, cell", table=BOX),
    "refine": Key("int", "uniform refinements (MACR_ADAP_MAIL RAFFINEMENT_UNIFORME; 2-D meshes)",
                  default=0, ge=0, le=MAX_REFINE),
}, doc="the mesh: file, rectangle or box", rules=(ExactlyOne(("file", "rectangle", "box")),))

MATERIAL = Table({
    "E": Key("float", "Young's modulus in Pa", required=True, gt=0),
    "nu": Key("float", "Poisson's ratio", required=True, gt=-1, lt=0.5),
    "model": Key("choice", "modelisation: plane stress, plane strain or 3D (default: C_PLAN, "
                 "3D with mesh.box)", choices=MODELS),
}, doc="E, nu, model: the elastic material")

DIRICHLET = Table({
    "group": Key("names", "face (3-D), edge or node group(s)", required=True),
    "DX": tformula("imposed x displacement in m, number or formula of x, y, (z,) t"),
    "DY": tformula("imposed y displacement in m, number or formula of x, y, (z,) t"),
    "DZ": tformula("imposed z displacement in m (3-D cases)"),
    "fonc_mult": fonc_mult(),
}, doc="DDL_IMPO: imposed displacements", rules=(AtLeastOne(("DX", "DY", "DZ")),))

TRACTION = Table({
    "group": Key("names", "edge group(s) (2-D) or face group(s) (3-D)", required=True),
    "FX": tformula("x force per unit length in N/m (FORCE_CONTOUR), per unit area in Pa in "
                   "3-D (FORCE_FACE)"),
    "FY": tformula("y force per unit length in N/m (FORCE_CONTOUR), per unit area in Pa in "
                   "3-D (FORCE_FACE)"),
    "FZ": tformula("z force per unit area in Pa (FORCE_FACE, 3-D cases)"),
    "PRES": tformula("pressure in Pa, > 0 pushes into the body (PRES_REP)"),
    "fonc_mult": fonc_mult(),
}, doc="FORCE_CONTOUR, FORCE_FACE or PRES_REP: loads on edges (2-D) or faces (3-D)",
    rules=(AtLeastOne(("FX", "FY", "FZ", "PRES")), NotBoth(("FX", "FY", "FZ"), ("PRES",))))

BODY_FORCE = Table({
    "FX": tformula("x force per unit volume in N/m^3"),
    "FY": tformula("y force per unit volume in N/m^3"),
    "FZ": tformula("z force per unit volume in N/m^3 (3-D cases)"),
    "fonc_mult": fonc_mult(),
}, doc="FORCE_INTERNE: body force", rules=(AtLeastOne(("FX", "FY", "FZ")),))

INTERFACE = Table({
    "type": Key("choice", "type of discontinuity", default="INTERFACE", choices=("INTERFACE",),
                refused={"FISSURE": _CRACK, "CRACK": _CRACK}),
    "level_set": formula("normal level set (FONC_LN), formula of x, y"),
    "level_set_field": Key("str", "name of nodal point data of the mesh file"),
    "law": Key("choice", "interface behaviour: " + "; ".join(f"{name} = {laws.get(name).doc}" for name in LAWS),
               default="contact", choices=LAWS),
    "max_offset": Key("float", "largest distance accepted between the zero of level_set and "
                      "the interface the mesh represents, as a fraction of the cell size (beyond "
                      "it the case is refused: refine the mesh, or raise this)", default=0.5, gt=0),
}, doc="DEFI_FISS_XFEM: the interface",
    rules=(ExactlyOne(("level_set", "level_set_field")),))

CONTACT = Table({
    "frottement": Key("choice", "friction law", default="SANS", choices=("COULOMB", "SANS")),
    "coulomb": Key("float", "Coulomb friction coefficient", default=0.0, ge=0),
    "integration": Key("choice", "where the contact conditions hold: NOEUD = at the multiplier "
                       "dofs (vertex-wise complementarity with positive lumped weights: answers "
                       "independent of coef_cont and coef_frot, Coulomb at every point), GAUSS = "
                       "code_aster's continuous method at the interface Gauss points",
                       default="NOEUD", choices=("NOEUD", "GAUSS")),
    "coef_cont": Key("float", "contact augmentation coefficient in Pa/m (default: E / h, h the "
                     "mean edge length of the cut cells); integration = GAUSS (NOEUD writes exact "
                     "conditions at the dofs: no augmentation, the rows are scaled by E / h)", gt=0),
    "coef_frot": Key("float", "friction augmentation coefficient in 1/m (default: E / (h mu |p|), "
                     "p the largest initial friction threshold); integration = GAUSS, as coef_cont",
                     gt=0),
    "contact_init": Key("choice", "initial contact status", default="OUI",
                        choices=("OUI", "NON", "INTERPENETRE"),
                        values={"OUI": True, "NON": False, "INTERPENETRE": "interpenetrated"},
                        booleans=True),
    "seuil_init": Key("float", "initial friction threshold in Pa, negative = compression "
                      "(integration = GAUSS; NOEUD starts from the sticking solution)"),
    "iter_cont_maxi": Key("int", "most contact status iterations", default=30, ge=1,
                          le=MAX_ITERATIONS),
    "iter_frot_maxi": Key("int", "most friction threshold iterations whose status loop ran to its end "
                          "(at most as many cut ones come on top)", default=10, ge=1,
                          le=MAX_ITERATIONS),
    "resi_frot": Key("float", "friction threshold convergence tolerance", default=1e-4, gt=0),
    "ordre_int": Key("int", "Gauss points per interface segment (default: 4, code_aster's, "
                     "or 8 where a cut cell is not affine: the shape functions of a distorted "
                     "quadrangle are not polynomials along the interface)", ge=1, le=8),
    "algo_lagr": Key("choice", "multiplier space: AUTO (= VERSION3) makes the vertex multipliers "
                     "unique (weak vertices aggregated, kernels of straight interfaces tied); "
                     "STABLE (2-D) ties the ends of the crossed edges in stars, one dof per star: "
                     "robust Newton in sliding, coarser multipliers; "
                     "NON = raw vertex space (may be singular, for comparison)", default="AUTO",
                     choices=("AUTO", "VERSION3", "STABLE", "NON")),
    "friction_unknown": Key("choice", "friction dof of integration = GAUSS: LAGS_F1 = code_aster's "
                            "semi-multiplier (exact |LAGS_F1| = 1 in slip), TRACTION = tangential "
                            "traction (stick tangent independent of the threshold: fewer "
                            "factorisations); NOEUD always solves for the traction",
                            default="LAGS_F1", choices=("LAGS_F1", "TRACTION")),
}, doc="DEFI_CONTACT: contact and friction settings", rules=(
    When("frottement", ("COULOMB",), require=("coulomb",),
         hint="give the friction coefficient, 0 for none"),
))

NEWTON = Table({
    "resi_glob_rela": Key("float", "relative residual tolerance", default=1e-6, gt=0),
    "iter_glob_maxi": Key("int", "most Newton iterations", default=20, ge=1, le=MAX_ITERATIONS),
}, doc="STAT_NON_LINE CONVERGENCE")

REFERENCE = Table({
    name: tformula(f"analytical {name}, formula of x, y, (z,) t") for name in FIELDS
}, doc="analytical solution: field name -> formula of x, y, (z,) t")

_NOT_MAX_ERROR = tuple(t for t in TEST_TYPES if t != "MAX_ERROR")
TEST = Table({
    "name": Key("str", "name of the test (each test its own)", max_length=100),
    "field": Key("choice", "tested field", required=True, choices=FIELDS),
    "type": Key("choice", "what is tested", required=True, choices=TEST_TYPES),
    "where": Key("condition", "condition selecting the points tested", context="field",
                 variables=CONDITION_VARIABLES),
    "point": Key("point", "[x, y] ([x, y, z] in 3-D) of the point tested, for type VALUE"),
    "reference": Key("float", "reference value"),
    "tolerance": Key("float", "tolerance", required=True, gt=0),
    "criterion": Key("choice", "absolute or relative tolerance", default="RELATIF",
                     choices=CRITERIA),
    "inst": Key("float", "instant of the results tested, one of [instants] (default: the "
                "last instant)"),
}, doc="TEST_TABLE: a check of the results", rules=(
    When("type", ("MAX_ERROR",), forbid=("reference",),
         hint="the error to reference.<field> is compared to 0"),
    When("type", ("VALUE",), require=("point",), hint="point = [x, y]"),
    When("type", tuple(t for t in TEST_TYPES if t != "VALUE"), forbid=("point",),
         hint="point is for type = \"VALUE\" only"),
    When("type", _NOT_MAX_ERROR, require=("reference",), hint="reference = <number>"),
))

OUTPUT = Table({
    "formats": Key("choices", "result file formats", default=["xdmf"], choices=OUTPUT_FORMATS),
    "plots": flag("draw the interface plots", default=True),
    "profile_point": Key("point", "3-D: [x, y, z] of a point of the planes cutting the interface for "
                                  "plot_profiles.png (default: the interface's centre)"),
    "profile_normal": Key("point", "3-D: [nx, ny, nz], the normal of the one plane cutting the interface "
                                   "for plot_profiles.png (default: the two coordinate planes through the "
                                   "point that contain the interface's main normal axis)"),
}, doc="what is written")

RANGE = Table({
    "start": Key("float", "first instant of the range (DEBUT)", required=True),
    "end": Key("float", "last instant of the range (JUSQU_A), > start", required=True),
    "steps": Key("int", "number of equal steps from start to end (NOMBRE)", required=True,
                 ge=1, le=MAX_INSTANTS),
}, doc="INTERVALLE: equal steps from start to end")

ECHEC = Table({
    "evenement": Key("choice", "the event handled: a step that does not converge",
                     default="ERREUR", choices=("ERREUR",)),
    "action": Key("choice", "DECOUPE: cut the step and solve the pieces; ARRET: stop",
                  default="DECOUPE", choices=("DECOUPE", "ARRET")),
    "subd_methode": Key("choice", "how a step is cut: MANUEL = into subd_pas equal pieces",
                        default="MANUEL", choices=("MANUEL",)),
    "subd_pas": Key("int", "pieces a failed step is cut into", default=4, ge=2, le=100),
    "subd_niveau": Key("int", "most nested cuts of a step (a piece of a piece ...)", default=3,
                       ge=1, le=MAX_SUBD),
}, doc="ECHEC: what to do with a step that does not converge")

INSTANTS = Table({
    "values": Key("numbers", "instants (DEFI_LIST_REEL VALE), increasing"),
    "ranges": Key("tables", "ranges of equal steps (INTERVALLE), several allowed: "
                  "[{start, end, steps}, ...]", table=RANGE),
    "echec": Key("table", ECHEC.doc, default={}, table=ECHEC),
}, doc="DEFI_LIST_INST: the instants computed (the first is the initial, unloaded state)",
    rules=(AtLeastOne(("values", "ranges")),))

FUNCTION = Table({
    "vale": Key("numbers", "t0, f0, t1, f1, ... (VALE: pairs, t increasing)"),
    "vale_para": Key("numbers", "t0, t1, ... increasing (VALE_PARA)"),
    "vale_fonc": Key("numbers", "f0, f1, ... (VALE_FONC, as many as vale_para)"),
    "interpol": Key("choice", "interpolation between the points", default="LIN",
                    choices=("LIN",)),
    "prol_gauche": Key("choice", "before the first abscissa: CONSTANT, LINEAIRE or EXCLU (no "
                       "value: an error)", default="EXCLU", choices=("CONSTANT", "LINEAIRE", "EXCLU")),
    "prol_droite": Key("choice", "after the last abscissa: CONSTANT, LINEAIRE or EXCLU",
                       default="EXCLU", choices=("CONSTANT", "LINEAIRE", "EXCLU")),
}, doc="DEFI_FONCTION: a piecewise linear function of time",
    rules=(NotBoth(("vale",), ("vale_para", "vale_fonc")), AtLeastOne(("vale", "vale_para"))))

FUNCTIONS = Table({}, doc="name = {vale = [...], prol_gauche, prol_droite}: functions of time "
                  "for fonc_mult (DEFI_FONCTION)",
                  extra=Key("table", "a piecewise linear function of time", table=FUNCTION))

PARAMETERS = Table({}, doc="name = number, usable in every formula",
                   extra=Key("float", "a number usable in every formula"))

CASE = Table({
    "title": Key("str", "title of the case (default: the file name)"),
    "parameters": Key("table", PARAMETERS.doc, default={}, table=PARAMETERS),
    "mesh": Key("table", MESH.doc, required=True, table=MESH),
    "material": Key("table", MATERIAL.doc, required=True, table=MATERIAL),
    "dirichlet": Key("tables", DIRICHLET.doc, default=[], table=DIRICHLET),
    "traction": Key("tables", TRACTION.doc, default=[], table=TRACTION),
    "body_force": Key("table", BODY_FORCE.doc, table=BODY_FORCE),
    "interface": Key("table", INTERFACE.doc, table=INTERFACE),
    "contact": Key("table", CONTACT.doc, default={}, table=CONTACT),
    "newton": Key("table", NEWTON.doc, default={}, table=NEWTON),
    "reference": Key("table", REFERENCE.doc, default={}, table=REFERENCE),
    "instants": Key("table", INSTANTS.doc, table=INSTANTS),
    "functions": Key("table", FUNCTIONS.doc, default={}, table=FUNCTIONS),
    "test": Key("tables", TEST.doc, default=[], table=TEST),
    "output": Key("table", OUTPUT.doc, default={}, table=OUTPUT),
}, doc="an X-FEM contact case")


def bounds(key: Key) -> str:
    """The range of a numeric key in words, such as ``"> -1 and < 0.5"`` ("" if none)."""
    parts = [f"{op} {_number(limit)}" for op, limit in
             ((">", key.gt), (">=", key.ge), ("<", key.lt), ("<=", key.le)) if limit is not None]
    return " and ".join(parts)


def _number(value: float) -> str:
    """``1000000`` for whole numbers (as written in a case file), ``0.5`` otherwise."""
    return str(int(value)) if float(value).is_integer() and abs(value) < 1e15 else f"{value:g}"


def reference(table: Table = CASE, prefix: str = "") -> list[str]:
    """A plain-text reference of the format: one line per key, from the schema."""
    lines = []
    for name, key in table.keys.items():
        dotted = f"{prefix}.{name}" if prefix else name
        if key.type in ("table", "tables"):
            assert key.table is not None          # table keys have their table
            brackets = ("{} = [{{...}}, ...]" if prefix else "[[{}]]") if key.type == "tables" \
                else "[{}]"
            lines.append(f"{brackets.format(dotted):26} {key.doc}")
            lines.extend(reference(key.table, dotted))
            extra = key.table.extra
            if extra is not None:
                lines.append(f"{dotted + '.<name>':26} {extra.doc}")
                if extra.type == "table":
                    assert extra.table is not None    # table keys have their table
                    lines.extend(reference(extra.table, dotted + ".<name>"))
            continue
        what = [key.type]
        if key.choices:
            what = [" | ".join(key.choices)]
        if bounds(key):
            what.append(bounds(key))
        if key.required:
            what.append("required")
        elif key.default is not None:
            what.append(f"default {json.dumps(key.default)}")
        lines.append(f"{dotted:26} {key.doc} ({', '.join(what)})")
    return lines
