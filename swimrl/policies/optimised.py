r"""The optimised hand-coded rule (``strategy=optimised``): the paper's minimal model
(``eq:fit``) written in frame-invariant terms, so that one formula reads the 2D signals
(:data:`~swimrl.physics.body2d.SIGNAL_NAMES`) and the 3D ones
(:data:`~swimrl.physics.body3d.SIGNAL_NAMES_3D`), with a gate in ``n_r`` on its
stabilising term and six coefficients optimised directly on ``R_hat``
(``docs/results/optimised_rules/``; derivation: ``docs/physics.md``, "Optimised rules"):

``Lambda = Lambda_max clip(z, -1, 1)``,

``z = c1 sqrt(1 - n_r^2) sign(S_np1) + c2 g(n_r) n.(omega x S n) / |(I - n n) S n|
+ c3 n_r - c4 tanh(S_nn tau_K)``,

``g(n_r) = sigmoid((n_r - n0) / w)`` (``w > 0``) or the step ``H(n_r - n0)`` (``w = 0``,
``H(0) = 0``), the strain and vorticity in units of ``1/tau_K``. The four terms
(:func:`rule_terms`):

* STO: ``sqrt(1 - n_r^2) sign(S_np1)`` (the sign of STO in 3D,
  :meth:`~swimrl.physics.body3d.Body3D.sto_sign`, times the lever
  ``|e_r.(I - n n)|``); in 2D ``-n_theta sign(S_np)``;
* stabilisation: ``n.(omega x S n) / |(I - n n) S n| = 2 |(I - n n) S n| Lambda*``,
  ``Lambda* = n.(omega x S n) / (2 |(I - n n) S n|^2)`` the shape that minimises the
  tumbling rate ``|dn/dt|``; in the body frame ``(S_np2 omega_p1 - S_np1 omega_p2) /
  (S_np1^2 + S_np2^2)^(1/2)``, in 2D ``-omega sign(S_np)`` (0 where the strain has no lever,
  ``(I - n n) S n = 0``);
* ``n_r`` (self-trapping) and ``tanh(S_nn tau_K)`` (strain avoidance), as in ``eq:fit``.

In the plane the 3D terms are the 2D ones (``p1 = -sign(n_theta) p``), so a 3D swimmer
confined to the plane gets the 2D rule; ``n0 = 0``, ``w = 0`` is ``eq:fit`` with its outer
``tanh`` replaced by the clip (:func:`rule_argument` is ``eq:fit``'s argument); ``c1 = inf``,
``c2 = c3 = c4 = 0`` is STO (wherever ``n_r != +-1``, where every ``Lambda`` is optimal).

Coefficients optimised for one regime are shipped as :data:`PRESETS`, each with the signals
it was optimised on: a preset is used only on those (2D on a 2D flow, 3D on a 3D flow;
:func:`resolve_coefficients`), and a preset's numbers never change (a new optimisation is a
new preset).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import torch
from torch import nn

from swimrl.errors import ConfigError
from swimrl.physics.body import body, body_of_signals
from swimrl.physics.body2d import SIGNAL_NAMES
from swimrl.physics.body3d import SIGNAL_NAMES_3D

RULE_COEFFS: tuple[str, ...] = ("c1", "c2", "c3", "c4", "n0", "w")
"""The rule's coefficients, in this order (the keys of ``conf/strategy/optimised.yaml``)."""


@dataclass(frozen=True)
class RulePreset:
    """Coefficients of the rule optimised for one regime.

    Parameters
    ----------
    coeffs
        ``(c1, c2, c3, c4, n0, w)``.
    signals
        The signal set they were optimised on: :data:`~swimrl.physics.body2d.SIGNAL_NAMES`
        (2D) or :data:`~swimrl.physics.body3d.SIGNAL_NAMES_3D` (3D).
    kubo
        The Kubo number of the training flows.
    record
        The optimisation's record (history and choice), under ``docs/results/``.
    """

    coeffs: tuple[float, ...]
    signals: tuple[str, ...]
    kubo: float
    record: str

    @property
    def dim(self) -> int:
        """2 or 3, from :attr:`signals`."""
        return signal_dimension(self.signals)


PRESETS: dict[str, RulePreset] = {
    "ku10_2d": RulePreset((1.957885931670428, 2.543642200661529, 1.5465418568375635,
                           1.7311190372714176, 0.26693241305068005, 0.34483952083513186),
                          SIGNAL_NAMES, 10.0, "docs/results/optimised_rules/ku10_2d/"),
    "ku1_2d": RulePreset((7.5724811102585, 4.611025610298027, 1.5882504649043008,
                          1.8246431688462144, 0.3690329559243528, 0.2152682491848516),
                         SIGNAL_NAMES, 1.0, "docs/results/optimised_rules/ku1_2d/"),
    "ku10_3d": RulePreset((2.352338417553584, 3.6574809363428997, 1.7175204244005036,
                           1.2108340854928188, 0.478987136349457, 0.08913951685922156),
                          SIGNAL_NAMES_3D, 10.0, "docs/results/optimised_rules/ku10_3d/"),
    "ku1_3d": RulePreset((3.670462444410366, 3.996877707974643, 0.7976094355148003,
                          1.3287436236068282, 0.0319777338641436, 0.384778387505669),
                         SIGNAL_NAMES_3D, 1.0, "docs/results/optimised_rules/ku1_3d/"),
}
"""The shipped coefficients, by regime: ``strategy=optimised strategy.preset=NAME``,
``compare.optimised_presets=[NAME]``; each names the signals it was optimised on and its
record under ``docs/results/optimised_rules/``."""


def signal_dimension(names: Sequence[str]) -> int:
    """The dimension of the body whose full signal set is ``names``
    (:func:`~swimrl.physics.body.body_of_signals`); ConfigError for any other set."""
    try:
        return body_of_signals(names).dim
    except ValueError as err:
        raise ConfigError(f"the optimised rule reads all the signals of a flow: {err}") from None


def rule_terms(signals: torch.Tensor, names: Sequence[str] | None = None
               ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor]:
    r"""The rule's four frame-invariant terms ``(n_r, STO, stabilisation, S_nn)`` of
    ``signals`` ``(..., k)``, the full signal set of a body (named ``names``, or read from
    the width ``k``): :meth:`~swimrl.physics.body.Body.invariant_terms`, each ``(...)``. 2D:
    ``(n_r, -n_theta sign S_np, -omega sign S_np, S_nn)``; 3D:
    ``(n_r, sqrt(1 - n_r^2) sign S_np1, (S_np2 omega_p1 - S_np1 omega_p2) / |(I - nn)Sn|,
    S_nn)``."""
    body_ = body_of_signals(signals if names is None else names)
    if signals.shape[-1] != len(body_.signal_names):
        raise ValueError(f"signals have {signals.shape[-1]} columns, the {body_.dim}D rule "
                         f"reads {len(body_.signal_names)}: {list(body_.signal_names)}")
    return body_.invariant_terms(signals)


def _coefficient(coeffs, i: int, like: torch.Tensor):
    c = coeffs[..., i] if isinstance(coeffs, torch.Tensor) else coeffs[i]
    return torch.as_tensor(c, dtype=like.dtype, device=like.device)


def rule_argument(signals: torch.Tensor, coeffs: Sequence[float] | torch.Tensor,
                  names: Sequence[str] | None = None) -> torch.Tensor:
    """``z`` of the module docstring (``Lambda = Lambda_max clip(z, -1, 1)``), ``(...)``.

    Parameters
    ----------
    signals
        ``(..., len(names))``.
    coeffs
        ``(c1, c2, c3, c4, n0, w)``: six numbers, or a tensor ``(..., 6)`` that broadcasts
        against ``signals[..., 0]`` (one rule per swimmer block, as the optimiser evaluates
        a population). ``c1 = inf`` is allowed (STO's sign wherever its lever is not 0).
    names
        The signals' names (:data:`~swimrl.physics.body2d.SIGNAL_NAMES` or
        :data:`~swimrl.physics.body3d.SIGNAL_NAMES_3D`; None: read from the width).
    """
    n_r, sto, stab, s_nn = rule_terms(signals, names)
    c1, c2, c3, c4, n0, w = (_coefficient(coeffs, i, n_r) for i in range(len(RULE_COEFFS)))
    soft = torch.sigmoid((n_r - n0) / torch.where(w > 0, w, 1.0))
    gate = torch.where(w > 0, soft, (n_r > n0).to(n_r.dtype))
    sto_term = torch.where(sto == 0, 0.0, c1 * sto)  # 0, not nan, for c1 = inf
    return sto_term + c2 * gate * stab + c3 * n_r - c4 * torch.tanh(s_nn)


def optimised_rule(signals: torch.Tensor, coeffs: Sequence[float] | torch.Tensor,
                   lam_max: float, names: Sequence[str] | None = None) -> torch.Tensor:
    """``Lambda = lam_max clip(z, -1, 1)`` (:func:`rule_argument`), ``(...)``."""
    return lam_max * torch.clamp(rule_argument(signals, coeffs, names), -1.0, 1.0)


def check_coefficients(coeffs: Sequence[float], key: str = "strategy.c1..w") -> tuple[float, ...]:
    """Six numbers ``(c1, c2, c3, c4, n0, w)``: finite (``c1`` may be ``+inf``), ``w >= 0``;
    ConfigError naming ``key`` otherwise."""
    allowed = ("six numbers c1, c2, c3, c4, n0, w: finite (c1 may be +inf), w >= 0")
    try:
        out = tuple(float(c) for c in coeffs)
    except (TypeError, ValueError):
        raise ConfigError(f"{key}={list(coeffs)} is invalid: allowed {allowed}") from None
    finite = all(map(math.isfinite, out[1:])) and (math.isfinite(out[0]) or out[0] == math.inf)
    if len(out) != len(RULE_COEFFS) or not finite or out[-1] < 0:
        raise ConfigError(f"{key}={list(coeffs)} is invalid: allowed {allowed}")
    return out


def preset_coefficients(name: str, dim: int, key: str = "strategy.preset") -> tuple[float, ...]:
    """The coefficients of the preset ``name`` for a ``dim``-dimensional flow; ConfigError
    naming ``key`` for an unknown preset or one optimised on the other dimension's signals."""
    if name not in PRESETS:
        raise ConfigError(f"{key}={name!r} is invalid: allowed one of {sorted(PRESETS)}")
    p = PRESETS[name]
    if p.dim != dim:
        fits = sorted(k for k, v in PRESETS.items() if v.dim == dim)
        raise ConfigError(
            f"{key}={name} is invalid with a {dim}D flow: {name} is a {p.dim}D rule, optimised "
            f"on the signals {list(p.signals)}, and the flow gives "
            f"{list(body(dim).signal_names)}; "
            f"allowed the {dim}D presets {fits}")
    return p.coeffs


def resolve_coefficients(preset: str | None, coeffs: Mapping[str, object] | None,
                         dim: int) -> tuple[float, ...]:
    """The coefficients of ``strategy=optimised`` on a ``dim``-dimensional flow: those of the
    preset ``preset`` (:func:`preset_coefficients`: it must have been optimised on that
    flow's signals), or with ``preset`` None the six ``coeffs`` ``c1..w`` (the same formula
    reads either signal set). ConfigError for a preset together with coefficients, or
    neither.
    """
    given = {k: v for k, v in (coeffs or {}).items() if v is not None}
    if preset is not None:
        if given:
            raise ConfigError(f"strategy.preset={preset} with strategy.{','.join(given)} set: "
                              "allowed a preset or the six coefficients, not both "
                              "(strategy.preset=null strategy.c1=... gives them)")
        return preset_coefficients(str(preset), dim)
    missing = [k for k in RULE_COEFFS if k not in given]
    if missing:
        raise ConfigError(f"strategy.preset=null and strategy.{','.join(missing)} missing: "
                          f"allowed a preset ({sorted(PRESETS)}) or all six coefficients "
                          f"{list(RULE_COEFFS)}")
    return check_coefficients([given[k] for k in RULE_COEFFS])


class OptimisedRule(nn.Module):
    """The optimised rule as a ``signals -> action`` module, ``(..., 1)``.

    Parameters
    ----------
    coeffs
        ``(c1, c2, c3, c4, n0, w)`` (:func:`check_coefficients`).
    shape_factor_max
        ``Lambda_max``.
    names
        The names of the ``signals`` columns it reads: the environment's full set, 2D or 3D
        (None: the body whose set has the width of the signals it is given).
    """

    def __init__(self, coeffs: Sequence[float], shape_factor_max: float,
                 names: Sequence[str] | None = None):
        super().__init__()
        self.register_buffer("coeffs", torch.tensor(check_coefficients(coeffs),
                                                    dtype=torch.float64))
        self.shape_factor_max = float(shape_factor_max)
        if names is not None:
            signal_dimension(names)
        self.names = None if names is None else tuple(names)

    def forward(self, signals: torch.Tensor) -> torch.Tensor:
        c = self.coeffs.to(signals.dtype)
        return optimised_rule(signals, c, self.shape_factor_max, self.names).unsqueeze(-1)
