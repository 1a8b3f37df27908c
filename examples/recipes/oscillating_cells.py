# examples/recipes/oscillating_cells.py
r"""A new flow for the swimrl commands, from outside the package: ``flow=oscillating_cells``.

The time-periodic cellular flow of Solomon & Gollub (1988, Phys. Rev. A 38, 6280): the steady
cells of ``flow=taylor_green`` swaying sideways, ``psi = (U/k) sin(k X) sin(k y)`` with
``X = x + b sin(Omega t + phi)``, which makes the paths between the cells chaotic; each
realisation draws its phase ``phi`` uniformly from the environment's generator:

    u = U (sin kX cos ky, -cos kX sin ky),
    A = d_j u_i = U k [[cos kX cos ky, -sin kX sin ky], [sin kX sin ky, -cos kX cos ky]].

Units as for every swimrl flow: ``u_rms = U / sqrt(2)``, ``tau_K = <A_ij A_ij>^{-1/2} = 1/(U k)``
at every time. The keys (``conf/flow/oscillating_cells.yaml`` next to this file):
``amplitude`` U, ``wavenumber`` k, ``oscillation`` b in cell widths (``pi/k``) and
``frequency`` Omega in units of ``1/tau_K``.

Importing this module registers the flow (:func:`swimrl.flows.registry.register_flow`). The
commands import it through Hydra: the flow's yaml pulls in ``conf/hooks/oscillating_cells.yaml``,
which names :class:`Registered` in ``hydra.callbacks``, and Hydra imports a callback's module
when the command starts (``PYTHONPATH`` must reach this file). Run as a script, it checks its
formulas (docs/recipes.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import torch
from hydra.experimental.callback import Callback

from swimrl.errors import as_float, one_of
from swimrl.flows.entry import POINT_KERNELS, FlowEntry
from swimrl.flows.pointwise import PointFlow
from swimrl.flows.registry import register_flow


class OscillatingCells(PointFlow):
    """The swaying cellular flow, evaluated at the swimmers (no grid)."""

    dim = 2

    def __init__(self, n_flows=1, amplitude=1.0, wavenumber=1.0, oscillation=0.3,
                 frequency=1.0, device="cpu", dtype=torch.float32):
        super().__init__(n_flows, device, dtype)
        self.amplitude, self.wavenumber = float(amplitude), float(wavenumber)
        self.u_rms = abs(self.amplitude) / math.sqrt(2.0)
        self.tau_k = 1.0 / (abs(self.amplitude) * self.wavenumber)
        self.sway = float(oscillation) * math.pi / self.wavenumber    # b, in flow lengths
        self.omega = float(frequency) / self.tau_k                     # Omega, in 1/time
        self.start_box = 2 * math.pi / self.wavenumber                 # one period of cells
        self._bound = torch.full((n_flows,), abs(self.amplitude), device=self.device,
                                 dtype=dtype)
        self.phase = torch.zeros(n_flows, device=self.device, dtype=torch.float64)

    def reset(self, flows=None):
        """New realisations (all, or where the bool ``flows`` is true): a new phase, t = 0."""
        super().reset(flows)
        new = torch.rand(self.n_flows, generator=self.generator, device=self.device,
                         dtype=torch.float64) * (2 * math.pi)
        self.phase.copy_(new if flows is None else torch.where(flows, new, self.phase))

    def speed_bound(self):
        return self._bound                                             # |u| <= |U|

    def sample(self, pos, flows=None):
        """``u`` ``(F', S, 2)`` and ``A_ij = d_j u_i`` ``(F', S, 2, 2)`` at ``pos``."""
        flows = self.flow_index(pos, flows)
        phase = self.omega * self.times(flows) + self.phase[flows].unsqueeze(-1)
        shift = self.sway * torch.sin(phase)                           # (F', 1), float64
        x = pos[..., 0] + shift.to(pos.dtype)
        k, amp = self.wavenumber, self.amplitude
        sx, cx = torch.sin(k * x), torch.cos(k * x)
        sy, cy = torch.sin(k * pos[..., 1]), torch.cos(k * pos[..., 1])
        u = amp * torch.stack((sx * cy, -cx * sy), -1)
        cc, ss = amp * k * cx * cy, amp * k * sx * sy
        grad = torch.stack((torch.stack((cc, -ss), -1), torch.stack((ss, -cc), -1)), -2)
        return u, grad


@dataclass(frozen=True)
class OscillatingCellsSpec:
    """The ``flow.*`` keys, checked on construction (one line naming a bad key)."""

    name: str
    amplitude: float
    wavenumber: float
    oscillation: float
    frequency: float

    def __post_init__(self):
        one_of("flow.name", self.name, ["oscillating_cells"])
        as_float("flow.amplitude", self.amplitude, lambda v: v != 0, "a non-zero number")
        as_float("flow.wavenumber", self.wavenumber, lambda v: v > 0, "> 0")
        as_float("flow.oscillation", self.oscillation, lambda v: v >= 0, ">= 0")
        as_float("flow.frequency", self.frequency, lambda v: True, "a finite number")


def build(spec, n_flows, device, dtype, generator, interval, duration):
    """The registry's builder: ``n_flows`` realisations (their phases drawn at each reset)."""
    return OscillatingCells(n_flows, spec.amplitude, spec.wavenumber, spec.oscillation,
                            spec.frequency, device, dtype)


register_flow(FlowEntry("oscillating_cells", OscillatingCellsSpec, build, 2,
                        kernels=POINT_KERNELS))


class Registered(Callback):
    """Named in ``hydra.callbacks``: Hydra imports this module (registering the flow) before
    the command starts; the callback itself does nothing."""


if __name__ == "__main__":  # python examples/recipes/oscillating_cells.py: check the formulas
    flow = OscillatingCells(1, amplitude=1.3, wavenumber=2.0, oscillation=0.3, frequency=0.7,
                            dtype=torch.float64)
    flow.reset()
    flow.advance(0.9)
    pos = torch.rand(1, 64, 2, dtype=torch.float64) * flow.start_box
    u, grad = flow.sample(pos)
    shift = flow.sway * math.sin(flow.omega * 0.9 + float(flow.phase[0]))
    k, amp, h = flow.wavenumber, flow.amplitude, 1e-5

    def psi(p):                                        # the stream function at time 0.9
        return amp / k * torch.sin(k * (p[..., 0] + shift)) * torch.sin(k * p[..., 1])

    def d(f, j):                                       # d/dx_j by central differences
        e = torch.zeros(2, dtype=torch.float64)
        e[j] = h
        return (f(pos + e) - f(pos - e)) / (2 * h)

    assert torch.allclose(u[..., 0], d(psi, 1), atol=1e-8)       # u_x = dpsi/dy
    assert torch.allclose(u[..., 1], -d(psi, 0), atol=1e-8)      # u_y = -dpsi/dx
    for j in (0, 1):                                              # A_ij = d_j u_i
        assert torch.allclose(grad[..., j], d(lambda p: flow.sample(p)[0], j), atol=1e-6)
    assert float(grad.diagonal(dim1=-2, dim2=-1).sum(-1).abs().max()) < 1e-12  # div u = 0
    n = 32                                             # u_rms, tau_K: averages over one period
    nodes = (torch.arange(n, dtype=torch.float64) + 0.5) * flow.start_box / n
    grid = torch.stack(torch.meshgrid(nodes, nodes, indexing="xy"), -1).reshape(1, -1, 2)
    u, grad = flow.sample(grid)
    u_rms = float(u.pow(2).sum(-1).mean().sqrt())
    tau_k = float(grad.pow(2).sum((-2, -1)).mean() ** -0.5)
    assert math.isclose(u_rms, flow.u_rms, rel_tol=1e-9)
    assert math.isclose(tau_k, flow.tau_k, rel_tol=1e-9)
    print(f"oscillating_cells: u = curl psi, A = grad u, div u = 0; u_rms = {u_rms:.4f}, "
          f"tau_K = {tau_k:.4f} (U / sqrt 2 = {flow.u_rms:.4f}, 1/(U k) = {flow.tau_k:.4f})")
