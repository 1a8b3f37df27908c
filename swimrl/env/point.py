r"""The environment of a flow evaluated at the swimmers' positions
(:class:`~swimrl.flows.pointwise.PointFlow`: the analytic flows and the 3D stochastic flow):
:class:`PointSwimmerEnv`, holding its :class:`~swimrl.physics.body.Body` (2D or 3D), with no
grid and no dimension of its own."""

from __future__ import annotations

import torch

from swimrl.conf_values import yaml_value
from swimrl.env.core import SwimmerEnv
from swimrl.env.params import EnvParams
from swimrl.errors import IntegrityError, one_of, require
from swimrl.flows.pointwise import PointFlow
from swimrl.flows.registry import POINT_KERNELS
from swimrl.flows.stochastic3d import StochasticFlow3D
from swimrl.physics.body import Body
from swimrl.physics.point_integrator import (
    integrate_point_interval,
    integrate_point_interval_fused,
)


class PointSwimmerEnv(SwimmerEnv):
    r"""The swimmers of :class:`~swimrl.env.core.SwimmerEnv` in a flow evaluated at their
    positions (:class:`~swimrl.flows.pointwise.PointFlow`), made by
    :func:`~swimrl.env.build.build_env` for such a flow.

    The flow is unbounded: positions are not wrapped (the image counts stay 0), swimmers start
    uniformly in the cube ``[0, flow.start_box)^d`` (at the origin for a linear flow). The
    body (:attr:`body`, the flow's dimension's unless given) gives the orientation
    (:attr:`orientation`: the angle in 2D, the unit vector in 3D), the channels from
    $(\boldsymbol u, \mathbb A)$, the signals, the draws and the Heun step. Every decision
    integrates ``T_u / dt`` Heun steps eagerly
    (:func:`~swimrl.physics.point_integrator.integrate_point_interval`);
    ``kernel=compiled`` (``auto`` on a GPU) evaluates the 3D stochastic flow by its compiled
    mode sum; ``kernel=fused`` (the 3D stochastic flow on the CPU) runs the whole interval in
    the fused C++ kernel
    (:func:`~swimrl.physics.point_integrator.integrate_point_interval_fused`).
    """

    def __init__(self, flow: PointFlow, n_swimmers: int, params: EnvParams,
                 generator: torch.Generator | None = None,
                 kernel: str = yaml_value("evaluate", "kernel"), ic_blocks: int = 1,
                 body: Body | None = None):
        super().__init__(flow, n_swimmers, params, generator=generator, kernel=kernel,
                         ic_blocks=ic_blocks, body=body)

    @staticmethod
    def velocity_unit(flow) -> float:
        """``u_rms`` of the flow, or ``ell_f / tau_K`` for a flow without one (linear)."""
        return flow.u_rms if flow.u_rms is not None else flow.ell_f / flow.tau_k

    def _select_kernel(self, kernel: str, device: torch.device):
        """``compiled`` (and ``auto`` on a device other than the CPU): the flow's compiled
        sampler where it has one (:meth:`~swimrl.flows.pointwise.PointFlow.compile_sampler`);
        the Heun steps stay eager (returns None). ``fused``: the 3D stochastic flow on the CPU
        only, the interval in
        :func:`~swimrl.physics.point_integrator.integrate_point_interval_fused` (returned).
        ``auto`` on the CPU stays eager (the committed 3D records' path)."""
        one_of("kernel", kernel, (*POINT_KERNELS, "fused"))
        if kernel == "fused":
            require(self.body.extra_rate is None, "kernel", kernel,
                    "one of ['auto', 'eager', 'compiled'] for a gyrotactic swimmer "
                    "(swimmer.bottom_heaviness set): the fused kernel has no torque")
            require(isinstance(self.flow, StochasticFlow3D), "kernel", kernel,
                    "one of ['auto', 'eager', 'compiled'] for this flow (fused: "
                    "flow=stochastic3d on the CPU)")
            require(device.type == "cpu", "kernel", kernel,
                    f"one of ['auto', 'eager', 'compiled'] on device={device} (fused: the CPU)")
            require(self.flow.dtype in (torch.float32, torch.float64), "kernel", kernel,
                    f"one of ['auto', 'eager', 'compiled'] with dtype {self.flow.dtype} "
                    "(fused: float32 or float64)")
            return integrate_point_interval_fused
        if kernel == "compiled" or (kernel == "auto" and device.type != "cpu"):
            self.flow.compile_sampler()
        return None

    def displacement(self) -> torch.Tensor:
        """``x - x_0`` ``(F, S, d)``: positions are not wrapped."""
        return self.pos - self.start_pos

    def start_position(self) -> torch.Tensor:
        return self.start_pos

    def length_resolution(self) -> float:
        return self.flow.ell_f

    def _wrap(self) -> None:
        """Nothing: the flow is unbounded."""

    def start_box(self) -> float:
        """The side of the cube ``[0, flow.start_box)^d`` the swimmers start in."""
        return float(self.flow.start_box)

    def _channels(self, pos: torch.Tensor) -> torch.Tensor:
        """The body's flow channels at ``pos`` ``(F, S, d)``, ``(F, S, c)``."""
        u, grad = self.flow.sample(pos)
        return self.body.channels(u, grad)

    def flow_velocity(self) -> torch.Tensor:
        """The flow's velocity at the swimmers, ``(F, S, d)``."""
        return self.flow.sample(self.pos)[0]

    def signals(self, displacement: torch.Tensor | None = None) -> torch.Tensor:
        """All the body's signals (:attr:`signal_names`) in the task's frame."""
        return self.body.signals(self._channels(self.pos), self.orientation,
                                 self.frame(displacement), self.tau_k)

    def _track_speed(self) -> None:
        bound = self.flow.speed_bound()
        if bound is not None:
            torch.maximum(self.max_flow_speed, bound.to(self.max_flow_speed.dtype),
                          out=self.max_flow_speed)

    def integrate(self, shape_factor: torch.Tensor) -> None:
        """``T_u / dt`` Heun steps of the body, the flow advanced between the stages,
        ``Lambda`` ``(F * S,)`` held, the flow's speed bound tracked after each step
        (:func:`~swimrl.physics.point_integrator.integrate_point_interval`, or the fused
        kernel)."""
        lam = shape_factor.view(*self.batch_size)
        self._track_speed()
        common = (self._advance, self._track_speed, self.pos, self.orientation, lam,
                  self.swim_speed, self.dt, self.params.n_substeps, self.params.rot_diffusion,
                  self.tau_k, self.generator)
        if self._kernel is not None:
            pos, orient = self._kernel(self.flow, self._flow_index, *common)
        else:
            pos, orient = integrate_point_interval(self.body, self._channels, *common)
        self.pos.copy_(pos.view_as(self.pos))
        self.orientation.copy_(orient.view_as(self.orientation))

    def _advance(self) -> None:
        self.flow.advance(self.dt)

    def check_displacement(self, slack: float = 1e-3) -> None:
        """:meth:`SwimmerEnv.check_displacement` where the flow bounds its speed; for a flow
        without a bound (linear), only that every displacement is finite."""
        if self.flow.speed_bound() is not None:
            super().check_displacement(slack)
            return
        dist = self.displacement().norm(dim=-1)
        if not bool(torch.isfinite(dist).all()):
            raise IntegrityError(
                f"impossible result: {int((~torch.isfinite(dist)).sum())} swimmers have a "
                "non-finite displacement, nothing written")
