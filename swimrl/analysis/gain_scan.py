r"""Sharpness diagnostic of a trained policy: ``R_hat`` of ``Lambda_max tanh(g mu(s))`` against g.

A PPO policy is trained as a stochastic policy ``u ~ N(mu(s), sigma^2)``, ``Lambda =
Lambda_max tanh(u)``, and evaluated at ``sigma -> 0``: ``Lambda = Lambda_max tanh(mu(s))``
(gain ``g = 1``). Multiplying the pre-``tanh`` mean by ``g > 1`` keeps the policy's decision
boundaries (the sign of ``mu``) and makes it closer to bang-bang; ``g -> 0`` makes it
spherical (``Lambda -> 0``). If ``R_hat`` rises with ``g`` the learned mean is *softer* than
the best policy with the same decision boundaries, i.e. training has not converged in the
magnitude of ``mu``. This is a diagnostic, never the reported performance of a policy: the
gain is chosen on the evaluation flows.

    swimrl-gain-scan policy=pretrained/ku10 flow.kubo=10 'gains=[1,2,3,5,10]'

All gains are evaluated on the same flows and initial conditions (same ``seed``). Prints a
Markdown table (``R_hat`` +- SEM, ratio to ``g = 1``).
"""

from __future__ import annotations

import copy
from dataclasses import dataclass

import torch

from swimrl.errors import require
from swimrl.evaluation.rollout import evaluate
from swimrl.runs.policy_files import load_policy
from swimrl.runs.records import markdown_table
from swimrl.runs.spec import RunSpec


@dataclass(frozen=True)
class GainScanConfig:
    """The policy ``policy`` evaluated on ``setup`` with its mean scaled by each of ``gains``;
    ``overwrite``: replace an earlier scan's record."""

    setup: RunSpec
    policy: str
    gains: tuple[float, ...]
    overwrite: bool

    def __post_init__(self) -> None:
        require(bool(self.gains) and all(g >= 0 for g in self.gains), "gains", list(self.gains),
                "a non-empty list of numbers >= 0")


class _Gain(torch.nn.Module):
    """``g mu(s)``: the pre-``tanh`` mean network scaled by a constant gain."""

    def __init__(self, mean: torch.nn.Module, gain: float):
        super().__init__()
        self.mean, self.gain = mean, float(gain)

    def forward(self, observation: torch.Tensor) -> torch.Tensor:
        return self.gain * self.mean(observation)


def with_gain(actor, gain: float):
    """Copy of a deterministic actor (``MeanPolicy`` inside) with its mean scaled by ``gain``."""
    out = copy.deepcopy(actor)
    policy = out.module
    if not hasattr(policy, "mean"):
        raise TypeError(f"expected a deterministic MeanPolicy actor, got {type(policy).__name__}")
    policy.mean = _Gain(policy.mean, gain)
    return out


def gain_scan(cfg: GainScanConfig) -> list[dict]:
    """``[{gain, R_hat_mean, R_hat_sem, per_flow}]`` for ``cfg.gains`` on common flows."""
    actor = load_policy(cfg.policy, cfg.setup.params)
    rows = []
    for g in cfg.gains:
        m = evaluate(cfg.setup, with_gain(actor, g), "policy")
        rows.append({"gain": g, **{k: m[k] for k in ("R_hat_mean", "R_hat_sem", "per_flow")}})
    return rows


def markdown(rows: list[dict]) -> str:
    """The scan as a Markdown table with ratios to the first row's mean."""
    ref = rows[0]["R_hat_mean"]
    cells = [[f"{r['gain']:g}", f"{r['R_hat_mean']:.4f} +- {r['R_hat_sem']:.4f}",
              f"{r['R_hat_mean'] / ref:.3f}"] for r in rows]
    return markdown_table(["gain g", "R_hat (mean +- SEM)", f"ratio to g = {rows[0]['gain']:g}"],
                          cells)
