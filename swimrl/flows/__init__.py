"""Flows the swimmers move in.

Every flow exposes the same five channels on a periodic grid, in this order
(see :data:`swimrl.flows.base.CHANNELS`):

``u_x, u_y, S_xx, S_xy, omega``

with ``S = (grad u + grad u^T)/2`` (traceless in 2D, ``S_yy = -S_xx``) and
``omega = d_x u_y - d_y u_x``.
"""

from swimrl.flows.base import CHANNELS, GriddedFlow

__all__ = ["CHANNELS", "GriddedFlow"]
