r"""Flows the swimmers move in.

Every flow exposes the same five channels on a periodic grid, in this order
(see :data:`swimrl.flows.base.CHANNELS`):

$$
u_x,\ u_y,\ S_{xx},\ S_{xy},\ \omega
$$

with $\mathbb S = (\nabla\boldsymbol u + \nabla\boldsymbol u^{\mathsf T})/2$ (traceless in 2D,
$S_{yy} = -S_{xx}$) and $\omega = \partial_x u_y - \partial_y u_x$.
"""

from swimrl.flows.base import CHANNELS, GriddedFlow

__all__ = ["CHANNELS", "GriddedFlow"]
