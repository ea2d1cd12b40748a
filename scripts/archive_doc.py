#!/usr/bin/env python3
"""Rewrite the dataset tables of docs/archive.md from the product tables (fkev_slepc/archive/products.py).

Usage: python scripts/archive_doc.py [--check]   (--check: exit 1 if the page is out of date)
"""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from doclib import regenerate  # noqa: E402
from fkev_slepc.archive.products_doc import replace_block  # noqa: E402

if __name__ == "__main__":
    raise SystemExit(regenerate("archive.md", replace_block, "archive_doc.py", sys.argv[1:]))
