"""What a :class:`~swimrl.env.core.SwimmerEnv` accounts besides the task's score: the energy
and shape-change costs of each decision (:func:`account`) and the per-swimmer outcomes of an
episode (:func:`outcomes`)."""

from __future__ import annotations

import math

import torch

from swimrl.env import vertical
from swimrl.physics.energy import drag_factor


def account(env, shape: torch.Tensor, moving: torch.Tensor) -> torch.Tensor | None:
    """Account the decision just taken by the ``moving`` swimmers of ``env`` with shape factor
    ``shape`` (``(F, S)``): ``E_hat += K(Lambda) T_u / T``,
    ``C_hat += |Lambda - Lambda_prev| T_u / T`` (0 at the first decision); returns the
    reward's cost ``w K(Lambda) v_s T_u + w_c |Lambda - Lambda_prev| v_s T_u`` (None when
    both weights are 0)."""
    drag = drag_factor(shape)
    zero = torch.zeros_like(drag)
    env.energy += torch.where(moving, drag, zero) / env.params.n_decisions
    w, w_c = env.params.reward.energy_weight, env.params.reward.shape_change_weight
    change = (shape - env.last_action).abs().nan_to_num(nan=0.0)
    env.shape_change += torch.where(moving, change, zero) / env.params.n_decisions
    env.last_action = torch.where(moving, shape, env.last_action)
    if w == 0 and w_c == 0:
        return None
    cost = (w * drag + w_c * change) * env.decision_length
    return torch.where(moving, cost, zero)


def outcomes(env) -> dict[str, torch.Tensor]:
    """Per-swimmer results of ``env`` besides its score.

    Returns
    -------
    dict[str, torch.Tensor]
        ``(F, S)`` each: ``energy`` (``E_hat``, :mod:`swimrl.physics.energy`),
        ``shape_change`` (``C_hat = (1/T) sum_i |Lambda_i - Lambda_{i-1}| T_u``, the
        quantity ``reward.shape_change_weight`` prices) and, for
        ``task=displacement``, ``swimming`` (``S_hat = (1/T) int n . e_r dt``, the swimmer's
        own share of ``R_hat = S_hat + (1/(v_s T)) int u . e_r dt``), for
        ``task=target``, ``arrived`` (0/1), ``arrival_time`` (units ``tau_K``; NaN where
        not arrived) and ``final_distance`` (``|X - x|``, units ``ell_f``); for
        ``task=vertical``, ``vertical_velocity`` (``<v_z>/v_s`` over the window, as the score)
        and ``trapped`` (0/1: the vertical excursion over the window below the flow's
        cell, :meth:`~swimrl.env.core.SwimmerEnv.cell_size`).
    """
    out = {"energy": env.energy.clone(), "shape_change": env.shape_change.clone()}
    if not env.task.target and not env.task.vertical:
        out["swimming"] = env.alignment.clone()
    if env.task.vertical:
        z = vertical.rise(env.displacement(), env.body.vertical_axis)
        out.update(vertical_velocity=env.window.vertical_velocity(
            z, env.swim_speed, env.window_time()), trapped=env.window.trapped(env.cell_size()))
    if env.task.target:
        time = env.arrival_step.to(env.energy.dtype) * env.params.update_interval
        rho = (env.target - env.displacement()).norm(dim=-1)
        out.update(arrived=env.arrived.to(env.energy.dtype),
                   arrival_time=torch.where(env.arrived, time, math.nan),
                   final_distance=rho / env.flow.ell_f)
    return out
