"""The one rewrite-or-check step of the scripts that generate parts of docs/ (archive_doc.py, cli_doc.py)."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Callable

ROOT = Path(__file__).resolve().parents[1]


def regenerate(page: str, replace_block: Callable[[str], str], script: str, argv: list[str]) -> int:
    """Rewrite the generated block of ``docs/<page>``; with ``--check`` only say whether it is current
    (exit 1 and a one-line hint if not)."""
    path = ROOT / "docs" / page
    text = path.read_text()
    new = replace_block(text)
    if "--check" in argv:
        if new != text:
            print(f"docs/{page} is out of date: run python scripts/{script}", file=sys.stderr)
        return 0 if new == text else 1
    path.write_text(new)
    return 0
