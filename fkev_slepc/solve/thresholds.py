"""The solve stage's thresholds, defined once: one frozen :class:`SolveSettings` per run.

Every engine (dense, SLEPc, cross-check) takes one and uses it everywhere a threshold decides
something: which eigenvalues are real (the divergence verdict, the pairs a point reports, the
pairs polished and accepted, the SLEPc engine's count of frequencies found), when a pair is
accepted (pair error and its one-ulp floor) and how it is polished. It is built from the scene
(``[analysis]`` imag_tol and damping_tol) and the options (``max_pair_error``: command line
``-fkev_max_pair_error`` > scene ``[solver.petsc]`` > code default) by :meth:`SolveSettings.from_scene`.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from fkev_slepc.scene import DAMPING_TOL, IMAG_TOL  # the scene's defaults: |Im λ| <= IMAG_TOL·|λ| is real
from fkev_slepc.scene import Problem, SceneError
from fkev_slepc.solve.petsc_init import command_line_options

# A point whose reported pairs have pair_error above this is not converged, whatever the
# solver's own test said (option -fkev_max_pair_error, or max_pair_error in [solver.petsc]).
# Measured (README, "SLEPc engine"): right pairs give 1e-14..1e-5 up to a few thousand DOFs,
# wrong pairs 0.1..1; on over-refined models (>~1e4 DOFs) every unpolished pair drifts toward 1,
# because the round-off in the assembled K grows like n_el⁴. Models keep K_s factored, and the
# engines polish such pairs (solve/polish.py), judged by polished_pair_error instead.
MAX_PAIR_ERROR = 1e-3
# ... and no more than this multiple of what one-ulp changes of the matrix entries explain
# (pair_error_floor): the accuracy contract of docs/numerical-stability.md. Measured there
# (scripts/stress.py random, conditioning, toggle, refine): pairs of both engines within a few
# times their frequency floor reach 8.8e6 (a dense pair 1e-4° before a toggle; refined meshes
# stay below 10); the old dense eigh(K, M) of a rhombus with a rigid crank and a 1e4 kg mass
# (f₁ 6.6e-6 wrong) had 6.5e8.
MAX_FLOOR_RATIO = 1e8

# Pairs whose plain pair_error is below this are left as the engine returned them. Measured on
# Bahgat-Willmert (docs/accuracy.md §2): the frequency error the round-off causes is ~4e-3 of the
# pair error (η 3e-8 -> 1e-10 at 64 elements per link, 3e-3 -> 7e-6 at 1,024), so below 1e-8
# the floor is under ~1e-10 and a polish (an LU per mode) would cost more than the solve.
POLISH_ABOVE = 1e-8
# ... or above this multiple of their one-ulp floor (SLEPc engine only). Measured with heavy
# lumped masses at B (scripts/stress.py conditioning): TOAR's pairs with pair error below 1e-8
# had up to 9.5e5 times their floor and frequencies up to 1,560x the conditioning floor off the
# Newton-refined ones; polished, within 3x. Refined meshes' right pairs stay below 10x.
POLISH_RATIO = 100.0
POLISH_MAX_STEPS = 8
POLISH_STEP_TOL = 1e-13
POLISH_MAX_RESTARTS = 3  # new factorizations at the improved λ when one shift stalls (polish.polish_pair)
# A polished eigenvalue may move at most this far (relative to |λ|) from the engine's: a polish is
# a refinement of a pair the engine found, not a search. Measured (scripts/polish_moves.py,
# Bahgat-Willmert, 10°, 500 rad/s, full, SLEPc): right pairs move by 4.9e-10, 1.5e-7 and 2.6e-5 at
# 64, 256 and 1,000 elements per link; a pair carried onto another eigenvalue moves by ~1:
# Bahgat-Willmert with a 1e-8 m crank gave QZ a cluster of exact zeros that the polish carried
# onto the pair nearest 0 (753.9 Hz reported four times, status ok).
POLISH_MAX_MOVE = 1e-2
# Two reported pairs whose vectors have a MAC above this are one mode found twice (a polish
# that converged onto a neighbour's pair): the point is flagged, not reported with a duplicate.
DUPLICATE_MAC = 0.99


@dataclass(frozen=True)
class SolveSettings:
    """Thresholds of one run, shared by every engine (archived with the solver settings).

    Attributes
    ----------
    imag_tol : |Im λ| <= imag_tol·|λ| is a real eigenvalue (scene ``analysis.imag_tol``).
    damping_tol : a reported mode with ζ < -damping_tol is unstable (``analysis.damping_tol``).
    max_pair_error : largest accepted pair error of a reported pair (``-fkev_max_pair_error``).
    max_floor_ratio : largest accepted pair error / one-ulp floor of a reported pair.
    polish_above, polish_ratio : pairs with pair error above this (or above this multiple of
        their floor, SLEPc engine) are polished (solve/polish.py).
    polish_max_steps, polish_step_tol, polish_max_restarts : the polish iteration's limits.
    polish_max_move : largest relative move |λ_polished - λ| / |λ| of a polished pair.
    duplicate_mac : MAC above which two reported pairs count as the same mode.

    Examples
    --------
    >>> SolveSettings().imag_tol
    1e-09
    >>> SolveSettings(imag_tol=1e-6).as_dict()["imag_tol"]
    1e-06
    """

    imag_tol: float = IMAG_TOL
    damping_tol: float = DAMPING_TOL
    max_pair_error: float = MAX_PAIR_ERROR
    max_floor_ratio: float = MAX_FLOOR_RATIO
    polish_above: float = POLISH_ABOVE
    polish_ratio: float = POLISH_RATIO
    polish_max_steps: int = POLISH_MAX_STEPS
    polish_step_tol: float = POLISH_STEP_TOL
    polish_max_restarts: int = POLISH_MAX_RESTARTS
    polish_max_move: float = POLISH_MAX_MOVE
    duplicate_mac: float = DUPLICATE_MAC

    def __post_init__(self):
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if not (isinstance(v, (int, float)) and v >= 0):
                raise ValueError(f"SolveSettings.{f.name} must be a number >= 0 (got {v!r})")
        if not self.imag_tol < 1.0:
            raise ValueError(f"SolveSettings.imag_tol must be < 1 (got {self.imag_tol!r})")

    @classmethod
    def from_scene(cls, scene=None, petsc_options=None, **overrides) -> SolveSettings:
        """The settings of a run of ``scene``: its ``[analysis]`` thresholds, ``max_pair_error``
        from the options (command line > ``petsc_options``, default the scene's ``[solver.petsc]``,
        > code default) and any explicit ``overrides`` (field name -> value).

        Raises
        ------
        SceneError
            When ``max_pair_error`` is not a number > 0 (named by where it was given).
        """
        values = {}
        if scene is not None:
            values.update(imag_tol=scene.analysis.imag_tol, damping_tol=scene.analysis.damping_tol)
            if petsc_options is None:
                petsc_options = scene.solver.petsc
        values["max_pair_error"] = max_pair_error_option(petsc_options or (), overrides.pop("max_pair_error", None))
        values.update(overrides)
        return cls(**values)

    def replace(self, **changes) -> SolveSettings:
        return dataclasses.replace(self, **changes)

    def as_dict(self) -> dict:
        """JSON-able (archived under the engine settings' ``thresholds``)."""
        return dataclasses.asdict(self)


def max_pair_error_option(petsc_options, explicit=None) -> float:
    """``max_pair_error`` with the precedence command line (``-fkev_max_pair_error``) > scene
    ``[solver.petsc]`` > ``explicit`` (a caller's code default) > :data:`MAX_PAIR_ERROR`."""
    value, source = (MAX_PAIR_ERROR, "default") if explicit is None else (explicit, "code")
    scene = {str(k).lstrip("-").removeprefix("fkev_"): v for k, v in dict(petsc_options).items()}
    if "max_pair_error" in scene:
        value, source = scene["max_pair_error"], "solver.petsc.max_pair_error"
    argv = command_line_options()
    for i, tok in enumerate(argv[:-1]):
        if tok in ("-fkev_max_pair_error", "--fkev_max_pair_error"):
            value, source = argv[i + 1], "-fkev_max_pair_error"
    try:
        out = float(value)
    except (TypeError, ValueError):
        out = float("nan")
    if not out > 0:
        name = "fkev_max_pair_error" if source != "-fkev_max_pair_error" else source
        raise SceneError("PETSc options", [Problem(source, f"{name}: must be a number > 0 (got {value!r})")])
    return out
