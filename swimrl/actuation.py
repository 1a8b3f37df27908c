r"""What the swimmer controls (``actuation=``): its shape, its swimming direction, or both.

* ``actuation=shape`` (the paper's): the action is the shape factor
  $\Lambda\in[-\Lambda_\max, \Lambda_\max]$.
* ``actuation=steer``: the action is the preferred direction $\boldsymbol k_a$ of a
  bottom-heavy swimmer (:mod:`swimrl.physics.gyrotaxis`; Colabrese et al. 2017), the shape
  held at ``actuation.shape_factor`` (0: a sphere). ``actuation.directions=continuous``: a
  vector $\boldsymbol a\in[-1, 1]^d$ whose direction is $\boldsymbol k_a =
  \boldsymbol a/|\boldsymbol a|$; ``discrete``: one of the $2d$ axis directions (in 2D
  right, up, left, down; in 3D $\pm\hat x, \pm\hat y, \pm\hat z$).
* ``actuation=shape_steer``: both, $(\Lambda, \boldsymbol a)$, continuous.

Steering needs a torque to steer with: ``swimmer.bottom_heaviness`` $B > 0$.
"""

from __future__ import annotations

from dataclasses import dataclass

from swimrl.conf_values import yaml_value
from swimrl.errors import as_float, keep_number_types, one_of, require

#: The actuations (``actuation=NAME``); the first is the default.
ACTUATIONS = ("shape", "steer", "shape_steer")
#: ``actuation.directions``.
DIRECTIONS = ("continuous", "discrete")


@dataclass(frozen=True)
class ActuationSpec:
    r"""``actuation.*``: what the action sets. The defaults are read from
    ``conf/actuation/shape.yaml`` (:mod:`swimrl.conf_values`).

    Parameters
    ----------
    name
        ``shape``, ``steer`` or ``shape_steer`` (:data:`ACTUATIONS`).
    directions
        ``continuous`` or ``discrete`` steering directions (read by the steering
        actuations; ``shape_steer``: continuous only).
    shape_factor
        ``actuation=steer``: the shape factor $\Lambda$ held (0: a sphere).
    """

    name: str = yaml_value("actuation/shape", "name")
    directions: str = yaml_value("actuation/shape", "directions")
    shape_factor: float = yaml_value("actuation/shape", "shape_factor")

    def __post_init__(self) -> None:
        one_of("actuation.name", self.name, ACTUATIONS)
        one_of("actuation.directions", self.directions, DIRECTIONS)
        as_float("actuation.shape_factor", self.shape_factor, lambda v: -1 < v < 1,
                 "in (-1, 1)")
        require(not (self.name == "shape_steer" and self.directions == "discrete"),
                "actuation.directions", self.directions,
                "'continuous' with actuation=shape_steer (a shape and a direction in one "
                "continuous action)")
        keep_number_types(self)

    @property
    def steers(self) -> bool:
        """True where the action sets a direction."""
        return self.name != "shape"

    @property
    def shapes(self) -> bool:
        """True where the action sets the shape."""
        return self.name != "steer"
