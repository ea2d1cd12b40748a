#!/usr/bin/env python3
"""Rewrite the reference part of docs/cli.md from the argparse parsers (fkev_slepc/cli/reference.py).

Usage: python scripts/cli_doc.py [--check]   (--check: exit 1 if the page is out of date)
"""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from doclib import regenerate  # noqa: E402
from fkev_slepc.cli.reference import replace_block  # noqa: E402

if __name__ == "__main__":
    raise SystemExit(regenerate("cli.md", replace_block, "cli_doc.py", sys.argv[1:]))
