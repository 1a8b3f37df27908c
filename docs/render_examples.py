"""Render ``examples/<name>.py`` as the docs page ``docs/examples/<name>.md``, run.

    python docs/render_examples.py                 # every example
    python docs/render_examples.py quickstart      # one

The scripts are in the jupytext percent format (``# %%`` code cells, ``# %% [markdown]``
text cells). Each is run here cell by cell, from the repository root, in one namespace:
a code cell's page block is followed by what it printed and by the figures it left open
(PNG files in ``docs/examples/<name>_files/``). The page records the sha256 of the script
it was rendered from; ``tests/test_docs_site.py`` fails when a script no longer matches its
page, so a changed example is rendered again before it is committed. The site build itself
runs nothing (``docs/hooks.py`` only copies the scripts for download).
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import os
import re
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = ROOT / "examples"
PAGES = ROOT / "docs" / "examples"
CELL = re.compile(r"^# %%(.*)$")
HEADER = re.compile(r"<!-- rendered by docs/render_examples.py from examples/(?P<script>\S+) "
                    r"sha256:(?P<digest>[0-9a-f]{64}) -->")


def digest(script: Path) -> str:
    return hashlib.sha256(script.read_bytes()).hexdigest()


def cells(source: str) -> list[tuple[str, str]]:
    """``(kind, text)`` of every non-empty cell, ``kind`` "markdown" or "code"."""
    out: list[tuple[str, list[str]]] = []
    kind, lines = "code", []
    for line in source.splitlines():
        m = CELL.match(line)
        if m:
            out.append((kind, lines))
            kind = "markdown" if "[markdown]" in m.group(1) or "[md]" in m.group(1) else "code"
            lines = []
        else:
            lines.append(line)
    out.append((kind, lines))
    result = []
    for kind, lines in out:
        text = "\n".join(lines).strip("\n")
        if not text.strip():
            continue
        if kind == "markdown":
            text = "\n".join(re.sub(r"^# ?", "", x) for x in text.splitlines())
        result.append((kind, text))
    return result


def page_code_blocks(page: str) -> list[str]:
    """The Python blocks of a rendered page (the script's code cells, in order)."""
    return [b.strip("\n") for b in re.findall(r"^```python\n(.*?)^```$", page, re.S | re.M)]


def run_cell(code: str, namespace: dict, name: str, index: int, files: Path) -> tuple[str, list]:
    """Run ``code``; what it printed and the figures it left open (saved, then closed), each
    with its caption."""
    import matplotlib.pyplot as plt

    buffer = io.StringIO()
    with contextlib.redirect_stdout(buffer):
        exec(compile(code, f"examples/{name}.py (cell {index})", "exec"), namespace)
    figures = []
    for k, number in enumerate(plt.get_fignums()):
        path = files / f"{name}_{index}_{k}.png"
        plt.figure(number).savefig(path, dpi=100)
        figures.append((path, figure_caption(path, number)))
    plt.close("all")
    return buffer.getvalue(), figures


def figure_caption(path: Path, number: int) -> str:
    """The caption of a figure a cell left open: its (sup)title and its panels' titles."""
    import matplotlib.pyplot as plt

    fig = plt.figure(number)
    titles = [ax.get_title() for ax in fig.axes if ax.get_title()]
    suptitle = fig._suptitle.get_text() if fig._suptitle is not None else ""
    panels = (titles[0] if len(titles) == 1 else
              "; ".join(f"({chr(97 + i)}) {t}" for i, t in enumerate(titles)))
    what = ". ".join(t for t in (suptitle, panels) if t)
    return f"The figure the cell above draws{': ' + what if what else ''}."


def render(name: str) -> Path:
    script = EXAMPLES / f"{name}.py"
    files = PAGES / f"{name}_files"
    files.mkdir(parents=True, exist_ok=True)
    for old in files.glob("*.png"):
        old.unlink()
    namespace = {"__name__": "__main__", "__file__": str(script)}
    parts = [f"<!-- rendered by docs/render_examples.py from examples/{script.name} "
             f"sha256:{digest(script)} -->"]
    note = (f"Script: [`examples/{script.name}`](../../examples/{script.name}) · run it from "
            f"the repository root, `python examples/{script.name}`, or open it as a notebook, "
            f"`jupytext --to notebook examples/{script.name}`. The outputs and figures below "
            "are those of such a run.")
    start = time.time()
    for index, (kind, text) in enumerate(cells(script.read_text(encoding="utf-8"))):
        if kind == "markdown":
            if index == 0 and text.startswith("# "):
                title, _, rest = text.partition("\n")
                text = f"{title}\n\n{note}\n{rest}"
            parts.append(text)
            continue
        parts.append(f"```python\n{text}\n```")
        printed, figures = run_cell(text, namespace, name, index, files)
        if printed.strip():
            parts.append(f"```text\n{printed.rstrip()}\n```")
        # the image, and on the next line its caption (docs/hooks.py makes them a <figure>)
        parts += [f"![{name}: figure of cell {index}]({name}_files/{f.name})\n{caption}"
                  for f, caption in figures]
    page = PAGES / f"{name}.md"
    page.write_text("\n\n".join(parts) + "\n", encoding="utf-8")
    print(f"{page.relative_to(ROOT)}: {time.time() - start:.0f} s", file=sys.stderr)
    return page


def main(argv: list[str]) -> None:
    os.chdir(ROOT)
    os.environ.setdefault("MPLBACKEND", "Agg")
    names = argv or sorted(p.stem for p in EXAMPLES.glob("*.py"))
    for name in names:
        render(name)


if __name__ == "__main__":
    main(sys.argv[1:])
