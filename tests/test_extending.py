"""docs/extending.md: its code blocks, run in order as one script, build a new flow, task,
reward, signal and swimmer model and check each (the asserts are on the page)."""

from __future__ import annotations

import re
from pathlib import Path

PAGE = Path(__file__).resolve().parent.parent / "docs" / "extending.md"


def test_the_extending_page_runs_as_written():
    blocks = re.findall(r"^```python\n(.*?)^```$", PAGE.read_text(encoding="utf-8"), re.S | re.M)
    assert len(blocks) >= 10
    namespace: dict = {"__name__": "extending"}
    for i, block in enumerate(blocks):
        exec(compile(block, f"{PAGE.name} (block {i})", "exec"), namespace)
    for name in ("CellularFlow", "UpwardEnv", "ShapePenalty", "OkuboWeiss", "GyrotacticEnv"):
        assert name in namespace
