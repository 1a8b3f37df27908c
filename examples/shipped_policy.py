# %% [markdown]
# # A shipped policy against the baselines
#
# swimrl ships trained policies as `pretrained/ku0.1`, `pretrained/ku1`, `pretrained/ku10`,
# `pretrained/ku1e7` (and `pretrained/dns`). This example evaluates `pretrained/ku10`, the
# short-time-optimal strategy (STO) and the naive swimmer (constant `Λ = 0.98`) on the same
# flows, from the same initial conditions, and draws the mean distance `R̂` of each: it
# is `swimrl-compare flow.kubo=10 'compare.strategies=[sto,naive,policy]'
# 'compare.policies=[pretrained/ku10]' compare.shared_flows=true` at a small size, written
# with the library's functions.
#
# `SWIMRL_EXAMPLE_SMALL=1` runs it at a tiny size (short episodes on a coarse grid: the
# numbers then mean little); `SWIMRL_EXAMPLE_OUT=DIR` chooses where the figure goes
# (default `examples/out/`).

# %%
import os
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from hydra import compose, initialize_config_module

from swimrl.config import compare_config
from swimrl.evaluation.compare import compare

SMALL = os.environ.get("SWIMRL_EXAMPLE_SMALL") == "1"
# figures: $SWIMRL_EXAMPLE_OUT, else examples/out/ (run from the repository root or examples/)
OUT = Path(os.environ.get("SWIMRL_EXAMPLE_OUT")
           or ("examples/out" if Path("examples").is_dir() else "out"))
OUT.mkdir(parents=True, exist_ok=True)

# %% [markdown]
# ## The comparison's config
#
# The command's config, composed with Hydra from the same overrides as its command line.
# With `compare.shared_flows=true` all the strategies run in one environment: each drives
# its own block of `eval.n_swimmers` swimmers per flow, started at the same positions and
# orientations in the same flows, so the ratios between strategies are paired flow by flow.
# The evaluation `seed` fixes the flows and the initial conditions. The full size is the
# paper's episode (`T = 200 τ_K` on the 400² grid) on 4 flows × 50 swimmers, about a
# minute on one CPU thread; the paper's protocol is 100 × 1000.

# %%
if SMALL:
    sizes = ["flow.n_grid=64", "flow.spacing=0.1", "episode.duration=2.0", "kernel=eager",
             "eval.n_flows=2", "eval.n_swimmers=8", "eval.flows_per_batch=2",
             "eval.progress=false"]
else:
    sizes = ["eval.n_flows=4", "eval.n_swimmers=50", "eval.flows_per_batch=4"]
overrides = ["flow.kubo=10", "compare.strategies=[sto,naive,policy]",
             "compare.policies=[pretrained/ku10]", "compare.shared_flows=true",
             "seed=1000000", "threads=1", *sizes]
with initialize_config_module("swimrl.conf", version_base="1.3"):
    cfg = compose(config_name="compare", overrides=overrides)

# %% [markdown]
# `compare_config` checks every value and returns the typed comparison: an `RunSpec`
# (flow, swimmer and episode parameters, runtime, sizes, seed) and the labelled variants
# (`naive` expanded over its shape factors, `policy` over the policy specs).

# %%
comparison = compare_config(cfg)
print(comparison.setup.flow)
print(comparison.setup.sizes)
print([variant.label for variant in comparison.variants])

# %% [markdown]
# ## The evaluation
#
# `compare` loads the policies, runs the strategies (`evaluate_shared`, the one evaluation
# loop) and returns the comparison record that `swimrl-compare` writes as
# `comparison.json`: one row per strategy, with `R̂` per flow, its mean ± SEM, and the
# ratio to the first row, paired over flows.

# %%
record = compare(comparison)
rows = record["rows"]
for row in rows:
    print(f"{row['label']:>24}: R_hat = {row['R_hat_mean']:.3f} +- {row['R_hat_sem']:.3f}, "
          f"{row['ratio_to_first']:.3f} +- {row['ratio_sem']:.3f} x {rows[0]['label']}")

# %% [markdown]
# ## The bar plot
#
# `R̂` is the mean distance from the start after `T`, in units of `v_s T` (what a swimmer
# swimming in a straight line in still fluid would cover). Bars: mean over flows ± SEM;
# dots: the flows. The colours of the paper's figures: smart orange, naive black, STO green.

# %%
COLOURS = {"sto": "tab:green", "naive": "0.2", "policy": "tab:orange"}
labels = [row["label"] for row in rows]
fig, ax = plt.subplots(figsize=(6, 4))
x = np.arange(len(rows))
ax.bar(x, [row["R_hat_mean"] for row in rows], yerr=[row["R_hat_sem"] for row in rows],
       color=[COLOURS[v.strategy.name] for v in comparison.variants], alpha=0.7, capsize=4)
for i, row in enumerate(rows):
    per_flow = np.asarray(row["per_flow"])
    ax.plot(np.full(per_flow.shape, x[i]) + np.linspace(-0.15, 0.15, per_flow.size),
            per_flow, "k.", ms=5)
ax.set_xticks(x, labels)
ax.set_ylabel("$\\hat R$ (units $v_s T$)")
ax.set_title(f"Ku = 10, {record['n_flows']} flows x {record['n_swimmers']} swimmers")
fig.tight_layout()
fig.savefig(OUT / "shipped_policy.png", dpi=120)
print("wrote", OUT / "shipped_policy.png")
