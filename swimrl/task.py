r"""What the swimmers are asked to do (``task=``) and what swimming costs (``reward.*``).

``task=displacement`` (the paper): get far from the start point; the reward per decision is
$r_i = |\boldsymbol x(t_i) - \boldsymbol x_0| - |\boldsymbol x(t_{i-1}) - \boldsymbol x_0|$,
the signals are taken in the polar frame of $\boldsymbol x - \boldsymbol x_0$.

``task=target`` (point-to-point navigation): each swimmer gets a target
$\boldsymbol X = \boldsymbol x_0 + D(\cos\varphi, \sin\varphi)$, $D$ = ``task.distance`` in
units of the flow length $\ell_f$, $\varphi$ uniform; with
$\rho = |\boldsymbol X - \boldsymbol x|$ the reward per decision is

$$
r_i = \rho(t_{i-1}) - \rho(t_i),
$$

which telescopes to $D - \rho_\mathrm{final}$. A swimmer with $\rho \le$
``task.arrival_radius`` ($\ell_f$) has arrived: its episode ends (``terminated``, no
bootstrap), it stops (no further motion, reward or energy) and stays counted as arrived.
The signals are taken in the frame of $\boldsymbol X - \boldsymbol x$
($n_r = \boldsymbol n\cdot\boldsymbol e$, $\boldsymbol e$ the unit vector towards the target).

``task=vertical`` (vertical migration, Colabrese et al. 2017): go up. The reward per decision is
the rise $r_i = z(t_i) - z(t_{i-1})$ ($z$ the vertical coordinate: $y$ in 2D, $z$ in 3D), the
signals are taken in the frame of the upward vertical ($n_r = \boldsymbol n\cdot\hat{\boldsymbol
z}$; in 2D $n_\theta = -n_x$), and the performance index is the mean vertical velocity over
the measuring window after a burn-in, $\langle v_z\rangle/v_s = [z(T) - z(T_b)]/[v_s(T -
T_b)]$, $T_b$ = ``task.burn_in`` ($\tau_K$). A swimmer whose vertical excursion
$\max z - \min z$ over the window stays below one cell of the flow
(:attr:`~swimrl.flows.pointwise.PointFlow.cell_size`) is trapped.

In the two other tasks the performance index is the undiscounted return over $v_s T$
($\hat R = |\boldsymbol x(T) - \boldsymbol x_0|/(v_s T)$, resp.
$(D - \rho_\mathrm{final})/(v_s T)$).

Energy (``reward.*``, :mod:`swimrl.physics.energy`): a decision with shape factor $\Lambda_i$
costs $w\,K(\Lambda_i)\,v_s T_u$ ($w$ = ``reward.energy_weight``) plus, optionally,
$w_c\,|\Lambda_i - \Lambda_{i-1}|\,v_s T_u$ ($w_c$ = ``reward.shape_change_weight``; none at
a swimmer's first decision), so the return over $v_s T$ is $\hat R - w\hat E - \dots$ with
$\hat E = \frac1T\int K(\Lambda)\,\mathrm dt$ the work against drag in units of the
equal-volume sphere's $6\pi\mu a\,v_s^2 T$.
"""

from __future__ import annotations

from dataclasses import dataclass

from swimrl.conf_values import yaml_value
from swimrl.errors import as_float, keep_number_types, one_of

#: The tasks (``task=NAME``); the first is the default.
TASKS = ("displacement", "target", "vertical")
#: What the reward counts (``reward.progress``); the first is the default (the task's reward).
PROGRESS = ("distance", "swimming")


@dataclass(frozen=True)
class TaskSpec:
    r"""``task.*``: the task's name, the target distance $D$ and the arrival radius (both in
    units of $\ell_f$; read by ``task=target`` only). The defaults are read from
    ``conf/task/displacement.yaml`` (:mod:`swimrl.conf_values`).

    Parameters
    ----------
    name
        ``displacement`` (the paper's: get far from the start) or ``target``
        (point-to-point navigation), one of :data:`TASKS`.
    distance
        ``task=target``: the distance $D$ of each swimmer's target from its start.
    arrival_radius
        ``task=target``: a swimmer this close to its target has arrived, ``< distance``.
    burn_in
        ``task=vertical``: $T_b$, the start of the measuring window (units $\tau_K$,
        ``< episode.duration``).
    """

    name: str = yaml_value("task/displacement", "name")
    distance: float = yaml_value("task/displacement", "distance")
    arrival_radius: float = yaml_value("task/displacement", "arrival_radius")
    burn_in: float = yaml_value("task/displacement", "burn_in")

    def __post_init__(self) -> None:
        one_of("task.name", self.name, TASKS)
        as_float("task.distance", self.distance, lambda v: v > 0, "> 0 (units ell_f)")
        as_float("task.arrival_radius", self.arrival_radius,
                 lambda v: 0 < v < float(self.distance),
                 f"in (0, task.distance={self.distance}) (units ell_f)")
        as_float("task.burn_in", self.burn_in, lambda v: v >= 0, ">= 0 (units tau_K)")
        keep_number_types(self)

    @property
    def target(self) -> bool:
        """True for point-to-point navigation."""
        return self.name == "target"

    @property
    def vertical(self) -> bool:
        """True for vertical migration."""
        return self.name == "vertical"


@dataclass(frozen=True)
class RewardSpec:
    r"""``reward.*``: weights of the energy cost $w\,K(\Lambda)\,v_s T_u$ and of the
    shape-change cost $w_c\,|\Delta\Lambda|\,v_s T_u$ per decision (0: the paper's reward).
    The defaults are read from ``conf/evaluate.yaml`` (:mod:`swimrl.conf_values`).

    Parameters
    ----------
    energy_weight
        $w \ge 0$: the cost of the drag of the shape, $K(\Lambda)$
        (:func:`~swimrl.physics.energy.drag_factor`).
    shape_change_weight
        $w_c \ge 0$: the cost of changing the shape between decisions.
    progress
        What the reward counts, one of :data:`PROGRESS`: ``distance`` (the task's reward,
        e.g. the paper's $r_i = |\boldsymbol x(t_i) - \boldsymbol x_0| - |\boldsymbol x(t_{i-1})
        - \boldsymbol x_0|$) or ``swimming``, the swimmer's own part of it,
        $r_i = \tfrac12 v_s T_u\,[n_r(t_{i-1}) + n_r(t_i)]$ (the trapezoid rule for
        $\int v_s\,\boldsymbol n\cdot\boldsymbol e_r\,\mathrm dt$ over the decision): the
        flow's advection $\boldsymbol u\cdot\boldsymbol e_r$, which no signal predicts, is left
        out of the learning signal. A training device only: $\hat R$ and every evaluation
        still measure the distance. Not with ``task=target``.
    """

    energy_weight: float = yaml_value("evaluate", "reward.energy_weight")
    shape_change_weight: float = yaml_value("evaluate", "reward.shape_change_weight")
    progress: str = yaml_value("evaluate", "reward.progress")

    def __post_init__(self) -> None:
        one_of("reward.progress", self.progress, PROGRESS)
        as_float("reward.energy_weight", self.energy_weight, lambda v: v >= 0, ">= 0")
        as_float("reward.shape_change_weight", self.shape_change_weight, lambda v: v >= 0,
                 ">= 0")
        keep_number_types(self)
