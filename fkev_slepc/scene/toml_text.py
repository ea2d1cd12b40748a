"""TOML text of a parsed document: the inverse of :func:`tomllib.loads` for what scene files hold
(used to write an edited scene, scene/edit.py, and the SI form of a ``[units]`` scene)."""

from __future__ import annotations

import datetime as _dt
import json
import math
import re
from typing import Any

_BARE = re.compile(r"[A-Za-z0-9_-]+")


def _key(k: str) -> str:
    return k if _BARE.fullmatch(k) else json.dumps(k)


def _value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        return repr(v) if math.isfinite(v) else ("inf" if v > 0 else "-inf")
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)  # JSON string escapes are TOML basic-string escapes
    if isinstance(v, (_dt.datetime, _dt.date, _dt.time)):
        return v.isoformat()
    if isinstance(v, dict):
        return "{" + ", ".join(f"{_key(k)} = {_value(x)}" for k, x in v.items()) + "}"
    if isinstance(v, list):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    raise TypeError(f"cannot write {type(v).__name__} value {v!r} to TOML")


def _is_tables(v: Any) -> bool:
    return isinstance(v, list) and bool(v) and all(isinstance(x, dict) for x in v)


def dumps(doc: dict) -> str:
    """TOML text of a document as :func:`tomllib.loads` returns it (``tomllib.loads(dumps(d)) == d``).

    Top-level tables become ``[name]`` / ``[name.sub]`` sections and top-level arrays of tables
    ``[[name]]`` items; anything deeper is written inline.

    Examples
    --------
    >>> import tomllib
    >>> d = {"title": "t", "links": [{"name": "a", "segments": [{"length_m": 0.1}]}], "solver": {"petsc": {"x": 1}}}
    >>> tomllib.loads(dumps(d)) == d
    True
    """
    lines = [f"{_key(k)} = {_value(v)}" for k, v in doc.items() if not isinstance(v, dict) and not _is_tables(v)]
    for k, v in doc.items():
        if isinstance(v, dict):
            lines += _table(v, [k])
        elif _is_tables(v):
            for item in v:
                lines += ["", f"[[{_key(k)}]]"] + [f"{_key(a)} = {_value(b)}" for a, b in item.items()]
    return "\n".join(lines) + "\n"


def _table(table: dict, path: list[str]) -> list[str]:
    head = ".".join(_key(p) for p in path)
    out = ["", f"[{head}]"] + [f"{_key(k)} = {_value(v)}" for k, v in table.items() if not isinstance(v, dict)]
    for k, v in table.items():
        if isinstance(v, dict):
            out += _table(v, [*path, k])
    return out
