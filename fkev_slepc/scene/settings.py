"""Readers for the settings sections of a scene file: ``[analysis]`` (grid, cases, modes,
tolerances, element, requested accuracy) and ``[solver]`` (engine and PETSc options).

Like :mod:`fkev_slepc.scene.sections` (the linkage itself), each reader records problems with
their dotted path in a :class:`~fkev_slepc.scene.schema.Reader` and returns ``None`` for a bad
section.
"""

from __future__ import annotations

import difflib
import re

from fkev_slepc.scene.cases import CASE_NAMES, case_name
from fkev_slepc.scene.model import DAMPING_TOL, ELEMENT_NAMES, IMAG_TOL, Analysis, Solver
from fkev_slepc.scene.schema import Reader, is_number, join, show

ANALYSIS_KEYS = ("crank_angles_deg", "cases", "modes", "mode_shapes", "imag_tol", "damping_tol", "element",
                 "rel_error", "gravity_m_s2")
SOLVER_KEYS = ("method", "petsc")
SOLVER_METHODS = ("auto", "slepc", "dense")
_PETSC_PREFIXES = ("pep_", "eps_", "st_", "ksp_", "pc_", "bv_", "ds_", "rg_", "fn_", "mat_", "log_")
_OPTION_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]*")


def read_analysis(r: Reader, doc) -> Analysis | None:
    table = r.table(doc, "analysis", "")
    if table is None:
        return None
    renamed = {"stability_tol": "renamed damping_tol (a threshold on the damping ratio -Re λ/|λ|)"}
    r.check_keys(table, "analysis", ANALYSIS_KEYS, hint=renamed.get)
    values = dict(
        crank_angles_deg=r.values(table, "crank_angles_deg", "analysis", default=(0.0,)),
        cases=_read_cases(r, table),
        modes=r.integer(table, "modes", "analysis", default=4, minimum=1),
        mode_shapes=r.boolean(table, "mode_shapes", "analysis", default=False),
        imag_tol=r.number(table, "imag_tol", "analysis", default=IMAG_TOL, minimum=0.0, below=1.0),
        damping_tol=r.number(table, "damping_tol", "analysis", default=DAMPING_TOL, minimum=0.0, below=1.0),
        element=r.string(table, "element", "analysis", default="thesis", choices=ELEMENT_NAMES),
        # ground-frame gravity [gx, gy] for loads and response (fkev loads/response; not the eigen-analysis)
        gravity_m_s2=r.point(table, "gravity_m_s2", "analysis", default=(0.0, 0.0)),
    )
    rel_error = None
    if "rel_error" in table:  # optional: None means "use the scene's meshes as given"
        rel_error = r.number(table, "rel_error", "analysis", positive=True, below=1.0)
        if rel_error is None:
            return None
    return None if None in values.values() else Analysis(**values, rel_error=rel_error)


def _read_cases(r: Reader, table) -> tuple[str, ...] | None:
    """Names or Table 3.1 numbers, deduplicated in the order given; ``"all"`` is all six."""
    where = "analysis.cases"
    value = table.get("cases", ["full"])
    items = list(enumerate(value)) if isinstance(value, list) else [(None, value)]
    if not items:
        r.add(where, "must not be empty")
        return None
    out, ok = [], True
    for k, item in items:
        at = where if k is None else join(where, k)
        try:
            if item == "all":
                names = CASE_NAMES
            elif isinstance(item, (str, int)) and not isinstance(item, bool):
                names = (case_name(item),)
            else:
                r.add(at, f"must be a case name or a Table 3.1 number 0-5 (got {show(item)})")
                ok = False
                continue
        except ValueError:
            if isinstance(item, int):
                r.add(at, f"case number must be 0-5, in Table 3.1 order (got {item})")
                ok = False
                continue
            close = difflib.get_close_matches(str(item), (*CASE_NAMES, "all"), n=1)
            tip = f"did you mean '{close[0]}'? " if close else ""
            known = ", ".join(CASE_NAMES)
            r.add(at, f"unknown case (got {show(item)}; {tip}known: {known}, 'all' or Table 3.1 numbers 0-5)")
            ok = False
            continue
        out.extend(n for n in names if n not in out)
    return tuple(out) if ok else None


def read_solver(r: Reader, doc) -> Solver | None:
    table = r.table(doc, "solver", "")
    if table is None:
        return None

    def petsc_hint(key: str) -> str | None:
        name = key.lstrip("-").removeprefix("fkev_")
        return "PETSc options go in [solver.petsc]" if name.startswith(_PETSC_PREFIXES) else None

    r.check_keys(table, "solver", SOLVER_KEYS, hint=petsc_hint)
    method = r.string(table, "method", "solver", default="auto", choices=SOLVER_METHODS)
    petsc = r.table(table, "petsc", "solver")
    options: dict[str, str] = {}
    ok = petsc is not None
    for key, value in (petsc or {}).items():
        at = join("solver.petsc", key)
        name = key.lstrip("-").removeprefix("fkev_")
        if not _OPTION_NAME.fullmatch(name):
            r.add(at, f"not a PETSc option name (got {show(key)}; e.g. pep_type)")
            ok = False
        elif name in options:
            r.add(at, f"option {show(name)} given twice")
            ok = False
        elif isinstance(value, bool):
            options[name] = "true" if value else "false"
        elif isinstance(value, str):
            options[name] = value
        elif is_number(value) and r.check_number(value, at) is not None:
            options[name] = str(value)
        elif not is_number(value):
            hint = " (quote option names that contain dots)" if isinstance(value, dict) else ""
            r.add(at, f"must be a string, number or boolean (got {show(value)}){hint}")
            ok = False
        else:
            ok = False
    if method is None or not ok:
        return None
    return Solver(method=method, petsc=tuple(options.items()))
