r"""Actor and critic networks (paper App. "Reinforcement learning algorithm").

* Actor of a bounded action (:func:`tanh_normal_actor`): a Gaussian in the pre-``tanh``
  space, ``u ~ N(mu(s), sigma^2)`` of the action's width ``m``, with the mean ``mu(s)`` from a
  fully connected ``tanh`` MLP (2 x 64 by default) on the ``observation`` key and a
  state-independent trainable ``sigma = max(exp(log_sigma), sigma_min)`` per component
  (TorchRL's ``scale_lb``; ``model.min_std``, 1e-4 by default, i.e. no bound in practice);
  the action is ``a = (high + low)/2 + (high - low)/2 tanh(u)`` (TorchRL ``TanhNormal`` with
  ``low``, ``high`` read from the environment's action spec, as in TorchRL's
  ``sota-implementations/ppo/utils_mujoco.py``; the paper's shape factor ``Lambda =
  Lambda_max tanh(u)`` in ``[-Lambda_max, Lambda_max]``), so that the probability ratio and
  the entropy of PPO include the Jacobian of the ``tanh`` map. Evaluation is deterministic:
  ``sigma -> 0``, i.e. ``Lambda = Lambda_max tanh(mu(s))`` (:class:`MeanPolicy`, or
  ``ExplorationType.DETERMINISTIC``).
* Actor of a discrete action (:func:`categorical_actor`, ``actuation=steer
  actuation.directions=discrete``): logits of the ``n`` choices from the same MLP, the
  action drawn from ``torch.distributions.Categorical``; evaluated by its most probable
  choice (:class:`ArgmaxPolicy`).
* Critic: a ``ValueOperator`` ``V(s)`` on an MLP of the same shape, writing ``state_value``.

Initialisation as in common PPO implementations: orthogonal weights (gain ``sqrt 2`` in the
hidden layers, ``0.01`` for the actor's output so that ``mu ~ 0`` (uniform choices) at the
start, ``1`` for the value output), zero biases.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import torch
from tensordict.nn import AddStateIndependentNormalScale, TensorDictModule
from torch import nn
from torchrl.data import Bounded, Categorical, Composite
from torchrl.modules import ProbabilisticActor, TanhNormal, ValueOperator

from swimrl.actuation import ActuationSpec
from swimrl.conf_values import yaml_value
from swimrl.errors import ConfigError, as_float, as_int, keep_number_types, one_of, require

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


def _action(spec):
    """The action's spec of ``spec`` (an actor's ``Composite`` spec, or the action spec)."""
    return spec["action"] if isinstance(spec, Composite) else spec


def action_width(spec) -> int:
    """Components ``m`` of a bounded action (shape ``(..., m)``), or choices ``n`` of a
    discrete one (``Categorical(n)``)."""
    spec = _action(spec)
    if isinstance(spec, Categorical):
        return int(spec.space.n)
    return int(spec.shape[-1])


def action_bounds(spec) -> tuple[float, float]:
    """``(low, high)`` of a bounded one-component action spec (the shape factor; or of an
    actor's spec); ValueError for a wider or a discrete action (:func:`action_layout`)."""
    spec = _action(spec)
    if not isinstance(spec, Bounded) or spec.shape[-1] != 1:
        raise ValueError(f"action_bounds reads a one-component action (the shape factor); "
                         f"this action is {describe_action(spec)}")
    return float(spec.space.low.reshape(-1)[0]), float(spec.space.high.reshape(-1)[0])


def describe_action(spec) -> str:
    """One line naming an action spec: ``Categorical(n=4)`` or ``Bounded(m=3, low=[..],
    high=[..])``."""
    spec = _action(spec)
    if isinstance(spec, Categorical):
        return f"Categorical(n={action_width(spec)})"
    low = [round(float(v), 6) for v in spec.space.low.reshape(-1, spec.shape[-1])[0]]
    high = [round(float(v), 6) for v in spec.space.high.reshape(-1, spec.shape[-1])[0]]
    return f"Bounded(m={spec.shape[-1]}, low={low}, high={high})"


def action_layout(spec) -> tuple[ActuationSpec, int | None]:
    r"""The actuation (:mod:`swimrl.actuation`) whose action spec
    (:func:`swimrl.env.actuation.action_spec`) ``spec`` is, and the dimension ``d`` of its
    direction (None for ``shape``), read from the spec alone:

    * ``Categorical(2d)``: ``steer``, discrete;
    * ``Bounded`` of width 1: ``shape``;
    * ``Bounded`` of width ``m > 1``: the direction components are bounded by $\pm 1$ and the
      shape factor by $\pm\Lambda_\max$ with $\Lambda_\max < 1$ (``swimmer.shape_factor_max``):
      ``shape_steer`` (``d = m - 1``) where component 0 is bounded below 1, else ``steer``
      (``d = m``).

    ValueError for a spec of none of these forms.
    """
    spec = _action(spec)
    if isinstance(spec, Categorical):
        n = action_width(spec)
        if n % 2:
            raise ValueError(f"a discrete steering action has 2d choices; this action is "
                             f"{describe_action(spec)}")
        return ActuationSpec(name="steer", directions="discrete"), n // 2
    m = action_width(spec)
    if m == 1:
        return ActuationSpec(name="shape"), None
    low = spec.space.low.reshape(-1, m)[0].double()
    high = spec.space.high.reshape(-1, m)[0].double()
    shapes = bool(high[0] < 1.0)
    ones = torch.ones(m - int(shapes), dtype=torch.float64)
    if not (torch.equal(high[int(shapes):], ones) and torch.equal(low[int(shapes):], -ones)):
        raise ValueError(f"a steering action has direction components in [-1, 1]; this action "
                         f"is {describe_action(spec)}")
    return ActuationSpec(name="shape_steer" if shapes else "steer"), m - int(shapes)


def layout_name(spec) -> str:
    """``actuation=NAME`` (with ``actuation.directions=discrete`` where so) and the flow's
    dimension of an action spec (:func:`action_layout`), e.g. ``actuation=steer in a 2D
    flow``."""
    actuation, dim = action_layout(spec)
    text = f"actuation={actuation.name}"
    if actuation.directions == "discrete":
        text += " actuation.directions=discrete"
    return text + (f" in a {dim}D flow" if dim is not None else "")


def check_action(trained, spec, what: str) -> None:
    """One-line :class:`~swimrl.errors.ConfigError` unless an actor acting in ``trained``
    (``what``, e.g. ``policy='runs/x'``) can act in the action spec ``spec``: the same
    actuation, discreteness and direction dimension (:func:`action_layout`; the bounds may
    differ: the environment clamps the shape factor to its own ``Lambda_max``)."""
    if action_layout(trained) != action_layout(spec):
        raise ConfigError(
            f"{what} acts with {layout_name(trained)} ({describe_action(trained)}); this "
            f"environment's action is {layout_name(spec)} ({describe_action(spec)}): evaluate "
            "it with the actuation and the flow dimension it was trained with")


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

    ``spec`` is the unbatched action spec of the environment, ``Bounded`` of shape ``(m,)``
    (the shape factor ``Lambda`` in ``[low, high]``: ``m = 1``; a steering vector: ``m > 1``,
    :mod:`swimrl.env.actuation`); the ``TanhNormal`` bounds are read from it (numbers for
    ``m = 1``, per-component tensors otherwise). Writes ``action`` and ``action_log_prob``.
    ``actor.module[0].module[0]`` is the mean network ``mu(s)`` (see :func:`mean_network`);
    ``sigma = max(exp(log_sigma), min_std)`` per component (below the bound ``log_sigma``
    gets no gradient).
    """
    m = action_width(spec)
    mean = make_mlp(n_obs, m, hidden, activation, 0.01, device, dtype)
    scale = AddStateIndependentNormalScale(
        m, scale_mapping="exp", scale_lb=min_std, init_value=math.log(init_std), device=device
    ).to(dtype)
    net = TensorDictModule(
        nn.Sequential(mean, scale), in_keys=["observation"], out_keys=["loc", "scale"]
    )
    if m == 1:  # the shape factor: numbers, as the committed policies were built
        low, high = action_bounds(spec)
    else:
        low = spec.space.low.reshape(-1, m)[0].to(device=device, dtype=dtype).clone()
        high = spec.space.high.reshape(-1, m)[0].to(device=device, dtype=dtype).clone()
    return ProbabilisticActor(
        net,
        in_keys=["loc", "scale"],
        spec=spec.to(device) if device is not None else spec,
        distribution_class=TanhNormal,
        distribution_kwargs={"low": low, "high": high},
        return_log_prob=True,
    )


def categorical_actor(
    n_obs: int,
    spec: Categorical,
    hidden: Sequence[int] = yaml_value("train", "model.hidden"),
    activation: str = yaml_value("train", "model.activation"),
    device=None,
    dtype=torch.float32,
) -> ProbabilisticActor:
    """``ProbabilisticActor`` ``observation -> logits -> Categorical -> action``: a discrete
    action of ``n`` choices (``spec``, the environment's unbatched ``Categorical(n)``; the
    steering directions of :func:`~swimrl.physics.gyrotaxis.axis_directions`), drawn from
    ``torch.distributions.Categorical`` on the ``n`` logits of an MLP (output gain 0.01: near
    uniform at the start). Writes ``logits``, ``action`` (an ``int64`` index) and
    ``action_log_prob``; ``actor.module[0].module[0]`` is the logits network (see
    :func:`mean_network`)."""
    logits = make_mlp(n_obs, action_width(spec), hidden, activation, 0.01, device, dtype)
    net = TensorDictModule(nn.Sequential(logits), in_keys=["observation"], out_keys=["logits"])
    return ProbabilisticActor(
        net,
        in_keys=["logits"],
        spec=spec.to(device) if device is not None else spec,
        distribution_class=torch.distributions.Categorical,
        return_log_prob=True,
    )


def is_categorical(actor: ProbabilisticActor) -> bool:
    """True for an actor of a discrete action (:func:`categorical_actor`)."""
    return isinstance(_action(actor.spec), Categorical)


def mean_network(actor: ProbabilisticActor) -> nn.Sequential:
    """The mean network ``mu(s)`` of an actor built by :func:`tanh_normal_actor` (the logits
    network of one built by :func:`categorical_actor`)."""
    return actor.module[0].module[0]


@torch.no_grad()
def policy_std(actor: ProbabilisticActor) -> torch.Tensor:
    """``sigma`` of the state-independent Gaussian (pre-``tanh``) of the actor, one per action
    component, as its scale module gives it to the ``TanhNormal`` (the bound ``min_std``
    applied); an empty tensor for a categorical actor, which has no ``sigma`` (the trainer
    then logs no ``policy/std``)."""
    if is_categorical(actor):
        return torch.empty(0)
    scale = actor.module[0].module[1]
    return scale(scale.state_independent_scale)[1]


def value_critic(
    n_obs: int,
    hidden: Sequence[int] = yaml_value("train", "model.hidden"),
    activation: str = yaml_value("train", "model.activation"),
    device=None,
    dtype=torch.float32,
    *,
    in_key: str,
) -> ValueOperator:
    """``ValueOperator`` ``in_key -> state_value`` (``n_obs`` inputs)."""
    return ValueOperator(
        make_mlp(n_obs, 1, hidden, activation, 1.0, device, dtype), in_keys=[in_key]
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


class BoxMeanPolicy(nn.Module):
    """Deterministic policy of an ``m``-component action in ``[low, high]`` (the ``sigma ->
    0`` limit of the ``TanhNormal``): ``a = (high + low)/2 + (high - low)/2 tanh(mu(s))`` per
    component. Dtypes as :class:`MeanPolicy`."""

    def __init__(self, mean: nn.Module, low: torch.Tensor, high: torch.Tensor):
        super().__init__()
        self.mean = mean
        self.register_buffer("centre", ((high + low) / 2).detach().clone())
        self.register_buffer("radius", ((high - low) / 2).detach().clone())

    def forward(self, observation: torch.Tensor) -> torch.Tensor:
        w = next(self.mean.parameters())
        mu = self.mean(observation.to(w.dtype))
        a = self.centre.to(mu) + self.radius.to(mu) * torch.tanh(mu)
        return a.to(observation.dtype)


class ArgmaxPolicy(nn.Module):
    """Deterministic policy of a discrete action: the index of the largest logit (``int64``,
    the observation's batch shape)."""

    def __init__(self, logits: nn.Module):
        super().__init__()
        self.logits = logits

    def forward(self, observation: torch.Tensor) -> torch.Tensor:
        w = next(self.logits.parameters())
        return self.logits(observation.to(w.dtype)).argmax(dim=-1)


def deterministic_actor(actor: ProbabilisticActor) -> TensorDictModule:
    """TensorDict actor ``observation -> action`` sharing the network of ``actor``: for the
    one-component shape factor ``Lambda_max tanh(mu)`` (:class:`MeanPolicy`, ``Lambda_max``
    the upper bound of the actor's action spec), for a wider bounded action
    :class:`BoxMeanPolicy`, for a discrete one :class:`ArgmaxPolicy`. The result's
    ``action_spec`` is the actor's (unbatched) action spec, which an evaluation checks against
    its environment's."""
    spec = _action(actor.spec)
    net = mean_network(actor)
    if is_categorical(actor):
        module: nn.Module = ArgmaxPolicy(net)
    elif action_width(spec) == 1:
        module = MeanPolicy(net, action_bounds(spec)[1])
    else:
        m = action_width(spec)
        module = BoxMeanPolicy(net, spec.space.low.reshape(-1, m)[0],
                               spec.space.high.reshape(-1, m)[0])
    policy = TensorDictModule(module, in_keys=["observation"], out_keys=["action"])
    policy.action_spec = spec
    return policy


def actor_critic(model: ModelSpec, n_obs: int, spec: Bounded | Categorical, device=None,
                 dtype=torch.float32, critic_obs: tuple[str, int] | None = None
                 ) -> tuple[ProbabilisticActor, ValueOperator]:
    """The actor (:func:`tanh_normal_actor` for a ``Bounded`` ``spec``,
    :func:`categorical_actor` for a ``Categorical`` one) and critic (:func:`value_critic`) of
    one agent, shaped by ``model`` (``model.*``), on ``n_obs`` signals; the critic on
    ``critic_obs = (key, width)`` where given (an asymmetric critic), else on the actor's."""
    shape = {"hidden": list(model.hidden), "activation": model.activation, "device": device,
             "dtype": dtype}
    if isinstance(_action(spec), Categorical):
        actor = categorical_actor(n_obs, _action(spec), **shape)
    else:
        actor = tanh_normal_actor(n_obs, spec, init_std=model.init_std, min_std=model.min_std,
                                  **shape)
    key, width = critic_obs or ("observation", n_obs)
    critic = value_critic(width, in_key=key, **shape)
    return actor, critic
