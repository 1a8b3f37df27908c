"""The mechanism probe (``swimrl-probe``, :mod:`swimrl.analysis.mechanism_probe`): Λ* against a
brute-force minimum of the physics' |ṅ|, the planar limit of the 3D formula, the Gaussian
samples' moments, STO against itself, the command at a tiny size and its bad input."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest
import torch

from swimrl.analysis.gaussian_states import gaussian_states
from swimrl.analysis.mechanism_probe import actions, mechanism_stats, sto_shape
from swimrl.env import EnvParams
from swimrl.physics.body2d import SIGNAL_NAMES, compute_signals
from swimrl.physics.body3d import SIGNAL_NAMES_3D, compute_signals_3d
from swimrl.physics.swimmer import swimmer_rhs
from swimrl.physics.swimmer3d import strain_tensor, swimmer_rhs_3d
from swimrl.physics.tumbling import stabilising_shape as _stabilising_shape
from swimrl.physics.tumbling import tumbling_rate as _tumbling_rate
from swimrl.policies.baselines import StrategySpec, build_strategy
from swimrl.policies.networks import action_spec

from .conftest import SMALL

NAMES = {2: SIGNAL_NAMES, 3: SIGNAL_NAMES_3D}


def tumbling_rate(signals, lam, dim):
    return _tumbling_rate(signals, NAMES[dim], lam)


def stabilising_shape(signals, dim, lam_max):
    return _stabilising_shape(signals, NAMES[dim], lam_max)


ROOT = Path(__file__).resolve().parents[1]
LAM_MAX = 0.98
POLICY_3D = ROOT / "docs/results/three_d/runs/ku10_seed0"


def physical_rate(g, lam: torch.Tensor) -> torch.Tensor:
    """|dn/dt| of the swimmer's right-hand side (not of the signals) at shape factors
    ``lam`` ``(n,)`` for the Gaussian states ``g``."""
    if g.dim == 3:
        return swimmer_rhs_3d(g.q, g.orientation, lam, 0.707)[1].norm(dim=-1)
    return swimmer_rhs(g.q, g.orientation, lam, 0.707)[1].abs()


@pytest.mark.parametrize("dim", [2, 3])
def test_stabilising_shape_is_the_brute_force_minimum_of_the_tumbling_rate(dim):
    g = gaussian_states(dim, 3000, seed=1)
    # the rate from the signals is the physics' |dn/dt| at any shape
    lam = torch.empty(3000, dtype=torch.float64).uniform_(-1, 1, generator=torch.Generator()
                                                           .manual_seed(2))
    assert torch.allclose(tumbling_rate(g.signals, lam, dim), physical_rate(g, lam),
                          rtol=0, atol=1e-12)
    star = stabilising_shape(g.signals, dim, LAM_MAX)
    assert star.abs().max() <= LAM_MAX
    grid = torch.linspace(-LAM_MAX, LAM_MAX, 197, dtype=torch.float64)
    scan = torch.stack([physical_rate(g, torch.full((3000,), float(x), dtype=torch.float64))
                        for x in grid])  # (197, n)
    best = scan.min(dim=0).values
    at_star = physical_rate(g, star)
    assert (at_star <= best + 1e-12).all()
    # and within one grid step of the scan's own minimiser (the parabola is strictly convex)
    step = float(grid[1] - grid[0])
    assert (star - grid[scan.argmin(dim=0)]).abs().max() <= step + 1e-12
    # STO's rule is at the bounds; its rate is never below Lambda*'s
    assert (physical_rate(g, sto_shape(g.signals, LAM_MAX)) >= at_star - 1e-12).all()


def test_planar_3d_stabilising_shape_equals_the_2d_one():
    gen = torch.Generator().manual_seed(3)
    n = 2000
    f64 = torch.float64
    theta = torch.rand(n, generator=gen, dtype=f64) * 2 * math.pi
    phi = torch.rand(n, generator=gen, dtype=f64) * 2 * math.pi  # e_r, not along n
    s_xx, s_xy, omega = (torch.randn(n, generator=gen, dtype=f64) for _ in range(3))
    zero = torch.zeros(n, dtype=f64)
    q2 = torch.stack((zero, zero, s_xx, s_xy, omega), -1)
    q3 = torch.stack((zero, zero, zero, s_xx, -s_xx, s_xy, zero, zero, zero, zero, omega), -1)
    e2 = torch.stack((phi.cos(), phi.sin()), -1)
    n3 = torch.stack((theta.cos(), theta.sin(), zero), -1)
    sig2 = compute_signals(q2, theta, e2, 1.0)
    sig3 = compute_signals_3d(q3, n3, torch.cat((e2, zero[:, None]), -1), 1.0)
    for lam_max in (LAM_MAX, 1e6):  # clipped and not
        assert torch.allclose(stabilising_shape(sig2, 2, lam_max),
                              stabilising_shape(sig3, 3, lam_max), rtol=1e-9, atol=1e-12)
    lam = torch.rand(n, generator=gen, dtype=f64) * 2 - 1
    assert torch.allclose(tumbling_rate(sig2, lam, 2), tumbling_rate(sig3, lam, 3), atol=1e-12)
    assert torch.equal(sto_shape(sig2, LAM_MAX), sto_shape(sig3, LAM_MAX))


def test_gaussian_samples_have_the_stated_moments():
    n = 200_000
    g2 = gaussian_states(2, n, seed=0)
    s2 = dict(zip(SIGNAL_NAMES, g2.signals.T, strict=True))
    tol = 5 * math.sqrt(2 / n)  # relative standard error of a variance, 5 times
    assert float(s2["S_nn"].var()) == pytest.approx(1 / 8, rel=tol)
    assert float(s2["S_np"].var()) == pytest.approx(1 / 8, rel=tol)
    assert float(s2["omega"].var()) == pytest.approx(1.0, rel=tol)
    # n uniform on the circle, e_r fixed: P(n_r > 0.8) = acos(0.8) / pi
    frac = float((s2["n_r"] > 0.8).double().mean())
    p = math.acos(0.8) / math.pi
    assert frac == pytest.approx(p, abs=5 * math.sqrt(p * (1 - p) / n))

    g3 = gaussian_states(3, n, seed=0)
    s3 = dict(zip(SIGNAL_NAMES_3D, g3.signals.T, strict=True))
    strain = strain_tensor(g3.q)
    trace = strain.diagonal(dim1=-2, dim2=-1).sum(-1)
    assert float(trace.abs().max()) < 1e-12
    assert float((strain * strain).sum((-1, -2)).mean()) == pytest.approx(0.5, rel=tol)
    for k in range(3):
        assert float(g3.q[:, 8 + k].var()) == pytest.approx(1 / 3, rel=tol)
    # isotropy: the body-frame components have the isotropic variances
    assert float(s3["S_nn"].var()) == pytest.approx(1 / 15, rel=tol)
    assert float(s3["S_np1"].var()) == pytest.approx(1 / 20, rel=tol)
    assert float(s3["S_np2"].var()) == pytest.approx(1 / 20, rel=tol)
    for name in ("omega_n", "omega_p1", "omega_p2"):
        assert float(s3[name].var()) == pytest.approx(1 / 3, rel=tol)
    assert torch.allclose(g3.orientation.norm(dim=-1), torch.ones(n, dtype=torch.float64))
    frac = float((s3["n_r"] > 0.8).double().mean())  # n_r uniform on [-1, 1]
    assert frac == pytest.approx(0.1, abs=5 * math.sqrt(0.09 / n))


@pytest.mark.parametrize("dim", [2, 3])
def test_sto_against_itself_correlates_fully(dim):
    g = gaussian_states(dim, 20_000, seed=4)
    params = EnvParams(signals=SIGNAL_NAMES_3D if dim == 3 else SIGNAL_NAMES)
    sto = build_strategy(StrategySpec("sto"), action_spec(LAM_MAX))
    lam = actions(sto, g.signals, params)
    rec = mechanism_stats(g.signals, lam, LAM_MAX, 0.8)
    assert rec["corr_sto"] == pytest.approx(1.0, abs=1e-12)
    t = rec["tumbling"]
    assert t["subject"]["mean"] == t["sto"]["mean"]
    assert t["star"]["mean"] < t["zero"]["mean"] < t["sto"]["mean"]
    assert rec["n_aligned"] == int((g.signals[:, 0] > 0.8).sum())
    naive = build_strategy(StrategySpec("naive", shape_factor=0.98), action_spec(LAM_MAX))
    rec = mechanism_stats(g.signals, actions(naive, g.signals, params), LAM_MAX, 0.8)
    assert rec["corr_sto"] is None and rec["corr_star"] is None  # a constant has none


BAD = [  # (arguments, what the one line names)
    (["probe.policies=[no/such/run]"], "no/such/run"),
    (["probe.n_r_min=1.5"], "probe.n_r_min=1.5"),
    (["probe.n_r_min=-2"], "probe.n_r_min=-2"),
    ([f"probe.policies=[{POLICY_3D}]", "probe.flow=config"], "2D flow"),  # 3D policy, 2D flow
    (["probe.states=[]"], "probe.states"),
]


@pytest.fixture(scope="module")
def cli(tmp_path_factory):
    """Every command of the tests below in one process (``tests/cli_cases.py``): a tiny
    probe of a shipped policy and the baselines (``probe.flow=config``), the same again
    (refused), two policies in their own flows, 2D and 3D (Gaussian states), and the bad
    input; returns the run directories and ``{"rc", "stderr"}`` of each."""
    tmp = tmp_path_factory.mktemp("probe")
    tiny = [*SMALL, "flow.kubo=10", "probe.flow=config", "eval.n_flows=2", "eval.n_swimmers=8",
            "eval.flows_per_batch=2", "probe.n_samples=4000",
            "probe.strategies=[policy,sto,naive]", "probe.policies=[pretrained/ku10]",
            f"hydra.run.dir={tmp / 'run'}"]
    own = ["threads=1", "probe.states=[gaussian]", "probe.n_samples=4000",
           f"probe.policies=[pretrained/ku1,{POLICY_3D}]", f"hydra.run.dir={tmp / 'own'}"]
    bad = [[*a, "threads=1", f"hydra.run.dir={tmp / 'bad' / str(i)}"]
           for i, (a, _) in enumerate(BAD)]
    cases = [["swimrl.cli.probe", a] for a in (tiny, tiny, own, *bad)]
    out = subprocess.run([sys.executable, "-m", "tests.cli_cases"], input=json.dumps(cases),
                         capture_output=True, text=True, timeout=300, cwd=ROOT,
                         env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert out.returncode == 0, out.stderr[-3000:]
    return tmp, json.loads(out.stdout.strip().splitlines()[-1])


def test_the_command_on_a_shipped_policy_and_the_baselines(cli):
    tmp, results = cli
    run = tmp / "run"
    assert results[0]["rc"] == 0, results[0]["stderr"][-3000:]
    rec = json.loads((run / "probe.json").read_text())
    assert (run / "probe.md").read_text().startswith("| strategy |")
    assert (run / "probe.png").stat().st_size > 0
    rows = {(r["label"], r["states"]): r for r in rec["rows"]}
    assert sorted(rows) == sorted((label, states) for states in ("gaussian", "flows")
                                  for label in ("policy(pretrained/ku10)", "sto",
                                                "naive(+0.98)"))
    for states in ("gaussian", "flows"):
        assert rows["sto", states]["corr_sto"] == pytest.approx(1.0, abs=1e-9)
        assert rows["naive(+0.98)", states]["corr_star"] is None
        pol = rows["policy(pretrained/ku10)", states]
        assert pol["dimension"] == 2 and pol["n_aligned"] > 0
        t = pol["tumbling"]
        assert t["star"]["mean"] <= min(t[k]["mean"] for k in ("zero", "subject", "sto"))
    flows = rows["policy(pretrained/ku10)", "flows"]
    # 2 flows x 8 swimmers x (N - 1) decisions (episode.duration=2: N = 20)
    assert flows["n_states"] == 2 * 8 * 19 and len(flows["per_flow"]["corr_star"]) == 2
    assert flows["flow"]["n_grid"] == 64 and flows["policy_sha256"]
    # the same command again is refused: one line, the record untouched
    lines = results[1]["stderr"].strip().splitlines()
    assert results[1]["rc"] == 2 and len(lines) == 1 and "probe.json exists" in lines[0]
    assert json.loads((run / "probe.json").read_text()) == rec
    # own flows: a 2D and a 3D policy, each probed in its dimension
    assert results[2]["rc"] == 0, results[2]["stderr"][-3000:]
    dims = [(r["dimension"], r["trained_flow"]) for r in
            json.loads((tmp / "own" / "probe.json").read_text())["rows"]]
    assert dims == [(2, "ku1"), (3, "stochastic3d_ku10")]


def test_bad_input_is_one_line_before_any_compute(cli):
    tmp, results = cli
    for res, (args, key) in zip(results[3:], BAD, strict=True):
        lines = res["stderr"].strip().splitlines()
        assert res["rc"] == 2 and len(lines) == 1 and key in lines[0], (args, res)
        assert lines[0].startswith("error: ") and "Traceback" not in res["stderr"]
    assert not (tmp / "bad").exists()  # no run directory
