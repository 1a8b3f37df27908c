r"""Flows evaluated at the swimmers' positions, without a grid, in 2D or 3D.

A :class:`PointFlow` gives, for $F$ flow realisations and $S$ points in each,
$u_i(\boldsymbol x, t)$ ``(F, S, d)`` and
$A_{ij}(\boldsymbol x, t) = \partial_j u_i(\boldsymbol x, t)$ ``(F, S, d, d)``,
both analytic (no interpolation): the analytic flows of :mod:`swimrl.flows.analytic` and
the random-Fourier-mode 3D stochastic flow of :mod:`swimrl.flows.stochastic3d`. Each flow
keeps its own time $t$ (``(F,)``, float64) and its reference scales ``u_rms`` (the total
rms $\langle\boldsymbol u\cdot\boldsymbol u\rangle^{1/2}$, ``None`` where the flow has none)
and ``tau_k`` $= \langle A_{ij}A_{ij}\rangle^{-1/2}$, the conventions of the 2D flows
(:mod:`swimrl.flows.stochastic`). The swimmer's channels follow from
$(\boldsymbol u, \mathbb A)$ by its body (:meth:`swimrl.physics.body.Body.channels`).
"""

from __future__ import annotations

import torch


def vorticity(grad: torch.Tensor) -> torch.Tensor:
    r"""$\omega_i = \epsilon_{ijk}\,\partial_j u_k$ of a 3D gradient $A_{ij} = \partial_j u_i$
    ``(..., 3, 3)``: $(A_{zy} - A_{yz}, A_{xz} - A_{zx}, A_{yx} - A_{xy})$."""
    return torch.stack((grad[..., 2, 1] - grad[..., 1, 2], grad[..., 0, 2] - grad[..., 2, 0],
                        grad[..., 1, 0] - grad[..., 0, 1]), -1)


class PointFlow:
    """Base class: ``n_flows`` realisations of a flow evaluated at points.

    Subclasses set :attr:`dim`, :attr:`u_rms` and :attr:`tau_k` and implement
    :meth:`sample`; a time-dependent or random one extends :meth:`advance` and
    :meth:`reset` (which here only move and zero the clock).

    Parameters
    ----------
    n_flows
        $F$, the realisations.
    device, dtype
        Where and in which precision the fields are evaluated (times are float64).
    """

    #: Space dimension ``d`` (2 or 3).
    dim: int = 3
    #: Reference velocity: ``<u.u>^{1/2}`` (all components), ``None`` for a flow without one.
    u_rms: float | None = 1.0
    #: Kolmogorov time ``<A_ij A_ij>^{-1/2}`` (the 2D flows' convention).
    tau_k: float = 1.0
    #: The flow length (units of ``task.distance``): the flow's own length scale.
    ell_f: float = 1.0
    #: Swimmers start uniformly in ``[0, start_box)^d`` (units of the flow's length).
    start_box: float = 10.0
    #: The random generator of a random flow (set by the environment; None: not random).
    generator: torch.Generator | None = None

    def __init__(self, n_flows: int, device: torch.device | str, dtype: torch.dtype):
        self.n_flows = int(n_flows)
        self.device = torch.device(device)
        self.dtype = dtype
        self.time = torch.zeros(self.n_flows, device=self.device, dtype=torch.float64)

    # -- interface for subclasses -------------------------------------------------------------
    def sample(self, pos: torch.Tensor, flows: torch.Tensor | None = None
               ) -> tuple[torch.Tensor, torch.Tensor]:  # pragma: no cover - abstract
        r"""$(\boldsymbol u, \mathbb A)$ at ``pos`` ``(F', S, d)`` in the flows ``flows`` (indices
        ``(F',)``, all flows if None): $\boldsymbol u$ ``(F', S, d)``,
        $A_{ij} = \partial_j u_i$ ``(F', S, d, d)``."""
        raise NotImplementedError

    def compile_sampler(self) -> None:
        """Use a compiled :meth:`sample` where the flow has one (``kernel=compiled``; the
        analytic flows have none and stay eager)."""

    def advance(self, dt: float) -> None:
        r"""Move every flow from $t$ to $t + \delta t$."""
        self.time += dt

    def reset(self, flows: torch.Tensor | None = None) -> None:
        """New realisations where ``flows`` (bool ``(F,)``) is true (all if None): here the
        clock is set to 0."""
        if flows is None:
            self.time.zero_()
        else:
            self.time[flows] = 0.0

    # -- shared -------------------------------------------------------------------------------
    def velocity(self, pos: torch.Tensor, flows: torch.Tensor | None = None) -> torch.Tensor:
        r"""$\boldsymbol u(\boldsymbol x, t)$ ``(F', S, d)`` at ``pos`` ``(F', S, d)`` (see
        :meth:`sample`)."""
        return self.sample(pos, flows)[0]

    def velocity_gradient(self, pos: torch.Tensor, flows: torch.Tensor | None = None
                          ) -> torch.Tensor:
        r"""$A_{ij} = \partial_j u_i$ ``(F', S, d, d)`` at ``pos`` ``(F', S, d)`` (see
        :meth:`sample`)."""
        return self.sample(pos, flows)[1]

    def flow_index(self, pos: torch.Tensor, flows: torch.Tensor | None) -> torch.Tensor:
        """The flows' indices ``(F',)`` (``arange(F)`` if None), checked against ``pos``."""
        if flows is None:
            flows = torch.arange(self.n_flows, device=self.device)
        flows = torch.as_tensor(flows, device=self.device).reshape(-1)
        if pos.dim() != 3 or pos.shape[-1] != self.dim or pos.shape[0] != flows.numel():
            raise ValueError(f"positions of shape {tuple(pos.shape)}: expected "
                             f"({flows.numel()}, S, {self.dim}) (flows, points, dimension)")
        return flows

    def speed_bound(self) -> torch.Tensor | None:
        r"""An upper bound of $\max_{\boldsymbol x}|\boldsymbol u(\boldsymbol x, t)|$ of each flow
        now, ``(F,)``; None where the flow has none (a linear flow: $|\boldsymbol u|$ grows with
        $|\boldsymbol x|$)."""
        return None

    def measured_stats(self) -> dict[str, float | None]:
        """The reference scales ``u_rms`` (None for a flow without one: a linear flow has no
        velocity scale) and ``tau_K``."""
        return {"u_rms": None if self.u_rms is None else float(self.u_rms),
                "tau_K": float(self.tau_k)}

    def times(self, flows: torch.Tensor) -> torch.Tensor:
        """The flows' times ``(F', 1)`` in float64."""
        return self.time[flows].unsqueeze(-1)
