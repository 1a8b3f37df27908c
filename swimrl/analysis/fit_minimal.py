r"""Fit of the paper's minimal model (``eq:fit``) to a strategy (``swimrl-fit-minimal``).

The strategy (usually a trained policy, ``strategy=policy policy=...``) is run on fresh
flows; every ``fit.sample_every`` decisions the five signals ``s`` and the action ``Lambda``
of every swimmer are recorded. SciPy's ``curve_fit`` then solves the least-squares problem

``min_c sum_samples [Lambda - Lambda_max tanh(-c1 n_theta sgn S_np
- c2 H(n_r) omega tau_K sgn S_np + c3 n_r - c4 tanh(S_nn tau_K))]^2``

(paper Sec. "From learned smart strategies to a minimal analytical model"). The run directory
gets ``fit.json`` with ``c1..c4``, their least-squares standard errors (too small: samples
along a trajectory are correlated), the fits on each flow alone and their standard error over
flows (``flow_sem``, the uncertainty to quote), the coefficient of determination ``R^2`` and
the command that evaluates the fitted model:

    swimrl-fit-minimal strategy=policy policy=pretrained/ku10 flow.kubo=10
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from scipy.optimize import curve_fit

from swimrl.env import build_env
from swimrl.errors import ConfigError, as_int, keep_number_types
from swimrl.evaluation.rollout import EvalConfig, actor_for, chunk_seed, run_episodes
from swimrl.flows.labels import ku_number
from swimrl.policies.baselines import build_strategy, minimal_model
from swimrl.runs.layout import RunLayout


@dataclass(frozen=True)
class FitConfig:
    """``swimrl-fit-minimal``: the strategy to sample and the decisions between samples."""

    eval: EvalConfig
    sample_every: int

    def __post_init__(self) -> None:
        as_int("fit.sample_every", self.sample_every)
        keep_number_types(self)


def sample_strategy(env, actor, sample_every: int,
                    with_flows: bool = False) -> tuple[np.ndarray, ...]:
    """Signals ``(K, 5)`` and actions ``(K,)`` seen along one episode of every swimmer (and,
    with ``with_flows``, the flow of each sample ``(K,)``)."""
    sig, act = [], []

    def record(i: int, td) -> None:
        if i % sample_every == 0:
            sig.append(td.get("signals").reshape(-1, 5).double().cpu())
            act.append(td.get("action").reshape(-1).double().cpu())

    run_episodes(env, actor, on_decision=record)
    out = (torch.cat(sig).numpy(), torch.cat(act).numpy())
    if with_flows:
        f, s = env.batch_size
        flows = np.tile(np.repeat(np.arange(f), s), len(sig))
        out = (*out, flows)
    return out


def fit_minimal(signals: np.ndarray, actions: np.ndarray, lam_max: float, p0=(1.0, 0, 0, 0)):
    """Least-squares ``c1..c4`` of ``eq:fit``; returns (coefficients, standard errors, R^2)."""

    def model(x, c1, c2, c3, c4):
        s = torch.from_numpy(x.T)
        return minimal_model(s, (c1, c2, c3, c4), lam_max).numpy()

    coeffs, cov = curve_fit(model, signals.T, actions, p0=list(p0), maxfev=20000)
    resid = actions - model(signals.T, *coeffs)
    r2 = 1.0 - resid.var() / actions.var() if actions.var() > 0 else float("nan")
    return coeffs, np.sqrt(np.diag(cov)), float(r2)


def read_coefficients(path: str | Path) -> tuple[str, tuple[float, ...]]:
    """``(label, (c1, c2, c3, c4))`` of a ``fit.json`` written by ``swimrl-fit-minimal``
    (a file, or the run directory holding it); the label is the run directory's name."""
    path = Path(path)
    if path.is_dir():
        path = RunLayout(path).fit
    if not path.is_file():
        raise ConfigError(f"compare.minimal_fits has {str(path)!r}: not a file; allowed the "
                          "fit.json (or its run directory) of swimrl-fit-minimal")
    try:
        coeffs = json.loads(path.read_text())["coefficients"]
        values = tuple(float(coeffs[k]) for k in ("c1", "c2", "c3", "c4"))
        if not all(map(math.isfinite, values)):
            raise ValueError(f"non-finite coefficients {values}")
        return path.parent.name, values
    except (ValueError, KeyError, TypeError) as err:
        raise ConfigError(f"compare.minimal_fits has {str(path)!r}: no coefficients c1..c4 "
                          f"({err}); allowed the fit.json of swimrl-fit-minimal") from None


def run_fit(cfg: FitConfig) -> dict:
    """Sample the configured strategy and fit the minimal model."""
    ev, setup = cfg.eval, cfg.eval.setup
    setup.runtime.apply()
    actor = actor_for(ev.strategy, ev.policy, setup.params)
    sizes = setup.sizes
    env = build_env(setup.flow, setup.params, setup.runtime, sizes.n_flows,
                    sizes.n_swimmers, chunk_seed(setup.seed, 0))
    if not isinstance(actor, torch.nn.Module):
        actor = build_strategy(actor, env.action_spec_unbatched)
    signals, actions, flows = sample_strategy(env, actor.to(setup.runtime.device),
                                              cfg.sample_every, with_flows=True)
    lam_max = env.params.shape_factor_max
    coeffs, err, r2 = fit_minimal(signals, actions, lam_max)
    names = ("c1", "c2", "c3", "c4")
    c = {k: float(v) for k, v in zip(names, coeffs, strict=True)}
    # samples along one trajectory are correlated, so curve_fit's standard errors are too
    # small; the spread of fits on independent flows is the honest uncertainty
    per_flow = np.array([fit_minimal(signals[flows == f], actions[flows == f], lam_max,
                                     p0=coeffs)[0] for f in range(sizes.n_flows)])
    spread = per_flow.std(axis=0, ddof=1) if sizes.n_flows > 1 else np.full(4, np.nan)
    flow = setup.record["flow"]
    knob = (f"flow.kubo={ku_number(flow['kubo'])}" if flow["name"] == "stochastic"
            else f"flow={flow['name']}")
    return {
        "coefficients": c,
        "stderr": {k: float(v) for k, v in zip(names, err, strict=True)},
        "per_flow": {k: per_flow[:, i].tolist() for i, k in enumerate(names)},
        "flow_sem": {k: float(v / np.sqrt(sizes.n_flows)) for k, v in zip(names, spread,
                                                                             strict=True)},
        "r2": r2,
        "n_samples": int(actions.size),
        "evaluate_with": "swimrl-eval strategy=minimal "
        + " ".join(f"strategy.{k}={v:.4g}" for k, v in c.items())
        + f" {knob}",
        "config": setup.record,
    }
