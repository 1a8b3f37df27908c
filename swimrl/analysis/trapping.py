r"""Trapping of naive gyrotactic swimmers in the Taylor-Green cellular flow: the condition
derived from the fixed points (``docs/physics.md``, "Gyrotaxis") and the measured map over
$(\Phi, \Psi)$.

In the papers' units ($k = 1$, $u_0 = 1$, time $1/\omega_0$, $\omega_0 = u_0 k$;
:class:`~swimrl.flows.analytic.TaylorGreenFlow` shifted by $\pi/2$) a naive gyrotactic sphere
($\boldsymbol k = \hat z$, $\Lambda = 0$) with heading $\boldsymbol n = (\sin\theta,
\cos\theta)$, $\theta$ from the vertical, obeys

$$
\dot x = -\tfrac12\cos x\sin z + \Phi\sin\theta, \quad
\dot z = \tfrac12\sin x\cos z + \Phi\cos\theta, \quad
\dot\theta = -\frac{\sin\theta}{2\Psi} - \tfrac12\cos x\cos z .
$$

A fixed point needs $\boldsymbol u = -\Phi\boldsymbol n$ ($|\boldsymbol u| = \Phi$) and the
torques to balance ($\sin\theta = -\Psi\omega$). Eliminating $\theta$: either $\cos x = 0$
($\omega = 0$, $\boldsymbol n$ vertical, $\cos z = \pm 2\Phi$; saddles), or
$\tan z = -2\Phi\Psi$ with $\sin^2 x = [4\Phi^2(1 + c^2) - c^2]/(1 - c^2)$, $c = 2\Phi\Psi$
(:func:`fixed_points`). Their stability is read from the Jacobian's eigenvalues
(:func:`jacobian`); the attracting ones exist exactly where

$$
\Phi < \tfrac12 \quad\text{and}\quad \Psi < \Psi^*(\Phi) = (1 - 4\Phi^2)^{-1/2}
$$

(:func:`trapping_condition`; the eigenvalue computation and the closed form agree,
``tests/test_gyrotaxis.py``). :func:`naive_map` measures the trapped fraction of naive
swimmers over a grid of $(\Phi, \Psi)$ with the environment.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import torch

from swimrl.actuation import ActuationSpec
from swimrl.env import EnvParams, build_env
from swimrl.env.actuation import up_action
from swimrl.flows.analytic import GYROTAXIS_UNITS, TaylorGreenSpec
from swimrl.runtime import Runtime
from swimrl.task import TaskSpec


def rhs(state: np.ndarray, phi: float, psi: float) -> np.ndarray:
    r"""$(\dot x, \dot z, \dot\theta)$ of the naive swimmer (module docstring)."""
    x, z, th = state
    return np.array([-0.5 * math.cos(x) * math.sin(z) + phi * math.sin(th),
                     0.5 * math.sin(x) * math.cos(z) + phi * math.cos(th),
                     -math.sin(th) / (2 * psi) - 0.5 * math.cos(x) * math.cos(z)])


def jacobian(state: np.ndarray, phi: float, psi: float) -> np.ndarray:
    r"""$\partial(\dot x, \dot z, \dot\theta)/\partial(x, z, \theta)$ at ``state``."""
    x, z, th = state
    cx, sx, cz, sz = math.cos(x), math.sin(x), math.cos(z), math.sin(z)
    return np.array([[0.5 * sx * sz, -0.5 * cx * cz, phi * math.cos(th)],
                     [0.5 * cx * cz, -0.5 * sx * sz, -phi * math.sin(th)],
                     [0.5 * sx * cz, 0.5 * cx * sz, -math.cos(th) / (2 * psi)]])


def fixed_points(phi: float, psi: float) -> list[np.ndarray]:
    r"""Every fixed point $(x, z, \theta)$ in one period $[0, 2\pi)^2$ (module docstring):
    the generic family ($\tan z = -2\Phi\Psi$) and the separatrix one ($\cos x = 0$)."""
    points = []
    c = 2 * phi * psi
    if abs(1 - c * c) > 1e-12:
        s2 = (4 * phi * phi * (1 + c * c) - c * c) / (1 - c * c)
        if 0 <= s2 <= 1:
            for x in {math.asin(math.sqrt(s2)), math.pi - math.asin(math.sqrt(s2)),
                      math.pi + math.asin(math.sqrt(s2)), -math.asin(math.sqrt(s2))}:
                for z in (math.atan(-c), math.atan(-c) + math.pi):
                    u = np.array([-0.5 * math.cos(x) * math.sin(z),
                                  0.5 * math.sin(x) * math.cos(z)])
                    if abs(np.linalg.norm(u) - phi) > 1e-9:
                        continue
                    th = math.atan2(-u[0], -u[1])  # n = -u / phi
                    points.append(np.array([x % (2 * math.pi), z % (2 * math.pi), th]))
    if 2 * phi <= 1:
        for x in (math.pi / 2, 3 * math.pi / 2):
            for z in (math.acos(2 * phi), -math.acos(2 * phi), math.acos(-2 * phi),
                      -math.acos(-2 * phi)):
                for th in (0.0, math.pi):
                    s = np.array([x, z % (2 * math.pi), th])
                    if np.abs(rhs(s, phi, psi)).max() < 1e-9:
                        points.append(s)
    return [p for p in points if np.abs(rhs(p, phi, psi)).max() < 1e-9]


def stable_fixed_point(phi: float, psi: float) -> bool:
    """Whether any fixed point attracts (every eigenvalue of :func:`jacobian` with a
    negative real part)."""
    return any(np.linalg.eigvals(jacobian(p, phi, psi)).real.max() < 0
               for p in fixed_points(phi, psi))


def critical_psi(phi: float) -> float:
    r"""$\Psi^*(\Phi) = (1 - 4\Phi^2)^{-1/2}$ for $\Phi < 1/2$ (0 otherwise: no trap)."""
    return 1 / math.sqrt(1 - 4 * phi * phi) if 2 * phi < 1 else 0.0


def trapping_condition(phi: float, psi: float) -> bool:
    r"""$\Phi < 1/2$ and $\Psi < \Psi^*(\Phi)$: an attracting fixed point exists."""
    return psi < critical_psi(phi)


@dataclass(frozen=True)
class MapPoint:
    """One point of the naive map: the trapped fraction, ``<v_z>/v_s`` (mean and SEM over
    the swimmers) and the condition's prediction."""

    phi: float
    psi: float
    trapped: float
    vertical_velocity: float
    vertical_velocity_sem: float
    predicted: bool


def naive_map(phis: Sequence[float], psis: Sequence[float], n_swimmers: int, duration: float,
              burn_in: float, update_interval: float, dt: float, seed: int, runtime: Runtime,
              progress: Callable[[str], None] | None = None) -> list[MapPoint]:
    r"""The naive swimmers ($\boldsymbol k_a = \hat y$, a sphere) of ``task=vertical`` in
    ``flow=taylor_green`` at every $(\Phi, \Psi)$: ``n_swimmers`` random starts (the same for
    every point: one ``seed``), ``duration`` and ``burn_in`` in $\tau_K$
    ($\tau_K = 2/\omega_0$)."""
    u_ratio, w_tau = GYROTAXIS_UNITS["taylor_green"]
    steer = ActuationSpec(name="steer", directions="continuous", shape_factor=0.0)
    out = []
    for phi in phis:
        for psi in psis:
            params = EnvParams(swim_speed=u_ratio * phi, bottom_heaviness=psi / w_tau,
                               duration=duration, update_interval=update_interval, dt=dt,
                               signals=("n_r", "n_theta", "omega"), actuation=steer,
                               task=TaskSpec(name="vertical", burn_in=burn_in))
            env = build_env(TaylorGreenSpec(), params, runtime, 1, n_swimmers, seed)
            td = env.reset()
            up = torch.tensor(up_action(steer, env.dim, env.body.vertical_axis, 0.0),
                              dtype=env.pos.dtype, device=env.device)
            action = up.expand(*env.batch_size, -1).clone()
            for _ in range(params.n_decisions):
                td.set("action", action)
                td = env.step(td)["next"]
            res = env.outcomes()
            vz = res["vertical_velocity"].reshape(-1).double()
            point = MapPoint(phi, psi, float(res["trapped"].double().mean()),
                             float(vz.mean()), float(vz.std() / math.sqrt(vz.numel())),
                             trapping_condition(phi, psi))
            if progress is not None:
                progress(f"Phi = {phi:g}, Psi = {psi:g}: trapped {point.trapped:.3f}, "
                         f"<v_z>/v_s = {point.vertical_velocity:.3f}")
            out.append(point)
    return out
