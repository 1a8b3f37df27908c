"""The docs speak of the software: no page tells of the machine it was written on, and powers
of ten have one notation, ``1e7`` (as the configs take them: ``flow.kubo=1e7``, ``4e7``
frames) in prose, tables and commands; inside an equation they are TeX, ``$10^{7}$``."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PAGES = sorted([ROOT / "README.md", *(ROOT / "docs").glob("*.md"),
                *(ROOT / "docs").glob("beyond/*.md")])
#: What a page must not say of itself (the acceptance's grep).
MACHINE = re.compile(r"2-core|this machine|beside (two|three)")
#: Powers of ten written as ``10^7`` or ``10⁷`` (outside maths and code).
POWER = re.compile(r"10\^|10[⁰¹²³⁴⁵⁶⁷⁸⁹⁻]")
#: Maths (``$…$``, ``$$…$$``, ``\(…\)``, ``\[…\]``) and code (fenced, inline).
MATHS_OR_CODE = re.compile(
    r"```.*?```|\$\$.*?\$\$|\\\[.*?\\\]|\\\(.*?\\\)|(?<!\\)\$[^$\n]+\$|``[^`\n]+``|`[^`\n]+`",
    re.S)


def ids(pages):
    return [p.relative_to(ROOT).as_posix() for p in pages]


@pytest.mark.parametrize("page", PAGES, ids=ids(PAGES))
def test_the_page_does_not_speak_of_the_machine_it_was_written_on(page):
    hits = [f"{i}: {line.strip()}" for i, line in
            enumerate(page.read_text(encoding="utf-8").splitlines(), 1) if MACHINE.search(line)]
    assert hits == [], "\n".join(hits)


@pytest.mark.parametrize("page", PAGES, ids=ids(PAGES))
def test_powers_of_ten_are_written_1e7_outside_equations(page):
    prose = MATHS_OR_CODE.sub(" ", page.read_text(encoding="utf-8"))
    hits = [line.strip() for line in prose.splitlines() if POWER.search(line)]
    assert hits == [], "write powers of ten as 1e7 (in maths: $10^{7}$):\n" + "\n".join(hits)


def test_the_pattern_sees_what_it_must():
    """The two patterns find a machine phrase and a power of ten in prose, not in maths."""
    assert MACHINE.search("measured on this machine")
    assert POWER.search(MATHS_OR_CODE.sub(" ", "At Ku = 10^7 the flow"))
    assert not POWER.search(MATHS_OR_CODE.sub(" ", r"an error of $10^{-13}$ and `10^7`"))
