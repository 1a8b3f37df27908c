r"""Fig. ``dnsFlow`` from committed records (``swimrl-figures``): the DNS replay record
(:mod:`.dns_replay`, also drawn by videos 5, 10), the pooled PDFs of ``swimrl-dns-plots``, the
transfer records (:mod:`.dns_transfer`) and the DNS-trained runs' training curves.

* (a) the vorticity ``omega tau_K`` of a held-out DNS realisation with one smart swimmer's
  trajectory over ``glyph_window`` ``tau_K`` and its shape every ``glyph_every`` ``tau_K``:
  an ellipse along ``p`` with the aspect ratio ``a = ((1 + Lambda)/(1 - Lambda))^{1/2}`` of
  the spheroid (``Lambda = (a^2 - 1)/(a^2 + 1)``), capped at :data:`GLYPH_ASPECT_MAX` so the
  glyphs stay visible; prolate orange, oblate blue;
* (b) the PDFs of ``omega``, ``S_xx``, ``S_xy`` (each over its standard deviation) pooled
  over the stored runs, from ``dns_checks.json`` of ``swimrl-dns-plots``;
* (d), (e) ``<Lambda | S_np, n_theta>`` and ``<Lambda | S_np, omega>`` of the DNS-trained
  policy (``dns.trained``) on the same replay (the paper's (d), (e));
* (f) the DNS-trained runs' periodic held-out ``R_hat`` during training (``dns.curves``);
* (c) the transfer: ``R_hat / R_hat_STO`` of the policies trained at each Ku and of the
  minimal model with the coefficients fitted at each Ku, against that Ku; the DNS-trained
  runs (``dns.trained_seeds``: the mean of their ratios, band: the std over them) and naive
  as horizontal lines. All strategies run on the same flows (a flow = one held-out
  realisation and start time; ``swimrl-compare compare.shared_flows=true``, each strategy
  with its own swimmers); the point is the paired ratio of the means over all flows, the bars the
  standard deviation over independent realisations of each realisation's own ratio (start
  times of one stored run overlap, so their spread would understate it).

No input of the figure may lie under ``shipped_before/`` (the policies shipped before the
paper-budget runs): where ``dns.*`` names one (:func:`~.dns_replay.shipped_before_inputs`;
the committed replay record names ``dns.policy``, and ``docs/results/shipped_before/README.md``
lists the replay record and the transfer comparisons as made with those policies), (a), (c),
(d), (e) are not drawn and the figure is reported ``pending`` with the commands that remake them
(:data:`~.dns_replay.REMAKE`); (b) and (f) are drawn.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from swimrl.analysis.plots import pyplot
from swimrl.policies.baselines import StrategyLabel
from swimrl.runs.atomic import atomic_write_text
from swimrl.runs.curves import read_curves

from .dns_replay import dns_record, replay_markdown, replay_summary, shipped_before_pending
from .dns_transfer import (
    read_transfer,
    realisation_names,
    sample_std,
    trained_ratio,
    trained_ratio_markdown,
    transfer_markdown,
    transfer_summary,
)
from .settings import FiguresConfig, portable
from .style import COLORS, LABEL, save

#: Largest aspect ratio drawn for a glyph (the swimmers' own reach ~10 at |Lambda| = 0.98).
GLYPH_ASPECT_MAX = 4.0
#: The paper's colours of Fig. dnsFlow(b).
PDF_COLOURS = {"omega": "tab:blue", "S_xx": "tab:green", "S_xy": "tab:red"}


def spheroid_aspect(shape_factor: np.ndarray) -> np.ndarray:
    """Aspect ratio ``a = ((1 + Lambda) / (1 - Lambda))^{1/2}`` (inverse of
    ``Lambda = (a^2 - 1) / (a^2 + 1)``)."""
    lam = np.asarray(shape_factor, dtype=float)
    return np.sqrt((1 + lam) / (1 - lam))


# -- the figure ----------------------------------------------------------------------------------
def _glyphs(ax, path: np.ndarray, theta: np.ndarray, lam: np.ndarray, every: int,
            size: float) -> int:
    from matplotlib.patches import Ellipse

    n = 0
    for i in range(0, len(lam), every):
        a = min(float(spheroid_aspect(np.clip(lam[i], -0.999, 0.999))), GLYPH_ASPECT_MAX)
        a = max(a, 1 / GLYPH_ASPECT_MAX)
        color = "tab:orange" if lam[i] > 0 else "tab:blue"
        ax.add_patch(Ellipse(tuple(path[i]), size * math.sqrt(a), size / math.sqrt(a),
                             angle=math.degrees(float(theta[i])), facecolor=color,
                             edgecolor="k", lw=0.4, zorder=4))
        n += 1
    return n


def fig_dns_flow(rec: dict | None, pdfs: dict | None, transfer: dict[str, dict] | None,
                 path: Path, glyph_window: float = 20.0, glyph_every: float = 2.0,
                 title: str = "", dns_trained: Sequence[str] = ("policy(pretrained/dns)",),
                 curves: dict[str, dict[str, np.ndarray]] | None = None) -> dict:
    """(a) vorticity, trajectory and glyphs; (b) PDFs; (c) transfer ratios (``dns_trained``:
    the labels of the DNS-trained runs); (d), (e) the shipped DNS-trained policy's maps; (f)
    the DNS-trained runs' training curves (``{name: curves.csv columns}``). Panels whose
    record is None say so instead (or, for (f), stay empty)."""
    plt = pyplot()
    fig, axes = plt.subplots(2, 3, figsize=(14, 8.6))
    (a, b, c), (d, e, f) = axes
    drawn: dict = {}
    if curves:
        drawn["f"] = {}
        for name, curve in curves.items():
            x, y, err = (np.asarray(curve[k], dtype=float) for k in
                         ("frames", "eval/R_hat", "eval/R_hat_sem"))
            keep = np.isfinite(y)
            f.errorbar(x[keep] / 1e6, y[keep], yerr=np.nan_to_num(err[keep]), marker="o",
                       ms=3, capsize=2, label=name)
            drawn["f"][name] = y[keep].tolist()
        f.set_xlabel("training frames / $10^6$")
        f.set_ylabel(r"$\hat R$, periodic held-out evaluation")
        f.set_title("(f) training of the DNS-trained policies", fontsize=8)
        f.legend(fontsize=6, loc="lower right")
    else:
        f.axis("off")
    if rec is not None:
        tau_u = float(rec["update_interval"])  # decisions every T_u = update_interval tau_K
        n_win = int(round(glyph_window / tau_u))
        x = rec["smart_path"][0, : n_win + 1]
        # the stored field nearest the window's middle (first on a tie): the path is drawn
        # over the flow it swam through, not over the field at its start
        times = np.asarray(rec.get("field_time", np.zeros(1)), dtype=float)
        frame = int(np.argmin(np.abs(times - glyph_window / 2)))
        t_field = float(times[frame])
        vort = rec["vorticity"][frame]
        m = vort.shape[0]
        pad = 0.15  # box units around the path
        shift = np.floor(x.min(0) - pad)  # whole tiles covering the path and the margin
        reps = (np.ceil(x.max(0) + pad) - shift).astype(int).clip(min=1)
        extent = [shift[0], shift[0] + reps[0], shift[1], shift[1] + reps[1]]
        vmax = float(np.abs(rec["vorticity"]).max())
        im = a.imshow(np.tile(vort, (reps[1], reps[0])), origin="lower", extent=extent,
                      cmap="RdBu_r", vmin=-vmax, vmax=vmax, interpolation="bilinear")
        fig.colorbar(im, ax=a, shrink=0.8, label=f"$\\omega\\tau_K$ at $t = {t_field:g}\\,\\tau_K$")
        a.plot(x[:, 0], x[:, 1], color="k", lw=1.0, zorder=3)
        a.plot(*x[0], "r*", ms=12, zorder=5, label="start")
        g = _glyphs(a, x, rec["smart_theta"][0, :n_win], rec["smart_Lambda"][0, :n_win],
                    max(1, int(round(glyph_every / tau_u))), 0.06)
        a.set_xlim(x[:, 0].min() - pad, x[:, 0].max() + pad)
        a.set_ylim(x[:, 1].min() - pad, x[:, 1].max() + pad)
        a.set_aspect("equal")
        a.set_xlabel(r"$x/L$")
        a.set_ylabel(r"$y/L$")
        a.set_title(f"(a) smart swimmer, $t$ = 0-{glyph_window:g} $\\tau_K$; glyphs every "
                    f"{glyph_every:g} $\\tau_K$ (orange prolate, blue oblate);\nvorticity: "
                    f"the stored field nearest the path's middle time, $t = {t_field:g}\\,"
                    f"\\tau_K$", fontsize=8)
        drawn["a"] = {"glyphs": g, "grid": m, "window_decisions": n_win, "field_time": t_field}
        for ax, other, tag in ((d, "n_theta", "d"), (e, "omega", "e")):
            mean = rec[f"map_{other}"]
            im = ax.pcolormesh(rec[f"map_{other}_x"], rec[f"map_{other}_y"], mean.T,
                               cmap="coolwarm", vmin=-1, vmax=1)
            ax.set_xlabel(LABEL["S_np"])
            ax.set_ylabel(LABEL[other])
            ax.set_title(f"({tag}) DNS-trained policy: " + r"$\langle\Lambda\rangle$", fontsize=8)
            fig.colorbar(im, ax=ax, shrink=0.8, label=r"$\langle\Lambda\rangle$")
            drawn[tag] = int(np.isfinite(mean).sum())
    else:
        for ax in (a, d, e):
            ax.text(0.5, 0.5, "no DNS replay record", ha="center", transform=ax.transAxes)
    if pdfs:
        names = {"omega": r"$\omega$", "S_xx": r"$S_{xx}$", "S_xy": r"$S_{xy}$"}
        for name, d in pdfs.items():
            z, p = np.asarray(d["z"]), np.asarray(d["pdf"])
            keep = p > 0
            b.semilogy(z[keep], p[keep], label=names.get(name, name), color=PDF_COLOURS.get(name))
        zz = np.linspace(-6, 6, 241)
        b.semilogy(zz, np.exp(-zz**2 / 2) / math.sqrt(2 * math.pi), "k--", label="Gaussian")
        b.set_ylim(1e-7, 1)
        b.set_xlabel(r"$X/\sigma_X$")
        b.set_ylabel("PDF")
        b.legend(fontsize=7, frameon=False)
        drawn["b"] = sorted(pdfs)
    else:
        b.text(0.5, 0.5, "no pooled PDFs (swimrl-dns-plots)", ha="center", transform=b.transAxes)
    b.set_title("(b) gradient PDFs, pooled over the stored runs", fontsize=8)
    if transfer:
        drawn["c"] = _draw_transfer(c, transfer, tuple(dns_trained))
    else:
        c.text(0.5, 0.5, "no transfer records", ha="center", transform=c.transAxes)
    fig.suptitle(title, fontsize=8)
    fig.tight_layout()
    save(fig, path)
    return drawn


def _draw_transfer(ax, summary: dict[str, dict], dns_labels: tuple[str, ...]) -> dict:
    series: dict[str, list[tuple[float, float, float]]] = {"smart": [], "minimal": []}
    lines, other = {}, []
    for label, s in summary.items():
        parsed = StrategyLabel.parse(label)
        name, ku = parsed.name, parsed.kubo
        err = s["ratio_realisation_std"]
        if ku is not None and name in ("policy", "minimal"):
            kind = "minimal" if name == "minimal" else "smart"
            series[kind].append((ku, s["ratio"], 0.0 if math.isnan(err) else err))
        elif label in dns_labels:
            continue
        elif name in ("naive", "minimal"):
            lines[label] = s
        elif label != "sto":
            other.append(label)
    styles = {"smart": dict(color=COLORS["smart"], marker="o", ls="-",
                            label="smart, trained at Ku"),
              "minimal": dict(color="tab:purple", marker="s", ls="--",
                              label="minimal model, fitted at Ku")}
    for kind, pts in series.items():
        if pts:
            k, r, e = np.array(sorted(pts)).T
            ax.errorbar(k, r, yerr=e, capsize=3, **styles[kind])
    ax.axhline(1.0, color=COLORS["STO"], lw=1.5, label="STO")
    trained = [summary[t]["ratio"] for t in dns_labels if t in summary]
    if trained:
        mean = float(np.mean(trained))
        ax.axhline(mean, color="k", ls=":", lw=1.5,
                   label=f"trained in the DNS ({len(trained)} runs)")
        if len(trained) > 1:
            err = sample_std(np.asarray(trained))
            ax.axhspan(mean - err, mean + err, color="0.88", zorder=0)
        lines["trained in the DNS"] = {"ratio": mean}
    for label, s in lines.items():
        if label.startswith("naive"):
            ax.axhline(s["ratio"], color=COLORS["naive"], lw=1, label=label)
        elif label.startswith("minimal"):
            ax.axhline(s["ratio"], color="tab:purple", lw=1, ls="-.", label=label)
    ax.set_xscale("log")
    ax.set_xlabel("Ku of training")
    ax.set_ylabel(r"$\hat R / \hat R_{\rm STO}$ in the DNS")
    n = next(iter(summary.values()))
    ax.set_title(f"(c) transfer: {n['n_realisations']} held-out runs, {n['n_flows']} flows; "
                 "bars: std over runs", fontsize=8)
    ax.legend(fontsize=6, loc="lower right")
    return {**{k: [list(p) for p in sorted(v)] for k, v in series.items()},
            "lines": {k: v["ratio"] for k, v in lines.items()}, "not_drawn": other}


def build_dns_flow(cfg: FiguresConfig) -> dict:
    """Fig. dnsFlow from the committed records of ``cfg.dns`` (the replay record made first
    if missing and a finished store is there)."""
    if cfg.dns is None:
        return {"pending": "no dns.* records configured"}
    dns = cfg.dns
    stale = shipped_before_pending(dns)
    rec, why = (None, f"(a), (c), (d), (e): {stale}") if stale else dns_record(cfg, dns)
    pdfs = None
    if Path(dns.checks).exists():
        pdfs = json.loads(Path(dns.checks).read_text()).get("pooled_pdfs")
    per = read_transfer(dns.transfer) if Path(dns.transfer).exists() and not stale else {}
    summary = transfer_summary(per) if per else None
    title = ("(a), (c), (d), (e) pending: the DNS records were made with the policies under "
             "shipped_before/" if stale else "no replay record")
    if rec is not None:
        title = (f"(a) held-out DNS run {rec['input_store']}, smart = {rec['input_policy']}; "
                 f"(c) smart = the shipped policies, minimal = fits to them; (d, e) "
                 f"{rec['input_trained']} on {rec['input_n_swimmers']} swimmers x 1 start")
    curves = {Path(c).parent.name: read_curves(c) for c in dns.curves if Path(c).exists()}
    labels = tuple(StrategyLabel.policy(t).label for t in dns.trained_seeds)
    out = fig_dns_flow(rec, pdfs, summary, cfg.out / "dnsFlow.png", dns.glyph_window,
                       dns.glyph_every, title, labels, curves)
    if rec is not None:
        out["replay"] = replay_summary(rec)
        atomic_write_text(cfg.out / "dnsFlow_replay.md",
                          replay_markdown(out["replay"], str(rec["input_store"])))
    if summary:
        out["transfer"] = summary
        text = transfer_markdown(summary)
        transferred = StrategyLabel.policy(dns.policy).label
        if transferred in per and all(t in per for t in labels):
            out["trained_ratio"] = trained_ratio(per, transferred, labels)
            text += "\n" + trained_ratio_markdown(out["trained_ratio"],
                                                   realisation_names(dns.transfer))
        atomic_write_text(cfg.out / "dnsFlow_transfer.md", text)
    elif stale:
        atomic_write_text(cfg.out / "dnsFlow_transfer.md", f"Pending: {stale}\n")
    missing = [why] if why else []
    missing += [f"no pooled_pdfs in {dns.checks}"] if not pdfs else []
    missing += [f"no comparison.json under {dns.transfer}"] if not (summary or stale) else []
    missing += [f"no training curve {portable(c)}" for c in dns.curves if not Path(c).exists()]
    if missing:
        out["pending"] = "; ".join(missing)
    return out
