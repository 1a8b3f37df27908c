r"""Hand-coded strategies of a steering action (``actuation=steer``, :mod:`swimrl.actuation`)
in the 2D vertical-migration problem of Colabrese et al. (2017), with the interface of a
learned actor (``signals -> action``; the action a direction vector ``(..., 2)`` or, where
the directions are discrete, an index of :func:`~swimrl.physics.gyrotaxis.axis_directions`):

* :class:`HandRule` (``strategy=hand_rule``): steer up where the vorticity is weak, against
  the vortex's rotation inside it: $\boldsymbol k_a = \hat y$ for $|\omega|\tau_K \le w$,
  $+\hat x$ (clockwise from up) for $\omega\tau_K > w$, $-\hat x$ for $\omega\tau_K < -w$;
  $w$ = ``strategy.threshold`` (2/3: $\omega_0/3$ in the Taylor-Green flow, the 12 states'
  edge);
* :class:`TableStrategy` (``strategy=table``): a 12-state table (state
  :func:`~swimrl.physics.body2d.twelve_states` $\to$ right, up, left or down), e.g. the one
  :mod:`swimrl.analysis.table_search` finds.

Both read the 2D signals ``(n_r, n_theta, S_nn, S_np, omega)``; the 3D signals are refused in
one line.
"""

from __future__ import annotations

import torch
from torch import nn

from swimrl.errors import ConfigError
from swimrl.physics.body2d import SIGNAL_NAMES, twelve_states
from swimrl.physics.gyrotaxis import axis_directions

#: The four directions' letters, in :func:`~swimrl.physics.gyrotaxis.axis_directions` order.
LETTERS = "ruld"


def parse_table(text: str) -> tuple[int, ...]:
    """A table written as 12 letters of ``r u l d`` (state 0 first) -> action indices;
    ConfigError naming ``strategy.table`` otherwise."""
    text = str(text)
    if len(text) != 12 or any(c not in LETTERS for c in text):
        raise ConfigError(f"strategy.table={text!r} is invalid: allowed 12 letters of "
                          f"'{LETTERS}' (right, up, left, down), state 0 first")
    return tuple(LETTERS.index(c) for c in text)


def table_text(table) -> str:
    """The 12-letter form of a table of action indices."""
    return "".join(LETTERS[int(a)] for a in table)


class _Steering(nn.Module):
    """An action index per swimmer, given as a vector or an index."""

    def __init__(self, discrete: bool):
        super().__init__()
        self.discrete = discrete

    def index(self, signals: torch.Tensor) -> torch.Tensor:
        raise NotImplementedError

    def forward(self, signals: torch.Tensor) -> torch.Tensor:
        if signals.shape[-1] != len(SIGNAL_NAMES):
            raise ConfigError(f"strategy={self.name} reads the 2D signals {list(SIGNAL_NAMES)}; "
                              f"the flow gives {signals.shape[-1]} signals: allowed a 2D flow")
        idx = self.index(signals)
        if self.discrete:
            return idx
        return axis_directions(2, signals.device, signals.dtype)[idx]


class HandRule(_Steering):
    """``strategy=hand_rule`` (module docstring), vorticity edge ``threshold`` ($\\tau_K^{-1}$)."""

    name = "hand_rule"

    def __init__(self, threshold: float, discrete: bool):
        super().__init__(discrete)
        self.threshold = float(threshold)

    def index(self, signals: torch.Tensor) -> torch.Tensor:
        omega = signals[..., 4]
        up = torch.ones_like(omega, dtype=torch.long)
        return torch.where(omega > self.threshold, 0, torch.where(omega < -self.threshold, 2, up))


class TableStrategy(_Steering):
    """``strategy=table``: the action ``table[state]`` of the 12-state signal."""

    name = "table"

    def __init__(self, table, discrete: bool):
        super().__init__(discrete)
        self.register_buffer("table", torch.as_tensor(list(table), dtype=torch.long))

    def index(self, signals: torch.Tensor) -> torch.Tensor:
        return self.table[twelve_states(signals).argmax(-1)]
