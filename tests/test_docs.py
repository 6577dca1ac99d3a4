"""The documentation stays true to the code: the CLI reference is generated, every link resolves."""

import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"


def test_cli_reference_is_up_to_date():
    sys.path.insert(0, str(DOCS))
    try:
        import gen_cli_reference
    finally:
        sys.path.remove(str(DOCS))
    assert (DOCS / "cli.md").read_text(encoding="utf-8") == gen_cli_reference.render(), (
        "docs/cli.md is out of date: run python docs/gen_cli_reference.py")


def test_cli_reference_lists_every_command_and_option():
    from seamodem.cli import COMMANDS

    page = (DOCS / "cli.md").read_text(encoding="utf-8")
    for name in COMMANDS:
        assert f"## `seamodem {name}`" in page
    assert "| `--keep-audio` |" in page and "| `-o`, `--output` DIR | `demo_out` |" in page


def test_generator_check_mode_agrees():
    proc = subprocess.run([sys.executable, str(DOCS / "gen_cli_reference.py"), "--check"], capture_output=True,
                          text=True)
    assert proc.returncode == 0, proc.stderr


def _links(path: Path):
    text = path.read_text(encoding="utf-8")
    for target in re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", text):
        if not re.match(r"[a-z]+://", target):
            yield target


def test_index_links_every_page_and_every_link_resolves():
    index = (DOCS / "index.md").read_text(encoding="utf-8")
    pages = {p.name for p in DOCS.glob("*.md")} - {"index.md"}
    missing = [p for p in sorted(pages) if f"({p})" not in index]
    assert not missing, f"docs/index.md does not link {missing}"
    for page in [ROOT / "README.md", *DOCS.glob("*.md")]:
        for target in _links(page):
            assert (page.parent / target).exists(), f"{page.name}: broken link {target}"
