r"""Time stepping: ETDRK4 (Cox & Matthews 2002) with the stiff linear part treated exactly.

For $v' = Lv + N(v)$ with diagonal $L$ and step $h$ (Kassam & Trefethen 2005, eq. 26):

$$
\begin{aligned}
a &= E_2 v + Q\,N(v),\qquad b = E_2 v + Q\,N(a),\qquad c = E_2 a + Q\,(2N(b) - N(v)),\\
v_\mathrm{new} &= E v + f_1 N(v) + 2f_2\,(N(a) + N(b)) + f_3 N(c)
\end{aligned}
$$

with $E = e^{hL}$, $E_2 = e^{hL/2}$, $Q = (e^{hL/2} - 1)/L$,

$$
\begin{aligned}
f_1 &= h^{-2}L^{-3}\,[-4 - hL + e^{hL}(4 - 3hL + h^2L^2)],\\
f_2 &= h^{-2}L^{-3}\,[2 + hL + e^{hL}(-2 + hL)],\\
f_3 &= h^{-2}L^{-3}\,[-4 - 3hL - h^2L^2 + e^{hL}(4 - hL)],
\end{aligned}
$$

evaluated without cancellation by averaging over a complex contour around $hL$ (float64).
The scheme is exact for $N = 0$ ($v_\mathrm{new} = e^{hL}v$) and for constant $N$
($v_\mathrm{new} = e^{hL}v + (e^{hL} - 1)\,N/L$): hence the exact decay of single modes and
the exact steady state of the manufactured-solution test. Here $N$ = advection $+ f$ with
the forcing $f$ drawn once per step and held over the four stages.

CFL: before each step $C = \delta t\,\max_{\boldsymbol x}(|u_x| + |u_y|)/\delta x$ is checked
against ``cfl_max`` (default 1; the frozen-coefficient RK4 bound on the imaginary axis, 2.83,
over $k_\mathrm{max}\,\delta x = 2\pi/3$, gives 1.35) and :class:`CFLError` is raised instead
of stepping.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import torch

from swimrl.flows.dns.equation import Advection, linear_operator
from swimrl.flows.dns.forcing import SteadyForcing, StochasticForcing
from swimrl.flows.dns.grid import SpectralGrid
from swimrl.flows.dns.params import DNSParams
from swimrl.flows.dns.state import DNSState, zero_state


class CFLError(RuntimeError):
    """The CFL number exceeds ``cfl_max`` (or the flow is no longer finite)."""


def etdrk4_coefficients(L: torch.Tensor, h: float, n_contour: int = 64) -> dict[str, torch.Tensor]:
    r"""$E, E_2, Q, f_1, f_2, f_3$ for real diagonal $L$ (float64), by contour averaging.

    Each $\varphi(z)$ is the mean of $\varphi(z + r_j)$ over $r_j = \exp(i\pi(j - 1/2)/M)$,
    $j = 1, \dots, M$ on the unit circle (Kassam & Trefethen 2005), taking the real part.
    """
    L = L.double()
    r = torch.exp(1j * math.pi * (torch.arange(1, n_contour + 1, dtype=torch.float64) - 0.5)
                  / n_contour)
    lr = (h * L)[..., None] + r  # (..., M) complex
    e_lr = torch.exp(lr)
    q = h * ((torch.exp(lr / 2) - 1) / lr).mean(-1).real
    f1 = h * ((-4 - lr + e_lr * (4 - 3 * lr + lr**2)) / lr**3).mean(-1).real
    f2 = h * ((2 + lr + e_lr * (-2 + lr)) / lr**3).mean(-1).real
    f3 = h * ((-4 - 3 * lr - lr**2 + e_lr * (4 - lr)) / lr**3).mean(-1).real
    return {"E": torch.exp(h * L), "E2": torch.exp(h * L / 2), "Q": q, "f1": f1, "f2": f2,
            "f3": f3}


class ETDRK4:
    """ETDRK4 stepper for $v' = Lv + N(v)$; coefficients cast to the grid device.

    The coefficients are stored as complex tensors (real values): complex-by-complex products
    are faster than mixed real/complex ones in torch on CPU.
    """

    def __init__(self, L: torch.Tensor, dt: float, grid: SpectralGrid):
        self.dt = float(dt)
        c = etdrk4_coefficients(L, self.dt)
        c["f2"] = 2 * c["f2"]  # only 2 f2 is used
        self.coef = {k: v.to(grid.device, grid.complex_dtype) for k, v in c.items()}

    def step(
        self,
        v: torch.Tensor,
        n_v: torch.Tensor,
        nonlinear: Callable[[torch.Tensor], torch.Tensor],
    ) -> torch.Tensor:
        r"""One step from ``v`` given ``n_v`` $= N(v)$ (already evaluated); returns
        $v(t + \delta t)$."""
        c = self.coef
        e2v = c["E2"] * v
        a = (c["Q"] * n_v).add_(e2v)
        n_a = nonlinear(a)
        b = (c["Q"] * n_a).add_(e2v)
        n_b = nonlinear(b)
        cc = (c["Q"] * (2 * n_b).sub_(n_v)).add_(c["E2"] * a)
        n_c = nonlinear(cc)
        out = c["E"] * v
        out.add_(c["f1"] * n_v).add_(c["f2"] * n_a.add_(n_b)).add_(c["f3"] * n_c)
        return out


class DNS:
    r"""A batch of ``B`` independent DNS realisations advanced together.

    ``forcing``: ``None`` builds a :class:`StochasticForcing` with ``seeds`` (default
    ``0..B-1``) when ``epsilon > 0``; pass a :class:`SteadyForcing` for a deterministic one.
    ``advection_form``: ``"basdevant"`` (4 FFTs per evaluation, default) or ``"divergence"``
    (5 FFTs), see :class:`Advection`.
    After each step :attr:`last_forcing` holds the $\hat f$ used during that step.
    """

    def __init__(
        self,
        params: DNSParams,
        batch: int = 1,
        seeds: Sequence[int] | None = None,
        state: DNSState | None = None,
        forcing: StochasticForcing | SteadyForcing | None = None,
        advection_form: str = "basdevant",
    ):
        self.params = params
        self.grid = SpectralGrid(params.n, params.length, params.device, params.torch_dtype)
        if state is not None:
            batch = state.batch
        if seeds is None:
            seeds = list(range(batch))
        if len(seeds) != batch:
            raise ValueError(f"len(seeds)={len(seeds)} must equal the batch size {batch}")
        self.seeds = [int(s) for s in seeds]
        self.advection = Advection(self.grid, advection_form)
        self.linear = linear_operator(self.grid, params)
        self.stepper = ETDRK4(self.linear, params.dt, self.grid)
        if forcing is None and params.epsilon > 0:
            forcing = StochasticForcing(self.grid, params, self.seeds)
        self.forcing = forcing
        if state is None:
            state = zero_state(self.grid, batch)
        state.omega_hat = self.grid.truncate(state.omega_hat.to(self.grid.device,
                                                                self.grid.complex_dtype))
        self.state = state
        self.last_forcing: torch.Tensor | None = None
        self.last_cfl: float | None = None

    @property
    def dt(self) -> float:
        """Time step."""
        return self.params.dt

    def cfl_number(self, speed: torch.Tensor) -> torch.Tensor:
        r"""$C = \delta t\,\max_{\boldsymbol x}(|u_x| + |u_y|)/\delta x$ per realisation from
        ``speed``."""
        return speed * (self.params.dt / self.grid.spacing)

    def _check(self, speed: torch.Tensor) -> None:
        cfl = self.cfl_number(speed)
        worst = int(torch.argmax(torch.nan_to_num(cfl, nan=math.inf)))
        c = float(cfl[worst])
        self.last_cfl = c
        p = self.params
        where = f"at t={self.state.t:.6g} (step {self.state.step}, realisation {worst})"
        if not math.isfinite(c):
            raise CFLError(f"non-finite velocity {where}: the run has diverged; reduce dt")
        if c > p.cfl_max:
            raise CFLError(
                f"CFL number {c:.4g} exceeds the limit cfl_max={p.cfl_max:g} {where}: "
                f"dt={p.dt:.4g}, max(|u_x|+|u_y|)={float(speed[worst]):.4g}, "
                f"dx={self.grid.spacing:.4g}; reduce dt below {p.dt * p.cfl_max / c:.3g}"
            )

    def step(self, n_steps: int = 1) -> DNSState:
        """Advance all realisations by ``n_steps`` steps of size ``dt``; returns the state."""
        adv = self.advection
        for _ in range(int(n_steps)):
            s = self.state
            check = s.step % self.params.cfl_every == 0
            n_v, speed = adv(s.omega_hat, want_speed=check)
            if check:
                self._check(speed)
            f = self.forcing.draw(self.dt) if self.forcing is not None else None
            if f is None:
                def nonlinear(x: torch.Tensor) -> torch.Tensor:
                    return adv(x)[0]
            else:
                n_v = n_v + f

                def nonlinear(x: torch.Tensor, f: torch.Tensor = f) -> torch.Tensor:
                    return adv(x)[0] + f
            s.omega_hat = self.stepper.step(s.omega_hat, n_v, nonlinear)
            s.t += self.dt
            s.step += 1
            self.last_forcing = f
        return self.state

    def run(self, duration: float, callback: Callable[[DNS], None] | None = None) -> DNSState:
        """Advance by ``round(duration / dt)`` steps, calling ``callback(self)`` after each."""
        for _ in range(round(duration / self.dt)):
            self.step()
            if callback is not None:
                callback(self)
        return self.state
