r"""The short-time optimum for approaching a target, against brute force.

With ``e = (X - x)/rho`` the unit vector from the swimmer to the target ``X``, ``rho = |X - x|``
(the frame of ``compute_signals(q, theta, X - x, tau_K)``, so ``n_theta = n.(z x e)``) and
``e' = -(I - e e).x'/rho``:

``rho' = -e.x'``,  ``rho'' = (|x'|^2 - (e.x')^2)/rho - e.x''``,
``x'' = (x'.grad) u + d_t u + v_s theta' p``,  ``theta' = omega/2 + Lambda S_np``.

``x' = u + v_s n`` does not depend on ``Lambda``, hence neither do ``rho'``, the rotating-frame
term ``(|x'|^2 - (e.x')^2)/rho`` and the flow terms ``(x'.grad) u + d_t u``; with ``e.p = -n_theta``
the only ``Lambda`` in ``rho(t + dt) = rho + dt rho' + dt^2 rho''/2 + O(dt^3)`` is

``(v_s dt^2/2) Lambda n_theta S_np``,

minimised over ``|Lambda| <= Lambda_max`` by ``Lambda = -Lambda_max sign(n_theta) sign(S_np)``:
the paper's ``eq:sto`` with the frame pointing at the target (``ShortTimeOptimal``).

The brute force integrates ``swimmer_rhs`` (RK4, fine substeps, ``Lambda`` held) over one
interval ``dt`` from random states in random time-dependent incompressible flows,
``psi = sum_m A_m sin(k_m.x + phi_m - Omega_m t)`` (``|k_m|`` in ``[0.5, 2]``,
``Omega_m ~ N(0, 1)``), normalised to ``<d_i u_j d_i u_j> = sum_m A_m^2 |k_m|^4/2 = 1``, i.e.
``tau_K = 1`` (``u_rms`` between about 0.5 and 2); ``v_s = 1``, targets at distance 1 to 20.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import pytest
import torch

from swimrl.physics.body2d import compute_signals
from swimrl.physics.swimmer import swimmer_rhs
from swimrl.policies.baselines import N_THETA, S_NP, ShortTimeOptimal

SHAPE_FACTOR_MAX = 0.98
SWIM_SPEED = 1.0
TAU_K = 1.0  # the flows below are normalised to it
N_MODES = 4
F64 = torch.float64


@dataclass(frozen=True)
class FourierFlows:
    """One flow per state: ``psi = sum_m amp_m sin(k_m.x + phase_m - freq_m t)``, shapes
    ``(n, M, 2)`` for ``k`` and ``(n, M)`` for the rest."""

    k: torch.Tensor
    amp: torch.Tensor
    phase: torch.Tensor
    freq: torch.Tensor

    @classmethod
    def random(cls, n: int, gen: torch.Generator) -> FourierFlows:
        kmag = 0.5 + 1.5 * torch.rand(n, N_MODES, generator=gen, dtype=F64)
        angle = 2 * math.pi * torch.rand(n, N_MODES, generator=gen, dtype=F64)
        amp = torch.randn(n, N_MODES, generator=gen, dtype=F64)
        amp = amp / torch.sqrt((amp**2 * kmag**4).sum(-1, keepdim=True) / 2)  # tau_K = 1
        return cls(
            k=torch.stack((kmag * torch.cos(angle), kmag * torch.sin(angle)), -1),
            amp=amp,
            phase=2 * math.pi * torch.rand(n, N_MODES, generator=gen, dtype=F64),
            freq=torch.randn(n, N_MODES, generator=gen, dtype=F64) / TAU_K,
        )

    def channels(self, pos: torch.Tensor, t: float) -> torch.Tensor:
        """``(u_x, u_y, S_xx, S_xy, omega)`` at ``pos`` ``(n, g, 2)``: ``u = (psi_y, -psi_x)``,
        ``S_xx = psi_xy``, ``S_xy = (psi_yy - psi_xx)/2``, ``omega = -lap psi``."""
        arg = torch.einsum("ngd,nmd->ngm", pos, self.k) + (self.phase - self.freq * t)[:, None]
        kx, ky = self.k[:, None, :, 0], self.k[:, None, :, 1]
        c, s = self.amp[:, None] * torch.cos(arg), self.amp[:, None] * torch.sin(arg)
        psi_xx, psi_yy, psi_xy = -(kx * kx * s), -(ky * ky * s), -(kx * ky * s)
        return torch.stack(
            (
                (ky * c).sum(-1),
                -(kx * c).sum(-1),
                psi_xy.sum(-1),
                0.5 * (psi_yy - psi_xx).sum(-1),
                -(psi_xx + psi_yy).sum(-1),
            ),
            -1,
        )


def integrate(flows: FourierFlows, pos, theta, shape_factor, dt: float, n_sub: int):
    """RK4 of ``swimmer_rhs`` over ``[0, dt]`` in ``n_sub`` steps; arrays ``(n, g[, 2])``."""
    n, g = shape_factor.shape
    h = dt / n_sub

    def rhs(x, th, t):
        q = flows.channels(x, t).reshape(n * g, 5)
        vel, rate = swimmer_rhs(q, th.reshape(-1), shape_factor.reshape(-1), SWIM_SPEED)
        return vel.reshape(n, g, 2), rate.reshape(n, g)

    t = 0.0
    for _ in range(n_sub):
        v1, w1 = rhs(pos, theta, t)
        v2, w2 = rhs(pos + h / 2 * v1, theta + h / 2 * w1, t + h / 2)
        v3, w3 = rhs(pos + h / 2 * v2, theta + h / 2 * w2, t + h / 2)
        v4, w4 = rhs(pos + h * v3, theta + h * w3, t + h)
        pos = pos + h / 6 * (v1 + 2 * v2 + 2 * v3 + v4)
        theta = theta + h / 6 * (w1 + 2 * w2 + 2 * w3 + w4)
        t += h
    return pos, theta


@dataclass(frozen=True)
class BruteForce:
    """Random states, their signals, the rule's ``Lambda`` and the final distance
    ``rho`` ``(n, g)`` for each ``Lambda`` of ``grid``."""

    signals: torch.Tensor
    rule: torch.Tensor
    grid: torch.Tensor
    rho: torch.Tensor

    @classmethod
    def run(cls, n: int, dt: float, n_sub: int, n_grid: int, seed: int) -> BruteForce:
        gen = torch.Generator().manual_seed(seed)
        flows = FourierFlows.random(n, gen)
        pos0 = 20 * torch.rand(n, 2, generator=gen, dtype=F64) - 10
        theta0 = 2 * math.pi * torch.rand(n, generator=gen, dtype=F64)
        dist = 1 + 19 * torch.rand(n, generator=gen, dtype=F64)
        phi = 2 * math.pi * torch.rand(n, generator=gen, dtype=F64)
        target = pos0 + dist[:, None] * torch.stack((torch.cos(phi), torch.sin(phi)), -1)

        q0 = flows.channels(pos0[:, None], 0.0)[:, 0]
        signals = compute_signals(q0, theta0, target - pos0, TAU_K)
        rule = ShortTimeOptimal(SHAPE_FACTOR_MAX)(signals)[:, 0]

        grid = torch.linspace(-SHAPE_FACTOR_MAX, SHAPE_FACTOR_MAX, n_grid, dtype=F64)
        lam = grid.expand(n, n_grid)
        pos, _ = integrate(
            flows, pos0[:, None].expand(n, n_grid, 2), theta0[:, None].expand(n, n_grid),
            lam, dt, n_sub,
        )
        return cls(signals, rule, grid, (target[:, None] - pos).norm(dim=-1))

    @property
    def n_theta_s_np(self) -> torch.Tensor:
        """``n_theta S_np tau_K``."""
        return self.signals[:, N_THETA] * self.signals[:, S_NP]

    def agrees(self) -> torch.Tensor:
        """Whether the grid's argmin of ``rho`` is the bound the rule picks."""
        best = self.rho.argmin(-1)
        bound = torch.where(self.rule > 0, len(self.grid) - 1, 0)
        return best == bound


@pytest.mark.parametrize(("dt", "n_sub", "min_kept"), [(0.01, 4, 0.8), (0.1, 20, 0.25)])
def test_rule_is_the_brute_force_optimum_over_short_intervals(dt, n_sub, min_kept):
    """For ``|n_theta S_np| tau_K > 2 dt/tau_K`` the ``Lambda`` (of 197 in ``[-0.98, 0.98]``) that
    brings the swimmer closest to the target is the rule's bound.

    The threshold: the ``O(dt^3)`` terms of ``rho(t + dt)`` linear in ``Lambda`` are not
    proportional to ``n_theta S_np`` (``-v_s n_r omega Lambda S_np``,
    ``-v_s Lambda S_np e.(grad u).p``, ``2 v_s Lambda S_np x'.p/rho`` carry ``S_np`` alone,
    ``v_s n_theta Lambda D S_np/Dt`` carries ``n_theta`` alone), so they can outweigh
    ``(v_s dt^2/2) Lambda n_theta S_np`` where ``|n_theta S_np| = O(dt/tau_K)`` (flow rates of
    order ``1/tau_K``). Over 10^4 states the largest ``|n_theta S_np| tau_K`` at which the rule
    failed was ``0.3 dt`` (dt = 0.01) and ``0.8 dt`` (dt = 0.1): 2 leaves a margin; the states kept
    (``min_kept``) are most of them at dt = 0.01, about a third at dt = 0.1."""
    bf = BruteForce.run(n=600, dt=dt * TAU_K, n_sub=n_sub, n_grid=197, seed=1)
    kept = bf.n_theta_s_np.abs() > 2 * dt
    assert kept.double().mean() > min_kept
    assert bf.agrees()[kept].all()
    assert (bf.rule[kept].abs() == SHAPE_FACTOR_MAX).all()


def test_shape_enters_at_second_order_with_the_derived_coefficient():
    """``rho(Lambda_max) - rho(-Lambda_max) = v_s Lambda_max dt^2 n_theta S_np + O(dt^3)``: the
    residual falls by 10^3 when ``dt`` does by 10 (a ``Lambda`` term at first order, or a wrong
    coefficient at second, would leave a residual falling by 10 or 100), on every state."""
    residual = []
    for dt in (1e-2, 1e-3):
        bf = BruteForce.run(n=600, dt=dt * TAU_K, n_sub=2, n_grid=2, seed=2)
        diff = bf.rho[:, 1] - bf.rho[:, 0]
        predicted = SWIM_SPEED * SHAPE_FACTOR_MAX * dt**2 * bf.n_theta_s_np / TAU_K
        assert diff.abs().max() > 1e-2 * dt**2  # the prediction is not trivially small
        residual.append((diff - predicted).abs().max().item())
        assert residual[-1] < 2 * dt**3
    assert residual[0] / residual[1] > 500


def test_rule_is_not_the_optimum_over_long_intervals():
    """Over ``dt = 2 tau_K`` the held ``Lambda`` that gets closest is not the short-time rule's
    for a large fraction of states (45 % of these, 31 % of those with
    ``|n_theta S_np| tau_K > 0.2``; 40-48 % over five seeds): the rule is short-time optimal
    only."""
    bf = BruteForce.run(n=300, dt=2 * TAU_K, n_sub=100, n_grid=21, seed=3)
    assert bf.agrees().double().mean() < 0.75
    assert bf.agrees()[bf.n_theta_s_np.abs() > 0.2].double().mean() < 0.85
