"""The package's shape: no import cycle between the modules of ``swimrl``, and
docs/architecture.md names every module."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import grimp

import swimrl

PACKAGE = Path(swimrl.__file__).parent
ARCHITECTURE = PACKAGE.parent / "docs" / "architecture.md"


def find_cycle(imports: dict[str, set[str]]) -> list[str] | None:
    """A circle ``[a, b, ..., a]`` in the graph ``module -> modules it imports``, or None."""
    state: dict[str, int] = {}  # 1: on the current path, 2: done
    path: list[str] = []

    def visit(m: str) -> list[str] | None:
        state[m] = 1
        path.append(m)
        for n in sorted(imports.get(m, ())):
            if state.get(n) == 1:
                return path[path.index(n):] + [n]
            if n not in state and (found := visit(n)):
                return found
        path.pop()
        state[m] = 2
        return None

    for m in sorted(imports):
        if m not in state and (found := visit(m)):
            return found
    return None


def test_find_cycle_finds_a_circle_and_only_a_circle():
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b", "c"}, "b": {"c"}, "c": set()}) is None


def test_no_import_cycle_in_swimrl():
    """Every import between two modules of ``swimrl`` counts, those inside functions too
    (grimp reads them all), so a circle cannot be hidden in a function either."""
    graph = grimp.build_graph("swimrl", cache_dir=None)
    imports = {m: graph.find_modules_directly_imported_by(m) for m in graph.modules}
    assert len(imports) > 50
    assert find_cycle(imports) is None


def documented_files(text: str) -> set[str]:
    """The paths (relative to ``swimrl/``) of the tree under ``## Modules``: one entry a
    line, two spaces of indent per level, packages ending in ``/``."""
    block = re.search(r"^## Modules\n.*?```\n(.*?)```", text, re.S | re.M)
    assert block, "docs/architecture.md has no ## Modules tree"
    lines = [line for line in block.group(1).splitlines() if line.strip()]
    assert lines[0] == "swimrl/"
    files, parents = set(), []
    for line in lines[1:]:
        depth = (len(line) - len(line.lstrip())) // 2
        name = line.split()[0]
        parents = parents[:depth - 1]
        if name.endswith("/"):
            parents.append(name.rstrip("/"))
        else:
            files.add("/".join([*parents, name]))
    return files


def test_architecture_names_every_module():
    documented = documented_files(ARCHITECTURE.read_text())
    modules = {p.relative_to(PACKAGE).as_posix() for p in PACKAGE.rglob("*.py")}
    assert sorted(modules - documented) == [], "modules missing from docs/architecture.md"
    gone = sorted(f for f in documented if not (PACKAGE / f).is_file())
    assert gone == [], "docs/architecture.md names files that do not exist"


def test_the_library_imports_without_the_paper():
    """``swimrl.paper`` (the paper's figures) sits on top: the library (every module but the
    paper's and the commands') imports without it; checked in a fresh interpreter."""
    library = sorted(
        ".".join(("swimrl", *p.relative_to(PACKAGE).with_suffix("").parts)).removesuffix(
            ".__init__") for p in PACKAGE.rglob("*.py")
        if p.relative_to(PACKAGE).parts[0] not in ("paper", "cli"))
    assert {"swimrl", "swimrl.config", "swimrl.analysis", "swimrl.rl.run"} <= set(library)
    code = (f"import sys\nfor m in {library!r}:\n    __import__(m)\n"
            "print(sorted(m for m in sys.modules if m.split('.')[:2] == ['swimrl', 'paper']))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True)
    assert done.stdout.strip() == "[]", done.stdout
