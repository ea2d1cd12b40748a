#!/usr/bin/env python3
"""Rewrite the reference part of docs/cli.md from the argparse parsers (fkev_slepc/cli/reference.py).

Usage: python scripts/cli_doc.py [--check]   (--check: exit 1 if the page is out of date)
"""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from fkev_slepc.cli.reference import replace_block  # noqa: E402


def main(argv: list[str]) -> int:
    page = ROOT / "docs" / "cli.md"
    text = page.read_text()
    new = replace_block(text)
    if "--check" in argv:
        if new != text:
            print("docs/cli.md is out of date: run python scripts/cli_doc.py", file=sys.stderr)
        return 0 if new == text else 1
    page.write_text(new)
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
