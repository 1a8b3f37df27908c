r"""Actor and critic networks (paper App. "Reinforcement learning algorithm").

* Actor: a Gaussian in the pre-``tanh`` space, ``u ~ N(mu(s), sigma^2)``, with the mean
  ``mu(s)`` from a fully connected ``tanh`` MLP (2 x 64 by default) on the ``observation``
  key and a state-independent trainable ``sigma = exp(log_sigma)``; the action is
  ``Lambda = Lambda_max tanh(u)`` (TorchRL ``TanhNormal`` with ``low = -Lambda_max``,
  ``high = Lambda_max``), so that the probability ratio and the entropy of PPO include the
  Jacobian of the ``tanh`` map. Evaluation is deterministic: ``sigma -> 0``, i.e.
  ``Lambda = Lambda_max tanh(mu(s))`` (:class:`MeanPolicy`, or ``ExplorationType.DETERMINISTIC``).
* Critic: a ``ValueOperator`` ``V(s)`` on an MLP of the same shape, writing ``state_value``.

Initialisation as in common PPO implementations: orthogonal weights (gain ``sqrt 2`` in the
hidden layers, ``0.01`` for the actor's mean output so that ``mu ~ 0`` at the start, ``1``
for the value output), zero biases.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import torch
from tensordict.nn import AddStateIndependentNormalScale, TensorDictModule
from torch import nn
from torchrl.data import Bounded
from torchrl.modules import ProbabilisticActor, TanhNormal, ValueOperator

ACTIVATIONS = {"tanh": nn.Tanh, "relu": nn.ReLU, "elu": nn.ELU}


def make_mlp(
    n_in: int,
    n_out: int,
    hidden: Sequence[int] = (64, 64),
    activation: str = "tanh",
    out_gain: float = 1.0,
    device=None,
    dtype=torch.float32,
) -> nn.Sequential:
    """Fully connected ``n_in -> hidden... -> n_out`` network, orthogonal initialisation."""
    if activation not in ACTIVATIONS:
        raise ValueError(f"model.activation={activation!r} is invalid: allowed {list(ACTIVATIONS)}")
    layers: list[nn.Module] = []
    width = n_in
    for h in hidden:
        lin = nn.Linear(width, int(h), device=device, dtype=dtype)
        nn.init.orthogonal_(lin.weight, math.sqrt(2.0))
        nn.init.zeros_(lin.bias)
        layers += [lin, ACTIVATIONS[activation]()]
        width = int(h)
    out = nn.Linear(width, n_out, device=device, dtype=dtype)
    nn.init.orthogonal_(out.weight, out_gain)
    nn.init.zeros_(out.bias)
    layers.append(out)
    return nn.Sequential(*layers)


def make_actor(
    n_obs: int,
    shape_factor_max: float,
    hidden: Sequence[int] = (64, 64),
    activation: str = "tanh",
    init_std: float = 1.0,
    device=None,
    dtype=torch.float32,
) -> ProbabilisticActor:
    """``ProbabilisticActor`` ``observation -> (loc, scale) -> TanhNormal -> action``.

    Writes ``action`` (``Lambda`` in ``[-Lambda_max, Lambda_max]``) and ``action_log_prob``.
    ``actor.module[0].module[0]`` is the mean network ``mu(s)`` (see :func:`mean_network`).
    """
    if not init_std > 0:
        raise ValueError(f"model.init_std={init_std} is invalid: allowed > 0")
    mean = make_mlp(n_obs, 1, hidden, activation, 0.01, device, dtype)
    scale = AddStateIndependentNormalScale(
        1, scale_mapping="exp", init_value=math.log(init_std), device=device
    ).to(dtype)
    net = TensorDictModule(
        nn.Sequential(mean, scale), in_keys=["observation"], out_keys=["loc", "scale"]
    )
    lam = float(shape_factor_max)
    spec = Bounded(low=-lam, high=lam, shape=(1,), device=device, dtype=dtype)
    return ProbabilisticActor(
        net,
        in_keys=["loc", "scale"],
        spec=spec,
        distribution_class=TanhNormal,
        distribution_kwargs={"low": -lam, "high": lam},
        return_log_prob=True,
    )


def mean_network(actor: ProbabilisticActor) -> nn.Sequential:
    """The mean network ``mu(s)`` of an actor built by :func:`make_actor`."""
    return actor.module[0].module[0]


def log_std(actor: ProbabilisticActor) -> torch.Tensor:
    """``log sigma`` of the state-independent Gaussian (pre-``tanh``) of the actor."""
    return actor.module[0].module[1].state_independent_scale


def make_critic(
    n_obs: int,
    hidden: Sequence[int] = (64, 64),
    activation: str = "tanh",
    device=None,
    dtype=torch.float32,
) -> ValueOperator:
    """``ValueOperator`` ``observation -> state_value``."""
    return ValueOperator(
        make_mlp(n_obs, 1, hidden, activation, 1.0, device, dtype), in_keys=["observation"]
    )


class MeanPolicy(nn.Module):
    """Deterministic policy ``Lambda = Lambda_max tanh(mu(s))`` (the ``sigma -> 0`` limit).

    Inputs are cast to the network's dtype and the action back to the input dtype, so a
    float32 policy runs in a float64 environment.
    """

    def __init__(self, mean: nn.Module, shape_factor_max: float):
        super().__init__()
        self.mean = mean
        self.shape_factor_max = float(shape_factor_max)

    def forward(self, observation: torch.Tensor) -> torch.Tensor:
        w = next(self.mean.parameters())
        mu = self.mean(observation.to(w.dtype))
        return (self.shape_factor_max * torch.tanh(mu)).to(observation.dtype)


def deterministic_actor(actor: ProbabilisticActor, shape_factor_max: float) -> TensorDictModule:
    """TensorDict actor ``observation -> action`` sharing the mean network of ``actor``."""
    return TensorDictModule(
        MeanPolicy(mean_network(actor), shape_factor_max),
        in_keys=["observation"],
        out_keys=["action"],
    )
