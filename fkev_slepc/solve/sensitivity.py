"""Eigenvalue sensitivities d λ_k / d p to a numeric scene key p at one operating point.

For P(λ; p) = λ² M(p) + λ C(p) + K(p) with right and left eigenvectors P(λ)x = 0, yᴴP(λ) = 0
of a simple eigenvalue λ, differentiating P(λ(p); p) x(p) = 0 and multiplying by yᴴ gives

    dλ/dp = - yᴴ (λ² ∂M/∂p + λ ∂C/∂p + ∂K/∂p) x / yᴴ (2λ M + C) x.

The matrices are real, so yᴴ = zᵀ with Pᵀ z = 0: both vectors come from one sparse LU of
P(λ) (two steps of inverse iteration, ``trans="T"`` for z). ∂M/∂p, ∂C/∂p, ∂K/∂p are the
assembled operators of the scene with p ± h differenced (central, h = 1e-6·|p|): every piece
(kinematics at the fixed crank angle, axial forces, element matrices) moves with p, and the
truncation error of the difference is O(h²) ~ 1e-12 relative. A key that changes the mesh's
connectivity (a node moving past another, a DOF count) has no operator derivative on one
pattern; there dλ/dp is the central difference of the whole point's eigenvalues (h = 1e-4·|p|,
each mode matched to the nearest eigenvalue). Integer keys (``elements``) have no derivative.
Besides scene keys, ``speed_rad_s`` and ``angle_deg`` differentiate with respect to the point's
own crank speed (d f/dΩ: the slope of the Campbell diagram) and crank angle (per degree).

Frequency f = Im λ / 2π and damping ratio ζ = -Re λ / |λ| follow:
df = Im dλ / 2π, dζ = -Re dλ / |λ| + Re λ · Re(λ̄ dλ) / |λ|³. Derivatives are per unit of the
key in the scene's units (per m for ``length_m``, per Pa for ``youngs_modulus_pa``).
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from fkev_slepc.scene import Problem, Scene, SceneError
from fkev_slepc.scene.edit import canonical_key, parse_key, replace_values
from fkev_slepc.scene.schema import is_number, show
from fkev_slepc.model.operators import AssemblyError, Model
from fkev_slepc.solve.engines import make_engine
from fkev_slepc.solve.modes import postprocess
from fkev_slepc.solve.thresholds import SolveSettings
from fkev_slepc.status import json_list

REL_STEP = 1e-6  # operator differences: truncation h² ~ 1e-12, round-off ε/h ~ 1e-10 of the derivative
REPEATED_RTOL = 1e-9  # eigenvalues this close (relative) are taken as one double eigenvalue
REL_STEP_POINTS = 1e-4  # whole-point differences: eigenvalue errors ~1e-12 / h stay ~1e-8
# the point's own coordinates, differentiable like scene keys: d f/dΩ is the Campbell slope
POINT_KEYS = {"speed_rad_s": lambda theta, speed: float(speed), "angle_deg": lambda theta, speed: float(np.degrees(theta))}
# keys a scene may leave out, with the value the reader then uses
DEFAULTS = {"driver.acceleration_rad_s2": 0.0, "damping.mass_proportional_1_s": 0.0,
            "damping.stiffness_proportional_s": 0.0}


@dataclass(frozen=True)
class Sensitivity:
    """d/dp of each reported mode's eigenvalue, frequency and damping ratio at one point."""

    key: str  # as given
    value: float  # p at the point (scene units)
    step: float  # h of the central difference
    method: str  # "adjoint" (operators differenced) or "points" (whole points differenced)
    eigenvalue: np.ndarray  # complex (n_modes,), dλ/dp (1/s per unit of p)
    frequency_hz: np.ndarray  # df/dp (Hz per unit of p)
    damping_ratio: np.ndarray  # dζ/dp (per unit of p)
    frequency: np.ndarray  # f (Hz) at the point, for relative sensitivities
    repeated: tuple[int, ...] = ()  # 1-based modes sharing their eigenvalue with another: no derivative (NaN)

    @property
    def relative_frequency(self) -> np.ndarray:
        """(p / f) df/dp: % change of f per % change of p (dimensionless)."""
        with np.errstate(invalid="ignore", divide="ignore"):
            return self.value * self.frequency_hz / self.frequency

    def as_dict(self) -> dict:
        """The JSON of ``fkev point --sensitivity KEY --json`` (None for a missing mode)."""
        num = json_list
        return {"value": self.value, "step": self.step, "method": self.method,
                "frequency_hz": num(self.frequency_hz), "damping_ratio": num(self.damping_ratio),
                "relative_frequency": num(self.relative_frequency), "repeated_modes": list(self.repeated),
                "eigenvalue": [[v.real, v.imag] if np.isfinite(v) else None for v in self.eigenvalue]}


def key_value(scene: Scene, key: str) -> float:
    """The number at ``key`` in ``scene`` (a link key left to ``[link_defaults]`` read there).

    Raises
    ------
    SceneError
        The key leads nowhere, holds no number, or is an integer setting.
    """
    path, node = scene_value(scene, key)
    if node is None:
        raise SceneError(scene.source, [Problem(key, "is not set in the scene: set it first (Study.replace)")])
    parts = parse_key(path)
    if not is_number(node):
        raise SceneError(scene.source, [Problem(key, f"is not a number (got {show(node)}): no derivative")])
    if isinstance(node, int) and parts[-1] in ("elements", "third_elements", "modes"):
        raise SceneError(scene.source, [Problem(key, f"is an integer setting (got {node}): no derivative")])
    return float(node)


def scene_value(scene: Scene, key: str):
    """(``key`` with name indices as positions, the value the scene gives it or None): the scene's
    text, a link key left to ``[link_defaults]``, a default of :data:`DEFAULTS`.

    Raises
    ------
    SceneError
        A malformed key path, or a name index no item has.
    """
    doc = tomllib.loads(scene.source_text) if scene.source_text else {}
    try:
        path = canonical_key(doc, key)
        parts = parse_key(path)
    except (ValueError, SceneError) as err:
        problems = err.problems if isinstance(err, SceneError) else [Problem(key, str(err))]
        raise SceneError(scene.source, problems) from None
    node = doc
    for part in parts:
        node = node[part] if isinstance(node, (dict, list)) and _has(node, part) else None
    if node is None and parts[0] == "links" and len(parts) in (3, 5):  # inherited: segment <- link <- defaults
        link = doc["links"][parts[1]] if len(parts) == 5 and _has(doc.get("links", []), parts[1]) else {}
        node = link.get(parts[-1], doc.get("link_defaults", {}).get(parts[-1])) if isinstance(link, dict) else None
    return path, DEFAULTS.get(path) if node is None else node


def number_keys(scene: Scene) -> list[str]:
    """Every key path at which :func:`key_value` finds a number (positional indices): the numbers
    of the scene's text, each link's keys left to ``[link_defaults]``, :data:`DEFAULTS` and the
    point's own :data:`POINT_KEYS`.

    Examples
    --------
    >>> from fkev_slepc.scene import load_scene
    >>> "links[1].youngs_modulus_pa" in number_keys(load_scene(RUNS / "bahgat-willmert-1976.toml"))
    True
    """
    doc = tomllib.loads(scene.source_text) if scene.source_text else {}
    out = []

    def walk(node, path):
        if is_number(node):
            out.append(path)
        elif isinstance(node, dict):
            for k, v in node.items():
                walk(v, f"{path}.{k}" if path else k)
        elif isinstance(node, list):
            for i, v in enumerate(node):
                walk(v, f"{path}[{i}]")

    walk(doc, "")
    defaults = {k: v for k, v in doc.get("link_defaults", {}).items() if is_number(v)}
    for i, link in enumerate(doc.get("links", [])):
        out += [f"links[{i}].{k}" for k in defaults if isinstance(link, dict) and k not in link]
    return out + [k for k in (*DEFAULTS, *POINT_KEYS) if k not in out]


def _has(node, part) -> bool:
    return (isinstance(node, dict) and part in node) or (isinstance(node, list) and isinstance(part, int)
                                                         and -len(node) <= part < len(node))


def eigenvectors(qep, lam: complex, iterations: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """Right x and (transposed) left z with P(λ)x ≈ 0, P(λ)ᵀz ≈ 0, from one LU of P(λ)."""
    n = qep.n
    P = _pencil(qep, lam)
    try:
        lu = spla.splu(P)
    except RuntimeError:  # exactly singular at λ: shift by a rounding error
        lu = spla.splu(_pencil(qep, lam * (1 + 1e-13)))
    rng = np.random.default_rng(0)
    x = rng.standard_normal(n) + 1j * rng.standard_normal(n)
    z = x.copy()
    for _ in range(iterations):
        x, z = lu.solve(x), lu.solve(z, trans="T")
        x, z = x / np.linalg.norm(x), z / np.linalg.norm(z)
    return x, z


def _pencil(qep, lam: complex) -> sp.csc_matrix:
    P = (lam * lam) * qep.mass.astype(complex) + qep.stiffness
    if qep.damping is not None:
        P = P + lam * qep.damping
    return sp.csc_matrix(P)


def adjoint_derivative(qep, dM, dC, dK, lam: complex) -> complex:
    """dλ/dp = -zᵀ(λ²dM + λdC + dK)x / zᵀ(2λM + C)x for one simple eigenvalue λ of ``qep``."""
    x, z = eigenvectors(qep, lam)
    num = lam * lam * (dM @ x) + dK @ x
    den = 2.0 * lam * (qep.mass @ x)
    if dC is not None:
        num = num + lam * (dC @ x)
    if qep.damping is not None:
        den = den + qep.damping @ x
    return complex(-(z @ num) / (z @ den))


def mode_derivatives(lam: np.ndarray, dlam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(df/dp, dζ/dp) from λ and dλ/dp, elementwise."""
    a = np.abs(lam)
    with np.errstate(invalid="ignore", divide="ignore"):
        dzeta = -dlam.real / a + lam.real * (lam.conj() * dlam).real / a**3
    return dlam.imag / (2 * np.pi), dzeta


def _parts(model, pieces, speed: float, case: str) -> list:
    """[M, C, K_s, K - K_s] of one point, C = 0 when absent. K_s and the rest are apart so that
    each is differenced against its own size: a key that leaves K_s alone (an acceleration, a
    damping, the speed) differences to an exact zero there."""
    qep = model.qep(pieces, speed, case)
    C = qep.damping if qep.damping is not None else model.pattern.matrix(np.zeros(model.pattern.nnz))
    return [qep.mass, C, model.pattern.matrix(pieces.structural), qep.stiffness_rest]


MESH_CHANGED = "mesh changed"


def _operators_at(model, key: str, theta: float, speed: float, case: str):
    """``ops(v, must)``: the operator parts with ``key`` at ``v`` (None when ``v`` is out of range
    and not ``must``; :data:`MESH_CHANGED` where the DOFs would not mean the same)."""
    if key == "speed_rad_s":
        pieces = model.pieces(theta)
        return lambda v, must: _parts(model, pieces, v, case)
    if key == "angle_deg":
        return lambda v, must: _parts(model, model.pieces(float(np.radians(v))), speed, case)

    def ops(v, must):
        moved = _moved(model, key, v, case, must)
        if moved is None:
            return None
        return _parts(moved, moved.pieces(theta), speed, case) if same_mesh(model, moved) else MESH_CHANGED

    return ops


def _change(plus, minus) -> float:
    """Largest relative change ‖A₊ - A₋‖ / ‖A‖ over the operator parts (0: none changes)."""
    out = 0.0
    for a, b in zip(plus, minus):
        size = max(spla.norm(a), spla.norm(b))
        if size > 0:
            out = max(out, spla.norm(a - b) / size)
    return out


def _operator_derivative(ops, p: float, h: float):
    """(dM, dC, dK, h, how) by differencing ``ops`` (:func:`_operators_at`) at p ± h (forward from
    p where p - h is out of range), or None where the key changes the mesh. A step that moves no
    part by more than ~1e-9 relative (a zero-valued key, whose unit sets no scale) is rescaled
    once so the largest part moves by ~1e-7: round-off stays ~ε/1e-7 ~ 2e-9 of the derivative."""
    for attempt in range(2):
        hi, lo = ops(p + h, True), ops(p - h, False)
        if hi is MESH_CHANGED or lo is MESH_CHANGED:
            return None
        width, how = 2 * h, "adjoint"
        if lo is None:
            lo, width, how = ops(p, True), h, "adjoint (forward difference)"
        r = _change(hi, lo)
        if attempt == 1 or r == 0.0 or r > 1e-9:
            break
        h *= min(1e-7 / r, 1e8)
    dM, dC, dKs, dKr = ((a - b) / width for a, b in zip(hi, lo))
    return dM, dC, dKs + dKr, h, how


def same_mesh(a, b) -> bool:
    """Whether two models' DOFs mean the same (connectivity and pattern identical)."""
    ma, mb = a.mechanism, b.mechanism
    return (a.n_free == b.n_free and ma.elem_dofs.shape == mb.elem_dofs.shape
            and np.array_equal(ma.elem_dofs, mb.elem_dofs) and a.pattern.nnz == b.pattern.nnz
            and np.array_equal(a.pattern.indices, b.pattern.indices))


def point_sensitivity(model, theta: float, speed: float, case: str, eigenvalues: np.ndarray, key: str,
                      solve_point=None, rel_step: float | None = None) -> Sensitivity:
    """d/d``key`` of the reported modes ``eigenvalues`` of ``model`` at (θ rad, Ω rad/s, case).

    ``solve_point(scene) -> eigenvalues`` solves the same point on another scene: only needed
    (and only called) when the key changes the mesh (then whole points are differenced).

    Raises
    ------
    SceneError
        A bad key (named, with its value), or a scene at p ± h that is invalid or cannot be
        assembled at this crank angle.
    """
    scene = model.scene
    p = POINT_KEYS[key](theta, speed) if key in POINT_KEYS else key_value(scene, key)
    lam = np.asarray(eigenvalues, dtype=complex)
    found = np.isfinite(lam)
    scale = abs(p) if p != 0 else 1.0
    h = (rel_step or REL_STEP) * scale
    try:
        op = _operator_derivative(_operators_at(model, key, theta, speed, case), p, h)
        if op is not None:
            dM, dC, dK, h, method = op
            qep = model.qep(model.pieces(theta), speed, case)
            dlam = np.full(lam.shape, complex(np.nan, np.nan))
            dlam[found] = [adjoint_derivative(qep, dM, dC, dK, z) for z in lam[found]]
        else:
            h = (rel_step or REL_STEP_POINTS) * scale
            if solve_point is None or _moved(model, key, p - h, case, must=False) is None:
                raise SceneError(scene.source, [Problem(key, "changes the mesh: whole points are differenced, "
                                                        "which needs a point solver and p - h in range")])
            plus, minus = (np.asarray(solve_point(replace_values(scene, {key: v})), dtype=complex)
                           for v in (p + h, p - h))
            dlam = (_nearest(lam, plus) - _nearest(lam, minus)) / (2 * h)
            method = "points (the key changes the mesh: central difference of the point's eigenvalues)"
    except AssemblyError as err:
        raise SceneError(scene.source, [Problem(key, f"at {p:g} ± {h:.3g}: {err}")]) from None
    same = repeated(lam)
    dlam[same] = complex(np.nan, np.nan)  # a multiple eigenvalue has directional derivatives only
    df, dz = mode_derivatives(lam, dlam)
    return Sensitivity(key, p, h, method, dlam, df, dz, lam.imag / (2 * np.pi),
                       tuple(int(k) + 1 for k in np.flatnonzero(same)))


def repeated(lam: np.ndarray, rtol: float = REPEATED_RTOL) -> np.ndarray:
    """Mask of the eigenvalues within ``rtol`` (relative) of another one of ``lam``: the formula
    needs a simple eigenvalue (a double one splits, with one-sided derivatives along p).

    Examples
    --------
    >>> repeated(np.array([1 + 10j, 1 + 10j * (1 + 1e-12), 2 + 30j])).tolist()
    [True, True, False]
    """
    lam = np.asarray(lam, dtype=complex)
    ok = np.isfinite(lam)
    d = np.abs(lam[:, None] - lam[None, :])
    with np.errstate(invalid="ignore"):
        close = (d <= rtol * np.abs(lam)[:, None]) & ok[:, None] & ok[None, :]
    np.fill_diagonal(close, False)
    return close.any(axis=1)


def point_solver(theta: float, speed: float, case: str, n_modes: int, method: str = "auto"):
    """``solve(scene) -> eigenvalues`` of the ``n_modes`` reported modes of ``scene`` at one point
    (θ rad, Ω rad/s, case) with the engine ``method``: what :func:`point_sensitivity` differences
    where a key changes the mesh."""
    def solve(scene):
        model = Model(scene, cases=(case,))
        engine = make_engine(method, model.n_free, scene.solver.petsc, settings=SolveSettings.from_scene(scene))
        try:
            sol = engine.solve(model.qep(model.pieces(theta), speed, case), n_modes)
        finally:
            engine.close()
        an = scene.analysis
        return postprocess(sol, n_modes, an.imag_tol, an.damping_tol).eigenvalue

    return solve


def _moved(model, key: str, value: float, case: str, must: bool = True):
    """The model of ``model``'s scene with ``key`` at ``value`` (None when out of range and not ``must``)."""
    try:
        return Model(replace_values(model.scene, {key: value}), cases=(case,))
    except SceneError as err:
        if not must:
            return None
        raise SceneError(model.scene.source, [Problem(key, f"cannot be moved to {value:.17g} for the derivative")]
                         + err.problems) from None


def _nearest(ref: np.ndarray, cand: np.ndarray) -> np.ndarray:
    """For each ``ref`` eigenvalue the nearest of ``cand`` (NaN for a missing one)."""
    out = np.full(ref.shape, complex(np.nan, np.nan))
    ok = np.isfinite(cand)
    for i, z in enumerate(ref):
        if np.isfinite(z) and ok.any():
            out[i] = cand[ok][np.argmin(np.abs(cand[ok] - z))]
    return out
