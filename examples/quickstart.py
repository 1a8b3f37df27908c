# %% [markdown]
# # Quickstart: a shipped policy in five lines
#
# swimrl ships the policies it trained (`pretrained/ku0.1`, `ku1`, `ku10`, `ku1e7`, `dns`).
# The environment is a TorchRL `EnvBase`, so TorchRL's own `rollout` runs a whole episode of
# a shipped policy: here `pretrained/ku10` in two new realisations of the paper's stochastic
# flow at Ku = 10, 100 swimmers each, over the paper's episode `T = 200 τ_K` (2000
# decisions), about half a minute on one CPU thread. The first run also builds the fused CPU
# kernel (~30 s, once; it says so in one line).

# %%
from swimrl import EnvParams, Runtime, StochasticSpec, build_env, load_policy

params = EnvParams()  # the paper's swimmer and episode: v_s = 0.707, T = 200 τ_K, T_u = 0.1 τ_K
env = build_env(StochasticSpec(kubo=10.0), params, Runtime.from_names("cpu", "float32", 1),
                n_flows=2, n_swimmers=100, seed=0)
td = env.rollout(params.n_decisions, load_policy("pretrained/ku10", params))
print(f"R_hat = {env.score(td[..., -1]['next']).mean():.3f}")

# %% [markdown]
# `td` holds the whole episode, shape `(n_flows, n_swimmers, n_decisions)`: the
# observations, the actions (`Λ`), the rewards and, under `"next"`, the state after each
# decision. `env.score` is the paper's performance index `R̂ = |x(T) − x_0| / (v_s T)`
# (eq. 6) of every swimmer. The short-time-optimal baseline and the naive swimmer run the
# same way; `build_strategy` makes them from the environment's action spec:

# %%
from swimrl import StrategySpec, build_strategy

for name, spec in [("sto", StrategySpec("sto")), ("naive", StrategySpec("naive", 0.98))]:
    td_base = env.rollout(params.n_decisions, build_strategy(spec, env.action_spec_unbatched))
    print(f"{name:>5}: R_hat = {env.score(td_base[..., -1]['next']).mean():.3f}")

# %% [markdown]
# Each rollout resets the environment, so each strategy swims in new flow realisations
# here; `swimrl-compare` (and [the next example](shipped_policy.md)) puts them in the same
# flows from the same starts, for paired ratios. The distances of the policy's swimmers over
# time:

# %%
import os
from pathlib import Path

import matplotlib.pyplot as plt
import torch

OUT = Path(os.environ.get("SWIMRL_EXAMPLE_OUT")
           or ("examples/out" if Path("examples").is_dir() else "out"))
OUT.mkdir(parents=True, exist_ok=True)
distance = td["next", "distance"].squeeze(-1).flatten(0, 1)   # (swimmers, decisions), ℓ_f
t = torch.arange(1, distance.shape[-1] + 1) * params.update_interval   # t / τ_K
fig, ax = plt.subplots(figsize=(6, 4))
ax.plot(t, distance[:20].T, color="tab:orange", lw=0.5, alpha=0.6)
ax.plot(t, distance.mean(0), color="k", lw=2, label="mean over the swimmers")
ax.plot(t, env.swim_speed * env.tau_k * t, "k--", lw=1, label="$v_s t$ (in still fluid)")
ax.set(xlabel="$t / \\tau_K$", ylabel="$|x - x_0|$ ($\\ell_f$)",
       title="pretrained/ku10 at Ku = 10")
ax.legend()
fig.tight_layout()
fig.savefig(OUT / "quickstart.png", dpi=120)
print("wrote", OUT / "quickstart.png")
