r"""The 3D swimmer's signals, in the body frame $(\boldsymbol n,\boldsymbol p_1,\boldsymbol p_2)$,
in units of $\tau_K$.

With $\boldsymbol d = \boldsymbol x - \boldsymbol x_0$ the displacement from the start point
and $\boldsymbol e_r = \boldsymbol d/|\boldsymbol d|$:

* $n_r = \boldsymbol n\cdot\boldsymbol e_r$;
* $\boldsymbol p_1$ the unit vector along
  $\boldsymbol w = \boldsymbol e_r - (\boldsymbol e_r\cdot\boldsymbol n)\,\boldsymbol n$ (the
  direction in which $\boldsymbol n$ must turn towards $\boldsymbol e_r$;
  $\boldsymbol e_r = n_r\boldsymbol n + \sqrt{1 - n_r^2}\,\boldsymbol p_1$),
  $\boldsymbol p_2 = \boldsymbol n\times\boldsymbol p_1$;
* $S_{nn} = \boldsymbol n\cdot\mathbb S\boldsymbol n\,\tau_K$,
  $S_{np_1} = \boldsymbol p_1\cdot\mathbb S\boldsymbol n\,\tau_K$,
  $S_{np_2} = \boldsymbol p_2\cdot\mathbb S\boldsymbol n\,\tau_K$;
* $\omega_n = \boldsymbol\omega\cdot\boldsymbol n\,\tau_K$,
  $\omega_{p_1} = \boldsymbol\omega\cdot\boldsymbol p_1\,\tau_K$,
  $\omega_{p_2} = \boldsymbol\omega\cdot\boldsymbol p_2\,\tau_K$.

Conventions where the frame is undefined: at the start point ($|\boldsymbol d| < 10^{-12}$ in
flow units) $\boldsymbol e_r := \boldsymbol n$ ($n_r = 1$), as in 2D
(:mod:`swimrl.physics.signals`). Where $\boldsymbol e_r$ is parallel to $\boldsymbol n$
($|\boldsymbol w| < \sqrt\epsilon$ of the dtype: $3.5\times10^{-4}$ in float32,
$1.5\times10^{-8}$ in float64, below which the direction of $\boldsymbol w$ is not resolved to
better than $\sqrt\epsilon$ rad), $\boldsymbol p_1$ is the fixed perpendicular
$\boldsymbol f/|\boldsymbol f|$,
$\boldsymbol f = (\mathbb I - \boldsymbol n\boldsymbol n)\,\hat{\boldsymbol e}_k$,
$\hat{\boldsymbol e}_k$ the coordinate axis of the smallest $|n_k|$ (the first of equal ones).
There $\boldsymbol e_r\cdot\boldsymbol p_1 = 0$: the strain cannot turn $\boldsymbol n$ towards
$\boldsymbol e_r$ at first order, whatever $\boldsymbol p_1$ is.

In the plane ($\boldsymbol n$, $\boldsymbol d$ in the $x$-$y$ plane, $\boldsymbol\omega$ along
$z$), with the 2D $\boldsymbol p = \hat{\boldsymbol z}\times\boldsymbol n$ and
$n_\theta = \boldsymbol n\cdot(\hat{\boldsymbol z}\times\boldsymbol e_r)$:
$\boldsymbol e_r - (\boldsymbol e_r\cdot\boldsymbol n)\,\boldsymbol n
= (\boldsymbol e_r\cdot\boldsymbol p)\,\boldsymbol p = -n_\theta\,\boldsymbol p$, so
$\boldsymbol p_1 = -\mathrm{sign}(n_\theta)\,\boldsymbol p$,
$\boldsymbol p_2 = -\mathrm{sign}(n_\theta)\,\hat{\boldsymbol z}$ and
$S_{np_1} = -\mathrm{sign}(n_\theta)\,S_{np}$, $S_{np_2} = 0$,
$\omega_n = \omega_{p_1} = 0$, $\omega_{p_2} = -\mathrm{sign}(n_\theta)\,\omega$ (tested).
"""

from __future__ import annotations

import torch

from swimrl.physics.swimmer3d import strain_dot

SIGNAL_NAMES_3D: tuple[str, ...] = (
    "n_r", "S_nn", "S_np1", "S_np2", "omega_n", "omega_p1", "omega_p2",
)
"""All 3D signal names, in the order of :func:`compute_signals_3d`."""


def radial_direction(n: torch.Tensor, displacement: torch.Tensor) -> torch.Tensor:
    r"""$\boldsymbol e_r = \boldsymbol d/|\boldsymbol d|$, and $\boldsymbol n$ where
    $|\boldsymbol d| < 10^{-12}$ (the start point), ``(..., 3)``."""
    r = displacement.norm(dim=-1, keepdim=True)
    at_start = r < 1e-12
    return torch.where(at_start, n, displacement / torch.where(at_start, torch.ones_like(r), r))


def body_frame(n: torch.Tensor, e_r: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    r"""$(\boldsymbol p_1, \boldsymbol p_2)$: $\boldsymbol p_1$ along
    $\boldsymbol e_r - (\boldsymbol e_r\cdot\boldsymbol n)\,\boldsymbol n$ (the fixed
    perpendicular of the module docstring where that is shorter than $\sqrt\epsilon$),
    $\boldsymbol p_2 = \boldsymbol n\times\boldsymbol p_1$; each ``(..., 3)``.
    """
    w = e_r - (e_r * n).sum(-1, keepdim=True) * n
    wn = w.norm(dim=-1, keepdim=True)
    axis = torch.nn.functional.one_hot(n.abs().argmin(-1), 3).to(n.dtype)
    f = axis - (axis * n).sum(-1, keepdim=True) * n
    fixed = f / f.norm(dim=-1, keepdim=True)
    parallel = wn < torch.finfo(n.dtype).eps ** 0.5
    p1 = torch.where(parallel, fixed, w / torch.where(parallel, torch.ones_like(wn), wn))
    return p1, torch.linalg.cross(n, p1, dim=-1)


def compute_signals_3d(
    q: torch.Tensor, n: torch.Tensor, displacement: torch.Tensor, tau_k: float
) -> torch.Tensor:
    r"""All seven 3D signals
    $(n_r, S_{nn}, S_{np_1}, S_{np_2}, \omega_n, \omega_{p_1}, \omega_{p_2})$, the strain and
    vorticity components times $\tau_K$ (module docstring).

    Parameters
    ----------
    q
        Flow channels :data:`swimrl.physics.swimmer3d.CHANNELS_3D` at the swimmers,
        ``(..., 11)``.
    n
        Unit orientations, ``(..., 3)``.
    displacement
        $\boldsymbol x - \boldsymbol x_0$, ``(..., 3)``: its direction is $\boldsymbol e_r$
        ($\boldsymbol n$ at the start point).
    tau_k
        The flow's $\tau_K$, the unit of the strain and vorticity signals.

    Returns
    -------
    torch.Tensor
        ``(..., 7)``, in the order of :data:`SIGNAL_NAMES_3D`.
    """
    e_r = radial_direction(n, displacement)
    p1, p2 = body_frame(n, e_r)
    sn = strain_dot(q, n) * tau_k
    om = q[..., 8:11] * tau_k
    return torch.stack(
        (
            (n * e_r).sum(-1),
            (n * sn).sum(-1),
            (p1 * sn).sum(-1),
            (p2 * sn).sum(-1),
            (om * n).sum(-1),
            (om * p1).sum(-1),
            (om * p2).sum(-1),
        ),
        -1,
    )
