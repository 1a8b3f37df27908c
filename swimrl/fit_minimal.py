r"""``swimrl-fit-minimal``: fit the paper's minimal model (``eq:fit``) to a strategy.

The strategy (usually a trained policy, ``strategy=policy policy=...``) is run on fresh
flows; every ``fit.sample_every`` decisions the five signals ``s`` and the action ``Lambda``
of every swimmer are recorded. SciPy's ``curve_fit`` then solves the least-squares problem

``min_c sum_samples [Lambda - Lambda_max tanh(-c1 n_theta sgn S_np
- c2 H(n_r) omega tau_K sgn S_np + c3 n_r - c4 tanh(S_nn tau_K))]^2``

(paper Sec. "From learned smart strategies to a minimal analytical model"). The run directory
gets ``fit.json`` with ``c1..c4``, their standard errors, the coefficient of determination
``R^2`` and the command that evaluates the fitted model:

    swimrl-fit-minimal strategy=policy policy=pretrained/ku10 flow.kubo=10
"""

from __future__ import annotations

import json
import logging

import hydra
import numpy as np
import torch
from omegaconf import DictConfig, OmegaConf
from scipy.optimize import curve_fit

from swimrl.builders import build_env, setup_runtime
from swimrl.evaluate import chunk_seed, load_actor, validate_eval_cfg
from swimrl.paths import CONF_DIR, run_dir
from swimrl.strategies import minimal_model

log = logging.getLogger(__name__)


@torch.no_grad()
def sample_strategy(env, actor, sample_every: int) -> tuple[np.ndarray, np.ndarray]:
    """Signals ``(K, 5)`` and actions ``(K,)`` seen along one episode of every swimmer."""
    td = env.reset()
    sig, act = [], []
    for i in range(env.params.n_decisions):
        td = actor(td)
        if i % sample_every == 0:
            sig.append(td.get("signals").reshape(-1, 5).double().cpu())
            act.append(td.get("action").reshape(-1).double().cpu())
        td = env.step(td).get("next")
    return torch.cat(sig).numpy(), torch.cat(act).numpy()


def fit_minimal(signals: np.ndarray, actions: np.ndarray, lam_max: float, p0=(1.0, 0, 0, 0)):
    """Least-squares ``c1..c4`` of ``eq:fit``; returns (coefficients, standard errors, R^2)."""

    def model(x, c1, c2, c3, c4):
        s = torch.from_numpy(x.T)
        return minimal_model(s, (c1, c2, c3, c4), lam_max).numpy()

    coeffs, cov = curve_fit(model, signals.T, actions, p0=list(p0), maxfev=20000)
    resid = actions - model(signals.T, *coeffs)
    r2 = 1.0 - resid.var() / actions.var() if actions.var() > 0 else float("nan")
    return coeffs, np.sqrt(np.diag(cov)), float(r2)


def run_fit(cfg: DictConfig) -> dict:
    """Sample the configured strategy and fit the minimal model (validation first)."""
    params = validate_eval_cfg(cfg)
    every = int(cfg.fit.sample_every)
    if every < 1:
        raise ValueError(f"fit.sample_every={every} is invalid: allowed integer >= 1")
    device, dtype = setup_runtime(cfg)
    actor = load_actor(cfg, params)
    env = build_env(
        cfg,
        int(cfg.eval.n_flows),
        int(cfg.eval.n_swimmers),
        chunk_seed(int(cfg.seed), 0),
        device,
        dtype,
    )
    signals, actions = sample_strategy(env, actor.to(device), every)
    coeffs, err, r2 = fit_minimal(signals, actions, params.shape_factor_max)
    names = ("c1", "c2", "c3", "c4")
    c = {k: float(v) for k, v in zip(names, coeffs, strict=True)}
    flow = cfg.flow
    knob = f"flow.kubo={flow.kubo:g}" if flow.name == "stochastic" else f"flow={flow.name}"
    return {
        "coefficients": c,
        "stderr": {k: float(v) for k, v in zip(names, err, strict=True)},
        "r2": r2,
        "n_samples": int(actions.size),
        "evaluate_with": "swimrl-eval strategy=minimal "
        + " ".join(f"strategy.{k}={v:.4g}" for k, v in c.items())
        + f" {knob}",
        "config": OmegaConf.to_container(cfg, resolve=True),
    }


@hydra.main(config_path=str(CONF_DIR), config_name="fit_minimal", version_base="1.3")
def main(cfg: DictConfig) -> dict:
    out = run_dir() / "fit.json"
    if out.exists() and not cfg.overwrite:
        raise FileExistsError(f"{out} exists; pass overwrite=true to replace it")
    record = run_fit(cfg)
    out.write_text(json.dumps(record, indent=2))
    c, e = record["coefficients"], record["stderr"]
    print(
        "minimal model fit: "
        + ", ".join(f"{k} = {c[k]:.4f} +- {e[k]:.4f}" for k in c)
        + f"; R^2 = {record['r2']:.3f} over {record['n_samples']} samples\n"
        + record["evaluate_with"]
    )
    return record


if __name__ == "__main__":
    main()
