"""Typed readers for scene tables that collect problems instead of raising.

:mod:`fkev_slepc.scene` describes *what* a scene contains; this module knows *how* to read one
TOML value safely. Every reader takes the parent table, the key and the dotted path of that
table, records a :class:`~fkev_slepc.scene.Problem` for anything wrong (naming the full dotted
path and the offending value) and returns ``None`` for a bad value, so that parsing carries on
and the user sees every problem in one go (scikit-build-core style, not PyFR's first-error-wins).
"""

from __future__ import annotations

import difflib
import math
import re
from collections.abc import Mapping, Sequence
from typing import Any

from fkev_slepc.scene.model import Problem

# Marks "no default: the key is required". ``None`` as a default means "absent is fine, and a
# value that was already reported elsewhere (e.g. a bad [link_defaults] entry) stays silent".
REQUIRED = object()

MAX_RANGE_VALUES = 1_000_000  # a {start, stop, step} table that would allocate more is a typo


def show(value: Any) -> str:
    """Render ``value`` for a message, in TOML spelling where it differs from Python's."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return repr(value)
    if isinstance(value, float):
        return "nan" if math.isnan(value) else repr(value)
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k} = {show(v)}" for k, v in value.items()) + "}"
    if isinstance(value, list):
        return "[" + ", ".join(show(v) for v in value) + "]"
    return str(value)


def join(path: str, key: str | int) -> str:
    """Dotted path of ``key`` inside ``path`` (``links[1]`` + ``length_m``, ``cases`` + 2)."""
    if isinstance(key, int):
        return f"{path}[{key}]"
    return f"{path}.{key}" if path else key


def is_number(value: Any) -> bool:
    """TOML integer or float; a boolean is *not* a number (``True == 1`` in Python)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool)


# "links[3].segments[1].area_m2": an item of a top-level array of tables, and the key path in it
_ITEM_KEY = re.compile(r"(?P<array>[A-Za-z_]+)\[(?P<index>\d+)\]\.(?P<rest>.+)")

class Reader:
    """Collects problems while reading a parsed TOML document.

    Parameters
    ----------
    sections : mapping of section path -> allowed keys
        Used to point a misplaced key to the section it belongs in.
    """

    def __init__(self, sections: Mapping[str, Sequence[str]] = ()):
        self.problems: list[Problem] = []
        self.sections = dict(sections)

    def add(self, path: str, message: str) -> None:
        self.problems.append(Problem(path, message))

    # -- structure --------------------------------------------------------------------------
    def check_keys(self, table: Mapping[str, Any], path: str, allowed: Sequence[str], hint=None) -> None:
        """Report every key of ``table`` not in ``allowed``, with a "did you mean" if one is close.

        ``hint(key)`` may return an extra remark for a key with no close match.
        """
        for key in table:
            if key in allowed:
                continue
            exact = next((s for s, keys in self.sections.items() if s and s != path and key in keys), None)
            close = difflib.get_close_matches(key, allowed, n=2, cutoff=0.6)
            if close and exact is None:  # a key of another section verbatim is misplaced, not misspelt
                spelled = " or ".join(f"'{join(path, c)}'" for c in close)
                self.add(join(path, key), f"unknown key (did you mean {spelled}?)")
                continue
            home = join(exact, key) if exact is not None else self._section_of(key, exclude=path)
            extra = hint(key) if hint else None
            if home is not None:
                section = home.rpartition(".")[0]
                self.add(join(path, key), f"unknown key (did you mean '{home}'? it belongs in [{section}])")
            elif extra:
                self.add(join(path, key), f"unknown key ({extra})")
            else:
                known = ", ".join(allowed)
                self.add(join(path, key), f"unknown key (known keys: {known})")

    def _section_of(self, key: str, exclude: str) -> str | None:
        """Path of ``key`` (or a close spelling of it) in another section, if any."""
        for section, keys in self.sections.items():
            if section == exclude or not section:
                continue
            close = difflib.get_close_matches(key, keys, n=1, cutoff=0.7)
            if close:
                return join(section, close[0])
        return None

    def compacted(self) -> list[Problem]:
        """The problems with the same message about the same key of several items of one array
        of tables merged into one line, ``links[0, 1, 2].area_m2: missing required key``: a
        dropped ``[link_defaults]`` header otherwise gives one line per link and key."""
        groups: dict[tuple[str, str, str], list[str]] = {}
        order: list[tuple[str, str, str] | Problem] = []
        for p in self.problems:
            m = _ITEM_KEY.fullmatch(p.path)
            if m is None:
                order.append(p)
                continue
            key = (m["array"], m["rest"], p.message)
            if key not in groups:
                groups[key] = []
                order.append(key)
            groups[key].append(m["index"])
        out = []
        for item in order:
            if isinstance(item, Problem):
                out.append(item)
            else:
                array, rest, message = item
                out.append(Problem(f"{array}[{', '.join(groups[item])}].{rest}", message))
        return out

    def missing(self, path: str, remark: str = "") -> None:
        self.add(path, "missing required key" + (f" ({remark})" if remark else ""))

    def table(self, parent: Mapping[str, Any], key: str, path: str, *, required: bool = False):
        """Sub-table ``parent[key]`` (``{}`` when absent and optional), or ``None`` if invalid."""
        where = join(path, key)
        if key not in parent:
            if required:
                self.missing(where, f"add a [{where}] table")
                return None
            return {}
        value = parent[key]
        if not isinstance(value, dict):
            self.add(where, f"must be a table [{where}] (got {show(value)})")
            return None
        return value

    def tables(self, parent: Mapping[str, Any], key: str, path: str, *, required: bool = False):
        """Array of tables ``[[key]]`` as a list of ``(path, table)``; bad items are reported."""
        where = join(path, key)
        if key not in parent:
            if required:
                self.missing(where, f"add at least one [[{where}]] table")
            return []
        value = parent[key]
        if isinstance(value, dict):
            self.add(where, f"must be an array of tables: write [[{where}]], not [{where}]")
            return []
        if not isinstance(value, list):
            self.add(where, f"must be an array of tables [[{where}]] (got {show(value)})")
            return []
        if required and not value:
            self.add(where, "must not be empty")
        out = []
        for i, item in enumerate(value):
            if isinstance(item, dict):
                out.append((join(where, i), item))
            else:
                self.add(join(where, i), f"must be a table (got {show(item)})")
        return out

    def _absent(self, table: Mapping[str, Any], key: str, path: str, default, remark: str):
        """(True, default) if ``key`` is absent (reporting it when required), else (False, None)."""
        if key in table:
            return False, None
        if default is REQUIRED:
            self.missing(join(path, key), remark)
            return True, None
        return True, default

    # -- scalars ----------------------------------------------------------------------------
    def string(self, table, key, path, *, default=REQUIRED, choices=None, what=None, remark=""):
        """A string; with ``choices``, one of them (a close spelling gets a suggestion).

        ``what`` ("link", "joint") words the message as a reference to a named object.
        """
        absent, value = self._absent(table, key, path, default, remark)
        if absent:
            return value
        value, where = table[key], join(path, key)
        if not isinstance(value, str):
            self.add(where, f"must be a string (got {show(value)})")
            return None
        if choices is not None and value not in choices:
            close = difflib.get_close_matches(value, choices, n=1)
            tip = f"; did you mean '{close[0]}'?" if close else ""
            listed = ", ".join(map(repr, choices))
            if what is None:
                self.add(where, f"must be one of {listed} (got {show(value)}{tip})")
            else:
                known = f"; known: {listed}" if choices else ""
                self.add(where, f"unknown {what} (got {show(value)}{tip}{known})")
            return None
        return value

    def check_number(self, raw, where, *, positive=False, minimum=None, below=None):
        """Validate one number found at ``where``; return it as float, or ``None``.

        Messages quote ``raw`` as written (``-1`` stays ``-1``, ``-1.0`` stays ``-1.0``).
        """
        if not is_number(raw):
            kind = "a boolean" if isinstance(raw, bool) else "a string" if isinstance(raw, str) else None
            extra = f", not {kind}" if kind else ""
            self.add(where, f"must be a number{extra} (got {show(raw)})")
            return None
        value = float(raw)
        if not math.isfinite(value):
            self.add(where, f"must be finite (got {show(raw)})")
        elif positive and value <= 0:
            self.add(where, f"must be > 0 (got {show(raw)})")
        elif minimum is not None and value < minimum:
            self.add(where, f"must be >= {show(minimum)} (got {show(raw)})")
        elif below is not None and value >= below:
            self.add(where, f"must be < {show(below)} (got {show(raw)})")
        else:
            return value
        return None

    def number(self, table, key, path, *, default=REQUIRED, remark="", **limits):
        """A finite float (TOML int or float, never bool); ``positive``/``minimum``/``below``."""
        absent, value = self._absent(table, key, path, default, remark)
        if absent:
            return value
        return self.check_number(table[key], join(path, key), **limits)

    def integer(self, table, key, path, *, default=REQUIRED, minimum=None, remark=""):
        """A TOML integer (not a float with an integral value, not a boolean)."""
        absent, value = self._absent(table, key, path, default, remark)
        if absent:
            return value
        value, where = table[key], join(path, key)
        if isinstance(value, bool) or not isinstance(value, int):
            self.add(where, f"must be an integer (got {show(value)})")
            return None
        if minimum is not None and value < minimum:
            self.add(where, f"must be >= {minimum} (got {value})")
            return None
        return value

    def boolean(self, table, key, path, *, default=REQUIRED):
        absent, value = self._absent(table, key, path, default, "")
        if absent:
            return value
        value = table[key]
        if not isinstance(value, bool):
            self.add(join(path, key), f"must be true or false (got {show(value)})")
            return None
        return value

    def point(self, table, key, path, *, default=REQUIRED, remark=""):
        """An ``[x, y]`` pair of finite numbers."""
        absent, value = self._absent(table, key, path, default, remark)
        if absent:
            return value
        value, where = table[key], join(path, key)
        if not isinstance(value, list) or len(value) != 2:
            self.add(where, f"must be a pair [x, y] (got {show(value)})")
            return None
        xy = [self.check_number(v, join(where, i)) for i, v in enumerate(value)]
        return None if None in xy else (xy[0], xy[1])

    def values(self, table, key, path, *, default=REQUIRED, remark=""):
        """A number, a list of numbers, or a ``{start, stop, step}`` table (stop inclusive).

        Returns a tuple of floats, or ``None`` if anything was wrong.
        """
        absent, value = self._absent(table, key, path, default, remark)
        if absent:
            return value
        value, where = table[key], join(path, key)
        if isinstance(value, dict):
            return self._range(value, where)
        if not isinstance(value, list):
            if is_number(value):
                v = self.check_number(value, where)
                return None if v is None else (v,)
            self.add(where, f"must be a list of numbers or a table {{start, stop, step}} (got {show(value)})")
            return None
        if not value:
            self.add(where, "must not be empty")
            return None
        out = [self.check_number(v, join(where, i)) for i, v in enumerate(value)]
        return None if None in out else tuple(out)

    def _range(self, table, where):
        self.check_keys(table, where, ("start", "stop", "step"))
        start = self.number(table, "start", where)
        stop = self.number(table, "stop", where)
        step = self.number(table, "step", where, positive=True)
        if start is not None and stop is not None and stop < start:
            got = f"{show(table['stop'])} < {show(table['start'])}"
            self.add(join(where, "stop"), f"must be >= start (got {got})")
            return None
        if None in (start, stop, step):
            return None
        # Inclusive stop; the tolerance keeps e.g. 0..0.3 step 0.1 (ratio 2.9999999999999996)
        # at 4 values despite rounding.
        ratio = (stop - start) / step
        n = int(math.floor(ratio * (1 + 1e-12) + 1e-12)) + 1
        if n > MAX_RANGE_VALUES:
            limit = f"more than {MAX_RANGE_VALUES}"
            self.add(join(where, "step"), f"gives {n} values, {limit} (got {show(table['step'])})")
            return None
        # start + i*step (no drift from repeated addition), rounded to 15 digits so that
        # 0.1-steps give 0.3 rather than 0.30000000000000004 in archives and plots.
        return tuple(float(f"{start + i * step:.15g}") for i in range(n))

