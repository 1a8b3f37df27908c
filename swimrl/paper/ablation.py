"""Fig. ablation: (a) smart / STO per signal set, (b), (c) the minimal model with the
coefficients fitted at each Ku (``swimrl-fit-minimal``).

(a) reads the runs' held-out comparisons (:func:`read_held_out`): every ``comparison.json``
under ``<ablation>/held_out/`` (one per reduced-signal run) and the protocol's comparison at
the runs' Ku (``<results>/ku<KU>/comparison.json``, whose policy rows are the all-signal runs
``<curves>/ku<KU>_seed<k>``); a policy row names its run's ``policy.pt``, whose directory holds
the run's ``metrics.json`` (signals, seed, Ku, budget) and ``curves.csv``. All comparisons
evaluate on the same held-out flows (one seed, one number of flows; the swimmers per flow may
differ). (b) evaluates smart, the minimal model and STO at each Ku on ``robust_flows`` x
``robust_swimmers`` (the record's evaluations); (c) draws the fits. The figure's record
``<records>/ablation.json`` holds (b)'s per-flow values and the numbers of (a), (b), (c), with
the sha256 of every file (a) and (c) read.
"""

from __future__ import annotations

import json
import textwrap
from collections import Counter
from pathlib import Path

import numpy as np

from swimrl.analysis.plots import pyplot
from swimrl.analysis.signal_ablation import (
    AblationRun,
    canonical,
    check_one_ablation,
    draw_curves,
    draw_ratios,
    summarise_sets,
)
from swimrl.flows.labels import ku_display, ku_name
from swimrl.policies.baselines import StrategyLabel
from swimrl.runs.atomic import atomic_write_text
from swimrl.runs.curves import read_curves
from swimrl.runs.layout import RunLayout
from swimrl.runs.records import markdown_table

from .evaluations import Evaluation, eval_setup, per_flow_values, smart_policy
from .records import figure_record, record_sizes
from .settings import FiguresConfig, under_shipped_before
from .style import COLORS, save, shown


def read_fits(root: Path) -> dict[float, dict]:
    """``fit.json`` of ``swimrl-fit-minimal`` under ``root/ku*/``, keyed by Ku."""
    fits = {}
    for path in sorted(Path(root).glob("ku*/fit.json")):
        rec = json.loads(path.read_text())
        fits[float(rec["config"]["flow"]["kubo"])] = rec
    return dict(sorted(fits.items()))


def minimal_name(fit: dict) -> str:
    """Actor name of the minimal model with a fit's coefficients (``minimal(c1,c2,c3,c4)``)."""
    c = fit["coefficients"]
    return StrategyLabel.minimal_coeffs([c[k] for k in ("c1", "c2", "c3", "c4")]).label


def _draw_minimal(b, c, kus: np.ndarray, r: dict[str, np.ndarray], err: dict[str, np.ndarray],
                  coeffs: dict[str, np.ndarray], coeff_err: dict[str, np.ndarray]) -> None:
    """(b) R_hat of smart, the minimal model and STO against Ku; (c) c1..c4 against Ku."""
    colors = {**COLORS, "minimal": "tab:purple"}
    for name, y in r.items():
        b.errorbar(kus, y, yerr=err[name], color=colors[name], marker="o", capsize=3, label=name,
                   ls="--" if name == "minimal" else "-")
    b.set_xscale("log")
    b.set_xlabel("Ku")
    b.set_ylabel(r"$\hat R$")
    b.set_title("(b) smart and the minimal model", fontsize=9)
    b.legend(fontsize=7)
    shades = dict(zip(("c1", "c2", "c3", "c4"),
                      ("tab:blue", "tab:red", "tab:brown", "tab:pink"), strict=True))
    for k, y in coeffs.items():
        c.errorbar(kus, y, yerr=coeff_err[k], marker="o", capsize=3, label=f"$c_{k[1]}$",
                   color=shades[k])
    c.axhline(0, color="0.6", lw=0.8)
    c.set_xscale("log")
    c.set_xlabel("Ku")
    c.set_ylabel("fitted coefficient")
    c.set_title("(c) minimal-model coefficients", fontsize=9)
    c.legend(fontsize=7)


def fig_ablation(kus: np.ndarray, r: dict[str, np.ndarray], err: dict[str, np.ndarray],
                 coeffs: dict[str, np.ndarray], coeff_err: dict[str, np.ndarray], path: Path,
                 title: str = "", runs: list[AblationRun] | None = None,
                 held_out_seed: int | None = None) -> dict:
    """(a) smart / STO per signal set (the runs' held-out comparisons ``runs``, at one Ku;
    "no records" where there are none) and (a') their held-out curves; (b) R_hat of smart, the
    minimal model (fitted at each Ku) and STO against Ku; (c) the fitted c1..c4 against Ku."""
    plt = pyplot()
    fig, axes = plt.subplots(2, 2, figsize=(10, 7.6))
    (a, a2), (b, c) = axes
    out: dict = {}
    if runs:
        summary = summarise_sets(runs)
        draw_ratios(a, summary)
        out["ablation"] = {s["label"]: {"seeds": s["seeds"], "ratios": s["ratios"].tolist(),
                                        "mean": s["mean"], "std": s["std"]} for s in summary}
        out["curves_last"] = draw_curves(a2, runs, summary)
        out["table"] = held_out_markdown(runs, summary, held_out_seed)
        kubo, frames = runs[0].kubo, runs[0].frames
        a.set_title(f"(a) signal ablation, {ku_display(kubo)}, {frames / 1e6:g}M frames per run",
                    fontsize=9)
        a2.set_title("(a') the runs' held-out curves (mean, band: std over seeds)", fontsize=9)
    else:
        for ax in (a, a2):
            ax.text(0.5, 0.5, "signal ablation: no records", ha="center", va="center",
                    transform=ax.transAxes)
            ax.set_axis_off()
    _draw_minimal(b, c, kus, r, err, coeffs, coeff_err)
    fig.suptitle("\n".join(textwrap.fill(line, 150) for line in title.splitlines()), fontsize=8)
    fig.tight_layout()
    save(fig, path)
    return {"kubo": kus.tolist(), **{k: np.asarray(v).tolist() for k, v in r.items()},
            **{k: np.asarray(v).tolist() for k, v in coeffs.items()}, **out}


def held_out_markdown(runs: list[AblationRun], summary: list[dict],
                      seed: int | None = None) -> str:
    """The table of Fig. ablation (a): per signal set, each seed's smart and STO R_hat and
    paired ratio on the held-out flows, and the mean and std over seeds of the ratio."""
    flows = sorted({r.held_out[0] for r in runs})
    intro = (f"{ku_display(runs[0].kubo)}, {runs[0].frames / 1e6:g}M frames per run; each run's "
             f"smart and STO on the same {'/'.join(map(str, flows))} held-out flows"
             + (f" (evaluation seed {seed})" if seed is not None else "") + "\n\n")
    head = ["signals", "seeds", "smart R̂ per seed", "STO R̂ per seed",
            "smart / STO per seed (paired ± SEM)", "held-out flows x swimmers",
            "mean ± std over seeds"]
    rows = []
    for s in summary:
        mine = sorted((r for r in runs if r.signals == s["signals"]), key=lambda r: r.seed)
        sizes = sorted({f"{r.held_out[0]} x {r.held_out[1]}" for r in mine})
        rows.append([", ".join(s["signals"]), ", ".join(map(str, s["seeds"])),
                     ", ".join(f"{r.smart:.3f}" for r in mine),
                     ", ".join(f"{r.sto:.3f}" for r in mine),
                     ", ".join(f"{r.ratio:.3f} ± {r.ratio_sem:.3f}" for r in mine),
                     ", ".join(sizes),
                     f"**{s['mean']:.3f} ± {s['std']:.3f}**" if len(s["seeds"]) > 1
                     else f"**{s['mean']:.3f}** (one seed)"])
    return intro + markdown_table(head, rows)


def _comparison_runs(cmp_path: Path, files: list[Path],
                     run_dir: Path | None = None) -> tuple[list[AblationRun], dict]:
    """The runs of the policy rows of one held-out comparison and the comparison's ``seed``
    and ``n_flows``; the files read are appended to ``files``. A row's run directory is
    ``run_dir`` (``held_out/<run>/``: one policy row, the run's policy by its directory's
    name, wherever it was evaluated from) or else the directory of the ``policy.pt`` it names.
    ValueError (one line) where the comparison is not of its runs."""
    cmp = json.loads(Path(cmp_path).read_text())
    rows = cmp.get("rows") or []
    policy = [r for r in rows if StrategyLabel.parse(r["label"]).name == "policy"]
    if (not rows or rows[0]["label"] != StrategyLabel("sto").label or not policy
            or (run_dir is not None and len(policy) != 1)):
        raise ValueError(f"{cmp_path}: expected STO first and "
                         f"{'one policy row' if run_dir else 'one policy row or more'}, got "
                         f"{[r['label'] for r in rows]}")
    cmp_cfg = cmp["config"]
    files.append(Path(cmp_path))
    out = []
    for row in policy:
        named = Path(StrategyLabel.parse(row["label"]).arg)
        run = RunLayout(run_dir if run_dir is not None else named.parent)
        if named.parent.name != run.root.name:
            raise ValueError(f"{cmp_path}: its policy row {row['label']} is not the run "
                             f"{run.root.name}'s")
        if under_shipped_before(run.root) or not (run.metrics.is_file() and run.policy.is_file()):
            raise ValueError(f"{cmp_path}: row {row['label']}: no run directory {run.root} with "
                             "policy.pt and metrics.json; allowed: a run's policy.pt, not "
                             "under shipped_before/")
        metrics = json.loads(run.metrics.read_text())["config"]
        signals = canonical(metrics["signals"]["names"])
        if canonical(cmp_cfg["signals"]["names"]) != signals or (
                float(cmp_cfg["flow"]["kubo"]) != float(metrics["flow"]["kubo"])):
            raise ValueError(f"{cmp_path}: compared with signals {cmp_cfg['signals']['names']} "
                             f"at Ku = {cmp_cfg['flow']['kubo']}, its run {run.root} was trained "
                             f"with {list(signals)} at Ku = {metrics['flow']['kubo']}")
        curve = read_curves(run.curves) if run.curves.is_file() else {}
        has_eval = "eval/R_hat" in curve and np.isfinite(curve["eval/R_hat"]).any()
        files += [run.metrics, run.policy] + ([run.curves] if run.curves.is_file() else [])
        out.append(AblationRun(
            signals=signals, seed=int(metrics["seed"]), kubo=float(metrics["flow"]["kubo"]),
            frames=int(metrics["train"]["total_frames"]),
            held_out=(int(cmp["n_flows"]), int(cmp["n_swimmers"])),
            ratio=float(row["ratio_to_first"]), ratio_sem=float(row["ratio_sem"]),
            smart=float(row["R_hat_mean"]), sto=float(rows[0]["R_hat_mean"]),
            curve=curve if has_eval else None))
    return out, {"seed": int(cmp["seed"]), "n_flows": int(cmp["n_flows"])}


def read_held_out(ablation: Path, results: Path) -> tuple[list[AblationRun], dict, list[Path]]:
    """Ablation (a) from held-out comparisons: ``<ablation>/held_out/<run>/comparison.json`` of
    the run ``<ablation>/<run>/`` and the protocol's at the runs' Ku
    (``<results>/ku<KU>/comparison.json``: the all-signal runs).
    Returns the runs, the held-out flows (``{"seed", "n_flows"}``) and the files read.

    Raises ValueError (one line) where they do not form one ablation: runs of different Ku or
    budgets, comparisons on other flows (seed, number of flows), a signal set and seed twice."""
    name = RunLayout(ablation).comparison.name
    found = sorted(Path(ablation, "held_out").glob(f"*/{name}"))
    runs: list[AblationRun] = []
    held: list[dict] = []
    files: list[Path] = []
    for path in found:
        r, h = _comparison_runs(path, files, Path(ablation) / path.parent.name)
        runs += r
        held.append(h)
    if runs:
        protocol = Path(results) / ku_name(runs[0].kubo) / name
        if protocol.is_file():
            r, h = _comparison_runs(protocol, files)
            runs += r
            held.append(h)
    check_one_ablation(ablation, runs, {"kubo": {r.kubo for r in runs},
                                        "frames": {r.frames for r in runs},
                                        "held-out seed": {h["seed"] for h in held},
                                        "held-out n_flows": {h["n_flows"] for h in held}})
    return runs, (held[0] if held else {}), files


def _ablation_derived(rec: dict, evs: list[Evaluation], fits: dict[float, dict],
                      runs: list[AblationRun], held: dict) -> dict:
    """The numbers of (a) (per signal set), (b) (per Ku, from the evaluations) and (c)."""
    summary = summarise_sets(runs) if runs else []
    keys = ("c1", "c2", "c3", "c4")
    return {
        "signal_sets": [{"signals": list(s["signals"]), "seeds": s["seeds"],
                         "ratios": s["ratios"].tolist(),
                         "ratio_sems": [r.ratio_sem for r in sorted(
                             (r for r in runs if r.signals == s["signals"]),
                             key=lambda r: r.seed)],
                         "mean": s["mean"], "std": s["std"]} for s in summary],
        "held_out": held,
        "minimal": {ev.key: rec["evaluations"][ev.key]["derived"] for ev in evs},
        "coefficients": {ku_name(k): {c: f["coefficients"][c] for c in keys}
                         for k, f in fits.items()},
        "coefficient_errors": {ku_name(k): {c: f.get("flow_sem", f["stderr"])[c] for c in keys}
                               for k, f in fits.items()},
    }


def build_ablation(cfg: FiguresConfig) -> dict:
    """Fig. ablation: (a) from the held-out comparisons of the signal-ablation runs, (b) from
    the record's evaluations, (c) from the committed fits."""
    fits = read_fits(cfg.fits)
    if not fits:
        return {"pending": f"no ku*/fit.json under {cfg.fits}"}
    runs, held, files = read_held_out(cfg.ablation, cfg.results)
    names = ("smart", "minimal", "STO")
    evs = [Evaluation(ku_name(k), "sweep",
                      eval_setup(cfg, k, cfg.robust_flows, cfg.robust_swimmers),
                      dict(zip(names, (smart_policy(cfg, k), minimal_name(f), "sto"),
                               strict=True))) for k, f in fits.items()]
    ratios = (("smart", "STO"), ("minimal", "STO"), ("minimal", "smart"))
    sources = [*files, *sorted(Path(cfg.fits).glob("ku*/fit.json"))]
    rec = figure_record(cfg, "ablation", evs, lambda ev: per_flow_values(cfg, ev, ratios),
                        lambda r: _ablation_derived(r, evs, fits, runs, held), sources)
    kus = np.array(list(fits))
    derived = [rec["evaluations"][ev.key]["derived"] for ev in evs]
    r = {n: np.array([d["mean"][n] for d in derived]) for n in names}
    err = {n: np.array([d["std"][n] for d in derived]) for n in names}
    keys = ("c1", "c2", "c3", "c4")
    coeffs = {k: np.array([f["coefficients"][k] for f in fits.values()]) for k in keys}
    coeff_err = {k: np.array([f.get("flow_sem", f["stderr"])[k] for f in fits.values()])
                 for k in keys}
    n_fit = sorted({f"{f['config']['eval']['n_flows']} flows x "
                    f"{f['config']['eval']['n_swimmers']} swimmers" for f in fits.values()})
    if runs:
        counts = sorted(set(Counter(r.signals for r in runs).values()))
        per_set = "-".join(map(str, sorted({counts[0], counts[-1]})))
        swimmers = "/".join(map(str, sorted({r.held_out[1] for r in runs})))
        head = (f"(a) {len(runs)} runs ({shown(cfg.ablation)}, all signals: the protocol's), "
                f"{per_set} seed(s) per set; smart/STO paired on the same {held['n_flows']} "
                f"held-out flows (seed {held['seed']}) x {swimmers} swimmers, bars: std over "
                "seeds (one seed: its SEM, open marker)")
    else:
        head = f"(a) pending: no held-out comparisons under {shown(cfg.ablation)}/held_out"
    flows, swimmers = record_sizes(rec, "sweep")
    drawn = fig_ablation(
        kus, r, err, coeffs, coeff_err, cfg.out / "ablation.png",
        f"{head}\n(b) shipped smart policies; the minimal model with the coefficients fitted to "
        f"them at each Ku; STO; {flows} flows x {swimmers} swimmers per strategy, bars: std "
        f"over flows; (c) fits on {', '.join(n_fit)}, bars: SEM over flows", runs=runs,
        held_out_seed=held.get("seed"))
    if "table" in drawn:
        atomic_write_text(cfg.out / "ablation_signals.md", drawn["table"])
    drawn["record"] = str(cfg.records / "ablation.json")
    return drawn
