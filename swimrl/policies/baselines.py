r"""Baseline strategies with the interface of a learned actor.

Each is a :class:`tensordict.nn.TensorDictModule` reading ``signals`` (all five, in
:data:`swimrl.physics.signals.SIGNAL_NAMES` order, ``S`` and ``omega`` in units of ``1/tau_K``) and
writing ``action`` (the shape factor ``Lambda``, shape ``(..., 1)``) within
``[-Lambda_max, Lambda_max]`` (``Lambda_max`` from the environment's action spec):

* naive: ``Lambda = const`` (paper: ``0.98``);
* STO (``eq:sto``): ``Lambda = -Lambda_max sign(n_theta) sign(S_np)``;
* minimal model (``eq:fit``):
  ``Lambda = Lambda_max tanh[-c1 n_theta sign(S_np) - c2 H(n_r) omega tau_K sign(S_np)
  + c3 n_r - c4 tanh(S_nn tau_K)]``, ``H`` the Heaviside step (``H(0) = 0``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import torch
from tensordict.nn import TensorDictModule
from torch import nn
from torchrl.data import Bounded

from swimrl.errors import as_float, one_of, require
from swimrl.physics.signals import SIGNAL_NAMES
from swimrl.policies.networks import action_bounds

N_R, N_THETA, S_NN, S_NP, OMEGA = range(len(SIGNAL_NAMES))  # positions in SIGNAL_NAMES
STRATEGIES = ("naive", "sto", "minimal", "policy")


class NaiveShape(nn.Module):
    """Constant shape factor ``Lambda = shape_factor``."""

    def __init__(self, shape_factor: float):
        super().__init__()
        self.shape_factor = float(shape_factor)

    def forward(self, signals: torch.Tensor) -> torch.Tensor:
        return torch.full_like(signals[..., :1], self.shape_factor)


class ShortTimeOptimal(nn.Module):
    """STO (``eq:sto``): ``Lambda = -Lambda_max sign(n_theta) sign(S_np)``."""

    def __init__(self, shape_factor_max: float):
        super().__init__()
        self.shape_factor_max = float(shape_factor_max)

    def forward(self, signals: torch.Tensor) -> torch.Tensor:
        s = torch.sign(signals[..., N_THETA]) * torch.sign(signals[..., S_NP])
        return (-self.shape_factor_max * s).unsqueeze(-1)


def minimal_model(signals: torch.Tensor, coeffs: Sequence[float] | torch.Tensor, lam_max: float):
    """``eq:fit`` evaluated on ``signals`` ``(..., 5)``; returns ``Lambda`` ``(...)``."""
    c1, c2, c3, c4 = (coeffs[i] for i in range(4))
    n_r, n_th = signals[..., N_R], signals[..., N_THETA]
    s_nn, s_np, om = signals[..., S_NN], signals[..., S_NP], signals[..., OMEGA]
    sgn = torch.sign(s_np)
    heav = (n_r > 0).to(signals.dtype)
    arg = -c1 * n_th * sgn - c2 * heav * om * sgn + c3 * n_r - c4 * torch.tanh(s_nn)
    return lam_max * torch.tanh(arg)


class MinimalModel(nn.Module):
    """The paper's four-term minimal analytical model ``eq:fit`` with coefficients c1..c4."""

    def __init__(self, coeffs: Sequence[float], shape_factor_max: float):
        super().__init__()
        if len(coeffs) != 4:
            raise ValueError(f"minimal model needs 4 coefficients c1..c4, got {list(coeffs)}")
        self.register_buffer("coeffs", torch.tensor([float(c) for c in coeffs]))
        self.shape_factor_max = float(shape_factor_max)

    def forward(self, signals: torch.Tensor) -> torch.Tensor:
        c = self.coeffs.to(signals.dtype)
        return minimal_model(signals, c, self.shape_factor_max).unsqueeze(-1)


def as_actor(module: nn.Module) -> TensorDictModule:
    """Wrap a ``signals -> action`` module as a TensorDict actor."""
    return TensorDictModule(module, in_keys=["signals"], out_keys=["action"])


@dataclass(frozen=True)
class StrategySpec:
    """``strategy=NAME``: ``naive`` (with ``shape_factor``), ``sto``, ``minimal`` (with
    ``coeffs`` c1..c4) or ``policy`` (a trained policy, loaded by :mod:`.files`)."""

    name: str
    shape_factor: float | None = None
    coeffs: tuple[float, float, float, float] | None = None

    def __post_init__(self) -> None:
        one_of("strategy.name", self.name, STRATEGIES)
        if self.name == "naive":
            as_float("strategy.shape_factor", self.shape_factor, lambda v: abs(v) < 1, "(-1, 1)")
        if self.name == "minimal":
            require(self.coeffs is not None and len(self.coeffs) == 4, "strategy.c1..c4",
                    self.coeffs, "four numbers")

    def check_bound(self, shape_factor_max: float) -> None:
        """A naive shape factor must lie within ``[-Lambda_max, Lambda_max]``."""
        if self.name == "naive":
            require(
                abs(self.shape_factor) <= shape_factor_max,
                "strategy.shape_factor",
                self.shape_factor,
                f"[-{shape_factor_max}, {shape_factor_max}] (swimmer.shape_factor_max)",
            )


def build_strategy(spec: StrategySpec, action_spec: Bounded) -> TensorDictModule:
    """Baseline actor for ``spec``; ``Lambda_max`` is the upper bound of the environment's
    (unbatched) action spec."""
    lam_max = action_bounds(action_spec)[1]
    if spec.name == "naive":
        return as_actor(NaiveShape(spec.shape_factor))
    if spec.name == "sto":
        return as_actor(ShortTimeOptimal(lam_max))
    if spec.name == "minimal":
        return as_actor(MinimalModel(spec.coeffs, lam_max))
    raise ValueError(f"strategy {spec.name!r} is not a baseline (load a policy file instead)")
