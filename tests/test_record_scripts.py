"""Record scripts under docs/results/ rerun on their committed records give their committed
summaries (so a change to a record's format cannot leave a script silently broken)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def test_energy_100flows_summary_is_reproduced_from_its_record():
    folder = ROOT / "docs" / "results" / "beyond" / "energy_100flows"
    out = subprocess.run([sys.executable, str(folder / "summarise.py")], capture_output=True,
                         text=True, check=True, cwd=ROOT).stdout
    assert json.loads(out) == json.loads((folder / "summary.json").read_text())
