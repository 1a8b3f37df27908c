// MathJax 3 for pymdownx.arithmatex (generic mode): typeset the \( \) and \[ \] spans it
// writes, equations numbered by their \tag{} as in the paper. MathJax itself is the next
// script (tex-svg-full.js, served by the site: every TeX extension, \boldsymbol included,
// is in that one file, so nothing is fetched and the first typeset finds every macro).
window.MathJax = {
  tex: {
    inlineMath: [["\\(", "\\)"]],
    displayMath: [["\\[", "\\]"]],
    processEscapes: true,
    processEnvironments: true,
    tags: "none",
  },
  svg: { fontCache: "global" },
  options: {
    ignoreHtmlClass: ".*|",
    processHtmlClass: "arithmatex",
    // no context menu: its assistive extensions would be fetched on demand
    enableMenu: false,
  },
};

if (typeof document$ !== "undefined") {
  // mkdocs-material emits document$ at the first load (MathJax's own startup typesets that
  // page) and after each instant navigation: typeset the new page, chained after whatever
  // typesetting is still running, never beside it.
  let first = true;
  document$.subscribe(() => {
    if (first) {
      first = false;
      return;
    }
    const startup = window.MathJax.startup;
    if (!startup || !startup.promise) return;
    startup.promise = startup.promise.then(() => {
      startup.output.clearCache();
      MathJax.typesetClear();
      MathJax.texReset();
      return MathJax.typesetPromise();
    });
  });
}
