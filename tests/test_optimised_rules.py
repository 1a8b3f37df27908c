"""The optimised hand-coded rule (``strategy=optimised``, :mod:`swimrl.policies.optimised`):
the 3D rule on planar states is the 2D rule; the signs of its terms against the equations of
motion; its STO limit and its minimal-model member; presets only on their dimension's
signals; the strategy from the configs of ``swimrl-eval`` and ``swimrl-compare``."""

from __future__ import annotations

import math

import pytest
import torch
from hydra import compose, initialize_config_module

from swimrl.config import compare_config, eval_config
from swimrl.errors import ConfigError
from swimrl.evaluation.rollout import evaluate
from swimrl.physics.body2d import SIGNAL_NAMES, compute_signals
from swimrl.physics.body3d import SIGNAL_NAMES_3D, compute_signals_3d
from swimrl.physics.swimmer import strain_np
from swimrl.physics.swimmer3d import swimmer_rhs_3d
from swimrl.policies.baselines import ShortTimeOptimal, StrategySpec, minimal_model
from swimrl.policies.optimised import (
    PRESETS,
    RULE_COEFFS,
    OptimisedRule,
    check_coefficients,
    optimised_rule,
    preset_coefficients,
    resolve_coefficients,
    rule_argument,
    rule_terms,
)

LAM = 0.98
INF = math.inf
N = 4000


def planar_states(n: int = N, seed: int = 0):
    """Random planar states as the 2D and the 3D signals of the same swimmer, float64."""
    g = torch.Generator().manual_seed(seed)
    r = lambda *s: torch.randn(*s, generator=g, dtype=torch.float64)  # noqa: E731
    theta = torch.rand(n, generator=g, dtype=torch.float64) * 2 * math.pi
    d = r(n, 2) * 3
    u, s_xx, s_xy, om = r(n, 2), r(n), r(n), r(n)
    q2 = torch.stack((u[:, 0], u[:, 1], s_xx, s_xy, om), -1)
    zero = torch.zeros(n, dtype=torch.float64)
    q3 = torch.stack((u[:, 0], u[:, 1], zero, s_xx, -s_xx, s_xy, zero, zero, zero, zero, om), -1)
    n3 = torch.stack((torch.cos(theta), torch.sin(theta), zero), -1)
    d3 = torch.cat((d, zero[:, None]), -1)
    return compute_signals(q2, theta, d, 1.0), compute_signals_3d(q3, n3, d3, 1.0)


def states_3d(n: int = N, seed: int = 1):
    """Random 3D states: flow channels (traceless strain), orientation, displacement, the
    signals; float64."""
    g = torch.Generator().manual_seed(seed)
    q = torch.randn(n, 11, generator=g, dtype=torch.float64)
    nn_ = torch.randn(n, 3, generator=g, dtype=torch.float64)
    nn_ = nn_ / nn_.norm(dim=-1, keepdim=True)
    d = torch.randn(n, 3, generator=g, dtype=torch.float64) * 3
    return q, nn_, d, compute_signals_3d(q, nn_, d, 1.0)


def random_coeffs(k: int, seed: int = 2) -> list[tuple[float, ...]]:
    g = torch.Generator().manual_seed(seed)
    out = []
    for i in range(k):
        c = torch.rand(6, generator=g, dtype=torch.float64)
        w = 0.0 if i % 2 else 0.3 * float(c[5])
        out.append((4 * float(c[0]), 3 * float(c[1]), 2 * float(c[2]) - 0.5,
                    2 * float(c[3]) - 0.5, 2 * float(c[4]) - 1, w))
    return out


def test_the_3d_rule_on_planar_states_is_the_2d_rule():
    s2, s3 = planar_states()
    for a, b in zip(rule_terms(s2, SIGNAL_NAMES), rule_terms(s3, SIGNAL_NAMES_3D), strict=True):
        assert torch.allclose(a, b, rtol=0, atol=1e-12)
    for c in random_coeffs(6):
        lam2 = optimised_rule(s2, c, LAM, SIGNAL_NAMES)
        lam3 = optimised_rule(s3, c, LAM, SIGNAL_NAMES_3D)
        assert torch.allclose(lam2, lam3, rtol=0, atol=1e-10)
        assert lam2.abs().max() <= LAM and lam2.abs().max() > 0.5


def test_the_2d_terms_are_those_of_the_minimal_model():
    """n0 = 0, w = 0: the argument is eq:fit's (whose outer tanh the rule's clip replaces)."""
    s2, _ = planar_states(seed=3)
    for c in random_coeffs(4, seed=4):
        z = rule_argument(s2, (*c[:4], 0.0, 0.0), SIGNAL_NAMES)
        assert torch.allclose(LAM * torch.tanh(z), minimal_model(s2, c[:4], LAM), atol=1e-12)


def test_the_stabilising_term_turns_the_shape_towards_the_tumbling_minimum_3d():
    """The stabilising term alone (gate open) has the sign of Lambda* = n.(omega x Sn) /
    (2 |(I - nn)Sn|^2), the minimum of the tumbling rate |dn/dt| over Lambda (brute force
    on swimmer_rhs_3d), so it lowers |dn/dt| at first order."""
    q, n, d, s3 = states_3d(n=1000)
    stab = rule_terms(s3, SIGNAL_NAMES_3D)[2]
    lam_grid = torch.linspace(-20, 20, 4001, dtype=torch.float64)
    rates = torch.stack([swimmer_rhs_3d(q, n, lam, 1.0)[1].norm(dim=-1) for lam in lam_grid])
    best = lam_grid[rates.argmin(0)]
    lever = (s3[:, 2] ** 2 + s3[:, 3] ** 2).sqrt()
    lam_star = (s3[:, 3] * s3[:, 5] - s3[:, 2] * s3[:, 6]) / (2 * lever**2)
    ok = lam_star.abs() < 19
    assert ok.float().mean() > 0.9
    assert torch.allclose(best[ok], lam_star[ok], atol=0.01)
    assert torch.equal(torch.sign(stab), torch.sign(lam_star))
    assert torch.allclose(stab, 2 * lever * lam_star, atol=1e-12)
    lam = optimised_rule(s3, (0.0, 1.0, 0.0, 0.0, -2.0, 0.0), LAM, SIGNAL_NAMES_3D)
    eps = 1e-6
    rate0 = swimmer_rhs_3d(q, n, 0.0, 1.0)[1].norm(dim=-1)
    rate = swimmer_rhs_3d(q, n, eps * torch.sign(lam), 1.0)[1].norm(dim=-1)
    assert bool((rate < rate0).all())


def test_the_stabilising_term_in_the_plane_cancels_the_vorticity():
    """2D: Lambda* = -omega / (2 S_np) stops the rotation, dtheta/dt = omega/2 + Lambda S_np
    (eq. 2) = 0; the term -omega sign(S_np) has its sign."""
    g = torch.Generator().manual_seed(5)
    theta = torch.rand(N, generator=g, dtype=torch.float64) * 2 * math.pi
    s_xx, s_xy, om = (torch.randn(N, generator=g, dtype=torch.float64) for _ in range(3))
    s_np = strain_np(theta, s_xx, s_xy)
    lam_star = -om / (2 * s_np)
    assert torch.allclose(om / 2 + lam_star * s_np, torch.zeros(N, dtype=torch.float64),
                          atol=1e-12)
    s2, _ = planar_states(seed=6)
    stab = rule_terms(s2, SIGNAL_NAMES)[2]
    assert torch.equal(torch.sign(stab), torch.sign(-s2[:, 4] / s2[:, 3]))


def test_the_sto_term_turns_n_towards_e_r():
    """The STO term alone: Lambda d(n.e_r)/dt's Lambda-slope >= 0 (the slope is
    sqrt(1 - n_r^2) S_np1, docs/physics.md "STO in 3D"), in 3D and in the plane."""
    q, n, d, s3 = states_3d(seed=7)
    lam = optimised_rule(s3, (1.0, 0.0, 0.0, 0.0, 0.0, 0.0), LAM, SIGNAL_NAMES_3D)
    e_r = d / d.norm(dim=-1, keepdim=True)
    slope = ((swimmer_rhs_3d(q, n, 1.0, 1.0)[1] - swimmer_rhs_3d(q, n, 0.0, 1.0)[1])
             * e_r).sum(-1)
    assert bool((lam * slope >= 0).all()) and bool((lam != 0).all())
    s2, _ = planar_states(seed=8)
    lam2 = optimised_rule(s2, (1.0, 0.0, 0.0, 0.0, 0.0, 0.0), LAM, SIGNAL_NAMES)
    assert torch.equal(torch.sign(lam2), torch.sign(ShortTimeOptimal(LAM)(s2).squeeze(-1)))


def test_the_sto_limit_is_sto():
    """c1 = inf, c2 = c3 = c4 = 0 (any gate) is STO: exactly in 2D, n_theta = 0 and S_np = 0
    included; in 3D wherever n_r != +-1 (there every Lambda is optimal)."""
    s2, _ = planar_states(seed=9)
    s2[:50, 1] = 0.0  # n_theta = 0
    s2[50:100, 3] = 0.0  # S_np = 0
    _, _, _, s3 = states_3d(seed=10)
    for gate in ((0.0, 0.0), (0.5, 0.1), (2.0, 0.0)):
        c = (INF, 0.0, 0.0, 0.0, *gate)
        assert torch.equal(optimised_rule(s2, c, LAM, SIGNAL_NAMES),
                           ShortTimeOptimal(LAM)(s2).squeeze(-1))
        assert torch.equal(optimised_rule(s3, c, LAM, SIGNAL_NAMES_3D),
                           ShortTimeOptimal(LAM)(s3).squeeze(-1))
    assert not optimised_rule(s2, (INF, 0, 0, 0, 0, 0), LAM, SIGNAL_NAMES).isnan().any()


def test_the_gate():
    """w = 0: the step H(n_r - n0), H(0) = 0; w > 0: sigmoid((n_r - n0)/w), the step as
    w -> 0; the gate multiplies the stabilising term only."""
    s2, _ = planar_states(seed=11)
    n_r, _, stab, _ = rule_terms(s2, SIGNAL_NAMES)
    z = rule_argument(s2, (0.0, 1.0, 0.0, 0.0, 0.3, 0.0), SIGNAL_NAMES)
    assert torch.equal(z, torch.where(n_r > 0.3, stab, 0.0))
    z = rule_argument(s2, (0.0, 1.0, 0.0, 0.0, 0.3, 0.2), SIGNAL_NAMES)
    assert torch.allclose(z, torch.sigmoid((n_r - 0.3) / 0.2) * stab, atol=1e-14)
    at = s2[:1].clone()
    at[0, 0] = 0.3
    assert rule_argument(at, (0.0, 1.0, 0.0, 0.0, 0.3, 0.0), SIGNAL_NAMES).item() == 0.0
    sharp = rule_argument(s2, (0.0, 1.0, 0.0, 0.0, 0.3, 1e-9), SIGNAL_NAMES)
    assert torch.allclose(sharp, torch.where(n_r > 0.3, stab, 0.0), atol=1e-6)


def test_a_population_of_rules_broadcasts_over_swimmer_blocks():
    _, s3 = planar_states(seed=12)
    cs = random_coeffs(3, seed=13)
    blocks = s3[:300].reshape(1, 3, 100, 7)
    lam = optimised_rule(blocks, torch.tensor(cs, dtype=torch.float64)[:, None, :], LAM,
                         SIGNAL_NAMES_3D)
    for k, c in enumerate(cs):
        assert torch.equal(lam[0, k], optimised_rule(blocks[0, k], c, LAM, SIGNAL_NAMES_3D))


def test_the_module_reads_its_dimension_s_signals_only():
    rule = OptimisedRule((1, 1, 0, 0, 0, 0), LAM, SIGNAL_NAMES_3D)
    _, s3 = planar_states(n=10)
    assert rule(s3).shape == (10, 1)
    with pytest.raises(ValueError, match="3D rule reads 7"):
        rule(s3[:, :5])
    with pytest.raises(ConfigError, match="reads all the signals of a flow"):
        OptimisedRule((1, 1, 0, 0, 0, 0), LAM, ("n_r", "S_np"))


@pytest.mark.parametrize("coeffs", [(1, 2, 3, 4, 5), (1, 2, 3, 4, 0, -0.1),
                                    (1, INF, 0, 0, 0, 0), (math.nan, 0, 0, 0, 0, 0),
                                    (-INF, 0, 0, 0, 0, 0)])
def test_bad_coefficients_are_refused(coeffs):
    with pytest.raises(ConfigError, match="six numbers"):
        check_coefficients(coeffs)


def test_presets_only_on_their_dimension_s_signals():
    """Each preset names its signals; one of the other dimension is one clear error that
    names both signal sets and the presets that fit."""
    assert {p.dim for p in PRESETS.values()} == {2, 3}
    for name, p in PRESETS.items():
        assert preset_coefficients(name, p.dim) == p.coeffs == check_coefficients(p.coeffs)
        other = 5 - p.dim
        with pytest.raises(ConfigError) as err:
            preset_coefficients(name, other)
        msg = str(err.value)
        assert f"{p.dim}D rule" in msg and f"{other}D flow" in msg
        assert str(list(p.signals)) in msg
        assert all(k in msg for k, v in PRESETS.items() if v.dim == other)
    with pytest.raises(ConfigError, match="strategy.preset='bogus' is invalid"):
        resolve_coefficients("bogus", None, 2)
    with pytest.raises(ConfigError, match="not both"):
        resolve_coefficients("ku10_2d", {"c1": 1.0}, 2)
    with pytest.raises(ConfigError, match="n0,w missing"):
        resolve_coefficients(None, {"c1": 1, "c2": 1, "c3": 0, "c4": 0}, 3)
    given = dict(zip(RULE_COEFFS, (1, 2, 0.5, 0.25, 0.1, 0.05), strict=True))
    assert resolve_coefficients(None, given, 3) == (1, 2, 0.5, 0.25, 0.1, 0.05)


def _compose(name: str, *overrides: str):
    with initialize_config_module("swimrl.conf", version_base="1.3"):
        return compose(config_name=name, overrides=list(overrides))


def test_the_strategy_yamls():
    for yaml, preset in (("optimised", "ku10_2d"), ("optimised3d", "ku10_3d")):
        node = _compose("evaluate", f"strategy={yaml}").strategy
        assert set(node) == {"name", "preset", *RULE_COEFFS} and node.name == "optimised"
        assert node.preset == preset and preset in PRESETS


TINY_3D = ("flow=stochastic3d", "flow.kubo=10", "eval.n_flows=1", "eval.n_swimmers=3",
           "episode.duration=0.5", "eval.progress=false", "threads=1")
TINY_2D = ("flow.kubo=10", "flow.n_grid=64", "flow.spacing=0.1", "eval.n_flows=1",
           "eval.n_swimmers=3", "episode.duration=0.5", "eval.progress=false", "threads=1")


def test_eval_config_takes_the_preset_of_the_flow_s_dimension():
    c = eval_config(_compose("evaluate", *TINY_3D, "strategy=optimised3d"))
    assert c.strategy == StrategySpec("optimised", coeffs=PRESETS["ku10_3d"].coeffs)
    with pytest.raises(ConfigError, match="ku10_2d is invalid with a 3D flow"):
        eval_config(_compose("evaluate", *TINY_3D, "strategy=optimised"))
    with pytest.raises(ConfigError, match="ku10_3d is invalid with a 2D flow"):
        eval_config(_compose("evaluate", *TINY_2D, "strategy=optimised3d"))
    keys = [f"strategy.{k}={v}" for k, v in zip(RULE_COEFFS, (3, 2, 0.7, 0.4, 0, 0), strict=True)]
    c = eval_config(_compose("evaluate", *TINY_2D, "strategy=optimised", "strategy.preset=null",
                             *keys))
    assert c.strategy.coeffs == (3, 2, 0.7, 0.4, 0, 0)


def test_compare_expands_optimised_over_its_presets():
    c = compare_config(_compose("compare", *TINY_2D, "compare.strategies=[sto,optimised]",
                                "compare.optimised_presets=[ku10_2d]"))
    assert [v.label for v in c.variants] == ["sto", "optimised(ku10_2d)"]
    assert c.variants[1].strategy.coeffs == PRESETS["ku10_2d"].coeffs
    with pytest.raises(ConfigError, match="compare.optimised_presets=ku10_2d is invalid with a 3D"):
        compare_config(_compose("compare", *TINY_3D, "compare.strategies=[sto,optimised]",
                                "compare.optimised_presets=[ku10_2d]"))
    with pytest.raises(ConfigError, match="compare.optimised_presets is empty"):
        compare_config(_compose("compare", *TINY_2D, "compare.strategies=[sto,optimised]"))
    with pytest.raises(ConfigError, match="has no 'optimised'"):
        compare_config(_compose("compare", *TINY_2D, "compare.strategies=[sto]",
                                "compare.optimised_presets=[ku10_2d]"))


@pytest.mark.parametrize("tiny,yaml", [(TINY_2D, "optimised"), (TINY_3D, "optimised3d")])
def test_the_strategy_runs(tiny, yaml):
    """``swimrl-eval strategy=optimised`` (2D) and ``strategy=optimised3d`` (3D), tiny."""
    c = eval_config(_compose("evaluate", *tiny, f"strategy={yaml}"))
    m = evaluate(c.setup, c.strategy, "optimised")
    assert m["n_flows"] == 1 and 0 < m["R_hat_mean"] < 10
