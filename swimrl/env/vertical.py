r"""``task=vertical`` (:mod:`swimrl.task`) in the environment: the rise $z - z_0$, the
measuring window after the burn-in $T_b$, and its outcomes: the mean vertical velocity
$\langle v_z\rangle/v_s = [z(T) - z(T_b)]/[v_s(T - T_b)]$ and whether the swimmer is trapped
(its vertical excursion $\max z - \min z$ over the window below one cell of the flow)."""

from __future__ import annotations

import torch


def rise(displacement: torch.Tensor, vertical_axis: int) -> torch.Tensor:
    r"""$z - z_0$ of each swimmer from its displacement ``(F, S, d)``, ``(F, S)``."""
    return displacement[..., vertical_axis]


def burn_in_steps(burn_in: float, update_interval: float) -> int:
    """The decision after which the window starts, ``round(T_b / T_u)``."""
    return int(round(burn_in / update_interval))


class Window:
    r"""The measuring window of ``task=vertical`` for a batch of swimmers: $z(T_b)$ and the
    running $\max z$, $\min z$ since then (all ``(F, S)``)."""

    def __init__(self, batch: torch.Size, device, dtype, start_step: int):
        self.start_step = start_step
        self.start = torch.zeros(batch, device=device, dtype=dtype)
        self.top = torch.zeros(batch, device=device, dtype=dtype)
        self.bottom = torch.zeros(batch, device=device, dtype=dtype)

    def reset(self, mask: torch.Tensor) -> None:
        """Swimmers ``mask`` start over."""
        for x in (self.start, self.top, self.bottom):
            x[mask] = 0

    def update(self, z: torch.Tensor, step: torch.Tensor) -> None:
        r"""After a decision: at step $T_b/T_u$ the window opens at ``z``; after it, the
        excursion is tracked (``step``: each swimmer's decisions since its start)."""
        opening = step == self.start_step
        inside = step > self.start_step
        self.start.copy_(torch.where(opening, z, self.start))
        self.top.copy_(torch.where(opening, z, torch.where(inside, torch.maximum(self.top, z),
                                                           self.top)))
        self.bottom.copy_(torch.where(opening, z, torch.where(
            inside, torch.minimum(self.bottom, z), self.bottom)))

    def vertical_velocity(self, z: torch.Tensor, swim_speed: float, window_time: float
                          ) -> torch.Tensor:
        r"""$[z - z(T_b)]/(v_s\,(T - T_b))$ with ``z`` the final rise, ``(F, S)``."""
        return (z - self.start) / (swim_speed * window_time)

    def trapped(self, cell: float) -> torch.Tensor:
        r"""$\max z - \min z <$ ``cell`` over the window (0/1), ``(F, S)``."""
        return (self.top - self.bottom < cell).to(self.start.dtype)
