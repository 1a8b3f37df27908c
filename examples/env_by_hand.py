# %% [markdown]
# # The environment by hand
#
# A `SwimmerEnv` is a batch of swimmers (`n_flows x n_swimmers`) in batched realisations of a
# flow: swimmer `(f, s)` moves in flow `f`. One environment step is one decision interval
# `T_u`: the action is the shape factor `Λ ∈ [−Λ_max, Λ_max]`, held while the equations of
# motion are integrated, and the reward is the gain in distance from the start point.
#
# This example builds the environment on a small stochastic flow, steps it with a constant
# `Λ`, reads the signals a strategy sees, and plots a few trajectories.
#
# `SWIMRL_EXAMPLE_SMALL=1` runs it at a tiny size, `SWIMRL_EXAMPLE_OUT=DIR` chooses where the
# figure goes (default `examples/out/`).

# %%
import os
from pathlib import Path

import matplotlib.pyplot as plt
import torch

from swimrl.env import EnvParams, build_env
from swimrl.flows.stochastic import StochasticSpec
from swimrl.physics.body2d import SIGNAL_NAMES
from swimrl.runtime import Runtime

SMALL = os.environ.get("SWIMRL_EXAMPLE_SMALL") == "1"
# figures: $SWIMRL_EXAMPLE_OUT, else examples/out/ (run from the repository root or examples/)
OUT = Path(os.environ.get("SWIMRL_EXAMPLE_OUT")
           or ("examples/out" if Path("examples").is_dir() else "out"))
OUT.mkdir(parents=True, exist_ok=True)

# %% [markdown]
# ## The flow, the swimmer, the runtime
#
# `StochasticSpec` is the paper's stochastic flow at a Kubo number `Ku` (units: the flow's
# correlation length `ℓ_f = 1` and `u_rms = 1`, so `τ_K = 0.5`); the default grid is
# 400² nodes spaced 0.025 `ℓ_f` apart. `EnvParams` holds the swimmer and episode
# parameters in units of `τ_K` and `u_rms`: swimming speed `v_s = 0.707`, episodes of
# `T = 200 τ_K`, decisions every `T_u = 0.1 τ_K`, Heun steps of `δt = 0.01 τ_K`.
# Here the grid and the episode are shortened so that the example runs in seconds.

# %%
flow = StochasticSpec(kubo=10.0, n_grid=64, spacing=0.1)       # a 6.4 ℓ_f periodic box
params = EnvParams(duration=2.0 if SMALL else 20.0)             # T / τ_K
runtime = Runtime.from_names("cpu", "float32", threads=1, kernel="eager" if SMALL else "auto")
runtime.apply()
env = build_env(flow, params, runtime, n_flows=2, n_swimmers=16, seed=0)
print(env.batch_size, "swimmers;", params.n_decisions, "decisions of", params.n_substeps,
      "Heun steps each")
space = env.action_spec_unbatched.space
print(f"action: Λ in [{float(space.low):+.2f}, {float(space.high):+.2f}]")

# %% [markdown]
# ## Reset, then step with a constant shape factor
#
# `reset()` draws new flow realisations and puts the swimmers at random positions and
# orientations. Each step takes the `action` (`Λ` for every swimmer, shape `(F, S, 1)`) and
# returns the next observation under `"next"`. `env.displacement()` is the unwrapped
# `x − x_0` (the box is periodic), which we record to draw the trajectories.

# %%
shape_factor = 0.5
td = env.reset()
path = [env.displacement().clone()]
for _ in range(params.n_decisions):
    td["action"] = torch.full(env.action_spec.shape, shape_factor)
    td = env.step(td)["next"]
    path.append(env.displacement().clone())
path = torch.stack(path)                                # (N + 1, F, S, 2)
print("done after", params.n_decisions, "decisions:", bool(td["done"].all()))

# %% [markdown]
# ## The signals
#
# `td["signals"]` holds the five body-frame signals of every swimmer, in the order of
# `SIGNAL_NAMES`: the direction away from the start (`n_r`, `n_θ`), the strain along and
# across the swimming direction (`S_nn`, `S_np`) and the vorticity `ω`. `observation` is
# the subset the policy sees (`signals.names`; all five by default), `distance` is
# `|x − x_0|`. The return of an episode telescopes to the final distance.

# %%
signals = td["signals"]
for name, column in zip(SIGNAL_NAMES, signals.unbind(-1), strict=True):
    print(f"{name:>7}: mean {column.mean():+.3f}, std {column.std():.3f}")
distance = td["distance"].squeeze(-1)
print(f"mean distance after T: {distance.mean():.3f} ℓ_f "
      f"(swimming straight: v_s T = {env.reference_distance:.3f})")

# %% [markdown]
# ## A few trajectories

# %%
times = torch.arange(path.shape[0]) * params.update_interval
fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(9, 4))
for s in range(6):
    ax0.plot(path[:, 0, s, 0], path[:, 0, s, 1], lw=1)
    ax0.plot(path[-1, 0, s, 0], path[-1, 0, s, 1], "k.", ms=4)
ax0.plot(0, 0, "k+", ms=10)
ax0.set(xlabel="$x - x_0$ ($\\ell_f$)", ylabel="$y - y_0$ ($\\ell_f$)", aspect="equal",
        title=f"flow 0, $\\Lambda = {shape_factor}$")
r = path.norm(dim=-1).flatten(1)                         # (N + 1, F S)
ax1.plot(times, r, color="0.8", lw=0.5)
ax1.plot(times, r.mean(dim=1), "k", lw=2, label="mean")
ax1.set(xlabel="$t / \\tau_K$", ylabel="$|x - x_0|$ ($\\ell_f$)", title="distance")
ax1.legend()
fig.tight_layout()
fig.savefig(OUT / "env_by_hand.png", dpi=120)
print("wrote", OUT / "env_by_hand.png")
