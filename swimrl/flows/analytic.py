r"""Analytic flows: a constant velocity gradient, Arnold-Beltrami-Childress, 2D Taylor-Green.

Each gives $\boldsymbol u(\boldsymbol x, t)$ and $A_{ij} = \partial_j u_i$ in closed form at
batched positions ``(F, S, d)`` (:class:`~swimrl.flows.pointwise.PointFlow`); reference scales
as in 2D: $u_\mathrm{rms} = \langle\boldsymbol u\cdot\boldsymbol u\rangle^{1/2}$ (all
components, space average) and $\tau_K = \langle A_{ij}A_{ij}\rangle^{-1/2}$.

* :class:`LinearFlow` (2D or 3D): $\boldsymbol u = \mathbb A\boldsymbol x$ with a constant
  matrix $\mathbb A$ (``flow.gradient``), incompressible: $\mathrm{tr}\,\mathbb A = 0$ is
  required (:func:`check_gradient`). No velocity scale (``u_rms = None``: $|\boldsymbol u|$
  grows with $|\boldsymbol x|$); $\tau_K = (A_{ij}A_{ij})^{-1/2}$. The exact test bed of
  Jeffery orbits (simple shear
  $\mathbb A = \begin{pmatrix}0&\gamma&0\\0&0&0\\0&0&0\end{pmatrix}$).
* :class:`ABCFlow` (3D): a superposition of ABC flows (Arnold 1965, Childress 1970; Dombre
  et al. 1986, J. Fluid Mech. 167, 353), term $(A, B, C, k)$:

    $$
    \begin{aligned}
    \boldsymbol u = \big(&A\sin(kz + \phi) + C\cos(ky + \phi),\\
    &B\sin(kx + \phi) + A\cos(kz + \phi),\\
    &C\sin(ky + \phi) + B\cos(kx + \phi)\big),
    \qquad \phi(t) = \epsilon\sin(\omega t).
    \end{aligned}
    $$

    With $\epsilon = 0$ it is steady: one term is the stationary ABC flow of Colabrese et al.
    2018 (Phys. Rev. Fluids 3, 084301; the default $A = B = C = k = 1$), two terms, with
    their parameters, the "stationary superposition of two ABC flows" of Gustavsson et al.
    2017 (Eur. Phys. J. E 40, 110). Both of those flows are steady; the time dependence
    here is the phase-modulated ABC flow of the kinematic-dynamo literature (Brummell,
    Cattaneo & Tobias 2001, Fluid Dyn. Res. 28, 237: every argument shifted by
    $\epsilon\sin(\omega t)$), i.e. the steady pattern translated by
    $-\frac{\phi}{k}(1, 1, 1)$: incompressible and Beltrami
    ($\nabla\times\boldsymbol u = k\boldsymbol u$ per term) at every $t$. Each term has
    $\langle|\boldsymbol u|^2\rangle = A^2 + B^2 + C^2$,
    $\langle A_{ij}A_{ij}\rangle = k^2(A^2 + B^2 + C^2)$; terms of equal $k$ add their
    amplitudes, terms of different $k$ their moments.
* :class:`TaylorGreenFlow` (2D, steady cellular flow):
  $\boldsymbol u = U(\sin kx\cos ky, -\cos kx\sin ky)$; $u_\mathrm{rms} = U/\sqrt2$,
  $\tau_K = 1/(Uk)$.

Each is a flow of the registry (:mod:`swimrl.flows.registry`): ``flow=linear``, ``flow=abc``,
``flow=taylor_green`` (``conf/flow/*.yaml``; their specs and entries ``LINEAR_ENTRY``,
``ABC_ENTRY``, ``TAYLOR_GREEN_ENTRY`` at the end of this module). Their realisations are
identical (the flows are deterministic); the swimmers start uniformly in
``[0, start_box)^d`` (one period of the periodic flows, the origin of the linear flow).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

import torch

from swimrl.conf_values import yaml_value
from swimrl.errors import fail, keep_number_types, require
from swimrl.flows.entry import POINT_KERNELS, FlowEntry
from swimrl.flows.pointwise import PointFlow

#: The config key of the linear flow's matrix, and what it may be.
GRADIENT_KEY = "flow.gradient"
GRADIENT_ALLOWED = ("a 2x2 or 3x3 matrix (a list of rows) of finite numbers with zero trace "
                    "(incompressible: A_11 + A_22 (+ A_33) = 0)")
#: ``|tr A|`` allowed, relative to ``max |A_ij|`` (decimal entries such as 0.1 + 0.2 - 0.3).
TRACE_TOLERANCE = 1e-9


def _plain(value):
    """``value`` as nested lists (tensors, arrays, ListConfig), for checking and a one-line
    message; anything else unchanged."""
    if hasattr(value, "tolist"):
        return value.tolist()
    if isinstance(value, str | bytes | Mapping) or not isinstance(value, Iterable):
        return value
    return [_plain(v) for v in value]


def _number(v) -> float:
    """A finite real number (not a bool), or NaN."""
    if isinstance(v, bool):
        return math.nan
    try:
        return float(v)
    except (TypeError, ValueError):
        return math.nan


def check_gradient(value) -> tuple[tuple[float, ...], ...]:
    r"""``value`` as a traceless $d\times d$ matrix, $d$ = 2 or 3, or a :class:`ConfigError`
    ``flow.gradient=VALUE is invalid: allowed a 2x2 or 3x3 matrix ... zero trace ...``.

    $|\mathrm{tr}\,\mathbb A| \le 10^{-9}\max|A_{ij}|$ passes (round-off of decimal entries)."""
    shown = _plain(value)
    rows = shown if isinstance(shown, list) else None
    ok = (rows is not None and len(rows) in (2, 3)
          and all(isinstance(r, list) and len(r) == len(rows) for r in rows))
    require(ok, GRADIENT_KEY, shown, GRADIENT_ALLOWED)
    matrix = tuple(tuple(_number(v) for v in r) for r in rows)
    finite = all(math.isfinite(v) for r in matrix for v in r)
    require(finite, GRADIENT_KEY, shown, GRADIENT_ALLOWED)
    trace = math.fsum(matrix[i][i] for i in range(len(matrix)))
    scale = max(abs(v) for r in matrix for v in r)
    if abs(trace) > TRACE_TOLERANCE * scale:
        fail(GRADIENT_KEY, shown, f"{GRADIENT_ALLOWED}; its trace is {trace:g}")
    return matrix


class LinearFlow(PointFlow):
    r"""$\boldsymbol u(\boldsymbol x) = \mathbb A\boldsymbol x$, $\partial_j u_i = A_{ij}$: a
    constant velocity gradient in 2D or 3D.

    ``gradient`` is checked by :func:`check_gradient` (key ``flow.gradient``); ``dim`` is
    its size. ``u_rms = None`` (no velocity scale), ``tau_k`` $= (A_{ij}A_{ij})^{-1/2}$
    (``inf`` for $\mathbb A = 0$).
    """

    u_rms = None
    start_box = 0.0

    def __init__(self, gradient, n_flows: int = 1, device: torch.device | str = "cpu",
                 dtype: torch.dtype = torch.float32):
        matrix = check_gradient(gradient)
        super().__init__(n_flows, device, dtype)
        self.dim = len(matrix)
        self.gradient = torch.tensor(matrix, device=self.device, dtype=dtype)
        norm2 = math.fsum(v * v for r in matrix for v in r)
        self.tau_k = norm2**-0.5 if norm2 > 0 else math.inf

    def sample(self, pos: torch.Tensor, flows: torch.Tensor | None = None
               ) -> tuple[torch.Tensor, torch.Tensor]:
        r"""$u_i = A_{ij}x_j$ ``(F', S, d)`` and $\mathbb A$ broadcast to ``(F', S, d, d)``."""
        self.flow_index(pos, flows)
        u = pos @ self.gradient.T
        return u, self.gradient.expand(*pos.shape[:2], self.dim, self.dim)


def _check_terms(terms) -> tuple[tuple[float, float, float, float], ...]:
    """ABC terms ``((A, B, C, k), ...)``: finite amplitudes, ``k > 0``; else ConfigError
    naming ``flow.terms``."""
    allowed = "a non-empty list of [A, B, C, k] with finite A, B, C and k > 0"
    shown = _plain(terms)
    ok = (isinstance(shown, list) and len(shown) > 0
          and all(isinstance(t, list) and len(t) == 4 for t in shown))
    require(ok, "flow.terms", shown, allowed)
    out = tuple(tuple(_number(v) for v in t) for t in shown)
    ok = all(math.isfinite(v) for t in out for v in t) and all(t[3] > 0 for t in out)
    require(ok, "flow.terms", shown, allowed)
    return out  # type: ignore[return-value]


class ABCFlow(PointFlow):
    r"""A superposition of (phase-modulated) Arnold-Beltrami-Childress flows in 3D.

    $$
    \boldsymbol u = \sum_\mathrm{terms}
    \big(A\sin Z + C\cos Y,\ B\sin X + A\cos Z,\ C\sin Y + B\cos X\big)
    $$

    with $X = kx + \phi$, $Y = ky + \phi$, $Z = kz + \phi$, $\phi = \epsilon\sin(\omega t)$
    (module docstring: forms and sources). ``terms = ((A, B, C, k), ...)``; ``modulation`` is
    $\epsilon$, ``frequency`` is $\omega$. The gradient, $A_{ij} = \partial_j u_i$, has a zero
    diagonal ($u_x$ depends on $y, z$ only, ...), so $\mathrm{tr}\,\mathbb A = 0$ exactly.
    """

    dim: int = 3

    def __init__(self, n_flows: int = 1, terms: Sequence = ((1.0, 1.0, 1.0, 1.0),),
                 modulation: float = 0.0, frequency: float = 0.0,
                 device: torch.device | str = "cpu", dtype: torch.dtype = torch.float32):
        self.terms = _check_terms(terms)
        self.modulation = _number(modulation)
        self.frequency = _number(frequency)
        require(math.isfinite(self.modulation), "flow.modulation", modulation, "a finite number")
        require(math.isfinite(self.frequency), "flow.frequency", frequency, "a finite number")
        super().__init__(n_flows, device, dtype)
        by_k: dict[float, list[float]] = {}
        for a, b, c, k in self.terms:
            s = by_k.setdefault(k, [0.0, 0.0, 0.0])
            s[0], s[1], s[2] = s[0] + a, s[1] + b, s[2] + c
        energy = {k: math.fsum(v * v for v in s) for k, s in by_k.items()}
        u2 = math.fsum(energy.values())
        a2 = math.fsum(k * k * e for k, e in energy.items())
        self.u_rms = math.sqrt(u2)
        self.tau_k = a2**-0.5 if a2 > 0 else math.inf
        self.start_box = 2 * math.pi / min(t[3] for t in self.terms)
        #: Half the longest period, $\pi/k_\min$ (``task=vertical``'s trapping scale).
        self.cell_size = math.pi / min(t[3] for t in self.terms)
        bound = math.fsum(math.hypot(abs(a) + abs(c), abs(b) + abs(a), abs(c) + abs(b))
                          for a, b, c, _ in self.terms)
        self._bound = torch.full((self.n_flows,), bound, device=self.device, dtype=dtype)

    def speed_bound(self) -> torch.Tensor:
        r"""$|\boldsymbol u| \le \sum_\mathrm{terms}\big|(|A| + |C|, |B| + |A|, |C| + |B|)\big|$,
        ``(F,)``."""
        return self._bound

    def phase(self, flows: torch.Tensor) -> torch.Tensor:
        r"""$\phi(t) = \epsilon\sin(\omega t)$ of the flows ``(F', 1)``, computed in float64."""
        return self.modulation * torch.sin(self.frequency * self.times(flows))

    def sample(self, pos: torch.Tensor, flows: torch.Tensor | None = None
               ) -> tuple[torch.Tensor, torch.Tensor]:
        r"""$\boldsymbol u$ ``(F', S, 3)`` and $A_{ij} = \partial_j u_i$ ``(F', S, 3, 3)`` at
        ``pos``."""
        flows = self.flow_index(pos, flows)
        phi = self.phase(flows).to(self.dtype).unsqueeze(-1)         # (F', 1, 1)
        u = torch.zeros_like(pos)
        grad = pos.new_zeros(*pos.shape, 3)
        for a, b, c, k in self.terms:
            arg = k * pos + phi
            s, co = torch.sin(arg), torch.cos(arg)
            sx, sy, sz = s.unbind(-1)
            cx, cy, cz = co.unbind(-1)
            u += torch.stack((a * sz + c * cy, b * sx + a * cz, c * sy + b * cx), -1)
            grad[..., 0, 1] -= c * k * sy
            grad[..., 0, 2] += a * k * cz
            grad[..., 1, 0] += b * k * cx
            grad[..., 1, 2] -= a * k * sz
            grad[..., 2, 0] -= b * k * sx
            grad[..., 2, 1] += c * k * cy
        return u, grad


class TaylorGreenFlow(PointFlow):
    r"""The steady 2D Taylor-Green (cellular) flow
    $\boldsymbol u = U(\sin kx\cos ky, -\cos kx\sin ky)$.

    $$
    \mathbb A = Uk\begin{pmatrix}\cos kx\cos ky & -\sin kx\sin ky\\
    \sin kx\sin ky & -\cos kx\cos ky\end{pmatrix};
    $$

    $u_\mathrm{rms} = U/\sqrt2$, $\tau_K = 1/(Uk)$, vorticity $\omega = 2Uk\sin kx\sin ky$.

    It is the cellular flow of the gyrotaxis papers (Durham et al. 2011; Colabrese et al.
    2017), $\boldsymbol u = (u_0/2)(-\cos kx'\sin kz', \sin kx'\cos kz')$,
    $\omega = \omega_0\cos kx'\cos kz'$ with $\omega_0 = u_0 k$, on the lattice shifted by
    $x' = x - \pi/2k$, $z' = y - \pi/2k$ ($y$ vertical), with $U = u_0/2$
    (:data:`GYROTAXIS_UNITS`). One vortex, :attr:`cell_size`, is $\pi/k$ wide.
    """

    dim: int = 2

    def __init__(self, n_flows: int = 1, amplitude: float = 1.0, wavenumber: float = 1.0,
                 device: torch.device | str = "cpu", dtype: torch.dtype = torch.float32):
        self.amplitude = _number(amplitude)
        self.wavenumber = _number(wavenumber)
        require(math.isfinite(self.amplitude), "flow.amplitude", amplitude, "a finite number")
        require(math.isfinite(self.wavenumber) and self.wavenumber > 0, "flow.wavenumber",
                wavenumber, "a finite number > 0")
        super().__init__(n_flows, device, dtype)
        self.u_rms = abs(self.amplitude) / math.sqrt(2.0)
        rate = abs(self.amplitude) * self.wavenumber
        self.tau_k = 1.0 / rate if rate > 0 else math.inf
        self.start_box = 2 * math.pi / self.wavenumber
        #: One vortex of the lattice, $\pi/k$ (``task=vertical``'s trapping scale).
        self.cell_size = math.pi / self.wavenumber
        self._bound = torch.full((self.n_flows,), abs(self.amplitude), device=self.device,
                                 dtype=dtype)

    def speed_bound(self) -> torch.Tensor:
        r"""$|\boldsymbol u| \le |U|$, ``(F,)``."""
        return self._bound

    def sample(self, pos: torch.Tensor, flows: torch.Tensor | None = None
               ) -> tuple[torch.Tensor, torch.Tensor]:
        r"""$\boldsymbol u$ ``(F', S, 2)`` and $A_{ij} = \partial_j u_i$ ``(F', S, 2, 2)`` at
        ``pos``."""
        self.flow_index(pos, flows)
        amp, k = self.amplitude, self.wavenumber
        sx, sy = torch.sin(k * pos).unbind(-1)
        cx, cy = torch.cos(k * pos).unbind(-1)
        u = amp * torch.stack((sx * cy, -cx * sy), -1)
        cc, ss = amp * k * cx * cy, amp * k * sx * sy
        grad = torch.stack((torch.stack((cc, -ss), -1), torch.stack((ss, -cc), -1)), -2)
        return u, grad


#: The flows on which the gyrotaxis numbers $\Phi = v_s/u_0$ and $\Psi = B\omega_0$
#: (``swimmer.phi``, ``swimmer.psi``) are defined: ``(u_0/u_\mathrm{rms}, \omega_0\tau_K)``.
#: Taylor-Green: $u_0 = 2U$, $u_\mathrm{rms} = U/\sqrt2$, $\omega_0 = 2Uk$, $\tau_K = 1/(Uk)$,
#: so $v_s/u_\mathrm{rms} = 2\sqrt2\,\Phi$ and $B/\tau_K = \Psi/2$.
GYROTAXIS_UNITS: dict[str, tuple[float, float]] = {"taylor_green": (2 * math.sqrt(2.0), 2.0)}


# -- the registry's entries (flow=linear | abc | taylor_green) ---------------------------------
@dataclass(frozen=True)
class LinearSpec:
    r"""``flow=linear``: $\boldsymbol u = \mathbb A\boldsymbol x$ with $\mathbb A$ =
    ``flow.gradient`` ($2\times2$ or $3\times3$, traceless, not zero:
    $\tau_K = (A_{ij}A_{ij})^{-1/2}$ is the time unit). Defaults from
    ``conf/flow/linear.yaml``."""

    gradient: tuple = yaml_value("flow/linear", "gradient")
    name: str = yaml_value("flow/linear", "name")

    def __post_init__(self) -> None:
        matrix = check_gradient(self.gradient)
        require(any(v != 0 for r in matrix for v in r), GRADIENT_KEY, _plain(self.gradient),
                "a non-zero matrix (tau_K = (A_ij A_ij)^-1/2 is the unit of time)")
        object.__setattr__(self, "gradient", matrix)


@dataclass(frozen=True)
class ABCSpec:
    """``flow=abc``: superposed, optionally phase-modulated ABC flows (:class:`ABCFlow`).
    Defaults from ``conf/flow/abc.yaml``."""

    terms: tuple = yaml_value("flow/abc", "terms")
    modulation: float = yaml_value("flow/abc", "modulation")
    frequency: float = yaml_value("flow/abc", "frequency")
    name: str = yaml_value("flow/abc", "name")

    def __post_init__(self) -> None:
        object.__setattr__(self, "terms", _check_terms(self.terms))
        for key in ("modulation", "frequency"):
            value = getattr(self, key)
            require(not isinstance(value, bool) and math.isfinite(_number(value)),
                    f"flow.{key}", value, "a finite number")
        keep_number_types(self)


@dataclass(frozen=True)
class TaylorGreenSpec:
    """``flow=taylor_green``: the steady 2D cellular flow (:class:`TaylorGreenFlow`).
    Defaults from ``conf/flow/taylor_green.yaml``."""

    amplitude: float = yaml_value("flow/taylor_green", "amplitude")
    wavenumber: float = yaml_value("flow/taylor_green", "wavenumber")
    name: str = yaml_value("flow/taylor_green", "name")

    def __post_init__(self) -> None:
        amp, k = _number(self.amplitude), _number(self.wavenumber)
        require(math.isfinite(amp) and amp != 0, "flow.amplitude", self.amplitude,
                "a finite non-zero number")
        require(math.isfinite(k) and k > 0, "flow.wavenumber", self.wavenumber,
                "a finite number > 0")
        keep_number_types(self)


def _linear_dimension(flow) -> int:
    return len(flow["gradient"] if isinstance(flow, Mapping) else flow.gradient)


#: ``flow=linear`` in the registry (:data:`swimrl.flows.registry.BUILTIN_FLOWS`).
LINEAR_ENTRY = FlowEntry(
    "linear", LinearSpec,
    lambda spec, n, device, dtype, generator, interval, duration:
    LinearFlow(spec.gradient, n, device, dtype), _linear_dimension,
    kernels=POINT_KERNELS)
#: ``flow=abc`` in the registry.
ABC_ENTRY = FlowEntry(
    "abc", ABCSpec,
    lambda spec, n, device, dtype, generator, interval, duration:
    ABCFlow(n, spec.terms, spec.modulation, spec.frequency, device, dtype), 3,
    kernels=POINT_KERNELS)
#: ``flow=taylor_green`` in the registry.
TAYLOR_GREEN_ENTRY = FlowEntry(
    "taylor_green", TaylorGreenSpec,
    lambda spec, n, device, dtype, generator, interval, duration:
    TaylorGreenFlow(n, spec.amplitude, spec.wavenumber, device, dtype), 2,
    kernels=POINT_KERNELS)
