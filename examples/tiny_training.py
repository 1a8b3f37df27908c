# %% [markdown]
# # A tiny training and its curve
#
# `swimrl-train` trains a shape-control policy with stock TorchRL PPO, evaluates it on
# held-out flows and writes a run directory (`policy.pt`, `metrics.json`, `curves.csv`,
# TensorBoard logs in `tb/`). This example runs the same library function on a config
# composed with Hydra, as the command does, and draws the training curve. It trains for
# 6.4e5 frames, a few minutes on one CPU thread (the README's main job: 1.5e7 frames);
# `SWIMRL_EXAMPLE_SMALL=1` runs it in seconds, at a size where the numbers mean nothing.
#
# `SWIMRL_EXAMPLE_OUT=DIR` chooses where the run directory and the figure go (default
# `examples/out/`).

# %%
import json
import os
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from hydra import compose, initialize_config_module

from swimrl.config import train_config
from swimrl.rl.run import train
from swimrl.runs.curves import read_curves

SMALL = os.environ.get("SWIMRL_EXAMPLE_SMALL") == "1"
# figures: $SWIMRL_EXAMPLE_OUT, else examples/out/ (run from the repository root or examples/)
OUT = Path(os.environ.get("SWIMRL_EXAMPLE_OUT")
           or ("examples/out" if Path("examples").is_dir() else "out"))
OUT.mkdir(parents=True, exist_ok=True)

# %% [markdown]
# ## The config
#
# The overrides are those of the command line:
# `swimrl-train flow.kubo=10 episode.duration=20 train.n_flows=16 ...`. Episodes are
# shortened to `T = 20 τ_K` (200 decisions); each PPO update collects
# `train.rollout_length` decisions of each of the `train.n_flows × train.n_swimmers` swimmers. Every
# `train.eval_every` updates the deterministic policy is evaluated on held-out flows (the
# `eval/R_hat` curve); at the end `train.compare_baselines=true` evaluates STO and naive on
# the final evaluation's flows. `overwrite=true` lets the example run again in the same
# directory (a finished run is otherwise never overwritten).

# %%
TINY = ["flow.n_grid=64", "flow.spacing=0.1", "episode.duration=2.0", "kernel=eager",
        "train.n_flows=2", "train.n_swimmers=4", "train.rollout_length=10",
        "train.total_frames=320", "train.minibatch_size=40", "train.eval_every=2",
        "train.eval_flows=1", "train.eval_swimmers=4", "eval.n_flows=2", "eval.n_swimmers=4"]
FULL = ["episode.duration=20.0", "train.n_flows=16", "train.n_swimmers=8",
        "train.rollout_length=50", "train.total_frames=640000", "train.minibatch_size=640",
        "train.eval_every=10", "train.eval_flows=2", "train.eval_swimmers=32",
        "eval.n_flows=4", "eval.n_swimmers=50"]
sizes = TINY if SMALL else FULL
overrides = ["flow.kubo=10", "seed=0", "threads=1", "train.compile=false",
             "train.progress=false", "train.compare_baselines=true", "overwrite=true", *sizes]
with initialize_config_module("swimrl.conf", version_base="1.3"):
    cfg = compose(config_name="train", overrides=overrides)

# %% [markdown]
# ## Training
#
# `train_config` turns the composed config into the library's typed objects, checking
# every value first (a bad one stops here with one line naming the key); `train` trains in
# the run directory and returns the final evaluation (`metrics.json`).

# %%
run_dir = OUT / "tiny_training_run"
metrics = train(train_config(cfg), run_dir)
print(f"final evaluation: R_hat = {metrics['R_hat_mean']:.3f} +- {metrics['R_hat_sem']:.3f} "
      f"({metrics['n_flows']} flows x {metrics['n_swimmers']} swimmers)")
comparison = json.loads((run_dir / "comparison.json").read_text())["rows"]
final = {row["label"].split("(")[0]: row["R_hat_mean"] for row in comparison}
print("on the final evaluation's flows:", {k: round(v, 3) for k, v in final.items()})

# %% [markdown]
# ## The curve
#
# `curves.csv` holds the TensorBoard scalars of the run, one row per logged step (frames):
# the held-out evaluations `eval/R_hat` (± `eval/R_hat_sem`), the training episodes'
# `train/R_hat`, the policy's spread `policy/std` and the PPO diagnostics.
# `read_curves` reads its columns (NaN where a step did not log a tag). The periodic
# evaluations use their own few held-out flows; the final evaluation, with STO and naive on
# the same flows, is drawn at the last step.

# %%
curves = read_curves(run_dir / "curves.csv")
frames = curves["frames"]
fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(10, 4))
ev = np.isfinite(curves["eval/R_hat"])                     # rows with an evaluation
ax0.errorbar(frames[ev], curves["eval/R_hat"][ev], curves["eval/R_hat_sem"][ev], fmt="o-",
             capsize=3, label="held-out evaluation")
tr = np.isfinite(curves["train/R_hat"])
ax0.plot(frames[tr], curves["train/R_hat"][tr], ".", color="0.6", label="training episodes")
for (label, value), style in zip(final.items(), ("s", "^", "*"), strict=True):
    ax0.plot(frames[-1], value, style, ms=8, label=f"{label}, final evaluation")
ax0.set_ylim(bottom=0)
ax0.set(xlabel="frames", ylabel="$\\hat R$ (units $v_s T$)", title="Ku = 10")
ax0.legend(fontsize=8)
st = np.isfinite(curves["policy/std"])
ax1.plot(frames[st], curves["policy/std"][st], ".-")
ax1.set(xlabel="frames", ylabel="$\\sigma$", title="policy/std (pre-tanh Gaussian)")
fig.tight_layout()
fig.savefig(OUT / "tiny_training.png", dpi=120)
print("wrote", OUT / "tiny_training.png")
