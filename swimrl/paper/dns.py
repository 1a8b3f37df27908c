r"""Fig. ``dnsFlow`` and the DNS replay record (also drawn by videos 5, 10) from committed
records (``swimrl-figures``).

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
paper-budget runs): where ``dns.*`` names one (:func:`shipped_before_inputs`; the committed
replay record names ``dns.policy``, and ``docs/results/shipped_before/README.md`` lists the
replay record and the transfer comparisons as made with those policies), (a), (c), (d), (e)
are not drawn and the figure is reported ``pending`` with the commands that remake them
(:data:`REMAKE`); (b) and (f) are drawn.

The replay record (``record``) is made once from a finished stored run when that run exists
(``swimrl-dns seed=...``; the stores are too large to commit) and is then read from the
committed ``.npz``: a fresh clone draws the figure and the videos without the store. The
record keeps what it was made with (policy, store, sizes, seed, episode); a record made with
other settings is not used (delete it to remake it). Lengths are in units of the DNS box
``L`` (``reference_distance`` too).
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from swimrl.analysis.plots import pyplot
from swimrl.analysis.policy_maps import lambda_maps
from swimrl.evaluation.statistics import paired_ratio
from swimrl.flows.build import StoredRunSpec
from swimrl.flows.dns.store import store_status
from swimrl.policies.baselines import StrategyLabel
from swimrl.runs.atomic import atomic_write_text
from swimrl.runs.curves import read_curves
from swimrl.runs.layout import RunLayout
from swimrl.runs.policy_files import resolve_policy_file
from swimrl.runs.records import markdown_table, read_npz, write_npz
from swimrl.runs.spec import EvalSizes, RunSpec

from .records import (
    FRAME_EVERY,
    DNSFiguresConfig,
    FiguresConfig,
    portable,
    record_strategies,
    under_shipped_before,
)
from .style import COLORS, LABEL, save

#: Largest aspect ratio drawn for a glyph (the swimmers' own reach ~10 at |Lambda| = 0.98).
GLYPH_ASPECT_MAX = 4.0
#: The paper's colours of Fig. dnsFlow(b).
PDF_COLOURS = {"omega": "tab:blue", "S_xx": "tab:green", "S_xy": "tab:red"}


#: How the DNS records are remade with the current policies (``{store}``, ``{record}``,
#: ``{transfer}``: the ``dns.*`` paths).
REMAKE = ("swimrl-dns seed=2 (the held-out store {store}; docs/dns.md), then rm {record} and "
          "swimrl-figures only=dnsFlow dns.policy=pretrained/ku10 (and dns.policy=pretrained/ku10 "
          "in conf/figures.yaml); the transfer: swimrl-dns -m seed=3,4,5 and the swimrl-compare "
          "loop of docs/results.md, Fig. dnsFlow, into {transfer}/seed<s>")


def shipped_before_inputs(dns: DNSFiguresConfig) -> list[str]:
    """The ``dns.*`` inputs under ``shipped_before/`` (``KEY=VALUE``)."""
    keys = ("policy", "trained", "store", "record", "transfer", "checks")
    named = [(k, getattr(dns, k)) for k in keys if getattr(dns, k) is not None]
    named += [("trained_seeds", t) for t in dns.trained_seeds]
    named += [("curves", c) for c in dns.curves]
    return [f"dns.{k}={v}" for k, v in named if under_shipped_before(v)]


def shipped_before_pending(dns: DNSFiguresConfig) -> str:
    """Why the DNS records are not drawn and how to remake them ("" where no input is under
    ``shipped_before/``)."""
    inputs = shipped_before_inputs(dns)
    if not inputs:
        return ""
    return (f"{', '.join(inputs)} under shipped_before/: the replay record and the transfer "
            "comparisons were made with the earlier policies; remake them: "
            + REMAKE.format(store=portable(dns.store), record=portable(dns.record),
                            transfer=portable(dns.transfer)))


def replay_strategies(policy: str, trained: str) -> list[str]:
    """The replay record's strategies, in its order: smart, naive, STO, the DNS-trained one."""
    return [policy, "naive", "sto", trained]


def spheroid_aspect(shape_factor: np.ndarray) -> np.ndarray:
    """Aspect ratio ``a = ((1 + Lambda) / (1 - Lambda))^{1/2}`` (inverse of
    ``Lambda = (a^2 - 1) / (a^2 + 1)``)."""
    lam = np.asarray(shape_factor, dtype=float)
    return np.sqrt((1 + lam) / (1 - lam))


# -- the replay record ---------------------------------------------------------------------------
def record_inputs(cfg: FiguresConfig, dns: DNSFiguresConfig) -> dict[str, str]:
    """What a replay record depends on, as strings (kept in the record, compared on load)."""
    return {"policy": dns.policy, "trained": dns.trained, "store": Path(dns.store).name,
            "n_swimmers": str(dns.n_swimmers),
            "n_traj": str(dns.n_traj), "decode_n": str(dns.decode_n), "seed": str(cfg.seed),
            "params": json.dumps(dataclasses.asdict(cfg.params), sort_keys=True, default=str)}


def make_record(cfg: FiguresConfig, dns: DNSFiguresConfig) -> dict[str, np.ndarray]:
    """Smart (``dns.policy``), naive and STO from the same start time and initial conditions
    in ``dns.store``: clouds and trajectories every :data:`FRAME_EVERY` decisions, the
    vorticity of the run at those times, and smart's first ``n_traj`` swimmers at every
    decision (position, orientation, Lambda). Lengths in units of the box."""
    spec = StoredRunSpec((Path(dns.store),), decode_n=dns.decode_n)
    sizes = EvalSizes(1, dns.n_swimmers, 1, cfg.progress, dns.n_swimmers)
    setup = RunSpec(flow=spec, params=cfg.params, runtime=cfg.runtime, sizes=sizes,
                      seed=cfg.seed, record={})
    a = record_strategies(setup, replay_strategies(dns.policy, dns.trained), "DNS", FRAME_EVERY)
    box = float(a["box"])
    maps = {}  # the DNS-trained policy's maps (d), (e), as float32
    for other, (mean, (x, y)) in lambda_maps(a["signals"][0, 3], a["Lambda"][0, 3]).items():
        maps[f"map_{other}"] = mean.astype(np.float32)
        maps[f"map_{other}_x"], maps[f"map_{other}_y"] = x, y
    pos = np.swapaxes(a["position"], 0, 1)[:3, 0] / box  # (3, S, N+1, 2)
    disp = pos - pos[..., :1, :]
    nt = min(dns.n_traj, pos.shape[1])
    return {
        "cloud": disp[..., ::FRAME_EVERY, :].astype(np.float32),
        "traj_abs": pos[:, :nt, ::FRAME_EVERY].astype(np.float32),
        "smart_path": pos[0, :nt].astype(np.float32),
        "smart_theta": np.swapaxes(a["theta"], 0, 1)[0, 0, :nt].astype(np.float32),
        "smart_Lambda": np.swapaxes(a["Lambda"], 0, 1)[0, 0, :nt].astype(np.float32),
        "R_hat": np.swapaxes(a["R_hat"], 0, 1)[:, 0],
        "vorticity": a["vorticity"].astype(np.float16),
        "field_time": a["field_time"],
        "time": a["time"], "tau_K": a["tau_K"], "box": np.asarray(1.0),
        "reference_distance": np.asarray(float(a["reference_distance"]) / box),
        "box_dns": np.asarray(box), "update_interval": a["update_interval"],
        **{f"input_{k}": np.asarray(v) for k, v in record_inputs(cfg, dns).items()},
        **maps,
    }


def dns_record(cfg: FiguresConfig, dns: DNSFiguresConfig) -> tuple[dict | None, str]:
    """``(record, "")``: the committed record, made from ``dns.store`` first if it is missing;
    ``(None, why)`` when it is missing and cannot be made (no finished store, no policy) or
    was made with other inputs."""
    path = Path(dns.record)
    if not path.exists():
        status = store_status(dns.store) if Path(dns.store).exists() else None
        if status != "complete":
            return None, (f"no replay record {path} and no finished store {dns.store} "
                          f"(status {status}) to make it from")
        for key, spec in (("dns.policy", dns.policy), ("dns.trained", dns.trained)):
            try:
                if "/" in spec:  # a policy file (not a baseline such as naive(-0.5))
                    resolve_policy_file(spec)
            except (FileNotFoundError, ValueError) as err:
                return None, f"no replay record {path}: {key}={spec!r} ({err})"
        write_npz(make_record(cfg, dns), path)
    out = read_npz(path)
    made = {k[6:]: str(v) for k, v in out.items() if k.startswith("input_")}
    differ = sorted(k for k, v in record_inputs(cfg, dns).items() if made.get(k) != v)
    if differ:
        return None, (f"{path} was made with other {', '.join(differ)} (delete it to remake it "
                      "from the store)")
    out["vorticity"] = out["vorticity"].astype(np.float32)
    return out, ""


# -- (c) the transfer ----------------------------------------------------------------------------
def transfer_records(root: Path) -> list[Path]:
    """The ``comparison.json`` files under ``root``, one per held-out realisation, in the
    order every transfer reader uses."""
    return sorted(Path(root).rglob(RunLayout(root).comparison.name))


def read_transfer(root: Path) -> dict[str, np.ndarray]:
    """Per-flow ``R_hat`` of each strategy label over every ``comparison.json`` under
    ``root`` (one per held-out realisation), concatenated over realisations:
    ``{label: (flows,)}``, plus ``realisation`` (the index of each flow's record)."""
    per: dict[str, list[np.ndarray]] = {}
    which: list[np.ndarray] = []
    for i, path in enumerate(transfer_records(root)):
        rec = json.loads(path.read_text())
        for row in rec["rows"]:
            per.setdefault(row["label"], []).append(np.asarray(row["per_flow"], dtype=float))
        which.append(np.full(len(rec["rows"][0]["per_flow"]), i))
    if not per:
        return {}
    sizes = {len(v) for v in per.values()}
    if sizes != {len(which)}:
        raise ValueError(f"{root}: the records do not all hold the same strategies")
    out = {k: np.concatenate(v) for k, v in per.items()}
    out["realisation"] = np.concatenate(which)
    return out


def _std(x: np.ndarray) -> float:
    return float(np.std(x, ddof=1)) if np.size(x) > 1 else math.nan


def realisation_ratios(num: np.ndarray, den: np.ndarray, real: np.ndarray) -> np.ndarray:
    """``<num>_i / <den>_i`` for each realisation ``i`` (means over its flows, the same flows
    for both)."""
    return np.array([num[real == i].mean() / den[real == i].mean() for i in np.unique(real)])


def transfer_summary(per: dict[str, np.ndarray], reference: str = "sto") -> dict[str, dict]:
    """Per label: ``R_hat`` (mean and std over flows), the paired ratio of its mean to the
    ``reference``'s over all flows with its delta-method SEM (``ratio``, ``ratio_sem``, as
    ``swimrl-compare``), each realisation's own paired ratio and their std over
    realisations (``ratio_realisation_std``: the bars of Fig. dnsFlow(c))."""
    ref, real = per[reference], per["realisation"]
    out = {}
    for label, r in per.items():
        if label == "realisation":
            continue
        ratio, sem = paired_ratio(r, ref)
        by_real = realisation_ratios(r, ref, real)
        out[label] = {"R_hat": float(r.mean()), "R_hat_std": _std(r),
                      "ratio": ratio, "ratio_sem": sem,
                      "ratio_realisations": by_real.tolist(),
                      "ratio_realisation_std": _std(by_real),
                      "n_flows": int(r.size), "n_realisations": int(len(by_real))}
    return out


def transfer_markdown(summary: dict[str, dict]) -> str:
    """The transfer table: per strategy R_hat (mean and std over flows), the paired ratio to
    STO over all flows (+- delta-method SEM), each realisation's ratio and their std."""
    rows = []
    for label, s in summary.items():
        per = ", ".join(f"{r:.3f}" for r in s["ratio_realisations"])
        rows.append([label, f"{s['R_hat']:.3f} ± {s['R_hat_std']:.3f}",
                     f"{s['ratio']:.3f} ± {s['ratio_sem']:.3f}", per,
                     f"{s['ratio_realisation_std']:.3f}"])
    n = next(iter(summary.values()))
    head = ["strategy", f"R̂ (mean ± std over {n['n_flows']} flows)",
            "R̂ / R̂_STO (paired, ± SEM)",
            f"per realisation ({n['n_realisations']})", "std over realisations"]
    return markdown_table(head, rows)


def trained_ratio(per: dict[str, np.ndarray], transferred: str,
                  trained: Sequence[str]) -> dict:
    """The transferred policy against the DNS-trained runs, realisation by realisation:
    ``r_{k,i} = <R_hat_transferred>_i / <R_hat_trained_k>_i`` (means over the flows of
    realisation ``i``, the same flows for both), per realisation the mean and std over the
    runs ``k``, and per run its ratio over all flows."""
    real = per["realisation"]
    num = per[transferred]
    runs = np.array([realisation_ratios(num, per[t], real) for t in trained])  # (runs, real.)
    overall = [float(num.mean() / per[t].mean()) for t in trained]
    return {"transferred": transferred, "trained": list(trained),
            "per_realisation": runs.T.tolist(),
            "realisation_mean": runs.mean(0).tolist(),
            "realisation_std_over_runs": [_std(c) for c in runs.T],
            "overall": overall, "overall_mean": float(np.mean(overall)),
            "overall_std_over_runs": _std(np.asarray(overall))}


def realisation_names(root: Path) -> list[str]:
    """The held-out realisations of :func:`read_transfer` in its order: the directory of
    each ``comparison.json`` under ``root``."""
    return [p.parent.name for p in transfer_records(root)]


def trained_ratio_markdown(r: dict, names: Sequence[str] | None = None) -> str:
    """One row per held-out realisation (``names``, default 1, 2, ...): the ratio for each
    DNS-trained run, mean and std over the runs; last row: all flows."""
    head = ["held-out realisation", *[f"÷ {t}" for t in r["trained"]], "mean", "std over runs"]
    names = list(names) if names else [str(i + 1) for i in range(len(r["per_realisation"]))]
    rows = [[name, *[f"{v:.3f}" for v in per], f"{m:.3f}", f"{sd:.3f}"]
            for name, per, m, sd in zip(names, r["per_realisation"], r["realisation_mean"],
                                        r["realisation_std_over_runs"], strict=True)]
    rows.append(["all flows", *[f"{v:.3f}" for v in r["overall"]], f"{r['overall_mean']:.3f}",
                 f"{r['overall_std_over_runs']:.3f}"])
    return (f"{r['transferred']} / DNS-trained run, per held-out realisation (ratio of the "
            "mean R̂ over the same flows):\n\n" + markdown_table(head, rows))


def replay_summary(rec: dict) -> dict[str, dict]:
    """The replay record's strategies (:func:`replay_strategies`): ``R_hat`` (mean, SEM over
    swimmers) and the mean distance from the start after ``T`` in box units (``R_hat`` times
    the reference distance ``v_s T``)."""
    names = replay_strategies(str(rec["input_policy"]), str(rec["input_trained"]))
    ref = float(rec["reference_distance"])
    out = {}
    for name, r in zip(names, np.asarray(rec["R_hat"], dtype=float), strict=True):
        out[name] = {"R_hat": float(r.mean()), "R_hat_sem": _std(r) / math.sqrt(r.size),
                     "distance_L": float(r.mean() * ref), "n_swimmers": int(r.size)}
    return out


def replay_markdown(summary: dict[str, dict], store: str) -> str:
    """The replay record's table (the numbers of videos 5, 10)."""
    rows = [[k, f"{v['R_hat']:.3f} ± {v['R_hat_sem']:.3f}", f"{v['distance_L']:.2f}",
             str(v["n_swimmers"])] for k, v in summary.items()]
    return (f"Replay record (videos 5, 10; Fig. dnsFlow(a)): held-out run {store}, one start "
            "time, the same initial conditions for every strategy; ± SEM over swimmers.\n\n"
            + markdown_table(["strategy", "R̂", "mean distance after T / L", "swimmers"], rows))


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
            err = _std(np.asarray(trained))
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
