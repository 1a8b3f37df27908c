r"""Integrate all swimmers over one decision interval ($K = T_u/\delta t$ Heun steps).

The flow enters through a coefficient path $c(t_k)$, $k = 0, \dots, K$, drawn beforehand so
the kernel itself is deterministic and free of random-number calls:
$q(\boldsymbol x, t_k) = \sum_m c_m(t_k)\,I[Q_m](\boldsymbol x)$ ($I$ bilinear periodic
interpolation).

Three implementations with the same arithmetic:

* ``eager`` – :func:`integrate_interval`, plain torch ops on all swimmers at once (any device;
  the reference);
* ``fused`` – ``swimrl/physics/kernels/heun_cpu.cpp``, one pass per swimmer over the $K$
  steps with everything in registers (CPU; built on first use). Tested against the reference.
* ``compiled`` – :func:`integrate_interval` traced once by ``torch.compile(fullgraph=True)``
  (:func:`compiled_interval`): the $2K$ stages of gathers and pointwise arithmetic become a
  handful of generated kernels (Triton on CUDA, C++ on the CPU) instead of ~30 launches per
  stage; no graph break, so the call can sit inside a CUDA-graph capture. The default on CUDA
  (``kernel=auto``); on the CPU the hand-fused kernel is faster (``benchmarks/bench_env.py``:
  2.5x at 4096 swimmers), so ``auto`` keeps it there.

The 3D stochastic flow (:mod:`swimrl.flows.stochastic3d`, evaluated at the swimmers, no grid)
has its own fused CPU kernel, :func:`integrate_interval_3d_fused`
(``swimrl/physics/kernels/heun3d_cpu.cpp``): the $K$ steps of
:func:`~swimrl.physics.swimmer3d.heun_step_3d` per swimmer, the mode sum vectorised over the
modes, with the same coefficient-path contract (``kernel=fused`` of
:class:`~swimrl.env.PointSwimmerEnv`).

Every kernel is free of host synchronisation: no ``.item()``, no branch on a tensor value.
"""

from __future__ import annotations

import functools
import math

import torch

from swimrl.errors import one_of, require
from swimrl.flows.base import sample_basis
from swimrl.physics.kernels import load_cpu_kernel, load_cpu_kernel_3d
from swimrl.physics.swimmer import heun_step


def integrate_interval(
    table: torch.Tensor,
    coeff_path: torch.Tensor,
    flow_index: torch.Tensor,
    pos: torch.Tensor,
    theta: torch.Tensor,
    shape_factor: torch.Tensor,
    kicks: torch.Tensor | None,
    n: int,
    spacing: float,
    swim_speed: float,
    dt: float,
    extra_rate=None,
) -> tuple[torch.Tensor, torch.Tensor]:
    r"""Advance ``(pos, theta)`` by $K$ Heun steps of size ``dt`` with $\Lambda$ fixed.

    ``table`` is the flow basis ``(F n n, M 5)``, ``coeff_path`` ``(K+1, F, M)`` the
    coefficients at the step times, ``kicks`` ``(K, P)`` rotational-noise increments or None;
    ``extra_rate(theta)`` a further $\mathrm d\theta/\mathrm dt$ (the gyrotactic torque,
    :mod:`swimrl.physics.gyrotaxis`; only this kernel takes it).
    """
    stage = [0]

    def sample(p: torch.Tensor) -> torch.Tensor:
        return sample_basis(table, n, spacing, flow_index, coeff_path[stage[0]], p)

    def advance() -> None:
        stage[0] += 1

    for k in range(coeff_path.shape[0] - 1):
        kick = None if kicks is None else kicks[k]
        pos, theta = heun_step(sample, advance, pos, theta, shape_factor, swim_speed, dt, kick,
                               extra_rate)
    return pos, theta


def integrate_interval_fused(
    table, coeff_path, flow_index, pos, theta, shape_factor, kicks, n, spacing, swim_speed, dt
) -> tuple[torch.Tensor, torch.Tensor]:
    """Same contract as :func:`integrate_interval`, with the fused CPU kernel."""
    ext = load_cpu_kernel()
    if ext is None:
        raise RuntimeError("the fused CPU kernel could not be built; use kernel=eager")
    pos = pos.contiguous().clone()
    theta = theta.contiguous().clone()
    dtype = table.dtype
    ext.integrate_interval_cpu(
        table.contiguous(),
        coeff_path.to(dtype).contiguous(),
        flow_index.contiguous(),
        pos,
        theta,
        shape_factor.to(dtype).expand(theta.shape).contiguous(),
        None if kicks is None else kicks.to(dtype).contiguous(),
        int(n),
        float(spacing),
        float(swim_speed),
        float(dt),
    )
    return pos, theta


def integrate_interval_3d_fused(
    wavevectors: torch.Tensor,
    table: torch.Tensor,
    coeff_path: torch.Tensor,
    rows: torch.Tensor,
    flows: torch.Tensor,
    pos: torch.Tensor,
    orientation: torch.Tensor,
    shape_factor: torch.Tensor,
    rot_noise: torch.Tensor | None,
    n_waves: int,
    swim_speed: float,
    dt: float,
    rot_diffusion: float = 0.0,
) -> tuple[torch.Tensor, torch.Tensor]:
    r"""Advance ``(pos, orientation)`` ``(P, 3)`` of swimmers in the 3D stochastic flow by
    ``len(coeff_path) - 1`` steps of :func:`~swimrl.physics.swimmer3d.heun_step_3d`, $\Lambda$
    held, in the fused CPU kernel (``swimrl/physics/kernels/heun3d_cpu.cpp``); returns new
    tensors (the inputs are kept).

    The flow is that of :class:`~swimrl.flows.stochastic3d.StochasticFlow3D`:
    ``wavevectors`` ``(R, MK, 3)`` and ``table`` ``(R, 2MK, 12)`` of its basis rows
    (``n_waves`` modes per component), ``coeff_path`` ``(steps + 1, F, M)`` its coefficients at
    the step times (stage 1 of step $k$ at $t_k$, stage 2 at $t_{k+1}$), ``rows`` and
    ``flows`` ``(P,)`` each swimmer's basis row and flow. ``rot_noise`` ``(steps, P, 3)``: the
    standard normal numbers of :func:`~swimrl.physics.swimmer3d.rotational_diffusion` at each
    step (None: no noise), ``rot_diffusion`` $D_r$. Float32 or float64 CPU tensors.

    The kernel evaluates the terms of :func:`~swimrl.flows.stochastic3d.mode_sum` (equal to
    round-off), vectorised over the modes $n$, with $\phi_n = \boldsymbol k_n\cdot\boldsymbol x$:
    $\boldsymbol u = \sum_n w_n(\boldsymbol P_n\cos\phi_n + \boldsymbol Q_n\sin\phi_n)$,
    $A_{ij} = \sum_n w_n(Q_{ni}\cos\phi_n - P_{ni}\sin\phi_n)\,k_{nj}$; swimmers in runs of
    one flow (an environment's ``(F, S)`` batch) share the layout of their flow's modes.
    """
    ext = load_cpu_kernel_3d()
    if ext is None:
        raise RuntimeError("the fused 3D CPU kernel could not be built; use kernel=eager or "
                           "kernel=compiled")
    dtype = pos.dtype
    pos = pos.reshape(-1, 3).to(dtype).contiguous().clone()
    orientation = orientation.reshape(-1, 3).to(dtype).contiguous().clone()
    lam = torch.as_tensor(shape_factor, dtype=dtype).expand(pos.shape[:1]).contiguous()
    a = -math.expm1(-2.0 * (rot_diffusion * dt))  # as heun_step_3d's
    ext.integrate_interval_3d_cpu(
        wavevectors.to(dtype).contiguous(),
        table.to(dtype).contiguous(),
        coeff_path.to(dtype).contiguous(),
        rows.to(torch.int64).contiguous(),
        flows.to(torch.int64).contiguous(),
        pos,
        orientation,
        lam,
        None if rot_noise is None else rot_noise.to(dtype).reshape(-1, pos.shape[0], 3)
        .contiguous(),
        int(n_waves),
        float(swim_speed),
        float(dt),
        a,
    )
    return pos, orientation


@functools.cache
def compiled_interval():
    """:func:`integrate_interval` compiled by ``torch.compile(fullgraph=True, dynamic=False)``
    (one compilation per process and per combination of shapes, dtype and scalar arguments;
    ~30-60 s on the CPU, a few seconds on a GPU). ``fullgraph=True``: a graph break raises
    instead of silently splitting the interval into eager pieces."""
    return torch.compile(integrate_interval, fullgraph=True, dynamic=False)


def integrate_interval_compiled(
    table, coeff_path, flow_index, pos, theta, shape_factor, kicks, n, spacing, swim_speed, dt
) -> tuple[torch.Tensor, torch.Tensor]:
    """Same contract as :func:`integrate_interval`, through :func:`compiled_interval`."""
    return compiled_interval()(table, coeff_path, flow_index, pos, theta,
                               shape_factor.to(table.dtype), kicks, int(n), float(spacing),
                               float(swim_speed), float(dt))


KERNELS = ("auto", "eager", "fused", "compiled")


def select_kernel(name: str, device: torch.device, torque: bool = False):
    """The integration function for ``kernel=name``. ``auto``: ``fused`` on the CPU when it
    builds (else ``eager``), ``compiled`` on any other device. ``torque``: the swimmer feels a
    gyrotactic torque, which only ``eager`` integrates (``auto`` picks it; ``fused`` and
    ``compiled`` refuse in one line)."""
    one_of("kernel", name, KERNELS)
    if torque:
        require(name in ("auto", "eager"), "kernel", name,
                "'auto' or 'eager' for a gyrotactic swimmer (swimmer.bottom_heaviness set): "
                "only the eager kernel integrates its torque")
        return integrate_interval
    if name == "compiled" or (name == "auto" and device.type != "cpu"):
        return integrate_interval_compiled
    if name == "eager" or device.type != "cpu":
        require(name != "fused", "kernel", name,
                f"'auto', 'eager' or 'compiled' on device={device}")
        return integrate_interval
    if name == "auto" and load_cpu_kernel() is None:
        return integrate_interval
    return integrate_interval_fused
