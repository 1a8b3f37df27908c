r"""The swimmer's signals (paper Sec. II C), in the body frame and in units of $\tau_K$.

With $\boldsymbol d = \boldsymbol x - \boldsymbol x_0$ the displacement from the start point,
$\boldsymbol e_r = \boldsymbol d/|\boldsymbol d|$ and
$\boldsymbol e_\theta = \hat{\boldsymbol z}\times\boldsymbol e_r = (-e_{r,y}, e_{r,x})$:

* $n_r = \boldsymbol n\cdot\boldsymbol e_r$,
  $n_\theta = \boldsymbol n\cdot\boldsymbol e_\theta = \sin(\theta - \phi)$ ($\phi$ the polar
  angle of $\boldsymbol d$);
* $S_{nn}\tau_K = \boldsymbol n\cdot\mathbb S\cdot\boldsymbol n\,\tau_K$,
  $S_{np}\tau_K = \boldsymbol n\cdot\mathbb S\cdot\boldsymbol p\,\tau_K$, $\omega\tau_K$.

At the start point ($|\boldsymbol d| = 0$) the polar basis is undefined; swimrl defines
$\boldsymbol e_r := \boldsymbol n$ there, i.e. $n_r = 1$, $n_\theta = 0$ (the swimmer regards
its initial heading as outward). The same rule applies whenever $|\boldsymbol d| < 10^{-12}$
in flow units.
"""

from __future__ import annotations

import torch

from swimrl.errors import ConfigError
from swimrl.physics.swimmer import strain_nn, strain_np

SIGNAL_NAMES: tuple[str, ...] = ("n_r", "n_theta", "S_nn", "S_np", "omega")
"""All signal names, in the order of the ``signals`` key of the environment."""

#: Not a flow signal: the swimmer's own shape factor, the ``Lambda`` it held over the last
#: decision interval (0 before its first decision), observable with ``signals.names`` in 2D
#: and 3D (the state of ``reward.shape_change_weight``'s cost, which depends on it).
SHAPE_SIGNAL = "Lambda"


def compute_signals(
    q: torch.Tensor, theta: torch.Tensor, displacement: torch.Tensor, tau_k: float
) -> torch.Tensor:
    r"""All five signals $(n_r, n_\theta, S_{nn}\tau_K, S_{np}\tau_K, \omega\tau_K)$ (Sec. II C).

    Parameters
    ----------
    q
        Flow channels $(u_x, u_y, S_{xx}, S_{xy}, \omega)$ at the swimmers, ``(..., 5)``.
    theta
        Orientation angles, ``(...)``.
    displacement
        $\boldsymbol x - \boldsymbol x_0$, ``(..., 2)``: its direction is $\boldsymbol e_r$
        ($\boldsymbol n$ at the start point).
    tau_k
        The flow's $\tau_K$, the unit of the strain and vorticity signals.

    Returns
    -------
    torch.Tensor
        ``(..., 5)``, in the order of :data:`SIGNAL_NAMES`.
    """
    n = torch.stack((torch.cos(theta), torch.sin(theta)), -1)
    r = displacement.norm(dim=-1, keepdim=True)
    at_start = r < 1e-12
    e_r = torch.where(at_start, n, displacement / torch.where(at_start, torch.ones_like(r), r))
    n_r = (n * e_r).sum(-1)
    n_theta = n[..., 1] * e_r[..., 0] - n[..., 0] * e_r[..., 1]
    s_xx, s_xy, omega = q[..., 2], q[..., 3], q[..., 4]
    return torch.stack(
        (
            n_r,
            n_theta,
            strain_nn(theta, s_xx, s_xy) * tau_k,
            strain_np(theta, s_xx, s_xy) * tau_k,
            omega * tau_k,
        ),
        -1,
    )


def signal_indices(names, allowed: tuple[str, ...] = SIGNAL_NAMES) -> list[int]:
    """Positions of ``names`` in ``allowed`` (default :data:`SIGNAL_NAMES`; the 3D set is
    :data:`~swimrl.physics.signals3d.SIGNAL_NAMES_3D`); raises on unknown or repeated
    names."""
    names = list(names)
    if not names:
        raise ConfigError(f"signals.names is empty; choose a subset of {list(allowed)}")
    bad = [s for s in names if s not in allowed]
    if bad:
        raise ConfigError(f"signals.names has unknown {bad}; allowed: {list(allowed)}")
    if len(set(names)) != len(names):
        raise ConfigError(f"signals.names={names} repeats a signal")
    return [allowed.index(s) for s in names]
