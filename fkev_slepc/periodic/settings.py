"""Every tolerance and numerical knob of the periodic analyses in one frozen object (docs/archive.md,
"Periodic settings"; docs/stability.md, docs/response.md).

``PeriodicSettings()`` holds today's defaults (:data:`DEFAULTS`); ``replace(DEFAULTS, monodromy_tol=1e-12)``
or ``DEFAULTS.with_overrides(...)`` another set. A bad value raises :class:`SettingsError` (a
ValueError) naming the field and the value, when the object is made, so before any work.
``to_attrs()`` / ``from_attrs()``: flat, HDF5-attribute friendly (numbers, text, one float array),
round-tripping exactly; ``diff(other)``: the fields that differ with both values. The Floquet and
response products archive the whole object (``/floquet/settings``, ``/response/settings``) and a
``--resume`` compares it whole (:func:`resume_refusal`).

The module constants that other modules still export by name (``periodic.bands.DEFAULT_TOL``,
``periodic.truncation.REDUCE_TOL``, ``periodic.components.LINK_MODES``, ...) are read from
:data:`DEFAULTS`: the values live here only; the code reads the run's settings. An archive written
before a field of :data:`LATER` existed reads back with that field's default (the constant it ran with).
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields, replace

import numpy as np

SAFETY = 10.0  # the verdict rule: the multiplier error estimate counts this many times against an apparent growth
# fields a --resume may change: every archived monodromy stays valid and the band edges are refined further
REFINEMENTS = ("edge_rtol", "zeta_floor")
# fields added after the first archived settings, as module constants until then with today's defaults as
# values: an archive without one was computed with its default, which from_attrs fills in
LATER = ("auto_modes", "link_modes", "auto_min_steps", "links_step_ratio", "full_max_dofs", "attract_tol",
         "zeta_floor", "moving_modes", "moving_angles")


def _f(default, doc: str):
    """A field with its one-line meaning (``metadata["doc"]``: docs/archive.md's settings table)."""
    return field(default=default, metadata={"doc": doc})


class SettingsError(ValueError):
    """A bad settings value: ``field`` names it, ``value`` is what was given, ``rule`` what it must be."""

    def __init__(self, field: str, value, rule: str):
        super().__init__(f"{field}: {rule} (got {value!r})")
        self.field, self.value, self.rule = field, value, rule


@dataclass(frozen=True)
class PeriodicSettings:
    """The periodic analyses' tolerances and knobs (Floquet: docs/theory.md §18; response: docs/response.md §3)."""

    # the monodromy (fkev_slepc/periodic/floquet.py, fkev_slepc/periodic/magnus.py)
    magnus_order: int = _f(6, "order of the Gauss-Legendre Magnus integrator: 4 or 6")
    monodromy_tol: float = _f(1e-8, "error of the multipliers' moduli, relative to max(1, max|μ|), asked of the step doubling")
    steps: int = _f(0, "a fixed Magnus step count per revolution (0: doubled until monodromy_tol)")
    max_steps: int = _f(2**24, "full-model Magnus steps of one monodromy beyond which a run is refused before work")
    samples: int = _f(16, "exact generator samples the trigonometric interpolant starts from (doubled)")
    interp_tol: float = _f(1e-12, "relative midpoint error of the interpolant at which the samples stop doubling")
    max_samples: int = _f(1024, "the samples' cap (beyond interp_tol there: its bound enters the error)")
    # the reduction (fkev_slepc/periodic/truncation.py, reduce.py, components.py)
    reduce: str = _f("default", "none, default, auto, N (frozen modes per angle), links, links:N, moving, moving:R")
    basis_angles: int = _f(8, "crank angles of the frozen-mode pool over a revolution")
    threshold: float = _f(1e-10, "relative singular value at which a fixed frozen-mode basis is compressed")
    reduce_tol: float = _f(1e-3, "|Δ max|μ|| and relative frequency change that end the basis sequence")
    max_basis: int = _f(0, "largest basis of reduce=auto/links (0: no cap but the model's DOFs)")
    auto_modes: int = _f(4, "frozen modes per angle of reduce=auto's first pool; the Floquet frequencies compared")
    link_modes: int = _f(2, "fixed-interface modes per link of the first level of reduce=links (then doubled)")
    moving_modes: int = _f(8, "frozen modes of the first level of reduce=moving (then doubled)")
    moving_angles: int = _f(64, "crank angles at which reduce=moving samples the frozen modes")
    auto_min_steps: int = _f(60_000, "reduce=default: the full model below this many full-model Magnus steps")
    links_step_ratio: float = _f(4.0, "reduce=default above auto_min_steps: links where 4 x link_modes per link "
                                      "need 1/links_step_ratio of the full model's steps or fewer, else auto")
    # the verdict and the bands (fkev_slepc/periodic/bands.py, fkev_slepc/sweep/floquet_run.py)
    verdict_tol: float = _f(1e-6, "unstable where max|μ| - 1 > verdict_tol + 10 (SAFETY) x multiplier error")
    edge_rtol: float = _f(1e-6, "relative accuracy of the band edges")
    zeta_floor: float = _f(1e-4, "undamped scene: the modal damping ratio a band must need (ζ*) to be listed as "
                                 "surviving real damping (0: every band survives); a damped scene answers for its own")
    resonance_order: int = _f(3, "resonance candidates of order n <= this between stable grid speeds (0: none)")
    probe: bool = _f(False, "one more monodromy at each of those candidates")
    # the steady periodic response (fkev_slepc/periodic/response.py, steady.py)
    harmonics: int = _f(0, "a fixed harmonic-balance order H >= 2 (0: doubled from 8 until harmonic_tol)")
    harmonic_tol: float = _f(1e-8, "harmonic-balance error estimate (H vs H/2) asked")
    shoot: bool = _f(False, "cross-check by shooting on the monodromy (Floquet multipliers of the response)")
    shooting_tol: float = _f(1e-11, "relative error asked of the shooting monodromy")
    response_angles_deg: tuple = _f(tuple(float(a) for a in np.arange(0.0, 360.0, 5.0)), "output crank angles, deg")
    full_max_dofs: int = _f(48, "response reduce=default: the full model up to this many free DOFs, links above")
    attract_tol: float = _f(1e-8, "the response does not attract where max|μ| - 1 > attract_tol + 10 (SAFETY) x "
                                  "multiplier error (the verdict rule of verdict_tol)")

    def __post_init__(self):
        for f in fields(self):
            value = getattr(self, f.name)
            checked = _CHECKS[f.name](f.name, value)
            if checked is not value:
                object.__setattr__(self, f.name, checked)

    def with_overrides(self, **values) -> "PeriodicSettings":
        """A copy with the given fields replaced; a None value keeps the field (keyword arguments
        that were not given)."""
        return replace(self, **{k: v for k, v in values.items() if v is not None})

    def to_attrs(self) -> dict:
        """Flat attributes: ints, floats and text as they are, booleans as 0/1, the angles a float array."""
        out = {}
        for f in fields(self):
            v = getattr(self, f.name)
            out[f.name] = (np.asarray(v, dtype=float) if isinstance(v, tuple) else int(v) if isinstance(v, bool) else v)
        return out

    @classmethod
    def from_attrs(cls, attrs) -> "PeriodicSettings":
        """The settings written by :meth:`to_attrs` (an HDF5 attribute mapping or a dict). A missing
        field raises :class:`SettingsError` naming it (never a default in its place), except one of
        :data:`LATER` (an archive written before it was a field): its default, the value it was run with."""
        values = {}
        for f in fields(cls):
            if f.name not in attrs and f.name in LATER:
                continue
            if f.name not in attrs:
                raise SettingsError(f.name, None, "missing from the archived settings")
            v = attrs[f.name]
            default = getattr(DEFAULTS, f.name)
            if isinstance(default, tuple):
                v = tuple(float(x) for x in np.atleast_1d(np.asarray(v, dtype=float)))
            elif isinstance(default, bool):
                v = bool(v)
            elif isinstance(default, str):
                v = v.decode() if isinstance(v, bytes) else str(v)
            elif isinstance(default, int):
                v = int(v)
            else:
                v = float(v)
            values[f.name] = v
        return cls(**values)

    def as_json(self) -> dict:
        """Every field as JSON takes it (the angles a list): the settings a command prints whole."""
        return {f.name: list(v) if isinstance(v, tuple) else v for f in fields(self) for v in [getattr(self, f.name)]}

    def diff(self, other: "PeriodicSettings") -> dict:
        """``{field: (this value, other value)}`` of every field that differs."""
        return {f.name: (getattr(self, f.name), getattr(other, f.name)) for f in fields(self)
                if getattr(self, f.name) != getattr(other, f.name)}


def _int(low: int):
    def check(name, v):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < low:
            raise SettingsError(name, v, f"must be a whole number >= {low}")
        return int(v)
    return check


def _fraction(name, v):
    if isinstance(v, bool) or not isinstance(v, (int, float, np.floating, np.integer)) or not (
            np.isfinite(v) and 0.0 < v < 1.0):
        raise SettingsError(name, v, "must be in (0, 1)")
    return float(v)


def _floor(name, v):
    if isinstance(v, bool) or not isinstance(v, (int, float, np.floating, np.integer)) or not (
            np.isfinite(v) and 0.0 <= v < 1.0):
        raise SettingsError(name, v, "must be in [0, 1)")
    return float(v)


def _positive(name, v):
    if isinstance(v, bool) or not isinstance(v, (int, float, np.floating, np.integer)) or not (
            np.isfinite(v) and v > 0.0):
        raise SettingsError(name, v, "must be a finite number > 0")
    return float(v)


def _flag(name, v):
    if not isinstance(v, (bool, np.bool_)):
        raise SettingsError(name, v, "must be True or False")
    return bool(v)


def _order(name, v):
    if isinstance(v, bool) or v not in (4, 6):
        raise SettingsError(name, v, "must be 4 or 6 (the Gauss-Legendre Magnus orders)")
    return int(v)


def _harmonics(name, v):
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or (v != 0 and v < 2):
        raise SettingsError(name, v, "must be 0 (doubled until harmonic_tol) or a whole number >= 2")
    return int(v)


def _reduce(name, v):
    try:
        r = resolve_reduce(v)
    except ValueError as err:
        raise SettingsError(name, v, str(err).split(" (got ")[0]) from None
    return "none" if r is None else str(r)


def resolve_reduce(value):
    """The one resolver of ``reduce`` (Floquet and the response alike): the canonical value of what a
    user asked. **None means not given: the default**, ``"default"`` (decided per analysis: Floquet per
    speed by ``periodic.floquet.default_reduction``, the full model below ``auto_min_steps`` full-model
    steps 2·2π·ρ(A), above "links" where the link-component level of 4·``link_modes`` modes per link needs
    at most 1/``links_step_ratio`` of them, else "auto"; the response by
    ``periodic.component_response.response_reduction``, the full model up to ``full_max_dofs`` free DOFs,
    else "links": fields of :class:`PeriodicSettings`; docs/engine.md measures why); the full model is
    asked by ``"none"`` (resolved to None); "default", "auto", a whole number >= 1 (also as text),
    "links" (the link-frame component modes of fkev_slepc/periodic/components.py, modes per link doubled
    until converged), "links:N" (N >= 0 fixed-interface modes per link), "moving" (the moving frozen-mode
    basis of fkev_slepc/periodic/moving.py, its cutoff doubled until converged) or "moving:R" (R modes).
    ValueError otherwise."""
    if value is None:
        return "default"
    if isinstance(value, str) and value.strip().lower() == "none":
        return None
    if isinstance(value, str):
        v = value.strip().lower()
        if v in ("default", "auto", "links", "moving"):
            return v
        if v.startswith("links:") and v[6:].isdigit():
            return f"links:{int(v[6:])}"
        if v.startswith("moving:") and v[7:].isdigit() and int(v[7:]) >= 1:
            return f"moving:{int(v[7:])}"
        value = int(v) if v.isdigit() else value
    if isinstance(value, (int, np.integer)) and not isinstance(value, bool) and value >= 1:
        return int(value)
    raise ValueError("must be auto, none, default, links, links:N (modes per link >= 0), moving, moving:R "
                     f"(R >= 1 frozen modes) or a number of modes per angle >= 1 (got {value!r})")


def _angles(name, v):
    try:
        a = tuple(float(x) for x in np.atleast_1d(np.asarray(v, dtype=float)))
    except (TypeError, ValueError):
        raise SettingsError(name, v, "must be crank angles in degrees") from None
    if not a or not np.all(np.isfinite(a)):
        raise SettingsError(name, v, "must be one or more finite crank angles in degrees")
    return a


_CHECKS = {
    "magnus_order": _order, "monodromy_tol": _fraction, "steps": _int(0), "max_steps": _int(1), "samples": _int(2),
    "interp_tol": _fraction, "max_samples": _int(2), "reduce": _reduce, "basis_angles": _int(1),
    "threshold": _fraction, "reduce_tol": _fraction, "max_basis": _int(0), "auto_modes": _int(1),
    "link_modes": _int(1), "auto_min_steps": _int(0), "links_step_ratio": _positive, "verdict_tol": _fraction,
    "edge_rtol": _fraction, "resonance_order": _int(0), "probe": _flag, "harmonics": _harmonics,
    "harmonic_tol": _fraction, "shoot": _flag, "shooting_tol": _fraction, "response_angles_deg": _angles,
    "full_max_dofs": _int(0), "attract_tol": _fraction,
    "zeta_floor": _floor, "moving_modes": _int(1), "moving_angles": _int(8),
}

DEFAULTS = PeriodicSettings()
SCAN = PeriodicSettings(harmonic_tol=1e-6)  # the response speed scan's: a looser harmonic balance per speed


def resume_refusal(archived: PeriodicSettings | None, requested: PeriodicSettings, product: str) -> str | None:
    """Why a ``--resume`` of ``product`` cannot continue with ``requested``, or None: every field
    that differs from the archived settings (except :data:`REFINEMENTS`), each with both values;
    ``archived`` None (an archive written before the settings were recorded) is refused too."""
    if archived is None:
        return (f"cannot resume: /{product} was written before its periodic settings were archived "
                f"(no /{product}/settings); rerun with --force")
    changed = {k: v for k, v in archived.diff(requested).items() if k not in REFINEMENTS}
    if not changed:
        return None
    return "cannot resume: the periodic settings differ from the archive's: " + "; ".join(
        f"{k}: archive has {_show(a)}, this run {_show(b)}" for k, (a, b) in changed.items())


def _show(v) -> str:
    if isinstance(v, tuple):
        return f"{len(v)} angles {v[0]:g}..{v[-1]:g}" if len(v) > 3 else ",".join(f"{x:g}" for x in v)
    return f"{v:g}" if isinstance(v, float) else str(v)


def checked_settings(source, settings, overrides: dict, names: dict, bad: list | None = None) -> PeriodicSettings:
    """The :class:`~fkev_slepc.periodic.settings.PeriodicSettings` of a periodic run: ``settings``
    (None: the defaults) with ``overrides`` ({field: value}; None values not given) applied, or
    SceneError (of the scene file ``source``) listing ``bad`` and each bad value named as the caller
    calls it (``names[field]``, else ``settings.<field>``); each override is checked alone, so that
    every bad one is named, before any work."""
    from fkev_slepc.scene import Problem, SceneError

    bad = list(bad or [])
    base = DEFAULTS if settings is None else settings
    if not isinstance(base, PeriodicSettings):
        bad.append(Problem("settings", f"must be a PeriodicSettings (got {type(settings).__name__})"))
        raise SceneError(source, bad)
    given = {k: v for k, v in overrides.items() if v is not None}
    for key, value in given.items():
        try:
            replace(base, **{key: value})
        except SettingsError as err:
            bad.append(Problem(names.get(key, f"settings.{key}"), f"{err.rule} (got {err.value!r})"))
    if bad:
        raise SceneError(source, bad)
    return replace(base, **given)
