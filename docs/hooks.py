"""MkDocs hooks of the swimrl docs site (``mkdocs.yml``: ``hooks: [docs/hooks.py]``).

* **Examples.** Every ``examples/<name>.py`` (jupytext percent format: ``# %%`` code cells,
  ``# %% [markdown]`` text cells) becomes the page ``examples/<name>.md``: the text cells as
  Markdown, the code cells as Python blocks, nothing executed; the script itself is copied
  next to it for download.
* **Record links.** The pages link to record directories (``results/paper_protocol/``) and
  to record files left out of the site (``exclude_docs``: ``.pt``, ``.json``, ...), which
  browse fine on GitHub but are not pages. Such a link becomes a link to the directory's
  ``README.md`` page where there is one, else a link into the repository (``repo_url``,
  when set), else its text followed by the path as code.
* **GitHub's lists.** The pages are written for GitHub, where a list may follow a paragraph
  or a table line directly and a nested list may be indented by 2 spaces; Python-Markdown
  needs a blank line before the list and 4 spaces. Outside code blocks, such a list gets
  the blank line and such a nested item the 4 spaces (:func:`gfm_lists`).
* **Sphinx roles.** Docstrings cite code as ``:class:`~swimrl.env.EnvParams```; the API pages
  show the role's target as code, without the role.
"""

from __future__ import annotations

import posixpath
import re
from pathlib import Path

from mkdocs.structure.files import File, Files

EXAMPLES = "examples"
CELL = re.compile(r"^# %%(.*)$")
# [text](target) with a relative target: no scheme, no leading '/' or '#'
LINK = re.compile(r"(?<!!)\[(?P<text>[^\]]*)\]\((?P<target>(?![a-z][a-z0-9+.-]*:|/|#)[^)\s]+)\)")
ITEM = re.compile(r"^(?P<indent> *)(?P<marker>[*+-]|\d+[.)]) +\S")
ROLE = re.compile(r":(?:py:)?(?:mod|class|func|meth|attr|data|obj|exc|const):(<code>)~?")


# -- examples ---------------------------------------------------------------------------------
def percent_to_markdown(source: str, name: str) -> str:
    """The Markdown page of a percent-format script ``source`` (file name ``name``)."""
    cells: list[tuple[str, list[str]]] = []
    kind, lines = "code", []
    for line in source.splitlines():
        m = CELL.match(line)
        if m:
            cells.append((kind, lines))
            kind = "markdown" if "[markdown]" in m.group(1) or "[md]" in m.group(1) else "code"
            lines = []
        else:
            lines.append(line)
    cells.append((kind, lines))
    parts = []
    for kind, lines in cells:
        text = "\n".join(lines).strip("\n")
        if not text.strip():
            continue
        if kind == "markdown":
            parts.append("\n".join(re.sub(r"^# ?", "", x) for x in text.splitlines()))
        else:
            parts.append(f"```python\n{text}\n```")
    note = (f"[Download `{name}`]({name}) · run it from the repository root, "
            f"`python examples/{name}`, or open it as a notebook: "
            f"`jupytext --to notebook examples/{name}`.")
    if parts and parts[0].startswith("# "):
        title, _, rest = parts[0].partition("\n")
        parts[0] = f"{title}\n\n{note}\n{rest}"
    else:
        parts.insert(0, note)
    return "\n\n".join(parts) + "\n"


def on_files(files: Files, config) -> Files:
    root = Path(config.config_file_path).parent / EXAMPLES
    for script in sorted(root.glob("*.py")):
        page = percent_to_markdown(script.read_text(encoding="utf-8"), script.name)
        files.append(File.generated(config, f"{EXAMPLES}/{script.stem}.md", content=page))
        files.append(File.generated(config, f"{EXAMPLES}/{script.name}",
                                    abs_src_path=str(script)))
    return files


# -- record links -----------------------------------------------------------------------------
def on_page_markdown(markdown: str, page, config, files: Files) -> str:
    if page.file.generated_by is not None:
        return markdown
    docs = Path(config.docs_dir)
    here = posixpath.dirname(page.file.src_uri)

    def fix(m: re.Match) -> str:
        target = m.group("target")
        path, _, anchor = target.partition("#")
        rel = posixpath.normpath(posixpath.join(here, path))
        if rel.startswith("..") or not (docs / rel).exists():
            return m.group(0)            # left to mkdocs' own link check
        if (docs / rel).is_file() and files.get_file_from_path(rel) is not None:
            return m.group(0)            # a page or a file of the site
        readme = posixpath.join(rel, "README.md")
        if (docs / rel).is_dir() and files.get_file_from_path(readme) is not None:
            new = posixpath.relpath(readme, here or ".")
            return f"[{m.group('text')}]({new}{'#' + anchor if anchor else ''})"
        if config.repo_url:
            kind = "tree" if (docs / rel).is_dir() else "blob"
            url = f"{config.repo_url.rstrip('/')}/{kind}/main/docs/{rel}"
            return f"[{m.group('text')}]({url})"
        text = m.group("text")
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


# -- Sphinx roles in docstrings ---------------------------------------------------------------
def on_page_content(html: str, page, config, files: Files) -> str:
    if not page.file.src_uri.startswith("api/"):
        return html
    return ROLE.sub(r"\1", html)
