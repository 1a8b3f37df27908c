"""Pseudospectral DNS of forced 2D Navier-Stokes turbulence (paper eq. NSE, App. A).

Vorticity form on the bi-periodic box ``[0, L)^2`` (``L = 2 pi``), batched over realisations:

``d_t omega + u . grad omega = nu lap omega - alpha (-lap)^{-h} omega + f``,
``u = (d_y psi, -d_x psi)``, ``omega = d_x u_y - d_y u_x = -lap psi``.

Modules (FourierFlows.jl style): :mod:`.grid` (rfft2 wavenumbers, 2/3 mask), :mod:`.params`,
:mod:`.state` (``omega_hat`` and the kinematics, :func:`flow_channels`), :mod:`.equation`
(``L(k)`` and the advection term), :mod:`.forcing`, :mod:`.stepper` (ETDRK4, :class:`DNS`),
:mod:`.diagnostics`, :mod:`.store` (zarr writer, :class:`DNSStore` reader), :mod:`.cli`
(``swimrl-dns``), :mod:`.plots`. See ``docs/dns.md``.
"""

from swimrl.flows.dns.forcing import SteadyForcing, StochasticForcing
from swimrl.flows.dns.grid import SpectralGrid, dealias_cutoff
from swimrl.flows.dns.params import DNSParamError, DNSParams
from swimrl.flows.dns.state import (
    DNSState,
    flow_channels,
    random_state,
    state_from_vorticity,
    zero_state,
)
from swimrl.flows.dns.stepper import DNS, CFLError
from swimrl.flows.dns.store import DNSStore

__all__ = [
    "DNS",
    "CFLError",
    "DNSParamError",
    "DNSParams",
    "DNSState",
    "DNSStore",
    "SpectralGrid",
    "SteadyForcing",
    "StochasticForcing",
    "dealias_cutoff",
    "flow_channels",
    "random_state",
    "state_from_vorticity",
    "zero_state",
]
