"""Table 3.1 of the thesis as data: which motion-induced terms each case keeps.

Cases are named by the term they drop (docs/theory.md §11). Integers 0-5 are accepted as
aliases in Table 3.1's row order (not the Fortran INDEX order, which swaps 3 and 4).
"""

from __future__ import annotations

from dataclasses import dataclass
import difflib


@dataclass(frozen=True)
class Terms:
    """Motion-induced terms kept in a case (the structural stiffness and mass always are)."""

    motion: bool = True  # False: frozen structure, no motion terms at all (case 0)
    coriolis: bool = True
    tangential: bool = True
    normal: bool = True
    pseudo_normal: bool = True

    def keeps(self, term: str) -> bool:
        return self.motion and getattr(self, term)


CASES: dict[str, Terms] = {
    "structure": Terms(motion=False),
    "full": Terms(),
    "no_coriolis": Terms(coriolis=False),
    "no_tangential": Terms(tangential=False),
    "no_normal": Terms(normal=False),
    "no_pseudo_normal": Terms(pseudo_normal=False),
}
CASE_NAMES: tuple[str, ...] = tuple(CASES)
MOTION_TERMS = ("coriolis", "tangential", "normal", "pseudo_normal")


def case_name(value: str | int) -> str:
    """Canonical case name for a name or a Table 3.1 number (0-5); ValueError otherwise."""
    if isinstance(value, bool):
        raise ValueError(f"not a case: {value!r}")
    if isinstance(value, int):
        if 0 <= value < len(CASE_NAMES):
            return CASE_NAMES[value]
        raise ValueError(f"case number must be 0..5 (Table 3.1), got {value}")
    text = str(value).strip()
    if text.isdigit():
        return case_name(int(text))
    if text in CASES:
        return text

    near = difflib.get_close_matches(text.lower().replace("-", "_").replace(" ", "_"), CASE_NAMES, n=1, cutoff=0.6)
    hint = f"did you mean {near[0]!r}? " if near else ""
    raise ValueError(f"unknown case {value!r}; {hint}known: {', '.join(CASE_NAMES)} or 0-5")


def terms_used(cases: tuple[str, ...]) -> set[str]:
    """Motion terms that at least one of ``cases`` needs (the rest are never assembled)."""
    return {t for c in cases for t in MOTION_TERMS if CASES[c].keeps(t)}
