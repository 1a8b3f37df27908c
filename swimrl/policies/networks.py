r"""Actor and critic networks (paper App. "Reinforcement learning algorithm").

* Actor: a Gaussian in the pre-``tanh`` space, ``u ~ N(mu(s), sigma^2)``, with the mean
  ``mu(s)`` from a fully connected ``tanh`` MLP (2 x 64 by default) on the ``observation``
  key and a state-independent trainable ``sigma = max(exp(log_sigma), sigma_min)`` (TorchRL's
  ``scale_lb``; ``model.min_std``, 1e-4 by default, i.e. no bound in practice); the action is
  ``Lambda = Lambda_max tanh(u)`` (TorchRL ``TanhNormal`` with ``low``, ``high`` read from the
  environment's action spec ``[-Lambda_max, Lambda_max]``, as in TorchRL's
  ``sota-implementations/ppo/utils_mujoco.py``), so that the probability ratio and the
  entropy of PPO include the Jacobian of the ``tanh`` map. Evaluation is deterministic:
  ``sigma -> 0``, i.e. ``Lambda = Lambda_max tanh(mu(s))`` (:class:`MeanPolicy`, or
  ``ExplorationType.DETERMINISTIC``).
* Critic: a ``ValueOperator`` ``V(s)`` on an MLP of the same shape, writing ``state_value``.

Initialisation as in common PPO implementations: orthogonal weights (gain ``sqrt 2`` in the
hidden layers, ``0.01`` for the actor's mean output so that ``mu ~ 0`` at the start, ``1``
for the value output), zero biases.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import torch
from tensordict.nn import AddStateIndependentNormalScale, TensorDictModule
from torch import nn
from torchrl.data import Bounded, Composite
from torchrl.modules import ProbabilisticActor, TanhNormal, ValueOperator

from swimrl.conf_values import yaml_value
from swimrl.errors import as_float, as_int, keep_number_types, one_of, require

ACTIVATIONS = {"tanh": nn.Tanh, "relu": nn.ReLU, "elu": nn.ELU}
#: ``model.min_std`` that bounds nothing in practice (TorchRL's default ``scale_lb``): the
#: behaviour before the bound existed.
NO_STD_BOUND = 1e-4


@dataclass(frozen=True)
class ModelSpec:
    """Shape of actor and critic (``model.*``): hidden widths, activation, initial ``sigma``
    and its lower bound ``sigma_min``. (The keyword defaults of :func:`make_mlp`,
    :func:`tanh_normal_actor` and :func:`value_critic` are read from ``conf/train.yaml``'s
    ``model.*``, :mod:`swimrl.conf_values`.)"""

    hidden: tuple[int, ...]
    activation: str
    init_std: float
    min_std: float

    def __post_init__(self) -> None:
        require(len(self.hidden) > 0, "model.hidden", list(self.hidden),
                "a non-empty list of positive layer widths")
        for h in self.hidden:
            as_int("model.hidden", h)
        object.__setattr__(self, "activation", str(self.activation))
        one_of("model.activation", self.activation, ACTIVATIONS)
        as_float("model.init_std", self.init_std, lambda v: v > 0, "> 0")
        as_float("model.min_std", self.min_std, lambda v: 0 < v <= self.init_std,
                 f"in (0, model.init_std = {self.init_std}]")
        keep_number_types(self)


def make_mlp(
    n_in: int,
    n_out: int,
    hidden: Sequence[int] = yaml_value("train", "model.hidden"),
    activation: str = yaml_value("train", "model.activation"),
    out_gain: float = 1.0,
    device=None,
    dtype=torch.float32,
) -> nn.Sequential:
    """Fully connected ``n_in -> hidden... -> n_out`` network, orthogonal initialisation."""
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


def action_spec(shape_factor_max: float, device=None, dtype=torch.float32) -> Bounded:
    """Unbatched action spec ``Lambda in [-Lambda_max, Lambda_max]``, shape ``(1,)``."""
    lam = float(shape_factor_max)
    return Bounded(low=-lam, high=lam, shape=(1,), device=device, dtype=dtype)


def action_bounds(spec) -> tuple[float, float]:
    """``(low, high)`` of a bounded one-dimensional action spec (or of an actor's spec)."""
    if isinstance(spec, Composite):
        spec = spec["action"]
    return float(spec.space.low.reshape(-1)[0]), float(spec.space.high.reshape(-1)[0])


def tanh_normal_actor(
    n_obs: int,
    spec: Bounded,
    hidden: Sequence[int] = yaml_value("train", "model.hidden"),
    activation: str = yaml_value("train", "model.activation"),
    init_std: float = yaml_value("train", "model.init_std"),
    min_std: float = yaml_value("train", "model.min_std"),
    device=None,
    dtype=torch.float32,
) -> ProbabilisticActor:
    """``ProbabilisticActor`` ``observation -> (loc, scale) -> TanhNormal -> action``.

    ``spec`` is the unbatched action spec of the environment (``Lambda`` in ``[low, high]``);
    the ``TanhNormal`` bounds are read from it. Writes ``action`` and ``action_log_prob``.
    ``actor.module[0].module[0]`` is the mean network ``mu(s)`` (see :func:`mean_network`);
    ``sigma = max(exp(log_sigma), min_std)`` (below the bound ``log_sigma`` gets no gradient).
    """
    mean = make_mlp(n_obs, 1, hidden, activation, 0.01, device, dtype)
    scale = AddStateIndependentNormalScale(
        1, scale_mapping="exp", scale_lb=min_std, init_value=math.log(init_std), device=device
    ).to(dtype)
    net = TensorDictModule(
        nn.Sequential(mean, scale), in_keys=["observation"], out_keys=["loc", "scale"]
    )
    low, high = action_bounds(spec)
    return ProbabilisticActor(
        net,
        in_keys=["loc", "scale"],
        spec=spec.to(device) if device is not None else spec,
        distribution_class=TanhNormal,
        distribution_kwargs={"low": low, "high": high},
        return_log_prob=True,
    )


def mean_network(actor: ProbabilisticActor) -> nn.Sequential:
    """The mean network ``mu(s)`` of an actor built by :func:`tanh_normal_actor`."""
    return actor.module[0].module[0]


@torch.no_grad()
def policy_std(actor: ProbabilisticActor) -> torch.Tensor:
    """``sigma`` of the state-independent Gaussian (pre-``tanh``) of the actor, as its scale
    module gives it to the ``TanhNormal`` (the bound ``min_std`` applied)."""
    scale = actor.module[0].module[1]
    return scale(scale.state_independent_scale)[1]


def value_critic(
    n_obs: int,
    hidden: Sequence[int] = yaml_value("train", "model.hidden"),
    activation: str = yaml_value("train", "model.activation"),
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


def deterministic_actor(actor: ProbabilisticActor) -> TensorDictModule:
    """TensorDict actor ``observation -> action`` sharing the mean network of ``actor``; its
    bound ``Lambda_max`` is the upper bound of the actor's action spec."""
    return TensorDictModule(
        MeanPolicy(mean_network(actor), action_bounds(actor.spec)[1]),
        in_keys=["observation"],
        out_keys=["action"],
    )


def actor_critic(model: ModelSpec, n_obs: int, spec: Bounded, device=None,
                 dtype=torch.float32) -> tuple[ProbabilisticActor, ValueOperator]:
    """The actor (:func:`tanh_normal_actor`) and critic (:func:`value_critic`) of one agent,
    shaped by ``model`` (``model.*``), on ``n_obs`` signals, the actor bounded by ``spec``."""
    actor = tanh_normal_actor(n_obs, spec, hidden=list(model.hidden),
                              activation=model.activation, init_std=model.init_std,
                              min_std=model.min_std, device=device, dtype=dtype)
    critic = value_critic(n_obs, hidden=list(model.hidden), activation=model.activation,
                          device=device, dtype=dtype)
    return actor, critic
