"""Every number has its record: on the README, the reproduction and results pages and the
beyond-the-paper pages, every section with a results table (numbers with two or more
decimals) or a figure links a committed record (a file or folder under ``docs/results/`` or
a figure's record under ``docs/figures/``)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PAGES = sorted([ROOT / "README.md", ROOT / "docs" / "reproduction.md",
                ROOT / "docs" / "results.md", *(ROOT / "docs").glob("beyond/*.md")])
#: A link into the records.
RECORD = re.compile(r"\]\((?:\.\./)*(?:docs/)?(?:results|figures)/[^)]+\)")
TABLE = re.compile(r"(?:^\|.*\|[ \t]*$\n?)+", re.M)
RESULT = re.compile(r"\d\.\d{2,}")
FIGURE = re.compile(r"!\[[^\]]*\]\([^)]+\)")


def sections(text: str) -> list[str]:
    """The page cut at its headings, code (fenced and inline) left out."""
    text = re.sub(r"`[^`\n]+`", "", re.sub(r"```.*?```", "", text, flags=re.S))
    return re.split(r"\n(?=#{1,4} )", text)


def unrecorded(text: str) -> list[str]:
    """The first lines of the sections with a results table or a figure and no record link."""
    return [s.strip().splitlines()[0][:80] for s in sections(text)
            if (any(RESULT.search(t) for t in TABLE.findall(s)) or FIGURE.search(s))
            and not RECORD.search(s)]


@pytest.mark.parametrize("page", PAGES, ids=[p.relative_to(ROOT).as_posix() for p in PAGES])
def test_every_table_and_figure_links_its_record(page):
    assert unrecorded(page.read_text(encoding="utf-8")) == []


def test_the_check_sees_a_table_without_its_record():
    table = "## A\n\n| x | R |\n|---|---|\n| 1 | 0.531 |\n"
    assert unrecorded(table) == ["## A"]
    assert unrecorded(table + "\n[record](results/paper_protocol/table.md)\n") == []
    assert unrecorded("## B\n\n| key | meaning |\n|---|---|\n| T | 200 |\n") == []
