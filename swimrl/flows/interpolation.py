r"""Second-order (bilinear) interpolation on a periodic grid, batched over flows.

For a node-sampled field $f_{j,i} = f(ih, jh)$ and a point $(x, y)$ with
$s_x = x/h = i_0 + a$, $s_y = y/h = j_0 + b$ ($0 \le a, b < 1$):

$$
\begin{aligned}
f(x, y) \approx{}& (1-a)(1-b)\,f_{j_0,i_0} + a(1-b)\,f_{j_0,i_0+1}\\
&+ (1-a)\,b\,f_{j_0+1,i_0} + ab\,f_{j_0+1,i_0+1}
\end{aligned}
$$

indices taken modulo $N$ (periodic extension). The scheme is exact for bilinear
functions; for smooth $f$ the error is bounded by
$|\mathrm{err}| \le (h^2/8)\,(\max|f_{xx}| + \max|f_{yy}|)$ (second order in $h$).
"""

from __future__ import annotations

import torch


def bilinear_periodic(
    table: torch.Tensor, n: int, flow_index: torch.Tensor, pos: torch.Tensor, spacing: float
) -> torch.Tensor:
    """Interpolate channel-last grid data at points.

    Args:
        table: ``(F * n * n, C)`` node values, rows ordered ``(flow, iy, ix)``.
        n: grid points per side.
        flow_index: ``(P,)`` int64, flow of each point.
        pos: ``(P, 2)`` positions ``(x, y)``; any real value (wrapped periodically).
        spacing: grid spacing $h$.

    Returns:
        ``(P, C)`` interpolated values.
    """
    s = pos / spacing
    s0 = torch.floor(s)
    frac = s - s0
    i0 = s0.to(torch.int64).remainder(n)
    i1 = (i0 + 1).remainder(n)
    base = flow_index * (n * n)
    ix0, iy0 = i0[:, 0], i0[:, 1] * n
    ix1, iy1 = i1[:, 0], i1[:, 1] * n
    idx = torch.stack((base + iy0 + ix0, base + iy0 + ix1, base + iy1 + ix0, base + iy1 + ix1))
    a, b = frac[:, 0], frac[:, 1]
    wa, wb = 1 - a, 1 - b
    w = torch.stack((wa * wb, a * wb, wa * b, a * b)).unsqueeze(-1)
    rows = table.index_select(0, idx.reshape(-1)).view(4, pos.shape[0], table.shape[-1])
    return (rows * w).sum(0)
