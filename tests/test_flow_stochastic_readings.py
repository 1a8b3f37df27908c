"""Readings of the paper's flow specification (``flow.basis``, ``flow.amplitudes``, the box
``flow.n_grid``, ``flow.velocity_scale``): each option against its analytic statement."""

from __future__ import annotations

import math

import pytest
import torch

from swimrl.env import EnvParams, SwimmerEnv
from swimrl.errors import ConfigError
from swimrl.flows.build import build_flow
from swimrl.flows.grid import PeriodicGrid
from swimrl.flows.stochastic import TAU_K, StochasticFlow, StochasticSpec, gaussian_spectrum


def small(n_flows=3, kubo=1e7, seed=0, dtype=torch.float64, **options) -> StochasticFlow:
    gen = torch.Generator().manual_seed(seed)
    return StochasticFlow(n_flows, kubo, n_grid=16, spacing=0.5, dtype=dtype, generator=gen,
                          **options)


def test_defaults_are_the_paper_text_as_written():
    flow, spec = small(), StochasticSpec(10.0)
    assert flow.fixed_basis is None and flow.amplitudes == "stationary"
    assert (flow.u_rms, flow.tau_k, flow.tau_f) == (1.0, TAU_K, 1e7)
    assert (spec.basis, spec.amplitudes, spec.velocity_scale) == ("redrawn", "stationary", "total")
    assert not torch.equal(flow.basis[0], flow.basis[1])  # every realisation its own psi_i


def test_fixed_basis_is_one_set_of_fields_for_every_flow_and_episode():
    flow = small(4, basis="fixed", basis_seed=7)
    first = flow.basis.clone()
    assert all(torch.equal(first[0], first[f]) for f in range(1, 4))
    c0 = flow.coeffs.clone()
    flow.reset(torch.tensor([True, False, True, False]))  # new episodes of flows 0 and 2
    assert torch.equal(flow.basis, first)
    assert not torch.equal(flow.coeffs[0], c0[0]) and torch.equal(flow.coeffs[1], c0[1])
    # the set depends on basis_seed only, not on the flow's generator (chunks, strategies)
    assert torch.equal(small(2, seed=99, basis="fixed", basis_seed=7).basis[0], first[0])
    assert not torch.equal(small(2, basis="fixed", basis_seed=8).basis[0], first[0])
    # and it is a draw of the default's law: the default's first flow from generator seed 7
    assert torch.equal(small(1, seed=7).basis[0], first[0])


def test_normalised_amplitudes_put_c_on_the_unit_sphere():
    stat, norm = small(200), small(200, amplitudes="normalised")
    c = norm.coeffs
    assert torch.allclose((c**2).sum(1), torch.ones(200, dtype=torch.float64), atol=1e-14)
    # same draws xi, same direction: c_norm = c_stat / |c_stat|
    assert torch.allclose(c, stat.coeffs / stat.coeffs.norm(dim=1, keepdim=True), atol=1e-14)
    assert torch.equal(stat.basis, norm.basis)
    # <c_i^2> = 1/M in both readings: ensemble u_rms and tau_K unchanged
    assert (c**2).mean().item() == pytest.approx(1 / norm.n_basis, rel=1e-12)
    f32 = small(64, dtype=torch.float32, amplitudes="normalised")
    assert torch.allclose((f32.coeffs.double() ** 2).sum(1), torch.ones(64, dtype=torch.float64),
                          atol=1e-6)
    f32.reset(torch.arange(64) % 2 == 0)
    assert torch.allclose((f32.coeffs.double() ** 2).sum(1), torch.ones(64, dtype=torch.float64),
                          atol=1e-6)
    # OU steps unchanged: at Ku = 1e7 the norm diffuses by ~2 sqrt(2 t / (tau_f M)) (4e-4 here)
    norm.coefficient_path(200, 0.005)
    assert torch.allclose((norm.coeffs**2).sum(1), torch.ones(200, dtype=torch.float64),
                          atol=3e-3)


@pytest.mark.parametrize("n_grid, length", [(400, 10.0), (800, 20.0), (1600, 40.0)])
def test_larger_box_keeps_resolution_and_spectrum(n_grid, length):
    """L = n_grid * 0.025: u_rms = 1 and tau_K = 1/2 exactly from the discrete spectrum."""
    spec = StochasticSpec(1e7, n_grid=n_grid)
    grid = PeriodicGrid(spec.n_grid, spec.n_grid * spec.spacing)
    assert grid.length == pytest.approx(length, rel=1e-12) and grid.spacing == 0.025
    p = gaussian_spectrum(grid, 0.5, 1.0, "cpu")
    kx, ky = grid.wavenumbers()
    k2 = kx**2 + ky**2

    def moment(w):  # grid mean of f^2 for E|FFT f|^2 = N^2 P w
        return float((w * p).sum() / grid.n**2)

    assert moment(k2) == pytest.approx(1.0, rel=1e-9)
    a2 = moment(2 * (kx * ky) ** 2 + 0.5 * (ky**2 - kx**2) ** 2 + 0.5 * k2**2)
    assert a2**-0.5 == pytest.approx(TAU_K, rel=1e-9)
    # the lowest nonzero wavenumber 2 pi / L resolves the spectrum's peak (k ell_f = 1)
    assert 2 * math.pi / grid.length < 0.65


def test_component_velocity_scale_changes_only_the_reference_velocity():
    total, comp = small(2, kubo=10.0), small(2, kubo=10.0, velocity_scale="component")
    assert torch.equal(total.basis, comp.basis) and torch.equal(total.coeffs, comp.coeffs)
    assert comp.u_rms == pytest.approx(2**-0.5, rel=1e-15)
    assert comp.tau_f == pytest.approx(10.0 * 2**0.5, rel=1e-15)  # Ku against u_rms/sqrt 2
    assert comp.tau_k == TAU_K
    b = comp.basis  # the fields are the default's: <u_x^2> = <u.u>/2
    assert torch.equal(comp.grid_fields(), total.grid_fields())
    assert b[..., 0].pow(2).mean().item() == pytest.approx(b[..., 1].pow(2).mean().item(), rel=0.5)
    env = SwimmerEnv(comp, 2, EnvParams())
    assert env.swim_speed == pytest.approx(0.707 * 2**-0.5, rel=1e-12)  # 0.5 <u.u>^{1/2}
    assert env.reference_distance == pytest.approx(env.swim_speed * 200 * TAU_K, rel=1e-12)


def test_options_are_checked_and_reach_the_flow():
    for key, bad in (("basis", "frozen"), ("amplitudes", "unit"), ("velocity_scale", "x"),
                     ("basis_seed", -1)):
        with pytest.raises(ConfigError, match=f"flow.{key}="):
            StochasticSpec(1e7, **{key: bad})
    spec = StochasticSpec(1e7, n_grid=16, spacing=0.5, basis="fixed", basis_seed=3,
                          amplitudes="normalised", velocity_scale="component")
    flow = build_flow(spec, 2, torch.device("cpu"), torch.float64,
                      torch.Generator().manual_seed(0), 0.1, 200.0)
    assert torch.equal(flow.fixed_basis, small(1, basis="fixed", basis_seed=3).fixed_basis)
    assert flow.amplitudes == "normalised" and flow.u_rms == pytest.approx(2**-0.5)
