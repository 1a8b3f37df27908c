"""The swimmer's body (:mod:`swimrl.physics.body`): the one place the dimension is decided,
and the strategies that read it from their signals instead of taking it."""

from __future__ import annotations

import inspect
import re
from pathlib import Path

import pytest
import torch

from swimrl.env import EnvParams, build_env
from swimrl.errors import ConfigError
from swimrl.flows.stochastic3d import Stochastic3DSpec
from swimrl.physics.body import BODIES, Body, body, body_of_signals
from swimrl.physics.body2d import SIGNAL_NAMES, Body2D
from swimrl.physics.body3d import SIGNAL_NAMES_3D, Body3D
from swimrl.policies.baselines import StrategySpec, build_strategy
from swimrl.runtime import Runtime

ROOT = Path(__file__).resolve().parents[1]
#: The issue's grep: a dimension compared with (or set to) 2 or 3, or an ``is_3d`` flag.
DIM_CHECK = re.compile(r"\b(dim|d|dimension)\s*[!=<>]=?\s*[23]\b|is_3d")
#: The files allowed to hold one: the bodies and the environment builder.
ALLOWED = re.compile(r"^swimrl/(physics/body\w*\.py|env/build\.py)$")
CPU = Runtime.from_names("cpu", "float32", 1)
SHORT = {"duration": 0.2, "update_interval": 0.1, "dt": 0.05}


def test_no_dimension_check_outside_the_body():
    hits = []
    for path in sorted((ROOT / "swimrl").rglob("*.py")):
        rel = path.relative_to(ROOT).as_posix()
        for i, line in enumerate(path.read_text().splitlines(), 1):
            if DIM_CHECK.search(line) and not ALLOWED.match(rel):
                hits.append(f"{rel}:{i}: {line.strip()}")
    assert not hits, "dimension checks outside physics/body*.py:\n" + "\n".join(hits)


def test_the_grep_finds_a_dimension_check():  # negative control: the pattern can fail
    assert DIM_CHECK.search("        if self.dim == 3:")
    assert DIM_CHECK.search("names = A if dimension != 2 else B")
    assert not DIM_CHECK.search("    dim: int = 3")


@pytest.mark.parametrize("b", list(BODIES.values()))
def test_bodies_implement_the_protocol(b):
    members = [m for m in vars(Body) if not m.startswith("_")]
    members += list(Body.__annotations__)
    for m in members:
        assert hasattr(b, m), f"{type(b).__name__} lacks {m}"
    for m in [m for m in vars(Body) if callable(vars(Body)[m]) and not m.startswith("_")]:
        ours = inspect.signature(getattr(type(b), m)).parameters
        assert len(ours) == len(inspect.signature(getattr(Body, m)).parameters), m
    assert body(b.dim) is b and len(b.signal_names) == len(set(b.signal_names))


def test_body_choice_and_errors():
    assert isinstance(body(2), Body2D) and isinstance(body(3), Body3D)
    with pytest.raises(ConfigError, match="dimension 4 has no swimmer body"):
        body(4)
    assert body_of_signals(torch.zeros(2, 5)).signal_names == SIGNAL_NAMES
    assert body_of_signals(SIGNAL_NAMES_3D).dim == 3
    with pytest.raises(ValueError, match="6 signal columns are no body's full signal set"):
        body_of_signals(torch.zeros(2, 6))


def test_quickstart_sto_on_a_3d_env_is_the_3d_sto():
    """The quickstart's ``build_strategy(StrategySpec("sto"), env.action_spec_unbatched)`` on a
    3D environment: ``Lambda = Lambda_max sign(S_np1)``, not the 2D rule on 3D columns."""
    env = build_env(Stochastic3DSpec(kubo=10.0), EnvParams(**SHORT, signals=SIGNAL_NAMES_3D),
                    CPU, 2, 64, seed=3)
    actor = build_strategy(StrategySpec("sto"), env.action_spec_unbatched)
    td = actor(env.reset())
    s = td["signals"]
    want = 0.98 * torch.sign(s[..., SIGNAL_NAMES_3D.index("S_np1")])
    assert torch.equal(td["action"][..., 0], want)
    # the 2D rule read on the same columns would differ (columns 1 and 3 are S_nn, S_np2)
    wrong = -0.98 * torch.sign(s[..., 1]) * torch.sign(s[..., 3])
    assert not torch.equal(wrong, want)


def test_minimal_model_refuses_3d_signals_in_one_line():
    lam = build_strategy(StrategySpec("minimal", coeffs=(1.0, 1.0, 1.0, 1.0)),
                         build_env(Stochastic3DSpec(kubo=1.0),
                                   EnvParams(**SHORT, signals=SIGNAL_NAMES_3D), CPU, 1, 4,
                                   seed=0).action_spec_unbatched)
    with pytest.raises(ValueError, match="minimal model reads the 2D signals") as err:
        lam(build_env(Stochastic3DSpec(kubo=1.0), EnvParams(**SHORT, signals=SIGNAL_NAMES_3D),
                      CPU, 1, 4, seed=0).reset())
    assert "\n" not in str(err.value)
    with pytest.raises(ConfigError, match="strategy=minimal is invalid with a 3D flow"):
        StrategySpec("minimal", coeffs=(1.0, 1.0, 1.0, 1.0)).check_dimension(3)


def test_env_holds_its_body():
    env = build_env(Stochastic3DSpec(kubo=1.0), EnvParams(**SHORT, signals=SIGNAL_NAMES_3D),
                    CPU, 1, 4, seed=0)
    assert env.body is body(3) and env.orientation.shape == (1, 4, 3)
    with pytest.raises(AttributeError):
        _ = env.theta


def test_derived_signals_are_the_tumbling_quantities_and_agree_in_the_plane():
    """``lever = |(I - nn) S n|`` and ``torque = n.(omega x S n)`` computed from the vectors
    directly, in 3D; and a 3D swimmer in the plane derives the 2D body's values."""
    from swimrl.analysis.gaussian_states import gaussian_states
    from swimrl.physics.swimmer3d import strain_tensor

    g = gaussian_states(3, 500, seed=2)
    n, s, omega = g.orientation, strain_tensor(g.q), g.q[:, 8:11]
    sn = (s @ n.unsqueeze(-1)).squeeze(-1)
    perp = sn - (n * sn).sum(-1, keepdim=True) * n
    want = torch.stack((perp.norm(dim=-1), (n * torch.linalg.cross(omega, sn, dim=-1)).sum(-1)),
                       -1)
    got = body(3).derived(g.signals)
    torch.testing.assert_close(got[..., :2], want, rtol=0, atol=1e-12)
    assert body(2).derived_names[:2] == body(3).derived_names[:2] == ("lever", "torque")
    # the rule's terms: the STO term |(I - nn) e_r| sign(S_np1) and torque / lever
    e_r = g.e_r.reshape(3).to(torch.float64)
    side = (e_r - (n @ e_r).unsqueeze(-1) * n).norm(dim=-1) * torch.sign(g.signals[:, 2])
    torch.testing.assert_close(got[..., 2], side, rtol=0, atol=1e-12)
    torch.testing.assert_close(got[..., 3] * want[:, 0], want[:, 1], rtol=0, atol=1e-12)
    assert body(3).derived_names[2:] == body(2).derived_names[-2:] == ("sto_term", "stab_term")
    g2 = gaussian_states(2, 500, seed=3)
    theta = g2.orientation
    q3 = torch.zeros(500, 11, dtype=torch.float64)
    q3[:, 3], q3[:, 5], q3[:, 10] = g2.q[:, 2], g2.q[:, 3], g2.q[:, 4]  # S_xx, S_xy, omega_z
    q3[:, 4] = -g2.q[:, 2]                                              # S_yy = -S_xx
    n3 = torch.stack((theta.cos(), theta.sin(), 0 * theta), -1)
    e_r = torch.tensor([1.0, 0.0, 0.0], dtype=torch.float64).expand(500, 3)
    sig3 = body(3).signals(q3, n3, e_r, 1.0)
    d2 = body(2).derived(g2.signals)
    torch.testing.assert_close(body(3).derived(sig3), torch.cat((d2[..., :2], d2[..., -2:]), -1),
                               rtol=0, atol=1e-12)


def test_an_env_observes_derived_signals():
    names = (*SIGNAL_NAMES_3D, "lever", "torque", "Lambda")
    env = build_env(Stochastic3DSpec(kubo=10.0), EnvParams(**SHORT, signals=names), CPU, 1, 8,
                    seed=1)
    td = env.reset()
    obs, sig = td["observation"], td["signals"]
    assert obs.shape == (1, 8, 10)
    assert torch.equal(obs[..., :7], sig)
    assert torch.equal(obs[..., 7:9], body(3).derived(sig)[..., :2])
    assert torch.equal(obs[..., 9], torch.zeros(1, 8))
    with pytest.raises(ConfigError, match="unknown"):
        EnvParams(**SHORT, signals=("n_r", "lever2"))
