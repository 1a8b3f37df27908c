"""CUDA runs agree with the CPU reference (skipped without a GPU)."""

from __future__ import annotations

import pytest
import torch

from swimrl.env import EnvParams, SwimmerEnv
from swimrl.flows.stochastic import StochasticFlow

pytestmark = pytest.mark.gpu


def run(device: str) -> torch.Tensor:
    flow = StochasticFlow(
        2,
        10.0,
        n_grid=64,
        spacing=0.1,
        dtype=torch.float64,
        device="cpu",
        generator=torch.Generator().manual_seed(0),
    )
    basis, coeffs = flow.basis.clone(), flow.coeffs.clone()
    gen = torch.Generator(device=device).manual_seed(0)
    flow_d = StochasticFlow(
        2, 10.0, n_grid=64, spacing=0.1, dtype=torch.float64, device=device, generator=gen
    )
    env = SwimmerEnv(flow_d, 64, EnvParams(duration=1.0), generator=gen, kernel="eager")
    env.reset()
    # same flow and initial state on both devices; coefficients frozen (no device RNG)
    flow_d.basis.copy_(basis.to(device))
    flow_d.coeffs.copy_(coeffs.to(device))
    flow_d.advance = lambda dt: None
    env.pos.copy_(torch.linspace(0, 6, 128, dtype=torch.float64).view(2, 64, 1).expand(2, 64, 2))
    env.start_pos.copy_(env.pos)
    env.theta.copy_(torch.linspace(0, 6, 128, dtype=torch.float64).view(2, 64))
    lam = torch.linspace(-0.98, 0.98, 128, dtype=torch.float64, device=device)
    for _ in range(10):
        env.integrate(lam)
    return env.displacement().cpu()


def test_cuda_matches_cpu():
    assert torch.allclose(run("cuda"), run("cpu"), atol=1e-10)
