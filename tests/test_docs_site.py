"""The docs: the site builds strictly with every link resolved, the example pages are those of
the scripts as they are, and the copies of one fact (version, repository URL, the quickstart)
are equal.

The site test builds it once (~10 s) when the docs extras are installed
(``pip install -e '.[dev,docs]'``) and is skipped otherwise; ``.ci/run`` builds it strictly
as well, where ``docs/hooks.py`` turns MkDocs' INFO line about a link to an excluded file
into a warning."""

from __future__ import annotations

import hashlib
import html
import os
import posixpath
import re
import subprocess
import sys
from pathlib import Path
from urllib.parse import unquote, urlsplit

import pytest
import yaml

import swimrl

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
sys.path.insert(0, str(DOCS))
import render_examples  # noqa: E402  (docs/render_examples.py)

#: MkDocs and plugin lines about a link, whatever their level.
LINK_LINE = re.compile(r"link|anchor|cross-reference|not found|excluded", re.I)
HREF = re.compile(r"""(?:href|src)="([^"]*)\"""")
ID = re.compile(r"""\bid="([^"]+)\"""")


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    pytest.importorskip("mkdocs")
    pytest.importorskip("mkdocstrings")
    out = tmp_path_factory.mktemp("site")
    proc = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(out)],
        cwd=ROOT, capture_output=True, text=True, timeout=300,
        env={**os.environ, "NO_MKDOCS_2_WARNING": "1"})
    return proc, out


@pytest.mark.slow  # builds the docs site (~15 s; needs the docs extras)
def test_the_site_builds_strictly_and_mentions_no_link(site):
    proc, _ = site
    log = proc.stdout + proc.stderr
    assert proc.returncode == 0, log[-5000:]
    lines = [line for line in log.splitlines() if LINK_LINE.search(line)]
    assert lines == [], "\n".join(lines)


def local_targets(page: Path, out: Path):
    """``(url, file, anchor)`` of every link and image of ``page`` into the site."""
    for raw in HREF.findall(page.read_text(encoding="utf-8")):
        url = html.unescape(raw)
        parts = urlsplit(url)
        if parts.scheme or parts.netloc or url.startswith(("mailto:", "javascript:", "data:")):
            continue
        path = unquote(parts.path)
        if not path:
            target = page
        else:  # relative, or absolute from the site's root (404.html)
            here = "" if path.startswith("/") else page.parent.relative_to(out).as_posix()
            target = out / posixpath.normpath(posixpath.join(here, path.lstrip("/")))
            if target.is_dir():
                target = target / "index.html"
        yield url, target, parts.fragment


@pytest.mark.slow  # the built docs site
def test_every_link_of_the_built_site_resolves(site):
    """Every relative href and src of every page points at a file of the site, and every
    #anchor into a page at an id of that page."""
    proc, out = site
    assert proc.returncode == 0, (proc.stdout + proc.stderr)[-3000:]
    ids: dict[Path, set[str]] = {}
    bad = []
    pages = sorted(out.rglob("*.html"))
    assert len(pages) > 100
    for page in pages:
        for url, target, anchor in local_targets(page, out):
            if not target.is_file():
                bad.append(f"{page.relative_to(out)}: {url} (no such file)")
                continue
            if anchor and target.suffix == ".html":
                if target not in ids:
                    ids[target] = set(ID.findall(target.read_text(encoding="utf-8")))
                if html.unescape(unquote(anchor)) not in ids[target]:
                    bad.append(f"{page.relative_to(out)}: {url} (no such anchor)")
    assert bad == [], "\n".join(bad[:50])


@pytest.mark.slow  # the built docs site
def test_the_site_has_the_figures_equations_and_example_outputs(site):
    _, out = site
    reproduction = (out / "reproduction.html").read_text(encoding="utf-8")
    assert len(re.findall(r'<img [^>]*src="figures/', reproduction)) >= 10
    physics = (out / "physics.html").read_text(encoding="utf-8")
    assert physics.count('class="arithmatex"') > 40 and r"\tag{10}" in physics
    quickstart = (out / "examples" / "quickstart.html").read_text(encoding="utf-8")
    assert "R_hat = " in quickstart and "<img" in quickstart
    assert (out / "examples" / "quickstart.py").is_file()
    api = (out / "api" / "env.html").read_text(encoding="utf-8")
    assert api.count('class="autorefs autorefs-internal"') > 5


# -- the example pages ------------------------------------------------------------------------
SCRIPTS = sorted((ROOT / "examples").glob("*.py"))


@pytest.mark.parametrize("script", SCRIPTS, ids=[p.stem for p in SCRIPTS])
def test_example_page_was_rendered_from_the_script_as_it_is(script):
    page = DOCS / "examples" / f"{script.stem}.md"
    assert page.is_file(), f"run: python docs/render_examples.py {script.stem}"
    text = page.read_text(encoding="utf-8")
    header = render_examples.HEADER.search(text)
    assert header and header.group("script") == script.name
    assert header.group("digest") == hashlib.sha256(script.read_bytes()).hexdigest(), (
        f"examples/{script.name} changed since its page was rendered: "
        f"python docs/render_examples.py {script.stem}")
    code = [t for kind, t in render_examples.cells(script.read_text(encoding="utf-8"))
            if kind == "code"]
    assert render_examples.page_code_blocks(text) == code
    for image in re.findall(r"!\[[^\]]*\]\(([^)]+)\)", text):
        assert (page.parent / image).is_file(), image


# -- one fact, one value ------------------------------------------------------------------------
def test_the_readme_quickstart_is_the_example():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    snippet = re.search(r"```python\n(from swimrl import .*?)```", readme, re.S).group(1)
    first = next(t for kind, t in render_examples.cells(
        (ROOT / "examples" / "quickstart.py").read_text(encoding="utf-8")) if kind == "code")
    assert snippet.strip() == first.strip()


def test_version_and_repository_url_agree():
    tomllib = pytest.importorskip("tomllib")  # Python >= 3.11
    pyproject = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    citation = yaml.safe_load((ROOT / "CITATION.cff").read_text(encoding="utf-8"))
    mkdocs = (ROOT / "mkdocs.yml").read_text(encoding="utf-8")
    repo_url = re.search(r"^repo_url: (\S+)$", mkdocs, re.M).group(1)
    assert "version" in pyproject["project"]["dynamic"]
    assert pyproject["tool"]["setuptools"]["dynamic"]["version"] == {"attr": "swimrl.__version__"}
    assert citation["version"] == swimrl.__version__
    changelog = (ROOT / "CHANGELOG.md").read_text(encoding="utf-8")
    released = [v for v in re.findall(r"^## (\S+)$", changelog, re.M) if v != "Unreleased"]
    assert released[0] == swimrl.__version__  # the newest release; "Unreleased" above it
    assert citation["repository-code"] == repo_url == pyproject["project"]["urls"]["Repository"]


def test_the_public_api_is_exported_lazily_and_listed():
    assert set(swimrl.__all__) == {"__version__", *swimrl._EXPORTS}
    code = "import sys, swimrl; print('torch' in sys.modules)"
    light = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert light.stdout.strip() == "False", light.stderr
    index = (DOCS / "api" / "index.md").read_text(encoding="utf-8")
    for name, module in swimrl._EXPORTS.items():
        assert getattr(swimrl, name) is getattr(__import__(module, fromlist=[name]), name)
        assert f"#{module}.{name})" in index, name
