"""README's methods table is tools/front_page.py's, from a committed bench run, and has one row per
method of the registry (issue 35: the front page says what each method costs)."""

from __future__ import annotations

import re
import sys
from pathlib import Path

from depthimpostor.methods.registry import METHODS

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tools"))
import front_page  # noqa: E402


def readme_table() -> str:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    return text[text.index(front_page.BEGIN) + len(front_page.BEGIN):text.index(front_page.END)]


def test_the_table_has_a_row_per_registry_method_with_cost_and_error_columns() -> None:
    rows = re.findall(r"^\| `([a-z][a-z-]*)` \|", readme_table(), flags=re.MULTILINE)
    assert rows == [method.option for method in METHODS]
    assert "frame / mirror pass / bake ms, MiB" in readme_table() and "wrong object / surface" in readme_table()


def test_the_table_is_what_the_tool_makes_of_its_committed_run() -> None:
    """The table is the tool's output for the bench run it names (no hand edits)."""
    source = re.search(r"From `([^`]+)`", readme_table())
    assert source is not None and (ROOT / source.group(1)).is_file()
    header, rows = front_page.read_rows(ROOT / source.group(1))
    assert readme_table().strip() == front_page.table(header, rows, source.group(1)).strip()
    assert set(front_page.WHAT) == {method.option for method in METHODS}
