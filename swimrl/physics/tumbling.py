r"""Tumbling: how fast the flow turns the swimmer, and the shape that turns it least.

In 3D, eq. (1b) reads $\dot{\boldsymbol n} = \boldsymbol a + \Lambda\boldsymbol b$ with
$\boldsymbol a = \tfrac12\,\boldsymbol\omega\times\boldsymbol n$ and
$\boldsymbol b = (\mathbb I - \boldsymbol n\boldsymbol n)\mathbb S\boldsymbol n$, both
perpendicular to $\boldsymbol n$. $|\dot{\boldsymbol n}|^2$ is a parabola in $\Lambda$ with
its vertex at $-\boldsymbol a\cdot\boldsymbol b/|\boldsymbol b|^2$, where (the
$\boldsymbol n\boldsymbol n$ part drops out, $\boldsymbol a\perp\boldsymbol n$)
$\boldsymbol a\cdot\boldsymbol b = -\tfrac12\,\boldsymbol n\cdot(\boldsymbol\omega\times
\mathbb S\boldsymbol n)$; restricted to $[-\Lambda_\mathrm{max}, \Lambda_\mathrm{max}]$ it is
least at the clipped vertex

$$
\Lambda^* = \mathrm{clip}\,\frac{\tau}{2\ell^2},\qquad
\tau = \boldsymbol n\cdot(\boldsymbol\omega\times\mathbb S\boldsymbol n),\qquad
\ell = |(\mathbb I - \boldsymbol n\boldsymbol n)\mathbb S\boldsymbol n| .
$$

In the body frame of :mod:`swimrl.physics.body3d`
($\boldsymbol p_2 = \boldsymbol n\times\boldsymbol p_1$),
$\boldsymbol b = S_{np_1}\boldsymbol p_1 + S_{np_2}\boldsymbol p_2$ and
$\boldsymbol a = \tfrac12(\omega_{p_2}\boldsymbol p_1 - \omega_{p_1}\boldsymbol p_2)$, so

$$
|\dot{\boldsymbol n}|^2 = \left(\tfrac12\omega_{p_2} + \Lambda S_{np_1}\right)^2
 + \left(\Lambda S_{np_2} - \tfrac12\omega_{p_1}\right)^2,\qquad
\tau = S_{np_2}\,\omega_{p_1} - S_{np_1}\,\omega_{p_2},\qquad
\ell^2 = S_{np_1}^2 + S_{np_2}^2 .
$$

In 2D, eq. (2): $|\dot{\boldsymbol n}| = |\tfrac12\omega + \Lambda S_{np}|$, so
$\tau = -\omega S_{np}$, $\ell = |S_{np}|$ and $\Lambda^* = \mathrm{clip}(-\omega/(2S_{np}))$;
in the plane the 3D quantities are these. Where the strain has no lever ($\ell = 0$) every
$\Lambda$ gives the same rate and $\Lambda^* := 0$. Everything is read from a signal set,
2D (:data:`~swimrl.physics.body2d.SIGNAL_NAMES`) or 3D
(:data:`~swimrl.physics.body3d.SIGNAL_NAMES_3D`), named by the caller; strain and
vorticity in units of $1/\tau_K$, so the rates are in $1/\tau_K$.
"""

from __future__ import annotations

from collections.abc import Sequence

import torch

#: The signals each dimension's tumbling is read from.
PLANAR = ("S_np", "omega")
SPATIAL = ("S_np1", "S_np2", "omega_p1", "omega_p2")


def _columns(signals: torch.Tensor, names: Sequence[str]) -> dict[str, torch.Tensor]:
    """The columns of ``signals`` ``(..., len(names))`` that tumbling reads, by name; a set
    with neither the 3D nor the 2D ones is a ValueError naming both."""
    names = list(names)
    if signals.shape[-1] != len(names):
        raise ValueError(f"signals have {signals.shape[-1]} columns for {len(names)} names")
    for wanted in (SPATIAL, PLANAR):
        if all(k in names for k in wanted):
            return {k: signals[..., names.index(k)] for k in wanted}
    raise ValueError(f"tumbling needs the signals {list(SPATIAL)} (3D) or {list(PLANAR)} "
                     f"(2D); got {names}")


def torque_and_lever(signals: torch.Tensor, names: Sequence[str]
                     ) -> tuple[torch.Tensor, torch.Tensor]:
    r"""$(\tau, \ell)$ of the module docstring, each ``(...)``: in 3D
    $(S_{np_2}\omega_{p_1} - S_{np_1}\omega_{p_2},\ (S_{np_1}^2 + S_{np_2}^2)^{1/2})$, in 2D
    $(-\omega S_{np},\ |S_{np}|)$."""
    c = _columns(signals, names)
    if "S_np1" in c:
        s1, s2 = c["S_np1"], c["S_np2"]
        return s2 * c["omega_p1"] - s1 * c["omega_p2"], torch.sqrt(s1 * s1 + s2 * s2)
    return -c["omega"] * c["S_np"], c["S_np"].abs()


def tumbling_rate(signals: torch.Tensor, names: Sequence[str], lam) -> torch.Tensor:
    r"""$|\dot{\boldsymbol n}|\tau_K$ at the shape factor ``lam`` (a tensor ``(...)`` or a
    number), ``(...)``: $|\tfrac12\omega + \Lambda S_{np}|$ in 2D,
    $[(\tfrac12\omega_{p_2} + \Lambda S_{np_1})^2 + (\Lambda S_{np_2}
    - \tfrac12\omega_{p_1})^2]^{1/2}$ in 3D."""
    c = _columns(signals, names)
    lam = torch.as_tensor(lam, dtype=signals.dtype, device=signals.device)
    if "S_np1" in c:
        return torch.hypot(0.5 * c["omega_p2"] + lam * c["S_np1"],
                           lam * c["S_np2"] - 0.5 * c["omega_p1"])
    return (0.5 * c["omega"] + lam * c["S_np"]).abs()


def stabilising_shape(signals: torch.Tensor, names: Sequence[str],
                      shape_factor_max: float) -> torch.Tensor:
    r"""$\Lambda^* = \mathrm{clip}(\tau / (2\ell^2))$, the shape factor in
    $[-\Lambda_\mathrm{max}, \Lambda_\mathrm{max}]$ of least $|\dot{\boldsymbol n}|$,
    ``(...)``; 0 where $\ell = 0$."""
    torque, lever = torque_and_lever(signals, names)
    den = 2 * lever * lever
    lam = torch.where(den > 0, torque / torch.where(den > 0, den, 1.0), 0.0)
    return lam.clamp(-shape_factor_max, shape_factor_max)
