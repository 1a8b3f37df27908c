"""The environment's refusal of a physically impossible state (:func:`check_displacement`)."""

from __future__ import annotations

import math

import torch

from swimrl.errors import IntegrityError


def check_displacement(env, slack: float = 1e-3) -> None:
    """Refuse a physically impossible state: every swimmer of ``env`` (a
    :class:`~swimrl.env.core.SwimmerEnv`) obeys ``|x(t) - x_0| <= (v_s + U_f) t``, with ``t``
    its time since its start and ``U_f`` the bound of ``max_x |u|`` of its flow over that time
    (``env.max_flow_speed``), since ``dx/dt = u + v_s n`` and the Heun steps average two such
    velocities. ``slack`` (relative) covers float rounding. Raises
    :class:`~swimrl.errors.IntegrityError` (one line naming the worst swimmer and the bound)
    otherwise, NaN included."""
    t = env.step_count.to(env.pos.dtype) * (env.params.update_interval * env.tau_k)
    bound = (env.swim_speed + env.max_flow_speed).unsqueeze(1) * t
    dist = env.displacement().norm(dim=-1)
    bad = ~(dist <= bound * (1 + slack) + 1e-6 * env.length_resolution())
    if bool(bad.any()):
        excess = torch.where(bad, dist / bound.clamp_min(1e-30), torch.zeros_like(dist))
        excess = excess.nan_to_num(nan=math.inf)
        f, s = divmod(int(excess.argmax()), env.n_swimmers)
        raise IntegrityError(
            f"impossible result: swimmer {s} of flow {f} is {float(dist[f, s]):.4g} from "
            f"its start after t = {float(t[f, s]):.4g}, beyond (v_s + max|u|) t = "
            f"{float(bound[f, s]):.4g} (v_s = {env.swim_speed:.4g}, max|u| <= "
            f"{float(env.max_flow_speed[f]):.4g}); {int(bad.sum())} swimmers affected, "
            "nothing written"
        )
