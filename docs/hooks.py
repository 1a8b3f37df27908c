"""MkDocs hooks of the swimrl docs site (``mkdocs.yml``: ``hooks: [docs/hooks.py]``).

The pages are written to be read on GitHub as well as on the site; these hooks bridge the
two.

* **Examples.** The pages ``docs/examples/<name>.md`` are rendered, with the outputs and
  figures of a run, from ``examples/<name>.py`` by ``docs/render_examples.py`` (committed;
  ``tests/test_docs_site.py`` checks that each page was rendered from its script as it is
  now). The scripts themselves are copied into the site as ``examples/<name>.py``, so the
  pages' download links work there too.
* **Record links.** The pages link to record directories (``results/paper_protocol/``) and
  to record files left out of the site (``exclude_docs``: ``.pt``, ``.csv``, ...), which
  browse fine on GitHub but are not pages. Such a link becomes a link to the directory's
  ``README.md`` page where there is one, else a link into the repository (``repo_url``).
  A link to a file of the repository outside ``docs/`` (``../examples/quickstart.py``,
  ``../CITATION.cff``) goes to the site's copy of it if there is one, else into the
  repository. A file counts as part of the site only if the build includes it: MkDocs'
  ``Files.get_file_from_path`` also returns excluded files.
* **No unresolved link.** MkDocs reports a link to an excluded file at INFO level only, which
  ``--strict`` lets pass; here such a line is raised to a WARNING, so a strict build fails
  on it (``tests/test_docs_site.py`` builds the site and fails on any link line).
* **GitHub's lists.** The pages are written for GitHub, where a list may follow a paragraph
  or a table line directly and a nested list may be indented by 2 spaces; Python-Markdown
  needs a blank line before the list and 4 spaces. Outside code blocks, such a list gets
  the blank line and such a nested item the 4 spaces (:func:`gfm_lists`).
* **Sphinx roles.** Docstrings cite code as ``:class:`~swimrl.env.EnvParams```; on the API
  pages such a role becomes a cross-reference (mkdocs-autorefs) to the object's entry,
  resolved like Sphinx: absolute, or relative to the object whose docstring it is in and its
  parents; ``~`` shows the last name only. A target the API pages do not show (private, or
  outside swimrl) stays code.
* **Changelog.** ``CHANGELOG.md`` (repository root) is also the page ``changelog.md``.
* **MathJax, served by the site.** The equations are typeset by MathJax 3 (SVG output, every
  TeX extension in one file), copied into the site from the ``django-static-mathjax``
  package of the docs extras: no CDN is needed to read them (:func:`vendored_mathjax`).
* **Figures.** An image alone at the start of a paragraph (the GitHub-readable form
  ``![alt](figure.png)`` followed on the next lines by the caption text) becomes a
  ``<figure>``: the image links to itself at full size and the text is its ``<figcaption>``.
  An image without a caption is a warning, so a strict build fails on it (:func:`figures`).
* **Records in the site.** The record files of ``docs/results/`` (JSON, CSV, YAML, logs,
  ``.npz``) are files of the site, so a claim's link opens its record in a local build; a
  link to a record directory without a README opens a generated listing of its files
  (:func:`record_listings`). Only the policies' ``.pt`` files stay out (``exclude_docs``);
  a link to one goes into the repository.
"""

from __future__ import annotations

import functools
import logging
import os
import posixpath
import re
from pathlib import Path

from mkdocs.structure.files import File, Files

EXAMPLES = "examples"
# [text](target) with a relative target: no scheme, no leading '/' or '#'
LINK = re.compile(r"(?<!!)\[(?P<text>[^\]]*)\]\((?P<target>(?![a-z][a-z0-9+.-]*:|/|#)[^)\s]+)\)")
ITEM = re.compile(r"^(?P<indent> *)(?P<marker>[*+-]|\d+[.)]) +\S")
ROLE = re.compile(
    r":(?:py:)?(?:mod|class|func|meth|attr|data|obj|exc|const):<code>(?P<target>[^<]+)</code>")
HEADING_ID = re.compile(r'<h\d id="(?P<id>swimrl(?:\.\w+)*)"[^>]*class="doc doc-heading')
#: MkDocs' message for a link to a file that the build leaves out (logged at INFO).
EXCLUDED_LINK = "which is excluded from the built site"
#: The branch the repository links point at.
BRANCH = "main"


def repo_root(config) -> Path:
    return Path(config.config_file_path).parent


def in_site(files: Files, path: str) -> bool:
    """Whether the build has the file ``path`` (relative to ``docs/``) and includes it."""
    f = files.get_file_from_path(path)
    return f is not None and not f.inclusion.is_excluded()


def repo_link(config, rel: str, is_dir: bool) -> str | None:
    """The repository's URL of ``rel`` (relative to the repository root), or None."""
    if not config.repo_url:
        return None
    kind = "tree" if is_dir else "blob"
    return f"{config.repo_url.rstrip('/')}/{kind}/{BRANCH}/{rel}"


# -- failing on links the site cannot resolve -------------------------------------------------
class ExcludedLinkIsAWarning(logging.Filter):
    """Raise MkDocs' INFO line about a link to an excluded file to a WARNING."""

    def filter(self, record: logging.LogRecord) -> bool:
        if record.levelno < logging.WARNING and EXCLUDED_LINK in str(record.msg):
            record.levelno, record.levelname = logging.WARNING, "WARNING"
        return True


def on_config(config):
    log = logging.getLogger("mkdocs.structure.pages")
    if not any(isinstance(f, ExcludedLinkIsAWarning) for f in log.filters):
        log.addFilter(ExcludedLinkIsAWarning())
    return config


# -- files: MathJax, record listings, the example scripts and the changelog -------------------
#: Where the site serves MathJax (``mkdocs.yml``'s ``extra_javascript``), and the component.
MATHJAX_SITE = "javascripts/vendor/mathjax"
MATHJAX_COMPONENT = "tex-svg-full.js"


def vendored_mathjax() -> Path:
    """The ``es5/`` folder of MathJax 3 in the ``django-static-mathjax`` package (the docs
    extras), found without importing it (it is a Django app)."""
    import importlib.util

    spec = importlib.util.find_spec("mathjax")
    es5 = None
    for location in (spec.submodule_search_locations or []) if spec else []:
        candidate = Path(location) / "static" / "mathjax" / "es5"
        if (candidate / MATHJAX_COMPONENT).is_file():
            es5 = candidate
    if es5 is None:
        raise RuntimeError("MathJax not found: the docs need the docs extras "
                           "(pip install -e '.[dev,docs]', which installs django-static-mathjax)")
    return es5


def record_listings(files: Files, config) -> list[File]:
    """A page ``<dir>/index.md`` listing the files of every folder under ``docs/results/``
    that the site has no README page for, so a link to such a record folder opens in the
    site (:func:`on_page_markdown` sends folder links to ``README.md``, else ``index.md``)."""
    docs = Path(config.docs_dir)
    pages = []
    # os.walk follows the folder links of docs/results/ (paper_runs/ links its runs)
    folders = [Path(d) / name for d, names, _ in os.walk(docs / "results", followlinks=True)
               for name in names]
    for folder in sorted(folders):
        rel = folder.relative_to(docs).as_posix()
        if in_site(files, f"{rel}/README.md") or files.get_file_from_path(f"{rel}/index.md"):
            continue
        lines = [f"# `docs/{rel}/`", "",
                 "The files of this record folder (the policies' `.pt` files open from the "
                 "repository).", ""]
        for child in sorted(folder.iterdir()):
            if child.name.startswith(".") and child.name != ".hydra":  # a run's lock file
                continue
            name = child.name + ("/" if child.is_dir() else "")
            lines.append(f"- [`{name}`]({child.name}{'/' if child.is_dir() else ''})")
        pages.append(File.generated(config, f"{rel}/index.md", content="\n".join(lines) + "\n"))
    return pages


def on_files(files: Files, config) -> Files:
    root = repo_root(config)
    es5 = vendored_mathjax()
    files.append(File.generated(config, f"{MATHJAX_SITE}/{MATHJAX_COMPONENT}",
                                abs_src_path=str(es5 / MATHJAX_COMPONENT)))
    for page in record_listings(files, config):
        files.append(page)
    for script in sorted((root / EXAMPLES).glob("*.py")):
        files.append(File.generated(config, f"{EXAMPLES}/{script.name}",
                                    abs_src_path=str(script)))
    changelog = root / "CHANGELOG.md"
    if changelog.is_file():
        text = changelog.read_text(encoding="utf-8")
        # its links are relative to the repository root; on the site the page sits in docs/
        text = LINK.sub(lambda m: f"[{m.group('text')}](../{m.group('target')})", text)
        files.append(File.generated(config, "changelog.md", content=text))
    return files


# -- record links and links out of docs/ ------------------------------------------------------
def on_page_markdown(markdown: str, page, config, files: Files) -> str:
    root = repo_root(config)
    docs = Path(config.docs_dir)
    docs_rel = docs.resolve().relative_to(root.resolve()).as_posix()
    here = posixpath.dirname(page.file.src_uri)
    if page.file.generated_by is not None and page.file.src_uri == "changelog.md":
        here = ""  # the changelog's links were made relative to docs/ in on_files

    def fix(m: re.Match) -> str:
        text, target = m.group("text"), m.group("target")
        path, _, anchor = target.partition("#")
        suffix = f"#{anchor}" if anchor else ""
        rel = posixpath.normpath(posixpath.join(here, path))
        repo_rel = posixpath.normpath(posixpath.join(docs_rel, rel))
        if rel.startswith("..") and repo_rel.startswith(f"{docs_rel}/"):   # back into docs/
            rel = repo_rel[len(docs_rel) + 1:]
            target = posixpath.relpath(rel, here or ".") + suffix
            return fix(re.match(LINK, f"[{text}]({target})"))
        if rel.startswith(".."):                              # a file of the repository
            if repo_rel.startswith("..") or not (root / repo_rel).exists():
                return m.group(0)                            # left to mkdocs' own link check
            if repo_rel.startswith(f"{EXAMPLES}/") and in_site(files, repo_rel):
                return f"[{text}]({posixpath.relpath(repo_rel, here or '.')}{suffix})"
            url = repo_link(config, repo_rel, (root / repo_rel).is_dir())
            return m.group(0) if url is None else f"[{text}]({url}{suffix})"
        if not (docs / rel).exists():
            return m.group(0)                                # left to mkdocs' own link check
        if (docs / rel).is_file() and in_site(files, rel):
            return m.group(0)                                # a page or a file of the site
        for index in ("README.md", "index.md"):        # index.md: a record listing
            readme = posixpath.join(rel, index)
            if (docs / rel).is_dir() and in_site(files, readme):
                return f"[{text}]({posixpath.relpath(readme, here or '.')}{suffix})"
        url = repo_link(config, posixpath.join(docs_rel, rel), (docs / rel).is_dir())
        if url is not None:
            return f"[{text}]({url})"
        if text.startswith("`") and text.endswith("`"):
            return text
        return f"{text} (`docs/{rel}{'/' if (docs / rel).is_dir() else ''}`)"

    return gfm_lists(LINK.sub(fix, markdown))


# -- GitHub's lists -------------------------------------------------------------------------
def gfm_lists(markdown: str) -> str:
    """``markdown`` with a blank line before each top-level list that follows a non-blank line
    outside a list, and nested items indented by 1-3 spaces indented by 4 (see the module
    docstring); fenced code is left as it is."""
    out: list[str] = []
    fenced = in_list = False
    for line in markdown.split("\n"):
        if line.lstrip().startswith("```"):
            fenced = not fenced
        item = None if fenced else ITEM.match(line)
        indent = len(line) - len(line.lstrip(" "))
        if item and indent == 0:
            marker = item.group("marker")
            starts = marker in "*+-" or marker[:-1] == "1"     # what may interrupt a paragraph
            if starts and not in_list and out and out[-1].strip():
                out.append("")
            in_list = in_list or starts
        elif item and in_list and indent < 4:
            line = "    " + line.lstrip(" ")
        elif not fenced and line.strip() and indent == 0:
            in_list = False
        out.append(line)
    return "\n".join(out)


# -- Sphinx roles in docstrings -> cross-references -------------------------------------------
@functools.cache
def swimrl_objects(root: str):
    """The package as griffe reads it (statically, nothing imported)."""
    import griffe

    return griffe.load("swimrl", search_paths=[root])


def resolve(target: str, context: str, root: str) -> str | None:
    """The documented path of the role target ``target`` seen from the object ``context``
    (Sphinx's rules: absolute, else relative to the context and its parents), or None when
    the API pages do not show it."""
    pkg = swimrl_objects(root)
    name = target.lstrip(".")
    parts = context.split(".")
    candidates = [name] if name.startswith("swimrl.") else []
    candidates += [".".join([*parts[:i], name]) for i in range(len(parts), 0, -1)]
    for path in candidates:
        if not path.startswith("swimrl."):
            continue
        try:
            obj = pkg[path[len("swimrl."):]]
        except Exception:  # noqa: BLE001 - not there, or through an alias griffe cannot follow
            continue
        path = obj.target_path if obj.is_alias else obj.path
        try:
            if obj.is_alias:
                obj = pkg[path[len("swimrl."):]]
            # what mkdocstrings shows: an object with a docstring (a module or class: with
            # one in it), outside the commands, none of its names private
            documented = obj.has_docstrings if obj.kind.value in ("module", "class") \
                else bool(obj.docstring)
        except Exception:  # noqa: BLE001 - outside swimrl, or an alias griffe cannot follow
            return None
        shown = path.startswith("swimrl.") and not path.startswith("swimrl.cli")
        if documented and shown and not any(p.startswith("_") for p in path.split(".")):
            return path
        return None
    return None


# -- figures: an image paragraph becomes a <figure> with its caption -------------------------
#: A paragraph that starts with one or more images; the rest of it is the caption.
FIGURE = re.compile(r"<p>(?P<images>(?:\s*<img [^>]*>)+)(?P<caption>.*?)</p>", re.S)
IMG_SRC = re.compile(r'<img [^>]*src="(?P<src>[^"]+)"[^>]*>')
figure_log = logging.getLogger("mkdocs.plugins.swimrl.figures")


def figures(html: str, page) -> str:
    """``html`` with each image paragraph as a ``<figure>``: each image a link to itself at
    full size (a wide figure is shown at the column's width), the paragraph's text after the
    images its ``<figcaption>``; an image with no caption text is logged as a warning."""

    def figure(m: re.Match) -> str:
        caption = m.group("caption").strip()
        caption = re.sub(r"^<br\s*/?>", "", caption).strip()
        images = IMG_SRC.sub(
            lambda i: f'<a class="swimrl-enlarge" href="{i.group("src")}" '
                      f'title="Open the figure at full size">{i.group(0)}</a>',
            m.group("images").strip())
        if not re.sub(r"<[^>]+>", "", caption).strip():
            figure_log.warning("%s: a figure without a caption (%s): write its caption on the "
                               "line after the image", page.file.src_uri,
                               ", ".join(IMG_SRC.findall(m.group("images"))))
            return f'<figure class="swimrl-figure">{images}</figure>'
        return (f'<figure class="swimrl-figure">{images}'
                f"<figcaption>{caption}</figcaption></figure>")

    return FIGURE.sub(figure, html)


def on_page_content(html: str, page, config, files: Files) -> str:
    html = figures(html, page)
    if not page.file.src_uri.startswith("api/"):
        return html
    root = str(repo_root(config))
    headings = [(m.start(), m.group("id")) for m in HEADING_ID.finditer(html)]

    def context_at(pos: int) -> str:
        ctx = "swimrl"
        for start, ident in headings:
            if start > pos:
                break
            ctx = ident
        return ctx

    def role(m: re.Match) -> str:
        raw = m.group("target")
        short = raw.startswith("~")
        target = raw.lstrip("~")
        shown = target.lstrip(".").split(".")[-1] if short else target
        path = resolve(target, context_at(m.start()), root)
        if path is None:
            return f"<code>{shown}</code>"
        return f'<autoref identifier="{path}"><code>{shown}</code></autoref>'

    return ROLE.sub(role, html)
