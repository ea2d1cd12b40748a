"""Quoted program output compared with what the program prints, numbers to their printed digits.

A quoted number is a computed value rounded to the digits shown; on another CPU (another BLAS
kernel, another summation order) the same value differs in its last bits, and a value near a
rounding tie, or a finite-difference quotient, prints one unit off in its last digit (measured:
the README's sensitivity −66.1246 printed −66.1245 on an AMD EPYC). So the text between the
numbers must match exactly, integers (counts, mode numbers, crank orders, settings) exactly, and
a number with a fractional part or an exponent to within ``units`` units of its last printed
digit plus ``rtol`` of its value. A number off by more than that is a wrong number and fails.
"""

from __future__ import annotations

import re

NUM = r"[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?"
_NUM = re.compile(NUM)


def _plain(text: str) -> str:
    return text.replace("\u2212", "-")  # a typeset minus is a minus


def tolerance(quoted: str, units: float, rtol: float) -> float:
    """How far a printed value may be from ``quoted``: 0 for an integer, else ``units`` units
    of its last digit plus ``rtol`` of its value."""
    m = re.fullmatch(r"[-+]?(\d*)(?:\.(\d*))?(?:[eE]([-+]?\d+))?", quoted)
    if m is None or (m.group(2) is None and m.group(3) is None):
        return 0.0
    unit = 10.0 ** (int(m.group(3) or 0) - len(m.group(2) or ""))
    return units * unit * (1 + 1e-9) + rtol * abs(float(quoted))


def close(quoted: str, printed: str, units: float, rtol: float) -> bool:
    return abs(float(printed) - float(quoted)) <= tolerance(quoted, units, rtol)


ELIDED = "\u2026"  # "…" in a quoted line: printed text left out there (any text, numbers included)


def _piece(text: str, first: bool, last: bool) -> str:
    """The regex of a quoted piece: its text exact, each number a group; a line that starts or
    ends with a number does not match a piece of a longer one ("1" in "11"), but a number next
    to an ``…`` may continue into the text left out ("4434.59…" for 4434.596506)."""
    parts = _NUM.split(text)
    body = "".join(re.escape(t) + (f"({NUM})" if i < len(parts) - 1 else "") for i, t in enumerate(parts))
    numeric = len(parts) > 1
    return ("(?<![\\d.])" if first and numeric and not parts[0] else "") + body + (
        "(?![\\d.])" if last and numeric and not parts[-1] else "")


def line_in(quoted: str, printed_lines: list[str], units: float = 3, rtol: float = 0.0) -> bool:
    """Whether ``quoted`` (one line, whitespace already normalised) occurs in one of the printed
    lines with the same text and its numbers within :func:`tolerance`; an ``…`` in it stands for
    printed text left out (a round-off digit string, a timing, the rest of a long line)."""
    quoted = _plain(quoted)
    nums = _NUM.findall(quoted)
    pieces = quoted.split(ELIDED)
    pattern = re.compile(".*?".join(_piece(t, i == 0, i == len(pieces) - 1) for i, t in enumerate(pieces)))
    for line in map(_plain, printed_lines):
        pos = 0
        while (m := pattern.search(line, pos)) is not None:
            if all(close(q, p, units, rtol) for q, p in zip(nums, m.groups())):
                return True
            pos = m.start() + 1
    return False


def same_text(want: str, got: str, units: float, rtol: float) -> bool:
    """Whether two outputs are the same text (whitespace ignored) with the same numbers, each
    printed one within :func:`tolerance` of the wanted one."""
    want, got = _plain(want), _plain(got)
    wn, gn = _NUM.findall(want), _NUM.findall(got)
    squash = lambda s: ["".join(t.split()) for t in _NUM.split(s)]  # noqa: E731
    return (len(wn) == len(gn) and squash(want) == squash(got)
            and all(close(w, g, units, rtol) for w, g in zip(wn, gn)))
