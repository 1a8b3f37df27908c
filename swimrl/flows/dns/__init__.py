r"""Pseudospectral DNS of forced 2D Navier-Stokes turbulence (paper eq. NSE, App. A).

Vorticity form on the bi-periodic box $[0, L)^2$ ($L = 2\pi$), batched over realisations:

$$
\partial_t\omega + \boldsymbol u\cdot\nabla\omega
= \nu\nabla^2\omega - \alpha(-\nabla^2)^{-h}\omega + f,\qquad
\boldsymbol u = (\partial_y\psi, -\partial_x\psi),\quad
\omega = \partial_x u_y - \partial_y u_x = -\nabla^2\psi.
$$

Modules (FourierFlows.jl style): :mod:`.grid` (rfft2 wavenumbers, 2/3 mask), :mod:`.params`,
:mod:`.state` (``omega_hat`` and the kinematics, :func:`flow_channels`), :mod:`.equation`
($L(k)$ and the advection term), :mod:`.forcing`, :mod:`.stepper` (ETDRK4, :class:`DNS`),
:mod:`.diagnostics`, :mod:`.spinup` (spin-up and measured scales), :mod:`.store` (zarr layout and
writer), :mod:`.integrity` (chunk checksums, checked reads, the per-snapshot finite / rms
checks), :mod:`.verify` (a whole store checked, ``swimrl-dns-verify``), :mod:`.run` (the run
behind ``swimrl-dns``), :mod:`.sources` (the snapshot sources of the replay: a stored run
:class:`~swimrl.flows.dns.sources.DNSStore`, several runs, a live DNS), :mod:`.flow`
(``flow=dns_replay`` and ``flow=dns``: their specs, builders and registry entries). See
``docs/dns.md``.
"""

from swimrl.flows.dns.forcing import SteadyForcing, StochasticForcing
from swimrl.flows.dns.grid import SpectralGrid, dealias_cutoff
from swimrl.flows.dns.params import DNSParams
from swimrl.flows.dns.state import (
    DNSState,
    flow_channels,
    random_state,
    state_from_vorticity,
    zero_state,
)
from swimrl.flows.dns.stepper import DNS, CFLError

__all__ = [
    "DNS",
    "CFLError",
    "DNSParams",
    "DNSState",
    "SpectralGrid",
    "SteadyForcing",
    "StochasticForcing",
    "dealias_cutoff",
    "flow_channels",
    "random_state",
    "state_from_vorticity",
    "zero_state",
]
