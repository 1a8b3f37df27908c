r"""``swimrl-compare`` and ``swimrl-naive-scan``: several strategies on identical flows.

Every strategy is evaluated with the same ``seed``, hence on the same flow realisations and
from the same initial positions and orientations (common random numbers). Besides each
strategy's ``R_hat`` (mean +- SEM over flows) the table reports the ratio of its mean
``R_hat`` to the first strategy's, with the paired standard error (delta method).
Outputs in the run directory: ``comparison.json``, ``comparison.md`` and,
for a scan of constant shape factors, ``naive_scan.png`` (``R_hat`` against ``Lambda``).

    swimrl-compare flow.kubo=10                      # naive vs STO
    swimrl-compare flow.kubo=10 'compare.strategies=[naive,sto,policy]' \
        'compare.policies=[pretrained/ku10,outputs/train/my_run]'   # + trained policies
    swimrl-naive-scan flow.kubo=10                   # constant Lambda over [-0.98, 0.98]
"""

from __future__ import annotations

import copy
import json
import logging
import math
from pathlib import Path

import hydra
import numpy as np
from omegaconf import DictConfig, OmegaConf, open_dict

from swimrl.evaluate import evaluate, load_actor, summary_line, validate_eval_cfg
from swimrl.paths import CONF_DIR, run_dir

log = logging.getLogger(__name__)


def paired_ratio(a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    """``<a>/<b>`` over paired flows and its delta-method SEM ``std(a - r b) / (sqrt(n) <b>)``."""
    r = float(a.mean() / b.mean())
    sem = float((a - r * b).std(ddof=1) / math.sqrt(a.size) / b.mean()) if a.size > 1 else 0.0
    return r, sem


def strategy_variants(cfg: DictConfig) -> list[tuple[str, DictConfig, str | None]]:
    """(label, strategy config, policy) for ``compare.strategies``; ``naive`` expands over
    ``compare.naive_shape_factors``, ``minimal`` takes ``compare.minimal`` coefficients and
    ``policy`` expands over ``compare.policies`` (run dirs, checkpoints, ``pretrained/NAME``)."""
    out: list[tuple[str, DictConfig, str | None]] = []
    for name in cfg.compare.strategies:
        if name == "naive":
            for lam in cfg.compare.naive_shape_factors:
                out.append(
                    (
                        f"naive({float(lam):+.2f})",
                        OmegaConf.create({"name": "naive", "shape_factor": float(lam)}),
                        None,
                    )
                )
        elif name == "sto":
            out.append(("sto", OmegaConf.create({"name": "sto"}), None))
        elif name == "minimal":
            out.append(
                ("minimal", OmegaConf.create({"name": "minimal", **cfg.compare.minimal}), None)
            )
        elif name == "policy":
            policies = list(cfg.compare.get("policies") or [])
            if not policies:
                raise ValueError("compare.strategies has 'policy' but compare.policies is empty: "
                                 "allowed a list of run dirs, checkpoints or pretrained/NAME")
            for pol in policies:
                out.append((f"policy({pol})", OmegaConf.create({"name": "policy"}), str(pol)))
        else:
            raise ValueError(
                f"compare.strategies has {name!r}: allowed 'naive', 'sto', 'minimal', 'policy'"
            )
    if not out:
        raise ValueError(
            "compare.strategies is empty: allowed a list of 'naive', 'sto', 'minimal', 'policy'"
        )
    return out


def compare(cfg: DictConfig) -> dict:
    """Evaluate all variants (validated first) and return the comparison record."""
    variants = strategy_variants(cfg)
    cfgs = []
    actors = []
    for _, strat, policy in variants:
        c = copy.deepcopy(cfg)
        with open_dict(c):
            c.strategy = strat
            c.policy = policy
        params = validate_eval_cfg(c)
        if policy is None:
            evaluate_check_strategy(c)
            actors.append(None)
        else:  # load (and check the signal set of) every policy before any compute
            actors.append(load_actor(c, params))
        cfgs.append(c)
    results = []
    if cfg.compare.get("shared_flows", False):
        from swimrl.shared_eval import evaluate_shared
        from swimrl.strategies import build_strategy

        shared = [a if a is not None else build_strategy(c.strategy, float(
            c.episode.shape_factor_max)) for a, c in zip(actors, cfgs, strict=True)]
        for (label, strat, _), m in zip(variants, evaluate_shared(cfg, shared), strict=True):
            m.update(label=label, strategy=strat.name)
            print(f"{label}: R_hat = {m['R_hat_mean']:.4f} +- {m['R_hat_sem']:.4f} (shared flows)",
                  flush=True)
            results.append(m)
    else:
        for (label, _, _), c, actor in zip(variants, cfgs, actors, strict=True):
            m = evaluate(c, actor=actor)
            m["label"] = label
            print(summary_line(m), flush=True)
            results.append(m)
    ref = np.asarray(results[0]["per_flow"])
    rows = []
    for m in results:
        ratio, ratio_sem = paired_ratio(np.asarray(m["per_flow"]), ref)
        rows.append(
            {
                "label": m["label"],
                "R_hat_mean": m["R_hat_mean"],
                "R_hat_sem": m["R_hat_sem"],
                "R_hat_std": m["R_hat_std"],
                "ratio_to_first": ratio,
                "ratio_sem": ratio_sem,
                "per_flow": m["per_flow"],
                "swimmer_substeps_per_s": m["swimmer_substeps_per_s"],
                "wall_s": m["wall_s"],
            }
        )
    first = results[0]
    return {
        "shared_flows": bool(cfg.compare.get("shared_flows", False)),
        "rows": rows,
        "n_flows": first["n_flows"],
        "n_swimmers": first["n_swimmers"],
        "seed": first["seed"],
        "flow_stats": first["flow_stats"],
        "config": OmegaConf.to_container(cfg, resolve=True),
    }


def evaluate_check_strategy(cfg: DictConfig) -> None:
    """Strategy-specific checks (shape factor range etc.) before any compute."""
    from swimrl.strategies import build_strategy

    build_strategy(cfg.strategy, float(cfg.episode.shape_factor_max))


def markdown_table(record: dict) -> str:
    """The comparison as a Markdown table."""
    flow = record["config"]["flow"]
    knob = f"Ku = {flow['kubo']:g}" if flow["name"] == "stochastic" else flow["name"]
    first = record["rows"][0]["label"]
    lines = [
        f"{knob}, {record['n_flows']} flows x {record['n_swimmers']} swimmers, seed "
        f"{record['seed']}",
        "",
        f"| strategy | R_hat (mean +- SEM) | std over flows | ratio to {first} (paired) |",
        "|---|---|---|---|",
    ]
    for r in record["rows"]:
        lines.append(
            f"| {r['label']} | {r['R_hat_mean']:.4f} +- {r['R_hat_sem']:.4f} | "
            f"{r['R_hat_std']:.4f} | {r['ratio_to_first']:.3f} +- {r['ratio_sem']:.3f} |"
        )
    return "\n".join(lines) + "\n"


def plot_scan(record: dict, path) -> None:
    """``R_hat`` (mean +- SEM) against the constant shape factor of naive strategies."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = [r for r in record["rows"] if r["label"].startswith("naive(")]
    if len(rows) < 2:
        return
    lam = [float(r["label"][6:-1]) for r in rows]
    fig, ax = plt.subplots(figsize=(5, 3.5))
    ax.errorbar(
        lam,
        [r["R_hat_mean"] for r in rows],
        yerr=[r["R_hat_sem"] for r in rows],
        marker="o",
        capsize=3,
        color="k",
    )
    flow = record["config"]["flow"]
    ax.set_xlabel(r"constant shape factor $\Lambda$")
    ax.set_ylabel(r"$\hat R$")
    ax.set_title(
        f"naive strategies, Ku = {flow.get('kubo', float('nan')):g} "
        f"({record['n_flows']} flows x {record['n_swimmers']})"
    )
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _main(cfg: DictConfig) -> dict:
    out = run_dir()
    target = out / "comparison.json"
    if target.exists() and not cfg.overwrite:
        raise FileExistsError(f"{target} exists; pass overwrite=true to replace it")
    record = compare(cfg)
    write_comparison(record, out)
    plot_scan(record, out / "naive_scan.png")
    log.info("wrote %s", target)
    return record


def write_comparison(record: dict, out: Path) -> None:
    """``comparison.json`` (atomic replace) and ``comparison.md`` in ``out``; prints the table."""
    target = Path(out) / "comparison.json"
    tmp = target.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(record, indent=2))
    tmp.replace(target)
    table = markdown_table(record)
    (Path(out) / "comparison.md").write_text(table)
    print(table, flush=True)


@hydra.main(config_path=str(CONF_DIR), config_name="compare", version_base="1.3")
def main(cfg: DictConfig) -> dict:
    return _main(cfg)


@hydra.main(config_path=str(CONF_DIR), config_name="naive_scan", version_base="1.3")
def main_naive_scan(cfg: DictConfig) -> dict:
    return _main(cfg)


if __name__ == "__main__":
    main()
