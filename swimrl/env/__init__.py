r"""TorchRL environment: batched swimmers in batched flows.

Batch shape ``(n_flows, n_swimmers)``: swimmer ``(f, s)`` moves in flow realisation ``f``.
One environment step is one decision interval $T_u$: the action $\Lambda$ (shape factor,
bounded to $[-\Lambda_\mathrm{max}, \Lambda_\mathrm{max}]$) is held while the dynamics
(:mod:`swimrl.physics.swimmer`) is integrated over $T_u / \delta t$ Heun steps. Reward
(``eq:reward``, ``task=displacement``):

$$
r_i = |\boldsymbol x(t_i) - \boldsymbol x_0| - |\boldsymbol x(t_{i-1}) - \boldsymbol x_0|,
$$

so the undiscounted return telescopes to $|\boldsymbol x(t_N) - \boldsymbol x_0|$ (flow length
units); with ``task=target`` it is the decrease of the distance to the target, and
``reward.*`` adds the energy costs (:mod:`swimrl.task`). Episodes are truncated when their
flow has run $N = T / T_u$ decisions; with ``task=target`` a swimmer that arrives is
terminated. Keys:

* ``observation`` – the configured signal subset (``signals.names``), ``(F, S, k)``;
* ``signals`` – all the body's signals in :attr:`SwimmerEnv.signal_names` order (five in 2D,
  seven in 3D; what the baselines read);
* ``distance`` – ``|x - x_0|``, ``(F, S, 1)``;
* ``target_distance`` – ``task=target`` only: ``|X - x|``, ``(F, S, 1)``;
* ``action`` – ``Lambda``, ``(F, S, 1)``; ``reward``; ``done``/``terminated``/``truncated``.

Partial resets (``_reset`` mask ``(F, S, 1)``) start new swimmers at uniformly random
positions and orientations (and targets); a flow whose swimmers all reset also gets a new
realisation, and a swimmer started in a running flow ends with it (the flow's clock
truncates every episode in it, so the flows of a batch renew together, or in
:meth:`~SwimmerEnv.stagger`'s groups).
With ``ic_blocks = B > 1`` the ``S`` swimmers of a flow are ``B`` blocks of ``S / B`` that
start from the same positions and orientations (common random numbers: one block per
strategy in a paired comparison); the draws are those of an environment of ``S / B``
swimmers.
Positions are kept as a wrapped coordinate in ``[0, L)`` plus integer image counts, so the
unbounded displacement

$$
\boldsymbol x - \boldsymbol x_0
  = (\boldsymbol p - \boldsymbol p_0) + L (\boldsymbol m - \boldsymbol m_0)
$$

keeps float32 resolution of the grid cell however far the swimmer goes.

The package: :mod:`~swimrl.env.params` (:class:`EnvParams`), :mod:`~swimrl.env.core` (the
core :class:`SwimmerEnv`: specs, reset, step, task, costs; a gridded flow),
:mod:`~swimrl.env.point` (:class:`PointSwimmerEnv`: a flow evaluated at points, 2D or 3D, by
its :class:`~swimrl.physics.body.Body`) and :mod:`~swimrl.env.build` (:func:`build_env`, the
one place that picks the class and the body).
"""

from swimrl.env.build import build_env, env_from_flow
from swimrl.env.core import SwimmerEnv
from swimrl.env.params import EnvParams, clock_offsets
from swimrl.env.point import PointSwimmerEnv

__all__ = ["EnvParams", "PointSwimmerEnv", "SwimmerEnv", "build_env", "clock_offsets",
           "env_from_flow"]
