"""The docs as a reader sees them: the built site, served from 127.0.0.1, opened in headless
Chromium (Debian's ``chromium`` and ``chromium-driver``) at 1400 px with every other host
unreachable.

* every arithmatex span of the maths pages and of an API page is typeset by MathJax (served
  by the site itself, no CDN), with no error node and no ``\\[``, ``\\(`` or ``$$`` left as
  text, and no display equation wider than the column;
* every content image sits in a ``<figure>`` with a non-empty ``<figcaption>`` and shows at
  its native width or opens at full size on click.

A slow test: it needs the docs extras, Chromium and ChromeDriver. Without them it is skipped,
unless ``SWIMRL_REQUIRE_BROWSER=1`` (``.ci/run`` sets it), where a missing piece fails.
"""

from __future__ import annotations

import functools
import http.server
import os
import re
import shutil
import subprocess
import sys
import threading
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
pytestmark = pytest.mark.slow

#: The pages with maths (the acceptance's physics, extending and one API page).
MATH_PAGES = ["physics.html", "extending.html", "api/physics.html"]
#: The pages with figures: every page of the site whose HTML has a content image.
WIDTH = 1400


def need(what: str, ok: bool) -> None:
    """Skip (fail under ``SWIMRL_REQUIRE_BROWSER=1``) when ``what`` is missing."""
    if ok:
        return
    if os.environ.get("SWIMRL_REQUIRE_BROWSER") == "1":
        pytest.fail(f"{what} is missing and SWIMRL_REQUIRE_BROWSER=1")
    pytest.skip(f"{what} is missing")


def find(*names: str) -> str | None:
    return next((p for p in map(shutil.which, names) if p), None)


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    for module in ("mkdocs", "mkdocstrings", "selenium"):
        try:
            __import__(module)
        except ImportError:
            need(f"the Python package {module} (pip install -e '.[dev,docs]')", False)
    out = tmp_path_factory.mktemp("site")
    proc = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(out)],
        cwd=ROOT, capture_output=True, text=True, timeout=600,
        env={**os.environ, "NO_MKDOCS_2_WARNING": "1"})
    assert proc.returncode == 0, (proc.stdout + proc.stderr)[-5000:]
    return out


@pytest.fixture(scope="module")
def served(site):
    """The site on ``http://127.0.0.1:<port>/``."""
    handler = functools.partial(QuietHandler, directory=str(site))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{server.server_address[1]}/"
    server.shutdown()


class QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args) -> None:
        pass


@pytest.fixture(scope="module")
def browser(tmp_path_factory):
    chromium = find("chromium", "chromium-browser")
    driver_path = find("chromedriver")
    need("chromium (apt-get install chromium)", chromium is not None)
    need("chromedriver (apt-get install chromium-driver)", driver_path is not None)
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = chromium
    for flag in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-quic",
                 "--no-first-run", "--disable-background-networking", "--disable-sync",
                 "--disable-component-update", "--disable-dev-shm-usage",
                 f"--window-size={WIDTH},1000",
                 f"--user-data-dir={tmp_path_factory.mktemp('chromium')}",
                 # no host but the local server: a CDN would not answer
                 "--host-resolver-rules=MAP * ~NOTFOUND, EXCLUDE 127.0.0.1"):
        options.add_argument(flag)
    driver = webdriver.Chrome(service=Service(executable_path=driver_path), options=options)
    driver.set_script_timeout(120)
    driver.set_page_load_timeout(120)
    yield driver
    driver.quit()


def open_page(browser, url: str) -> None:
    """Load ``url`` and wait until MathJax has typeset it (when the page has maths)."""
    browser.get(url)
    state = browser.execute_async_script("""
        const done = arguments[arguments.length - 1];
        const t0 = Date.now();
        (function wait() {
          if (!document.querySelector('.arithmatex')) return done('no maths');
          const mj = window.MathJax;
          if (mj && mj.startup && mj.startup.promise && mj.typesetPromise)
            return mj.startup.promise.then(() => done('typeset'), e => done('error: ' + e));
          if (Date.now() - t0 > 60000) return done('MathJax never loaded');
          setTimeout(wait, 100);
        })();
    """)
    assert state in ("typeset", "no maths"), f"{url}: {state}"


MATH_STATE = """
const spans = [...document.querySelectorAll('.md-content .arithmatex')];
const content = document.querySelector('.md-content').cloneNode(true);
content.querySelectorAll('pre, code, mjx-container').forEach(e => e.remove());
// an equation's own width: MathJax gives the SVG's width (or, with a tag, its min-width) in
// ex; the theme's max-width: 100% would only shrink a wider one to the column
function natural(svg) {
  const probe = document.createElement('div');
  probe.style.cssText = 'position:absolute;visibility:hidden;width:100ex';
  svg.parentNode.appendChild(probe);
  const ex = probe.getBoundingClientRect().width / 100;
  probe.remove();
  for (const w of [svg.getAttribute('width'), svg.style.minWidth])
    if (w && w.endsWith('ex')) return parseFloat(w) * ex;
  return svg.getBoundingClientRect().width;
}
const wide = [...document.querySelectorAll('.md-content div.arithmatex')]
  .map(d => [d, Math.max(d.scrollWidth,
                         ...[...d.querySelectorAll('mjx-container > svg')].map(natural))])
  .filter(([d, w]) => w > d.clientWidth + 1)
  .map(([d, w]) => d.textContent.slice(0, 60)
                   + ' (' + Math.round(w) + ' px > ' + d.clientWidth + ')');
return {
  spans: spans.length,
  typeset: spans.filter(s => s.querySelectorAll('mjx-container').length === 1).length,
  errors: document.querySelectorAll(
    'mjx-merror, [data-mjx-error], [data-mml-node="merror"]').length,
  raw: (content.innerText.match(/\\\\\\[|\\\\\\(|\\$\\$/g) || []).length,
  wide: wide,
};
"""


@pytest.mark.parametrize("page", MATH_PAGES)
def test_every_equation_renders_offline_and_fits_the_column(site, served, browser, page):
    html = (site / page).read_text(encoding="utf-8")
    in_html = len(re.findall(r'class="arithmatex"', html))
    assert in_html > 0, f"{page} has no maths"
    open_page(browser, served + page)
    state = browser.execute_script(MATH_STATE)
    assert state["spans"] == in_html, state
    assert state["typeset"] == in_html, f"{page}: {in_html - state['typeset']} spans not typeset"
    assert state["errors"] == 0, f"{page}: {state['errors']} MathJax error nodes"
    assert state["raw"] == 0, f"{page}: {state['raw']} TeX delimiters left as text"
    assert state["wide"] == [], f"{page}: display equations wider than the column: {state['wide']}"


FIGURE_STATE = """
const imgs = [...document.querySelectorAll('.md-content img')];
return imgs.map(img => {
  const fig = img.closest('figure');
  const cap = fig ? fig.querySelector('figcaption') : null;
  const link = img.closest('a');
  return {
    src: img.getAttribute('src'),
    loaded: img.complete && img.naturalWidth > 0,
    caption: cap ? cap.innerText.trim().length : 0,
    native: img.naturalWidth <= img.getBoundingClientRect().width + 1,
    enlarges: link !== null && link.href === img.src,
  };
});
"""


def pages_with_images(site: Path) -> list[str]:
    return sorted(p.relative_to(site).as_posix() for p in site.rglob("*.html")
                  if re.search(r'<article[^>]*>.*?<img ', p.read_text(encoding="utf-8"), re.S))


def test_every_figure_has_a_caption_and_opens_full_size(site, served, browser):
    pages = pages_with_images(site)
    assert "reproduction.html" in pages and "index.html" in pages, pages
    bad = []
    for page in pages:
        open_page(browser, served + page)
        for img in browser.execute_script(FIGURE_STATE):
            problems = [what for what, ok in (
                ("not loaded", img["loaded"]), ("no figcaption", img["caption"] > 0),
                ("shrunk and no link to full size", img["native"] or img["enlarges"])) if not ok]
            if problems:
                bad.append(f"{page}: {img['src']}: {', '.join(problems)}")
    assert bad == [], "\n".join(bad)


def test_record_links_open_in_the_site(site):
    """A link to a record (a file or folder under ``docs/results/``) opens in the built site;
    only the policies' ``.pt`` files (left out of the site) link into the repository."""
    import yaml

    repo = yaml.safe_load((ROOT / "mkdocs.yml").read_text(encoding="utf-8").split("\ntheme:")[0]
                          .replace("!!python", "#"))["repo_url"].rstrip("/")
    into_repo = re.compile(rf'href="{re.escape(repo)}/(?:blob|tree)/main/docs/results/([^"#]*)')
    bad = sorted({f"{page.relative_to(site)}: {target}"
                  for page in site.rglob("*.html")
                  for target in into_repo.findall(page.read_text(encoding="utf-8"))
                  if not target.endswith(".pt")})
    assert bad == [], "\n".join(bad[:40])
    # the records themselves are files of the site
    assert (site / "results" / "paper_protocol" / "ku10" / "comparison.json").is_file()
    assert (site / "results" / "paper_runs" / "ku10_seed0" / "metrics.json").is_file()
