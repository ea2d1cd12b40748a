"""docs/cli.md covers every command and flag: its reference part is generated from the argparse
parsers (fkev_slepc/cli/reference.py, scripts/cli_doc.py) and must be current."""

import subprocess
import sys

from clitools import ROOT
from fkev_slepc.cli import build_parser
from fkev_slepc.cli.reference import BEGIN, END, reference, replace_block


def test_docs_cli_reference_is_current():
    text = (ROOT / "docs/cli.md").read_text()
    assert BEGIN in text and END in text
    assert replace_block(text) == text, "docs/cli.md is out of date: run python scripts/cli_doc.py"


def test_every_command_and_flag_is_in_the_reference():
    parser = build_parser()
    ref = reference(parser)
    for flag in ("-v", "--quiet", "--version"):
        assert f"`{flag}`" in ref
    for name, sub in parser.commands.items():
        assert f"### `fkev {name}`" in ref
        section = ref.split(f"### `fkev {name}`", 1)[1].split("\n### ", 1)[0]
        for action in sub._actions:
            for opt in action.option_strings:
                if opt not in ("-h", "--help"):
                    assert f"`{opt}`" in section, (name, opt)


def test_cli_doc_check_flags_a_stale_page(tmp_path):
    stale = replace_block("# page\n", "### `fkev nothing`\n")
    assert replace_block(stale) != stale  # a stale block is regenerated
    r = subprocess.run([sys.executable, str(ROOT / "scripts/cli_doc.py"), "--check"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
