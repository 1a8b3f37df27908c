r"""Flows as time-dependent linear combinations of gridded basis fields.

Every flow in swimrl has the form

$$
q(\boldsymbol x, t) = \sum_{m=1}^{M} c_m(t)\,Q_m(\boldsymbol x)
$$

where $q = (u_x, u_y, S_{xx}, S_{xy}, \omega)$ are the five channels the swimmer needs and
$Q_m$ are node values on a periodic grid. The stochastic flow (paper Sec. II B) has $M$
stream-function components with Ornstein-Uhlenbeck $c_m$; a stored DNS run has two
snapshots with linear-in-time weights $(1 - a, a)$. Sampling interpolates the $5M$
channels at the points (bilinear, :mod:`swimrl.flows.interpolation`) and contracts with
$c_m(t)$; the domain is periodically extended so swimmers move in the unbounded plane.
"""

from __future__ import annotations

import torch

from swimrl.flows.grid import PeriodicGrid
from swimrl.flows.interpolation import bilinear_periodic

CHANNELS: tuple[str, ...] = ("u_x", "u_y", "S_xx", "S_xy", "omega")
"""The five flow channels every flow provides, in this order."""
N_CHANNELS = len(CHANNELS)


def gradient_norm2(q: torch.Tensor) -> torch.Tensor:
    r"""$A_{ij}A_{ij}$ with $A_{ij} = \partial_j u_i$ from channels:
    $2S_{xx}^2 + 2S_{xy}^2 + \omega^2/2$.

    (2D incompressible: $\partial_x u_x = -\partial_y u_y = S_{xx}$,
    $\partial_y u_x = S_{xy} - \omega/2$, $\partial_x u_y = S_{xy} + \omega/2$.)
    """
    return 2 * q[..., 2] ** 2 + 2 * q[..., 3] ** 2 + 0.5 * q[..., 4] ** 2


def field_stats(q: torch.Tensor, weights: torch.Tensor | None = None) -> dict[str, float]:
    r"""$u_\mathrm{rms} = \langle\boldsymbol u\cdot\boldsymbol u\rangle^{1/2}$ and
    $\tau_K = \langle A_{ij}A_{ij}\rangle^{-1/2}$ of node values ``q`` ``(R, n, n, 5)``: the
    mean over all nodes, or with ``weights`` ``(R,)`` the weighted mean of the per-row means."""
    u2, a2 = q[..., 0] ** 2 + q[..., 1] ** 2, gradient_norm2(q)
    if weights is None:
        return {"u_rms": u2.mean().item() ** 0.5, "tau_K": a2.mean().item() ** -0.5}
    w = weights / weights.sum()
    return {"u_rms": (w * u2.mean((1, 2))).sum().item() ** 0.5,
            "tau_K": (w * a2.mean((1, 2))).sum().item() ** -0.5}


def max_speed(q: torch.Tensor) -> torch.Tensor:
    r"""$\max_{\boldsymbol x}|\boldsymbol u(\boldsymbol x)| = \max_j (u_x^2 + u_y^2)^{1/2}$ over
    the nodes of channels ``q``
    ``(..., n, n, M, 5)``: ``(..., M)``, one value per basis field."""
    return (q[..., 0] ** 2 + q[..., 1] ** 2).amax(dim=(-3, -2)).sqrt()


class GriddedFlow:
    r"""Base class: ``n_flows`` independent realisations of
    $q(\boldsymbol x, t) = \sum_m c_m(t)\,Q_m(\boldsymbol x)$.

    Subclasses fill :attr:`basis` (``(R, n, n, M, 5)``, float) and :attr:`coeffs`
    (``(R, M)``) and implement :meth:`advance` and :meth:`reset`. A basis row is one
    realisation; several flows may share a row (a replay in which they replay the same run
    from the same time): :meth:`rows` maps flows to rows (the identity by default,
    $R = F$). ``u_rms`` and ``tau_k`` are the flow's reference scales (ensemble values) in
    its own units. A new flow is a subclass (``docs/extending.md``).

    Parameters
    ----------
    grid
        The periodic node grid of the basis fields.
    n_flows
        $F$, the realisations.
    n_basis
        $M$, the basis fields per realisation.
    device, dtype
        Where and in which precision the basis is kept.
    n_rows
        $R$, the basis rows (default $F$).
    """

    u_rms: float = 1.0
    tau_k: float = 1.0

    @property
    def ell_f(self) -> float:
        r"""The flow length $\ell_f$ (units of targets, :mod:`swimrl.task`):
        $2u_\mathrm{rms}\tau_K$, the stochastic flow's relation
        $\tau_K = \ell_f/(2u_\mathrm{rms})$, which a flow with its own correlation length
        (:class:`~swimrl.flows.stochastic.StochasticFlow`) overrides."""
        return 2.0 * self.u_rms * self.tau_k

    def __init__(self, grid: PeriodicGrid, n_flows: int, n_basis: int, device, dtype,
                 n_rows: int | None = None):
        self.grid = grid
        self.n_flows = int(n_flows)
        self.n_basis = int(n_basis)
        self.device = torch.device(device)
        self.dtype = dtype
        n = grid.n
        rows = self.n_flows if n_rows is None else int(n_rows)
        self.basis = torch.zeros(rows, n, n, n_basis, N_CHANNELS, device=self.device, dtype=dtype)
        self.coeffs = torch.zeros(rows, n_basis, device=self.device, dtype=dtype)
        self.time = torch.zeros(n_flows, device=self.device, dtype=torch.float64)
        #: ``max_x |u|`` of each basis field, ``(R, M)``: kept current by the subclasses
        #: (:meth:`refresh_mode_speed` after they write :attr:`basis`) for :meth:`speed_bound`.
        self.mode_speed = torch.zeros(rows, n_basis, device=self.device, dtype=dtype)

    # -- interface for subclasses -------------------------------------------------------------
    def advance(self, dt: float) -> None:  # pragma: no cover - abstract
        r"""Advance the coefficients (and, where needed, the basis) from $t$ to $t + \delta t$."""
        raise NotImplementedError

    def reset(self, flows: torch.Tensor | None = None) -> None:  # pragma: no cover - abstract
        """Draw new realisations where ``flows`` (bool ``(F,)``) is true (all if None)."""
        raise NotImplementedError

    def rows(self, flow_index: torch.Tensor) -> torch.Tensor:
        """Basis row (index into :attr:`table` blocks and :attr:`coeffs`) of each flow in
        ``flow_index``; valid until the next :meth:`reset` or :meth:`coefficient_path`."""
        return flow_index

    def coefficient_path(self, n_steps: int, dt: float) -> torch.Tensor:
        r"""Coefficients of the basis rows at $t, t + \delta t, \dots, t + N\delta t$
        ($N$ = ``n_steps``): ``(n_steps + 1, R, M)``.

        Advances the flow to $t + N\delta t$ (as ``n_steps`` calls of :meth:`advance`).
        """
        path = [self.coeffs.clone()]
        for _ in range(n_steps):
            self.advance(dt)
            path.append(self.coeffs.clone())
        return torch.stack(path)

    def refresh_mode_speed(self, rows: torch.Tensor | None = None) -> None:
        """Recompute :attr:`mode_speed` of the basis ``rows`` (all if None), a row at a time."""
        rows = range(self.basis.shape[0]) if rows is None else rows.reshape(-1).tolist()
        for r in rows:
            self.mode_speed[r] = max_speed(self.basis[r])

    def speed_bound(self, path: torch.Tensor) -> torch.Tensor:
        r"""Upper bound of the flow speed over the times of a coefficient ``path``
        ``(K, R, M)``, per basis row ``(R,)``:

        $$
        \max_{\boldsymbol x, k}|\boldsymbol u(\boldsymbol x, t_k)|
        \le \max_k \sum_m |c_m(t_k)|\,\max_{\boldsymbol x}|Q_m(\boldsymbol x)|,
        $$

        exact for the sampled flow too, since bilinear interpolation is a convex combination
        of node values.
        """
        return (path.abs() * self.mode_speed).sum(-1).amax(0)

    # -- sampling -----------------------------------------------------------------------------
    @property
    def table(self) -> torch.Tensor:
        """Basis as a ``(R * n * n, M * 5)`` row table for gathers."""
        return self.basis.view(-1, self.n_basis * N_CHANNELS)

    def sample(
        self, flow_index: torch.Tensor, pos: torch.Tensor, coeffs: torch.Tensor | None = None
    ) -> torch.Tensor:
        r"""Channels $q(\boldsymbol x, t)$, ``(P, 5)``, at ``pos`` ``(P, 2)`` in flows
        ``flow_index``.

        $q = \sum_m c_m(t)\,I[Q_m](\boldsymbol x)$ with $I$ the bilinear periodic interpolant
        and $c$ the current coefficients of the basis rows (or ``coeffs``, ``(R, M)``).
        """
        c = self.coeffs if coeffs is None else coeffs
        rows = self.rows(flow_index)
        return sample_basis(self.table, self.grid.n, self.grid.spacing, rows, c, pos)

    def grid_fields(self, flows: torch.Tensor | None = None, stride: int = 1) -> torch.Tensor:
        r"""Current node values $q_j(t) = \sum_m c_m(t)\,Q_m(\boldsymbol x_j)$ of ``flows`` (all if
        None) on every ``stride``-th node: ``(len(flows), n/stride, n/stride, 5)``."""
        if flows is None:
            flows = torch.arange(self.n_flows, device=self.device)
        r = self.rows(torch.as_tensor(flows, device=self.device).reshape(-1))
        basis = self.basis[:, ::stride, ::stride].index_select(0, r)
        return torch.einsum("fm,fyxmc->fyxc", self.coeffs[r], basis)

    def measured_stats(self) -> dict[str, float]:
        r"""Grid averages over all flows:
        $u_\mathrm{rms} = \langle\boldsymbol u\cdot\boldsymbol u\rangle^{1/2}$,
        $\tau_K = \langle A_{ij}A_{ij}\rangle^{-1/2}$."""
        return field_stats(self.grid_fields().double())


def sample_basis(
    table: torch.Tensor,
    n: int,
    spacing: float,
    flow_index: torch.Tensor,
    coeffs: torch.Tensor,
    pos: torch.Tensor,
) -> torch.Tensor:
    r"""$q(\boldsymbol x) = \sum_m c_m\,I[Q_m](\boldsymbol x)$ from a ``(F n n, M 5)`` table;
    returns ``(P, 5)``."""
    m = coeffs.shape[-1]
    rows = bilinear_periodic(table, n, flow_index, pos, spacing)
    if m == 1:
        return rows * coeffs[flow_index]
    rows = rows.view(-1, m, N_CHANNELS)
    return (coeffs[flow_index].unsqueeze(-1) * rows).sum(1)
