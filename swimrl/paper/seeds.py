r"""Fig. seedSpread: the studies that first used one policy per Ku, with every training seed of
the protocol (``docs/results/three_seeds``), drawn from their records, no evaluation:

* (a)-(d) Fig. robustness at Ku = 10: ``<R_smart> / <R_STO>`` (paired, ± SEM over flows)
  against ``D_r``, ``T``, ``T_u`` and ``v_s``, one line per seed
  (``robustness/ku10_seed<S>/robustness{-noise,}.json``);
* (e) Fig. ablation (b): smart / STO and minimal / STO per Ku and seed, the minimal model
  fitted to that seed's policy (``ablation_b/ku<KU>_seed<S>/ablation.json``);
* (f), (g) the minimal model's coefficients ``c1, c2`` and ``c3, c4`` against Ku, one line
  per seed, ± SEM over flows of the per-flow fits (``minimal_fits/ku<KU>_seed<S>/fit.json``);
* (h) the transfer to DNS turbulence: smart / STO of each Ku's policy per seed, pooled over the
  held-out DNS realisations (``dns_transfer/seed<s>/comparison.json``: the flows of every
  realisation, paired with STO), drawn once such records exist.

A panel whose records are missing says so in the figure; the figure is pending when all are.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np

from swimrl.analysis.plots import pyplot
from swimrl.evaluation.statistics import paired_ratio
from swimrl.flows.labels import ku_name, parse_ku_name

from .style import COLORS, save

#: The protocol's training seeds per Ku.
SEEDS = (0, 1, 2)
KUS = (0.1, 1.0, 10.0, 1e7)
#: Panels (a)-(d): (record, key of its ``derived``, axis label).
SWEEPS = (("robustness-noise", "rot_diffusion", r"$D_r\tau_K$"),
          ("robustness", "duration", r"$T/\tau_K$"),
          ("robustness", "update_interval", r"$T_u/\tau_K$"),
          ("robustness", "swim_speed", r"$v_s/u_{\rm rms}$"))
COEFFICIENTS = ("c1", "c2", "c3", "c4")
MARKERS = {0: "o", 1: "s", 2: "^"}
#: Panels (a)-(d), (h): one shade of the smart colour per seed.
SEED_COLORS = {0: "#fdae61", 1: "#e6550d", 2: "#7f2704"}
#: A row of one training seed in a DNS transfer comparison: ``policy(<...>/ku<KU>_seed<S>)``
#: or ``minimal(ku<KU>_seed<S>)`` (groups: kind, Ku name, seed).
SEEDED_ROW = re.compile(r"(policy|minimal)\((?:.*/)?(ku[^/_)]+)_seed(\d+)/?\)")


def _read(path: Path) -> dict | None:
    return json.loads(path.read_text()) if path.is_file() else None


def sweep_ratios(root: Path) -> dict[str, dict[int, dict]]:
    """``{key: {seed: {"x", "ratio", "sem"}}}`` of the robustness records of every seed."""
    out: dict[str, dict[int, dict]] = {}
    for record, key, _ in SWEEPS:
        for seed in SEEDS:
            rec = _read(root / "robustness" / f"ku10_seed{seed}" / f"{record}.json")
            if rec is None:
                continue
            d = rec["derived"][key]
            out.setdefault(key, {})[seed] = {"x": d["x"], "ratio": d["smart/STO"],
                                             "sem": d["smart/STO_sem"]}
    return out


def ablation_ratios(root: Path) -> dict[str, dict[int, dict]]:
    """``{ku name: {seed: {"smart/STO": (value, sem), "minimal/STO": ...}}}``."""
    out: dict[str, dict[int, dict]] = {}
    for ku in KUS:
        name = ku_name(ku)
        for seed in SEEDS:
            rec = _read(root / "ablation_b" / f"{name}_seed{seed}" / "ablation.json")
            if rec is None:
                continue
            r = rec["derived"]["minimal"][name]["ratio"]
            out.setdefault(name, {})[seed] = {k: (r[k]["value"], r[k]["sem"])
                                              for k in ("smart/STO", "minimal/STO")}
    return out


def fit_coefficients(root: Path) -> dict[int, dict[str, dict]]:
    """``{seed: {"ku": [...], "c1": {"value": [...], "sem": [...]}, ...}}`` in Ku order."""
    out: dict[int, dict] = {}
    for seed in SEEDS:
        for ku in KUS:
            fit = _read(root / "minimal_fits" / f"{ku_name(ku)}_seed{seed}" / "fit.json")
            if fit is None:
                continue
            d = out.setdefault(seed, {"ku": [], **{c: {"value": [], "sem": []}
                                                   for c in COEFFICIENTS}})
            d["ku"].append(ku)
            for c in COEFFICIENTS:
                d[c]["value"].append(fit["coefficients"][c])
                d[c]["sem"].append(fit["flow_sem"][c])
    return out


def pooled_rows(root: Path) -> tuple[list[str], dict[str, list[np.ndarray]]]:
    """The realisations (``dns_transfer/seed<s>/``) and every row's per-flow ``R_hat`` in each
    of them, in realisation order; a row absent from some realisation or with another number of
    flows than STO's there is refused (ValueError)."""
    records = sorted((root / "dns_transfer").glob("seed*/comparison.json"))
    names = [p.parent.name for p in records]
    rows: dict[str, list[np.ndarray]] = {}
    for path in records:
        table = {r["label"]: np.asarray(r["per_flow"]) for r in
                 json.loads(path.read_text())["rows"]}
        for label, values in table.items():
            if values.size != table["sto"].size:
                raise ValueError(f"{path}: row {label} has {values.size} flows, "
                                 f"sto {table['sto'].size}")
            rows.setdefault(label, []).append(values)
    for label, per in rows.items():
        if len(per) != len(records):
            raise ValueError(f"row {label} is missing from some of {names}")
    return names, rows


def dns_transfer_ratios(root: Path) -> dict:
    r"""Smart / STO in the DNS per training Ku and seed, pooled over the realisations: the
    per-flow ``R_hat`` of every ``dns_transfer/seed<s>/comparison.json`` (each flow a start
    window of one realisation; :func:`pooled_rows`), paired with STO's on the same flows
    (:func:`~swimrl.evaluation.statistics.paired_ratio`). ``{"realisations": [...],
    "n_flows": n, ku name: {seed: (value, sem)}}``; empty without records."""
    names, rows = pooled_rows(root)
    if not names:
        return {}
    sto = np.concatenate(rows["sto"])
    out: dict = {"realisations": names, "n_flows": int(sto.size)}
    for label, per in rows.items():
        m = SEEDED_ROW.fullmatch(label)
        if m and m.group(1) == "policy" and parse_ku_name(m.group(2)) is not None:
            out.setdefault(m.group(2), {})[int(m.group(3))] = paired_ratio(
                np.concatenate(per), sto)
    return out


def _offset(seed: int, x: np.ndarray) -> np.ndarray:
    """``x`` on a log axis shifted a little per seed so that the error bars do not overlap."""
    return x * 10 ** ((seed - 1) * 0.025)


def _ku_text(kubo: float, prefix: str = "Ku = ") -> str:
    """``Ku = 0.1`` ... ``Ku = 10^7`` as a tick label."""
    e = int(round(np.log10(kubo)))
    return prefix + (f"$10^{{{e}}}$" if e >= 3 else f"{kubo:g}")


def _missing(ax, what: str) -> None:
    ax.text(0.5, 0.5, f"no records:\n{what}", ha="center", va="center", fontsize=8,
            transform=ax.transAxes)
    ax.set_axis_off()


def build_seed_spread(root: Path, path: Path) -> dict:
    """Fig. seedSpread from the records under ``root`` (``docs/results/three_seeds``) into
    ``path``; the numbers drawn, or ``{"pending": ...}`` without any record."""
    root = Path(root)
    sweeps, ablation = sweep_ratios(root), ablation_ratios(root)
    fits, dns = fit_coefficients(root), dns_transfer_ratios(root)
    if not (sweeps or ablation or fits or dns):
        return {"pending": f"no records under {root}"}
    plt = pyplot()
    fig, axes = plt.subplots(2, 4, figsize=(16, 7.2))
    for ax, (_, key, label), tag in zip(axes[0], SWEEPS, "abcd", strict=True):
        if key not in sweeps:
            _missing(ax, f"robustness/ku10_seed*/ ({key})")
            continue
        for seed, d in sweeps[key].items():
            x = np.asarray(d["x"], dtype=float)
            log = bool((x > 0).all())
            ax.errorbar(_offset(seed, x) if log else x, d["ratio"], yerr=d["sem"],
                        color=SEED_COLORS[seed], marker=MARKERS[seed], capsize=2, lw=1,
                        label=f"seed {seed}")
            if log:
                ax.set_xscale("log")
            else:
                ax.set_xscale("symlog", linthresh=float(x[x > 0].min()))
            ax.set_xticks(x, [f"{v:g}" for v in x], rotation=45 if x.size > 4 else 0)
            ax.minorticks_off()
        ax.axhline(1, color=COLORS["STO"], ls="--", lw=1)
        ax.set_xlabel(label)
        ax.set_ylabel(r"$\hat R_{\rm smart}/\hat R_{\rm STO}$ (paired, $\pm$ SEM)")
        ax.set_title(f"({tag}) robustness, Ku = 10", fontsize=9)
        ax.legend(fontsize=7)
    ax = axes[1, 0]
    if ablation:
        names = [ku_name(k) for k in KUS if ku_name(k) in ablation]
        for i, name in enumerate(names):
            for seed, r in ablation[name].items():
                for j, (key, color) in enumerate((("smart/STO", COLORS["smart"]),
                                                  ("minimal/STO", "tab:purple"))):
                    v, e = r[key]
                    ax.errorbar(i + (seed - 1) * 0.12 + (j - 0.5) * 0.04, v, yerr=e,
                                color=color, marker=MARKERS[seed], capsize=2, ls="none",
                                label=f"{key.split('/')[0]}, seed {seed}" if i == 0 else None)
        ax.set_xticks(range(len(names)), [_ku_text(parse_ku_name(n)) for n in names])
        ax.axhline(1, color=COLORS["STO"], ls="--", lw=1)
        ax.set_ylabel(r"$\hat R/\hat R_{\rm STO}$ (paired, $\pm$ SEM)")
        absent = [f"{_ku_text(parse_ku_name(n), 'Ku ')} seed {s}" for n in names
                  for s in SEEDS if s not in ablation[n]]
        ax.set_title("(e) ablation (b): smart and its minimal model"
                     + (f"\n(no record: {', '.join(absent)})" if absent else ""), fontsize=9)
        ax.legend(fontsize=6, ncol=2)
    else:
        _missing(ax, "ablation_b/ku*_seed*/")
    for ax, pair, tag in ((axes[1, 1], ("c1", "c2"), "f"), (axes[1, 2], ("c3", "c4"), "g")):
        if not fits:
            _missing(ax, "minimal_fits/ku*_seed*/")
            continue
        for c, color in zip(pair, ("tab:blue", "tab:red"), strict=True):
            for seed, d in fits.items():
                ax.errorbar(_offset(seed, np.asarray(d["ku"])), d[c]["value"],
                            yerr=d[c]["sem"], color=color, marker=MARKERS[seed], capsize=2,
                            lw=1, label=f"{c}, seed {seed}")
        ax.set_xscale("log")
        ax.set_xticks(KUS, [_ku_text(k, "") for k in KUS])
        ax.minorticks_off()
        ax.axhline(0, color="0.6", lw=0.8)
        ax.set_xlabel("Ku")
        ax.set_ylabel("coefficient ($\\pm$ SEM over flows)")
        ax.set_title(f"({tag}) minimal model {', '.join(pair)} per seed", fontsize=9)
        ax.legend(fontsize=6, ncol=2)
    ax = axes[1, 3]
    names = [ku_name(k) for k in KUS if ku_name(k) in dns]
    if names:
        for i, name in enumerate(names):
            for seed, (v, e) in sorted(dns[name].items()):
                ax.errorbar(i + (seed - 1) * 0.15, v, yerr=e, color=SEED_COLORS[seed],
                            marker=MARKERS[seed], capsize=2, ls="none",
                            label=f"seed {seed}" if i == 0 else None)
        ax.set_xticks(range(len(names)), [_ku_text(parse_ku_name(n)) for n in names])
        ax.set_xlabel("policy trained at")
        ax.axhline(1, color=COLORS["STO"], ls="--", lw=1)
        ax.set_ylabel(r"$\hat R_{\rm smart}/\hat R_{\rm STO}$ in the DNS (paired, $\pm$ SEM)")
        ax.set_title(f"(h) transfer to DNS: {len(dns['realisations'])} realisations, "
                     f"{dns['n_flows']} windows", fontsize=9)
        ax.legend(fontsize=7)
    else:
        _missing(ax, "dns_transfer/seed*/ with the seeds' policies")
    fig.suptitle("The protocol's three training seeds per Ku (markers), on the same flows; "
                 "records: docs/results/three_seeds", fontsize=9)
    fig.tight_layout()
    save(fig, path)
    return {"robustness": sweeps, "ablation": ablation, "fits": fits, "dns": dns}


def build_seed_spread_figure(cfg) -> dict:
    """``swimrl-figures only=seedSpread``: from ``cfg.three_seeds`` into ``cfg.out``."""
    out = build_seed_spread(cfg.three_seeds, cfg.out / "seedSpread.png")
    return {k: v for k, v in out.items() if k == "pending"} or {"drawn": sorted(out)}
