r"""Baseline strategies with the interface of a learned actor.

Each is a :class:`tensordict.nn.TensorDictModule` reading ``signals`` (all of the body's: the
five of :data:`swimrl.physics.body2d.SIGNAL_NAMES` in 2D, the seven of
:data:`swimrl.physics.body3d.SIGNAL_NAMES_3D` in 3D, read from their width by
:func:`~swimrl.physics.body.body_of_signals`; ``S`` and ``omega`` in units of ``1/tau_K``) and
writing ``action`` (the shape factor ``Lambda``, shape ``(..., 1)``) within
``[-Lambda_max, Lambda_max]`` (``Lambda_max`` from the environment's action spec):

* naive: ``Lambda = const`` (paper: ``0.98``); where the action steers (``actuation=steer``,
  ``shape_steer``, :mod:`swimrl.actuation`) the passive gyrotactic swimmer instead, which
  steers straight up (:class:`NaiveSteer`), the only baseline of a steering action;
* STO (``eq:sto``): ``Lambda = -Lambda_max sign(n_theta) sign(S_np)`` in 2D,
  ``Lambda = Lambda_max sign(S_np1)`` in 3D (below);
* minimal model (``eq:fit``):
  ``Lambda = Lambda_max tanh[-c1 n_theta sign(S_np) - c2 H(n_r) omega tau_K sign(S_np)
  + c3 n_r - c4 tanh(S_nn tau_K)]``, ``H`` the Heaviside step (``H(0) = 0``);
* the optimised rule (:mod:`.optimised`): ``eq:fit`` in frame-invariant terms, 2D and 3D,
  with six coefficients optimised on ``R_hat``.

**STO in 3D**, derived as ``eq:sto``: with ``r = |x - x_0|``, ``e_r = (x - x_0)/r``,
``d(n.e_r)/dt = e_r.dn/dt + n.de_r/dt``, ``de_r/dt = (I - e_r e_r) dx/dt / r``, and
``dx/dt = u + v_s n`` does not contain ``Lambda``, so neither does ``de_r/dt``; of
``dn/dt = (omega x n)/2 + Lambda (I - n n) S n`` only the strain term does, and
``e_r.(I - n n) S n = (e_r - (e_r.n) n).S n = sqrt(1 - n_r^2) p1.S n``:
``d(n.e_r)/dt = Lambda sqrt(1 - n_r^2) S_np1 + (Lambda-independent terms)``. The same factor
is the shape-dependent term of the distance (``eq:sto``'s expansion):
``r(t + dt) = (v_s Lambda dt^2/2) sqrt(1 - n_r^2) S_np1 + ...``. Linear in ``Lambda`` with a
coefficient of the sign of ``S_np1``, both are maximised over ``[-Lambda_max, Lambda_max]``
by ``Lambda = Lambda_max sign(S_np1)``; where ``n`` is parallel to ``e_r`` (``n_r = +-1``) or
``S_np1 = 0`` every ``Lambda`` is optimal (the rule gives ``Lambda_max`` or 0). In the plane
(``p1 = -sign(n_theta) p``) this is the 2D rule. The sign ``sigma`` of each body's rule is
:meth:`~swimrl.physics.body.Body.sto_sign`.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass

import torch
from tensordict.nn import TensorDictModule
from torch import nn
from torchrl.data import Bounded, Categorical

from swimrl.actuation import ActuationSpec
from swimrl.env.actuation import up_action
from swimrl.errors import ConfigError, as_float, one_of, require
from swimrl.flows.labels import parse_ku_name
from swimrl.physics.body import body, body_of_signals
from swimrl.physics.body2d import SIGNAL_NAMES
from swimrl.policies.networks import action_bounds, action_layout, describe_action
from swimrl.policies.optimised import RULE_COEFFS, OptimisedRule, check_coefficients
from swimrl.policies.steering import HandRule, TableStrategy

N_R, N_THETA, S_NN, S_NP, OMEGA = range(len(SIGNAL_NAMES))  # positions in SIGNAL_NAMES
STRATEGIES = ("naive", "sto", "minimal", "optimised", "policy", "hand_rule", "table")
#: The baselines that set the shape factor alone (refused where the action steers).
SHAPE_ONLY = ("sto", "minimal", "optimised")
#: The baselines that steer alone (:mod:`.steering`; refused where the action is the shape).
STEER_ONLY = ("hand_rule", "table")
_LABEL = re.compile(r"(\w+)\((.*)\)", re.DOTALL)


class NaiveShape(nn.Module):
    """The naive strategy: a constant shape factor ``Lambda = shape_factor`` (the paper's naive
    baseline: 0.98, Sec. III A).

    Parameters
    ----------
    shape_factor
        The constant ``Lambda``.
    """

    def __init__(self, shape_factor: float):
        super().__init__()
        self.shape_factor = float(shape_factor)

    def forward(self, signals: torch.Tensor) -> torch.Tensor:
        return torch.full_like(signals[..., :1], self.shape_factor)


class NaiveSteer(nn.Module):
    r"""The naive strategy of a steering action: the passive gyrotactic swimmer, whose
    preferred direction is the upward vertical $\hat{\boldsymbol z}$ (the last axis: $\hat y$
    in 2D, $\hat z$ in 3D), at the constant shape factor where the action sets it
    (:func:`~swimrl.env.actuation.up_action`): the action ``up`` for every swimmer, a vector
    ``(..., m)`` or (``discrete``) an ``int64`` index ``(...)``.

    Parameters
    ----------
    up
        The action: a list of ``m`` numbers, or an index.
    """

    def __init__(self, up: list[float] | int):
        super().__init__()
        self.index = up if isinstance(up, int) else None
        self.register_buffer("up", torch.tensor(up if isinstance(up, list) else [0.0]))

    def forward(self, signals: torch.Tensor) -> torch.Tensor:
        batch = signals.shape[:-1]
        if self.index is not None:
            return torch.full(batch, self.index, dtype=torch.int64, device=signals.device)
        return self.up.to(signals).expand(*batch, -1).clone()


class ShortTimeOptimal(nn.Module):
    """Short-time optimisation (the paper's eq. 10, ``eq:sto``): ``Lambda = Lambda_max sigma``
    with the body's sign ``sigma`` (:meth:`~swimrl.physics.body.Body.sto_sign`:
    ``-sign(n_theta) sign(S_np)`` in 2D, ``sign(S_np1)`` in 3D; the body read from the width
    of the ``signals`` key); with ``amplitudes = (a_+, a_-)`` the energy-aware family: the same
    sign choice with the prolate amplitude ``a_+`` where ``sigma > 0`` and the oblate ``-a_-``
    where ``sigma < 0`` (0 where ``sigma = 0``); ``a_+ = a_- = a`` is STO at
    ``Lambda_max = a``.

    Parameters
    ----------
    shape_factor_max
        ``Lambda_max``.
    amplitudes
        ``(a_+, a_-)`` in ``[0, Lambda_max]``, or None (both ``Lambda_max``).
    """

    def __init__(self, shape_factor_max: float,
                 amplitudes: tuple[float, float] | None = None):
        super().__init__()
        self.shape_factor_max = float(shape_factor_max)
        self.amplitudes = None if amplitudes is None else tuple(float(a) for a in amplitudes)

    def forward(self, signals: torch.Tensor) -> torch.Tensor:
        sigma = body_of_signals(signals).sto_sign(signals)
        if self.amplitudes is None:
            return (self.shape_factor_max * sigma).unsqueeze(-1)
        prolate, oblate = self.amplitudes
        lam = torch.where(sigma > 0, prolate, torch.where(sigma < 0, -oblate, 0.0))
        return lam.to(signals.dtype).unsqueeze(-1)


def minimal_model(signals: torch.Tensor, coeffs: Sequence[float] | torch.Tensor, lam_max: float):
    """``eq:fit`` evaluated on ``signals`` ``(..., 5)``, the 2D set (ValueError for any
    other); returns ``Lambda`` ``(...)``."""
    if body_of_signals(signals).signal_names != SIGNAL_NAMES:
        raise ValueError(f"the minimal model reads the 2D signals {list(SIGNAL_NAMES)}; it was "
                         f"given {signals.shape[-1]} columns (use strategy=optimised in 3D)")
    c1, c2, c3, c4 = (coeffs[i] for i in range(4))
    n_r, n_th = signals[..., N_R], signals[..., N_THETA]
    s_nn, s_np, om = signals[..., S_NN], signals[..., S_NP], signals[..., OMEGA]
    sgn = torch.sign(s_np)
    heav = (n_r > 0).to(signals.dtype)
    arg = -c1 * n_th * sgn - c2 * heav * om * sgn + c3 * n_r - c4 * torch.tanh(s_nn)
    return lam_max * torch.tanh(arg)


class MinimalModel(nn.Module):
    """The paper's four-term minimal analytical model (eq. 13, ``eq:fit``):
    ``Lambda = Lambda_max tanh[-c1 n_theta sgn S_np - c2 H(n_r) omega tau_K sgn S_np
    + c3 n_r - c4 tanh(S_nn tau_K)]``.

    Parameters
    ----------
    coeffs
        ``c1..c4`` (``swimrl-fit-minimal`` fits them to a strategy).
    shape_factor_max
        ``Lambda_max``.
    """

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
    ``coeffs`` c1..c4), ``optimised`` (with ``coeffs`` c1, c2, c3, c4, n0, w:
    :mod:`.optimised`) or ``policy`` (a trained policy, loaded by :mod:`.files`).

    Parameters
    ----------
    name
        One of :data:`STRATEGIES`.
    shape_factor
        ``naive``: the constant ``Lambda``, in ``(-1, 1)``.
    coeffs
        ``minimal``: ``(c1, c2, c3, c4)``; ``optimised``: ``(c1, c2, c3, c4, n0, w)`` (a
        preset's are checked against the flow's signals where the config is read,
        :func:`~swimrl.policies.optimised.resolve_coefficients`).
    amplitudes
        ``sto``: ``(a_+, a_-)``, the prolate and oblate amplitudes (:class:`ShortTimeOptimal`;
        None: both ``Lambda_max``).
    threshold
        ``hand_rule``: the vorticity edge $w$ in units of $1/\tau_K$
        (:class:`~swimrl.policies.steering.HandRule`).
    table
        ``table``: twelve action indices (:class:`~swimrl.policies.steering.TableStrategy`).
    """

    name: str
    shape_factor: float | None = None
    coeffs: tuple[float, ...] | None = None
    amplitudes: tuple[float, float] | None = None
    threshold: float | None = None
    table: tuple[int, ...] | None = None

    def __post_init__(self) -> None:
        one_of("strategy.name", self.name, STRATEGIES)
        if self.name == "naive":
            as_float("strategy.shape_factor", self.shape_factor, lambda v: abs(v) < 1, "(-1, 1)")
        if self.name == "minimal":
            require(self.coeffs is not None and len(self.coeffs) == 4, "strategy.c1..c4",
                    self.coeffs, "four numbers")
        if self.name == "optimised":
            require(self.coeffs is not None, "strategy.c1..w", self.coeffs,
                    f"six numbers {list(RULE_COEFFS)}")
            object.__setattr__(self, "coeffs", check_coefficients(self.coeffs))
        if self.name == "hand_rule":
            as_float("strategy.threshold", self.threshold, lambda v: v >= 0,
                     ">= 0 (units 1/tau_K)")
        if self.name == "table":
            require(self.table is not None and len(self.table) == 12
                    and all(a in range(4) for a in self.table), "strategy.table", self.table,
                    "12 action indices in 0..3")
        if self.amplitudes is not None:
            allowed = "a pair [a_+, a_-] of numbers in [0, 1) (strategy=sto only)"
            pair = tuple(self.amplitudes)
            require(self.name == "sto" and len(pair) == 2, "compare.sto_amplitudes",
                    list(pair), allowed)
            for a in pair:
                as_float("compare.sto_amplitudes", a, lambda v: 0 <= v < 1, allowed)
            object.__setattr__(self, "amplitudes", tuple(float(a) for a in pair))

    def check_dimension(self, dim: int) -> None:
        """``strategy=minimal`` reads ``n_theta`` and ``S_np``: refused for a body (of a
        ``dim``-dimensional flow) without them."""
        names = body(dim).signal_names
        if self.name == "minimal" and not {"n_theta", "S_np"} <= set(names):
            raise ConfigError(f"strategy={self.name} is invalid with a {dim}D flow: allowed "
                              "naive, sto, optimised or policy (the minimal model reads the 2D "
                              f"signals n_theta and S_np; the flow gives {list(names)})")

    def check_actuation(self, actuation: ActuationSpec) -> None:
        """Where the action steers (``actuation=steer`` or ``shape_steer``) the baselines of
        the shape factor (``sto``, ``minimal``, ``optimised``) are refused with one line."""
        if actuation.steers and self.name in SHAPE_ONLY:
            raise ConfigError(
                f"strategy={self.name} is invalid with actuation={actuation.name}: allowed naive "
                f"(the gyrotactic swimmer steering straight up), {', '.join(STEER_ONLY)} or "
                f"policy ({self.name} sets the shape factor alone; actuation=shape)")
        if actuation.name != "steer" and self.name in STEER_ONLY:
            raise ConfigError(
                f"strategy={self.name} is invalid with actuation={actuation.name}: allowed "
                f"actuation=steer ({self.name} chooses a direction at a fixed shape)")

    def check_bound(self, shape_factor_max: float) -> None:
        """A naive shape factor (STO's amplitudes) must lie within ``[-Lambda_max,
        Lambda_max]``."""
        if self.amplitudes is not None:
            require(max(self.amplitudes) <= shape_factor_max, "compare.sto_amplitudes",
                    list(self.amplitudes),
                    f"amplitudes in [0, {shape_factor_max}] (swimmer.shape_factor_max)")
        if self.name == "naive":
            require(
                abs(self.shape_factor) <= shape_factor_max,
                "strategy.shape_factor",
                self.shape_factor,
                f"[-{shape_factor_max}, {shape_factor_max}] (swimmer.shape_factor_max)",
            )


def build_strategy(spec: StrategySpec, action_spec: Bounded | Categorical
                   ) -> TensorDictModule:
    """Baseline actor for ``spec``; ``Lambda_max`` is the upper bound of the environment's
    (unbatched) action spec. The actor reads the body from the width of the ``signals`` it
    is given (:func:`~swimrl.physics.body.body_of_signals`): the same actor is the 2D STO on
    2D signals and the 3D STO on 3D signals; the minimal model refuses 3D signals with one
    error. A steering action spec (``actuation=steer``, ``shape_steer``; read by
    :func:`~swimrl.policies.networks.action_layout`, its direction's dimension ``d`` from
    its width) admits ``naive`` alone: :class:`NaiveSteer`, the vertical being the last of
    the ``d`` axes (:attr:`~swimrl.physics.body.Body.vertical_axis`), the shape factor (for
    ``shape_steer``) ``spec.shape_factor``; the others raise one line
    (:meth:`StrategySpec.check_actuation`).

    Parameters
    ----------
    spec
        ``naive``, ``sto``, ``minimal`` or ``optimised`` (a policy is loaded with
        :func:`~swimrl.runs.policy_files.load_policy`).
    action_spec
        The environment's ``action_spec_unbatched``.

    Returns
    -------
    TensorDictModule
        ``signals -> action``, the policy of TorchRL's ``env.rollout(n, policy)``.
    """
    actuation, dim = action_layout(action_spec)
    if spec.name == "policy":
        raise ValueError(f"strategy {spec.name!r} is not a baseline (load a policy file instead)")
    if actuation.steers:
        try:
            spec.check_actuation(actuation)
        except ConfigError as err:
            raise ConfigError(f"{err} (the action is {describe_action(action_spec)})") from None
        discrete = actuation.directions == "discrete"
        if spec.name == "hand_rule":
            return as_actor(HandRule(spec.threshold, discrete))
        if spec.name == "table":
            return as_actor(TableStrategy(spec.table, discrete))
        up = up_action(actuation, dim, body(dim).vertical_axis, spec.shape_factor)
        return as_actor(NaiveSteer(up))
    spec.check_actuation(actuation)
    lam_max = action_bounds(action_spec)[1]
    if spec.name == "naive":
        return as_actor(NaiveShape(spec.shape_factor))
    if spec.name == "sto":
        return as_actor(ShortTimeOptimal(lam_max, spec.amplitudes))
    if spec.name == "minimal":
        return as_actor(MinimalModel(spec.coeffs, lam_max))
    return as_actor(OptimisedRule(spec.coeffs, lam_max))


@dataclass(frozen=True)
class StrategyLabel:
    """A strategy's label: ``NAME`` or ``NAME(ARG)``.

    The rows of ``swimrl-compare`` (:meth:`naive`, :meth:`minimal`, :meth:`policy`):
    ``sto``, ``naive(+0.98)`` (the shape factor, ``%+.2f``), ``minimal`` (the config's
    coefficients) or ``minimal(FIT)`` (a fit's run directory), ``policy(SPEC)``; the actors
    of the figures: ``naive`` (``Lambda = 0.98``), ``naive(0.98)``, ``sto``,
    ``minimal(c1,c2,c3,c4)`` (:meth:`minimal_coeffs`) or a policy spec.
    :meth:`parse` reads a label back (``StrategyLabel.parse(str(label)) == label`` where the
    argument is not empty).
    """

    name: str
    arg: str = ""

    @property
    def label(self) -> str:
        """``name`` or ``name(arg)``."""
        return f"{self.name}({self.arg})" if self.arg else self.name

    def __str__(self) -> str:
        return self.label

    @classmethod
    def parse(cls, text: str) -> StrategyLabel:
        """``naive(+0.98)`` -> ``StrategyLabel("naive", "+0.98")``; text that is not
        ``WORD(...)`` (``sto``, a policy spec) is the name."""
        m = _LABEL.fullmatch(str(text))
        return cls(m.group(1), m.group(2)) if m else cls(str(text))

    @classmethod
    def naive(cls, shape_factor: float) -> StrategyLabel:
        """``naive(+0.98)``: a comparison's row of a constant shape factor."""
        return cls("naive", f"{float(shape_factor):+.2f}")

    @classmethod
    def sto(cls, amplitudes: Sequence[float] | None = None) -> StrategyLabel:
        """``sto``, or ``sto(+0.98,-0.30)``: STO choosing between the shape factors ``a_+``
        and ``-a_-`` (``%+.2f``)."""
        if amplitudes is None:
            return cls("sto")
        prolate, oblate = amplitudes
        return cls("sto", f"{float(prolate):+.2f},{-float(oblate):+.2f}")

    @classmethod
    def minimal(cls, fit: str = "") -> StrategyLabel:
        """``minimal(FIT)`` (the fit's run directory), or ``minimal``: a comparison's row."""
        return cls("minimal", str(fit))

    @classmethod
    def minimal_coeffs(cls, coeffs: Sequence[float]) -> StrategyLabel:
        """``minimal(c1,c2,c3,c4)`` (``%.6g``): the minimal model with these coefficients."""
        return cls("minimal", ",".join(f"{float(c):.6g}" for c in coeffs))

    @classmethod
    def policy(cls, spec: str) -> StrategyLabel:
        """``policy(SPEC)``: a comparison's row of a trained policy."""
        return cls("policy", str(spec))

    @property
    def numbers(self) -> tuple[float, ...]:
        """The numbers of the argument: ``naive(+0.98)`` -> ``(0.98,)``,
        ``minimal(1,0,0,0)`` -> ``(1.0, 0.0, 0.0, 0.0)``."""
        return tuple(float(x) for x in self.arg.split(","))

    @property
    def kubo(self) -> float | None:
        """The Ku a policy was trained or a minimal model fitted at, where the argument (or
        a bare label) ends in a ``ku<number>`` path component (``policy(pretrained/ku10)``,
        ``minimal(ku1e7)``); None otherwise (``policy(runs/ku10_seed0)``)."""
        last = (self.arg or self.name).rstrip("/").rsplit("/", 1)[-1]
        return parse_ku_name(last)
