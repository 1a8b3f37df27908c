r"""The paper's stochastic flow carried to 3D, as random Fourier modes at the swimmers.

Units: $\ell_f = u_\mathrm{rms} = 1$, with
$u_\mathrm{rms} = \langle\boldsymbol u\cdot\boldsymbol u\rangle^{1/2}$ the rms of the whole
velocity vector (the 2D flow's default ``velocity_scale="total"``; one component has rms
$u_\mathrm{rms}/\sqrt3$), so $\tau_f = \mathrm{Ku}\,\ell_f/u_\mathrm{rms} = \mathrm{Ku}$.

Model. $\boldsymbol u = \nabla\times\boldsymbol a$,
$\boldsymbol a(\boldsymbol x, t) = \sum_{i=1}^{M} c_i(t)\,\boldsymbol a_i(\boldsymbol x)$, each
$\boldsymbol a_i$ a vector of three independent Gaussian fields with
$\langle a_i^p(\boldsymbol x)\,a_j^q(\boldsymbol x')\rangle
= \delta_{ij}\delta_{pq}\,B\exp(-r^2/2\ell^2)$, $r = |\boldsymbol x - \boldsymbol x'|$,
$B = u_\mathrm{rms}^2\ell^2/6$, and the coefficients of the 2D flow:
$\langle c_i(t)\,c_j(t')\rangle = \frac{\delta_{ij}}{M}\exp(-|t - t'|/\tau_f)$. $\boldsymbol u$ is
incompressible, Gaussian given the $c_i$ (as in 2D), statistically homogeneous and
isotropic, with ($f = \exp(-r^2/2\ell^2)$, :func:`velocity_covariance`)

$$
R_{ij}(\boldsymbol r) = \langle u_i(\boldsymbol x)\,u_j(\boldsymbol x + \boldsymbol r)\rangle
= \frac{u_\mathrm{rms}^2}{3}\,f\left[\Big(1 - \frac{r^2}{2\ell^2}\Big)\delta_{ij}
+ \frac{r_i r_j}{2\ell^2}\right]:
$$

longitudinal correlation $R_{LL}(r)/R_{LL}(0) = \exp(-r^2/2\ell^2)$, the Gaussian
correlation of length $\ell_f$ (the same as the 2D flow's: there, too, the velocity's
longitudinal correlation is the stream function's Gaussian). Moments (derivatives of $R$
at 0; $\langle A_{ij}A_{kl}\rangle = -\partial_j\partial_l R_{ik}(0)$,
:func:`gradient_covariance`):

* $\langle u_i u_j\rangle = \delta_{ij}\,u_\mathrm{rms}^2/3$,
  $\langle\boldsymbol u\cdot\boldsymbol u\rangle = u_\mathrm{rms}^2$;
* $\langle A_{ij}A_{kl}\rangle = \frac{u_\mathrm{rms}^2}{6\ell^2}\,(4\delta_{ik}\delta_{jl} -
  \delta_{ij}\delta_{kl} - \delta_{il}\delta_{jk})$ (the isotropic incompressible form;
  its contraction with $\delta_{ij}$ vanishes: $\mathrm{tr}\,\mathbb A = 0$);
  $\langle A_{ij}A_{ij}\rangle = 5u_\mathrm{rms}^2/\ell^2$, $\langle A_{ij}A_{ji}\rangle = 0$,
  so $\langle S_{ij}S_{ij}\rangle = \langle O_{ij}O_{ij}\rangle = 5/2$ and
  $\langle|\boldsymbol\omega|^2\rangle = 5$;
* $\tau_K = \langle A_{ij}A_{ij}\rangle^{-1/2} = \ell_f/(\sqrt5\,u_\mathrm{rms}) = 0.447$ (the
  2D flow's definition, $\tau_K = \ell_f/(2u_\mathrm{rms})$ there; here it equals
  $(2\langle S_{ij}S_{ij}\rangle)^{-1/2}$, the turbulence $(\nu/\varepsilon)^{1/2}$).

Representation (why not a grid: the paper's $h = \ell_f/40$ on a $10\,\ell_f$ box is
$400^3\times M\times 12$ values; a coarse grid would add an interpolation error to the
gradients that the swimmer reads). Each $\boldsymbol a_i$ is a sum of $K$ random Fourier modes,

$$
\boldsymbol a_i(\boldsymbol x) = \sqrt{B/K}\sum_{n=1}^{K}
\big[\boldsymbol\xi_n\cos(\boldsymbol k_n\cdot\boldsymbol x)
+ \boldsymbol\eta_n\sin(\boldsymbol k_n\cdot\boldsymbol x)\big],\qquad
\boldsymbol k_n\sim\mathcal N(0, \mathbb I/\ell^2),\quad
\boldsymbol\xi_n, \boldsymbol\eta_n\sim\mathcal N(0, \mathbb I_3),
$$

so $\boldsymbol u = \sum_{i,n} c_i\,[\boldsymbol P_n\cos(\boldsymbol k_n\cdot\boldsymbol x) +
\boldsymbol Q_n\sin(\boldsymbol k_n\cdot\boldsymbol x)]$ with
$\boldsymbol P_n = \sqrt{B/K}\,\boldsymbol k_n\times\boldsymbol\eta_n$ and
$\boldsymbol Q_n = -\sqrt{B/K}\,\boldsymbol k_n\times\boldsymbol\xi_n$, and
$A_{ij} = \sum c_i\,[Q_i\cos - P_i\sin]\,k_j$ analytically;
$\boldsymbol k_n\cdot\boldsymbol P_n = \boldsymbol k_n\cdot\boldsymbol Q_n = 0$, so
$\nabla\cdot\boldsymbol u = \mathrm{tr}\,\mathbb A = 0$ to round-off, mode by mode. The
wavevectors are drawn per realisation (with ``basis="redrawn"``). Its error:

* Over realisations (wavevectors, amplitudes, $c_i$) every second moment above is exact
  for any $K$ ($E[\cos(\boldsymbol k\cdot\boldsymbol r)] = \exp(-r^2/2\ell^2)$ for
  $\boldsymbol k\sim\mathcal N(0, \mathbb I/\ell^2)$).
* One realisation is Gaussian given its wavevectors, with the covariance
  $B K^{-1}\sum_n\cos(\boldsymbol k_n\cdot\boldsymbol r)$ per component of $\boldsymbol a_i$:
  exact at $r = 0$, with a random error of std $B\,(1 - f(r)^2)/\sqrt{2K}$ (at most
  $0.088\,B$ for $K = 64$). Its space averages are the mode sums
  (:meth:`StochasticFlow3D.realisation_moments`): per component field,
  $\langle\boldsymbol u\cdot\boldsymbol u\rangle$ has a relative spread $\sqrt{1.5/K}$ (0.15)
  and $\langle A_{ij}A_{ij}\rangle$ $\sqrt{5.3/K}$ (0.29) about 1 and 5; the $c_i$ spread
  $\sum_i c_i^2$ far more ($\sqrt{2/M} = 0.63$, as in 2D).
* The one-point law over realisations is a Gaussian scale mixture: a velocity component has
  excess kurtosis $6/M + 9/(MK)$; $6/M$ comes from the $c_i$ (the 2D flow has it too),
  $9/(MK) = 0.028$ ($M = 5$, $K = 64$) from the modes; Gaussian as $K$ grows.

Defaults: $M = 5$ (the paper's), $K = 64$ modes per component ($MK = 320$ per
realisation: the per-realisation spread of the flow's energy from the modes is a quarter of
that from the $c_i$; the cost is a $(S, 3)\times(3, MK)$ and two $(S, MK)\times(MK, 12)$
products per evaluation). The field is unbounded, not periodic: no box, no periodic images
(the 2D box adds images, $< 2e^{-12.5}$ in the covariance), positions need no wrapping;
phases $\boldsymbol k\cdot\boldsymbol x$ are evaluated in the flow's dtype (float32: an
absolute phase error about $6\times10^{-8}\,|\boldsymbol k|\,|\boldsymbol x|$,
$2\times10^{-5}$ at $|\boldsymbol x| = 100\,\ell_f$).

OU update (exact for any step, as in 2D):
$c(t + \delta t) = c\,e^{-\delta t/\tau_f} + \sqrt{(1 - e^{-2\delta t/\tau_f})/M}\;\xi$;
$c(0)\sim\mathcal N(0, 1/M)$.

``basis="redrawn"`` (default) draws new wavevectors and amplitudes with every realisation
(:meth:`~StochasticFlow3D.reset`); ``"fixed"`` draws one set from its own generator seeded
with ``basis_seed`` and gives it to every realisation, which then differ only by $c_i$
(the ensemble moments then hold on average over ``basis_seed``, as in 2D).

``flow=stochastic3d`` (:class:`Stochastic3DSpec`, ``conf/flow/stochastic3d.yaml``) builds it
through the flow registry (:mod:`swimrl.flows.registry`; the entry :data:`STOCHASTIC3D_ENTRY`).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import torch

from swimrl.conf_values import yaml_value
from swimrl.errors import as_float, as_int, keep_number_types, one_of
from swimrl.flows.entry import POINT_KERNELS, FlowEntry
from swimrl.flows.pointwise import PointFlow
from swimrl.flows.stochastic import OUCoefficients

#: Kolmogorov time ``<A_ij A_ij>^{-1/2}`` in units ``ell_f / u_rms`` (module docstring).
TAU_K = 1.0 / math.sqrt(5.0)
#: Default ``M``, the OU components (the paper's, as the 2D flow's ``n_modes``).
N_MODES: int = yaml_value("flow/stochastic3d", "n_modes")
#: Default ``K``, random Fourier modes per component.
N_WAVES = yaml_value("flow/stochastic3d", "n_waves")
#: Options of ``basis`` (first = default), as the 2D flow's.
BASIS_MODES = ("redrawn", "fixed")


def potential_amplitude(ell: float = 1.0, u_rms: float = 1.0) -> float:
    r"""$B = u_\mathrm{rms}^2\ell^2/6$: the variance of one component of $\boldsymbol a_i$ that
    gives $\langle\boldsymbol u\cdot\boldsymbol u\rangle = 6B/\ell^2 = u_\mathrm{rms}^2$."""
    return u_rms**2 * ell**2 / 6.0


def velocity_covariance(r: torch.Tensor, ell: float = 1.0, u_rms: float = 1.0) -> torch.Tensor:
    r"""The velocity covariance at separations ``r`` ``(..., 3)``: ``(..., 3, 3)``,

    $$
    R_{ij}(\boldsymbol r) = \langle u_i(\boldsymbol x)\,u_j(\boldsymbol x + \boldsymbol r)\rangle
    = \frac{u_\mathrm{rms}^2}{3}\,f\left[\Big(1 - \frac{r^2}{2\ell^2}\Big)\delta_{ij}
    + \frac{r_i r_j}{2\ell^2}\right],\qquad f = \exp(-r^2/2\ell^2).
    $$
    """
    s = (r * r).sum(-1, keepdim=True).unsqueeze(-1) / ell**2           # (..., 1, 1)
    eye = torch.eye(3, dtype=r.dtype, device=r.device)
    rr = r.unsqueeze(-1) * r.unsqueeze(-2) / (2 * ell**2)
    return (u_rms**2 / 3) * torch.exp(-0.5 * s) * ((1 - 0.5 * s) * eye + rr)


def gradient_covariance(ell: float = 1.0, u_rms: float = 1.0,
                        dtype: torch.dtype = torch.float64) -> torch.Tensor:
    r"""$\langle A_{ij}A_{kl}\rangle = \frac{u_\mathrm{rms}^2}{6\ell^2}\,(4\delta_{ik}\delta_{jl} -
    \delta_{ij}\delta_{kl} - \delta_{il}\delta_{jk})$ at one point, indexed ``[i, j, k, l]``
    ``(3, 3, 3, 3)``."""
    d = torch.eye(3, dtype=dtype)
    e = torch.einsum
    form = 4 * e("ik,jl->ijkl", d, d) - e("ij,kl->ijkl", d, d) - e("il,jk->ijkl", d, d)
    return u_rms**2 / (6 * ell**2) * form


def mode_sum(pos: torch.Tensor, k: torch.Tensor, table: torch.Tensor, c: torch.Tensor,
             n_waves: int) -> torch.Tensor:
    r"""$(\boldsymbol u, \mathbb A)$ flattened, ``(F', S, 12)``:
    $[w\cos(\boldsymbol k\cdot\boldsymbol x), w\sin(\boldsymbol k\cdot\boldsymbol x)]$ ``@ table``
    with the per-mode weight $w_n = c_{\lfloor n/K\rfloor}$ ($K$ = ``n_waves``), ``pos``
    ``(F', S, 3)``, ``k`` ``(F' or 1, MK, 3)``, ``table`` ``(F' or 1, 2MK, 12)``, ``c``
    ``(F', M)``."""
    w = c.repeat_interleave(n_waves, dim=-1).repeat(1, 2).unsqueeze(-2)  # (F', 1, 2MK)
    phase = pos @ k.transpose(-1, -2)                                    # (F', S, MK)
    return (torch.cat((torch.cos(phase), torch.sin(phase)), -1) * w) @ table


@functools.cache
def compiled_mode_sum():
    """:func:`mode_sum` compiled by ``torch.compile(fullgraph=True, dynamic=False)``: the
    phases, their cosines and sines and the weights fused into the products (one
    compilation per process and combination of shapes, ~10 s on the CPU). Agrees with
    :func:`mode_sum` to float32 round-off (``tests/test_flows3d.py``). Each new shape
    (batch, a fixed basis's ``(1, MK, 3)``), dtype or grad mode compiles again; past
    dynamo's recompile limit (8) a call runs eagerly with a warning: a run uses a few shapes
    (training and evaluation batches)."""
    return torch.compile(mode_sum, fullgraph=True, dynamic=False)


class StochasticFlow3D(OUCoefficients, PointFlow):
    r"""``n_flows`` realisations of the 3D stochastic flow at Kubo number ``kubo``.

    Each realisation has $M$ potential components of $K$ modes each (module docstring)
    and its coefficients $c_i$; :meth:`reset` redraws both for the selected flows (with
    ``basis="fixed"``: only the $c_i$). Bad values raise :class:`~swimrl.errors.ConfigError`
    naming ``flow.<keyword>``.

    Attributes: :attr:`wavevectors` ``(R, MK, 3)``; the velocity amplitudes
    :attr:`amp_cos` ($\boldsymbol P_n$) and :attr:`amp_sin` ($\boldsymbol Q_n$) and the
    potential's :attr:`pot_cos` ($\sqrt{B/K}\,\boldsymbol\xi_n$) and :attr:`pot_sin`
    ($\sqrt{B/K}\,\boldsymbol\eta_n$), all ``(R, MK, 3)``, mode $n$ belonging to component
    $\lfloor n/K\rfloor$; $R = F$ (redrawn) or 1 (fixed); :attr:`coeffs` ``(F, M)``.
    """

    dim: int = 3
    u_rms = 1.0
    ell_f = 1.0
    tau_k = TAU_K

    def __init__(
        self,
        n_flows: int,
        kubo: float,
        n_modes: int = N_MODES,
        n_waves: int = N_WAVES,
        device: torch.device | str = yaml_value("evaluate", "device"),
        dtype: torch.dtype = torch.float32,
        generator: torch.Generator | None = None,
        basis: str = yaml_value("flow/stochastic3d", "basis"),
        basis_seed: int = yaml_value("flow/stochastic3d", "basis_seed"),
    ):
        self.kubo = as_float("flow.kubo", kubo, lambda f: f > 0, "> 0")
        self.n_basis = as_int("flow.n_modes", n_modes)
        self.n_waves = as_int("flow.n_waves", n_waves)
        self.basis_mode = one_of("flow.basis", basis, BASIS_MODES)
        seed = as_int("flow.basis_seed", basis_seed, low=0)
        super().__init__(n_flows, device, dtype)
        self.tau_f = self.kubo * self.ell_f / self.u_rms
        self.generator = generator
        #: The mode sum of :meth:`sample`: :func:`mode_sum`, or compiled
        #: (:meth:`compile_sampler`).
        self._mode_sum = mode_sum
        n = self.n_basis * self.n_waves
        rows = 1 if self.basis_mode == "fixed" else self.n_flows
        shape = (rows, n, 3)
        self.wavevectors = torch.zeros(shape, device=self.device, dtype=dtype)
        self.pot_cos = torch.zeros(shape, device=self.device, dtype=dtype)
        self.pot_sin = torch.zeros(shape, device=self.device, dtype=dtype)
        self.amp_cos = torch.zeros(shape, device=self.device, dtype=dtype)
        self.amp_sin = torch.zeros(shape, device=self.device, dtype=dtype)
        #: ``[P_n, Q_n (x) k_n]`` over ``[Q_n, -P_n (x) k_n]`` ``(R, 2MK, 12)``: ``(u, A)`` is
        #: ``[w cos, w sin] @ table`` (:meth:`sample`).
        self.table = torch.zeros(rows, 2 * n, 12, device=self.device, dtype=dtype)
        #: ``sum_{n in i} (|P_n| + |Q_n|)`` of each component ``(R, M)`` (:meth:`speed_bound`).
        self.component_speed = torch.zeros(rows, self.n_basis, device=self.device, dtype=dtype)
        self.coeffs = torch.zeros(self.n_flows, self.n_basis, device=self.device, dtype=dtype)
        if self.basis_mode == "fixed":
            own = torch.Generator(device=self.device).manual_seed(seed)
            self._draw_modes(torch.zeros(1, dtype=torch.long, device=self.device), own)
        self.reset()

    # -- drawing ------------------------------------------------------------------------------
    def _randn(self, *shape: int, dtype=None, generator=None) -> torch.Tensor:
        return torch.randn(*shape, device=self.device, dtype=dtype or self.dtype,
                           generator=generator or self.generator)

    def _draw_modes(self, rows: torch.Tensor, generator: torch.Generator | None) -> None:
        """New wavevectors ``k ~ N(0, I/ell^2)`` and amplitudes ``xi, eta ~ N(0, I)`` of the
        basis ``rows``, drawn in float64, stored in the flow's dtype."""
        f64, n = torch.float64, self.wavevectors.shape[1]
        count = rows.numel()
        k = self._randn(count, n, 3, dtype=f64, generator=generator) / self.ell_f
        xi = self._randn(count, n, 3, dtype=f64, generator=generator)
        eta = self._randn(count, n, 3, dtype=f64, generator=generator)
        scale = math.sqrt(potential_amplitude(self.ell_f, self.u_rms) / self.n_waves)
        self.wavevectors[rows] = k.to(self.dtype)
        self.pot_cos[rows] = (scale * xi).to(self.dtype)
        self.pot_sin[rows] = (scale * eta).to(self.dtype)
        p = scale * torch.linalg.cross(k, eta)
        q = -scale * torch.linalg.cross(k, xi)
        self.amp_cos[rows] = p.to(self.dtype)
        self.amp_sin[rows] = q.to(self.dtype)

        def outer(a: torch.Tensor) -> torch.Tensor:  # a_n (x) k_n, flattened (i, j) -> 3 i + j
            return (a.unsqueeze(-1) * k.unsqueeze(-2)).flatten(-2)

        table = torch.cat((torch.cat((p, outer(q)), -1), torch.cat((q, -outer(p)), -1)), 1)
        self.table[rows] = table.to(self.dtype)
        speed = (p.norm(dim=-1) + q.norm(dim=-1)).unflatten(-1, (self.n_basis, self.n_waves))
        self.component_speed[rows] = speed.sum(-1).to(self.dtype)

    def reset(self, flows: torch.Tensor | None = None) -> None:
        """Redraw the modes (unless fixed) and ``c_i(0) ~ N(0, 1/M)`` of the flows where
        ``flows`` (bool ``(F,)``) is true (all if None); their clocks start at 0."""
        if flows is None:
            idx = torch.arange(self.n_flows, device=self.device)
        else:
            idx = torch.as_tensor(flows, device=self.device).nonzero().flatten()
        if idx.numel() == 0:
            return
        if self.basis_mode == "redrawn":
            self._draw_modes(idx, self.generator)
        self.coeffs[idx] = self._randn(idx.numel(), self.n_basis) / math.sqrt(self.n_basis)
        self.time[idx] = 0.0


    # -- evaluation ---------------------------------------------------------------------------
    def _modes(self, flows: torch.Tensor, coeffs: torch.Tensor | None):
        """Per-mode weights ``c_{n // K}`` ``(F', MK, 1)`` and the basis tensors of ``flows``
        (broadcast over flows for a fixed basis)."""
        c = (self.coeffs if coeffs is None else coeffs)[flows]
        w = c.repeat_interleave(self.n_waves, dim=-1).unsqueeze(-1)
        if self.wavevectors.shape[0] == 1:
            return w, self.wavevectors, self.amp_cos, self.amp_sin, self.pot_cos, self.pot_sin
        return (w, self.wavevectors[flows], self.amp_cos[flows], self.amp_sin[flows],
                self.pot_cos[flows], self.pot_sin[flows])

    def sample(self, pos: torch.Tensor, flows: torch.Tensor | None = None,
               coeffs: torch.Tensor | None = None) -> tuple[torch.Tensor, torch.Tensor]:
        r"""$\boldsymbol u$ ``(F', S, 3)`` and $A_{ij} = \partial_j u_i$ ``(F', S, 3, 3)`` at
        ``pos`` ``(F', S, 3)`` in ``flows`` (all if None), with the current coefficients (or
        ``coeffs`` ``(F, M)``):

        $$
        \boldsymbol u = \sum_n w_n\big(\boldsymbol P_n\cos\boldsymbol k_n\cdot\boldsymbol x
        + \boldsymbol Q_n\sin\boldsymbol k_n\cdot\boldsymbol x\big),\qquad
        A_{ij} = \sum_n w_n\big(Q_{ni}\cos\boldsymbol k_n\cdot\boldsymbol x
        - P_{ni}\sin\boldsymbol k_n\cdot\boldsymbol x\big)\,k_{nj},
        $$

        as one product
        $[w\cos(\boldsymbol k\cdot\boldsymbol x), w\sin(\boldsymbol k\cdot\boldsymbol x)]$ ``@``
        :attr:`table` ``(F', S, 12)``.
        """
        everything = flows is None
        flows = self.flow_index(pos, flows)
        c = self.coeffs if coeffs is None else coeffs
        rows_all = self.wavevectors.shape[0] == 1 or everything
        k = self.wavevectors if rows_all else self.wavevectors[flows]
        table = self.table if rows_all else self.table[flows]
        if not everything:
            c = c[flows]
        out = self._mode_sum(pos, k, table, c, self.n_waves)
        return out[..., :3], out[..., 3:].unflatten(-1, (3, 3))

    def compile_sampler(self) -> None:
        """Evaluate :meth:`sample` by :func:`compiled_mode_sum` (``kernel=compiled``)."""
        self._mode_sum = compiled_mode_sum()

    def velocity(self, pos: torch.Tensor, flows: torch.Tensor | None = None) -> torch.Tensor:
        r"""$\boldsymbol u$ alone (no gradient products), ``(F', S, 3)``."""
        flows = self.flow_index(pos, flows)
        w, k, p, q, _, _ = self._modes(flows, None)
        phase = pos @ k.transpose(-1, -2)
        return torch.cos(phase) @ (w * p) + torch.sin(phase) @ (w * q)

    def vector_potential(self, pos: torch.Tensor, flows: torch.Tensor | None = None
                         ) -> torch.Tensor:
        r"""$\boldsymbol a = \sum_i c_i\,\boldsymbol a_i(\boldsymbol x)$ ``(F', S, 3)``, whose curl
        is :meth:`velocity`."""
        flows = self.flow_index(pos, flows)
        w, k, _, _, xi, eta = self._modes(flows, None)
        phase = pos @ k.transpose(-1, -2)
        return torch.cos(phase) @ (w * xi) + torch.sin(phase) @ (w * eta)

    def realisation_moments(self) -> tuple[torch.Tensor, torch.Tensor]:
        r"""Space averages $\langle\boldsymbol u\cdot\boldsymbol u\rangle$ and
        $\langle A_{ij}A_{ij}\rangle$ of each flow at its current $c$, ``(F,)`` float64: the
        mode sums $\sum_n w_n^2\,(|\boldsymbol P_n|^2 + |\boldsymbol Q_n|^2)/2$ and the same
        with $|\boldsymbol k_n|^2$ (exact for distinct wavevectors, i.e. almost surely)."""
        flows = torch.arange(self.n_flows, device=self.device)
        w, k, p, q, _, _ = self._modes(flows, None)
        energy = 0.5 * (w.double().squeeze(-1) ** 2) * ((p.double() ** 2).sum(-1)
                                                         + (q.double() ** 2).sum(-1))
        return energy.sum(-1), (energy * (k.double() ** 2).sum(-1)).sum(-1)

    def measured_stats(self) -> dict[str, float]:
        r"""Averages over all flows of the space averages:
        $u_\mathrm{rms} = \langle\boldsymbol u\cdot\boldsymbol u\rangle^{1/2}$,
        $\tau_K = \langle A_{ij}A_{ij}\rangle^{-1/2}$ (the 2D flow's :meth:`measured_stats`)."""
        u2, a2 = self.realisation_moments()
        return {"u_rms": u2.mean().item() ** 0.5, "tau_K": a2.mean().item() ** -0.5}

    def speed_bound(self) -> torch.Tensor:
        r"""$\max_{\boldsymbol x}|\boldsymbol u(\boldsymbol x, t)|
        \le \sum_n |w_n|\,(|\boldsymbol P_n| + |\boldsymbol Q_n|)$ of each flow at its current
        coefficients, ``(F,)``
        ($|\boldsymbol P\cos + \boldsymbol Q\sin| \le |\boldsymbol P| + |\boldsymbol Q|$)."""
        return (self.coeffs.abs() * self.component_speed).sum(-1)


@dataclass(frozen=True)
class Stochastic3DSpec:
    r"""``flow=stochastic3d``: the 3D stochastic flow at Kubo number ``kubo`` (module
    docstring). Defaults from ``conf/flow/stochastic3d.yaml``.

    Parameters
    ----------
    kubo
        $\mathrm{Ku} = \tau_f u_\mathrm{rms}/\ell_f$.
    n_modes
        $M$, the OU components.
    n_waves
        $K$, the random Fourier modes per component.
    basis
        ``redrawn`` (new modes per flow and episode) or ``fixed`` (one set, ``basis_seed``).
    basis_seed
        The seed of the fixed modes.
    name
        The config group's name.
    """

    kubo: float
    n_modes: int = yaml_value("flow/stochastic3d", "n_modes")
    n_waves: int = yaml_value("flow/stochastic3d", "n_waves")
    basis: str = yaml_value("flow/stochastic3d", "basis")
    basis_seed: int = yaml_value("flow/stochastic3d", "basis_seed")
    name: str = yaml_value("flow/stochastic3d", "name")

    def __post_init__(self) -> None:
        as_float("flow.kubo", self.kubo, lambda v: v > 0, "> 0 (e.g. 0.1, 1, 10, 1e7)")
        as_int("flow.n_modes", self.n_modes)
        as_int("flow.n_waves", self.n_waves)
        one_of("flow.basis", self.basis, BASIS_MODES)
        as_int("flow.basis_seed", self.basis_seed, low=0)
        keep_number_types(self)


def _build(spec: Stochastic3DSpec, n_flows, device, dtype, generator, interval, duration
           ) -> StochasticFlow3D:
    return StochasticFlow3D(n_flows, spec.kubo, spec.n_modes, spec.n_waves, device=device,
                            dtype=dtype, generator=generator, basis=spec.basis,
                            basis_seed=spec.basis_seed)


def _bytes(spec: Stochastic3DSpec, n_flows: int, dtype: torch.dtype, interval: float) -> int:
    """Five ``(M K, 3)`` mode tables per realisation."""
    size = torch.empty((), dtype=dtype).element_size()
    return n_flows * spec.n_modes * spec.n_waves * 15 * size


#: ``flow=stochastic3d`` in the registry (:data:`swimrl.flows.registry.BUILTIN_FLOWS`).
STOCHASTIC3D_ENTRY = FlowEntry("stochastic3d", Stochastic3DSpec, _build, 3, table_bytes=_bytes,
                               kernels=(*POINT_KERNELS, "fused"))  # fused: heun3d_cpu.cpp
