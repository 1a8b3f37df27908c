r"""Streaming statistics of a policy's decisions, behind Figs. ku0.1, kuInf and ku_pattern (and
the maps of beyondEnergy): :class:`DecisionStats`, filled as an evaluation runs by
:class:`DecisionRecorder` so that no decision is stored, and read by :func:`map_mean`,
:func:`snn_statistic`, :func:`correlation`, :func:`sign_agreement` and
:func:`map_correlation`:

* the maps ``<Lambda | x, y>`` (:data:`MAPS`): sums and counts on fixed bins, the ranges
  those of :func:`~swimrl.analysis.policy_maps.lambda_maps` (S_np and omega over their
  symmetric 99.5 % range, n_theta over ``[-1, 1]``) taken from the first decision of the first
  flow chunk (swimmers placed uniformly: the Eulerian distribution; every seed's evaluation
  has the same flows and initial conditions, hence the same bins); a mean is drawn where a bin
  holds at least 5 decisions;
* the S_nn statistic (:func:`snn_statistic`): a histogram of S_nn (:data:`SNN_BINS` bins over
  three times the first decision's largest ``|S_nn|``, the tails in the end bins) with the
  counts of ``Lambda > 0`` and ``Lambda < 0``: the lowest (highest) fraction ``q`` of the
  decisions is the bins up to the one where the cumulative count reaches ``q n``, a set
  larger than ``q n`` by less than one bin's count (``n_low``, ``n_high`` are recorded);
* the correlation of Lambda with ``n_theta S_np`` (moments), the mean ``|Lambda|``;
* the agreement with STO (:func:`sign_agreement`): the counts of decisions with
  ``sign(Lambda) = sign(Lambda_STO)``, with the opposite sign, and where STO has no sign
  (``n_theta S_np = 0``: each trajectory's first decision, where ``n_theta = 0``); the measure
  of Fig. ku0.1's collapse onto STO;
* a sample of decisions (every :data:`SAMPLE_EVERY`-th decision of the first flow chunk,
  about :data:`SAMPLE_SIZE`) for the scatter plots.
"""

from __future__ import annotations

import math

import numpy as np
import torch

from swimrl.analysis.policy_maps import SIGNAL

#: The maps: name -> (x signal, y signal, (condition signal, sign, threshold) or None, bins).
#: ``n_theta``, ``omega``: Fig. ku_pattern (and dnsFlow (d), (e)); ``omega_nr_pos``,
#: ``omega_nr_neg``: Fig. kuInf (b), (c) (``n_r >= 0.8``, ``n_r <= -0.8``); ``inset``: the
#: inset of Fig. ku0.1 (b).
MAPS = {
    "n_theta": ("S_np", "n_theta", None, 30),
    "omega": ("S_np", "omega", None, 30),
    "omega_nr_pos": ("S_np", "omega", ("n_r", 1.0, 0.8), 30),
    "omega_nr_neg": ("S_np", "omega", ("n_r", -1.0, 0.8), 30),
    "inset": ("n_theta", "S_np", None, 24),
}
#: Bins of the S_nn histogram of the S_nn statistic.
SNN_BINS = 40_000
#: Fraction of the decisions in each tail of the S_nn statistic (the paper: 1 %).
SNN_Q = 0.01
#: The sample of decisions kept for scatter plots: every SAMPLE_EVERY-th decision of the first
#: flow chunk, about SAMPLE_SIZE in all.
SAMPLE_EVERY, SAMPLE_SIZE = 20, 20_000
#: Fewest decisions in a bin whose mean is drawn.
MIN_COUNT = 5


class DecisionStats:
    """Streaming statistics of decisions ``(signals (..., 5), Lambda (...))``: the maps'
    sums and counts, the S_nn histogram, the moments of ``(n_theta S_np, Lambda)`` and a
    sample (see the module docstring). The first :meth:`add` fixes the ranges."""

    def __init__(self) -> None:
        self.ranges: dict[str, tuple[float, float]] | None = None
        self.sums = {k: np.zeros((b, b)) for k, (*_, b) in MAPS.items()}
        self.counts = {k: np.zeros((b, b), dtype=np.int64) for k, (*_, b) in MAPS.items()}
        self.snn = np.zeros((3, SNN_BINS), dtype=np.int64)  # all, Lambda > 0, Lambda < 0
        self.moments = np.zeros(7)  # n, sx, sy, sxx, syy, sxy, sum |Lambda|
        self.sign = np.zeros(3, dtype=np.int64)  # sign(Lambda) vs sign(Lambda_STO): =, !=, 0
        self.sample: list[tuple[np.ndarray, np.ndarray]] = []

    def _fix_ranges(self, sig: torch.Tensor) -> None:
        def symmetric(x: torch.Tensor) -> tuple[float, float]:
            m = float(torch.quantile(x.abs().float(), 0.995)) or 1.0
            return (-m, m)

        snn = float(sig[:, SIGNAL["S_nn"]].abs().max()) * 3 or 1.0
        self.ranges = {"n_theta": (-1.0, 1.0), "S_np": symmetric(sig[:, SIGNAL["S_np"]]),
                       "omega": symmetric(sig[:, SIGNAL["omega"]]), "S_nn": (-snn, snn)}

    def add(self, signals, lam, keep: bool = False) -> None:
        """Decisions ``lam`` taken at ``signals`` (tensors or arrays); ``keep``: also into
        the sample."""
        sig = torch.as_tensor(signals).reshape(-1, 5).double()
        lam = torch.as_tensor(lam).reshape(-1).double()
        if self.ranges is None:
            self._fix_ranges(sig)
        for name, (xs, ys, cond, bins) in MAPS.items():
            x, y, w = sig[:, SIGNAL[xs]], sig[:, SIGNAL[ys]], lam
            if cond is not None:
                c, sign, thr = cond
                m = sig[:, SIGNAL[c]] * sign >= thr
                x, y, w = x[m], y[m], w[m]
            ix, okx = _bin(x, self.ranges[xs], bins)
            iy, oky = _bin(y, self.ranges[ys], bins)
            ok = okx & oky
            flat = (ix * bins + iy)[ok]
            self.counts[name] += torch.bincount(flat, minlength=bins * bins).numpy().reshape(
                bins, bins)
            self.sums[name] += torch.bincount(flat, weights=w[ok],
                                              minlength=bins * bins).numpy().reshape(bins, bins)
        lo, hi = self.ranges["S_nn"]
        i = ((sig[:, SIGNAL["S_nn"]] - lo) / (hi - lo) * SNN_BINS).floor().long()
        i = i.clamp(0, SNN_BINS - 1)
        for row, mask in enumerate((None, lam > 0, lam < 0)):
            idx = i if mask is None else i[mask]
            self.snn[row] += torch.bincount(idx, minlength=SNN_BINS).numpy()
        x = sig[:, SIGNAL["n_theta"]] * sig[:, SIGNAL["S_np"]]
        self.moments += np.array([x.numel(), float(x.sum()), float(lam.sum()),
                                  float((x * x).sum()), float((lam * lam).sum()),
                                  float((x * lam).sum()), float(lam.abs().sum())])
        # STO (eq:sto): sign(Lambda_STO) = -sign(n_theta) sign(S_np) = -sign(x)
        agree = -torch.sign(lam) * torch.sign(x)
        self.sign += np.array([int((agree > 0).sum()), int((agree < 0).sum()),
                               int((agree == 0).sum())], dtype=np.int64)
        if keep:
            self.sample.append((sig.float().numpy(), lam.float().numpy()))

    def arrays(self) -> dict[str, np.ndarray]:
        """Everything as arrays (the cached form; :func:`map_mean`, :func:`snn_statistic`,
        :func:`correlation` read it)."""
        out: dict[str, np.ndarray] = {"snn_hist": self.snn, "moments": self.moments,
                                      "sign_STO": self.sign,
                                      "snn_range": np.asarray(self.ranges["S_nn"])}
        for name, (xs, ys, _, bins) in MAPS.items():
            out[f"map_{name}_sum"], out[f"map_{name}_count"] = self.sums[name], self.counts[name]
            out[f"map_{name}_x"] = np.linspace(*self.ranges[xs], bins + 1)
            out[f"map_{name}_y"] = np.linspace(*self.ranges[ys], bins + 1)
        if self.sample:
            out["sample_signals"] = np.concatenate([s for s, _ in self.sample])
            out["sample_Lambda"] = np.concatenate([lam for _, lam in self.sample])
        else:
            out["sample_signals"], out["sample_Lambda"] = np.zeros((0, 5)), np.zeros(0)
        return out


def _bin(x: torch.Tensor, rng: tuple[float, float], bins: int) -> tuple[torch.Tensor, torch.Tensor]:
    """Bin index of ``x`` in ``bins`` equal bins of ``rng`` (the right edge in the last bin,
    as :func:`numpy.histogramdd`) and whether it lies in the range."""
    lo, hi = rng
    i = ((x - lo) / (hi - lo) * bins).floor().long()
    i = torch.where(x == hi, bins - 1, i)
    return i.clamp(0, bins - 1), (x >= lo) & (x <= hi)


def decision_stats(signals: np.ndarray, lam: np.ndarray) -> dict[str, np.ndarray]:
    """:class:`DecisionStats` arrays of recorded decisions at once (``signals (..., 5)``),
    the whole record also as the sample."""
    st = DecisionStats()
    st.add(signals, lam, keep=True)
    return st.arrays()


def map_mean(a: dict[str, np.ndarray], name: str,
             min_count: int = MIN_COUNT) -> tuple[np.ndarray, list[np.ndarray]]:
    """``<Lambda | x, y>`` of map ``name`` (NaN where fewer than ``min_count`` decisions) and
    its bin edges ``[x, y]``, from :meth:`DecisionStats.arrays`."""
    s, c = a[f"map_{name}_sum"], a[f"map_{name}_count"]
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = s / c
    mean[c < max(1, min_count)] = np.nan
    return mean, [a[f"map_{name}_x"], a[f"map_{name}_y"]]


def snn_statistic(a: dict[str, np.ndarray], q: float = SNN_Q) -> dict[str, float]:
    """``P(Lambda > 0 | S_nn in its lowest q)`` and ``P(Lambda < 0 | S_nn in its highest q)``
    from the S_nn histogram, with the thresholds (bin edges) and the sample counts."""
    total, pos, neg = (np.asarray(h, dtype=np.int64) for h in a["snn_hist"])
    n = int(total.sum())
    edges = np.linspace(*a["snn_range"], total.size + 1)
    lo = int(np.searchsorted(np.cumsum(total), q * n))  # last bin of the lowest q
    hi = total.size - 1 - int(np.searchsorted(np.cumsum(total[::-1]), q * n))
    n_low, n_high = int(total[: lo + 1].sum()), int(total[hi:].sum())
    return {"q": q, "S_nn_low": float(edges[lo + 1]), "S_nn_high": float(edges[hi]),
            "p_pos_given_low": float(pos[: lo + 1].sum() / max(n_low, 1)),
            "p_neg_given_high": float(neg[hi:].sum() / max(n_high, 1)),
            "n_low": n_low, "n_high": n_high, "n": n}


def correlation(a: dict[str, np.ndarray]) -> float:
    """Pearson correlation of Lambda with ``n_theta S_np`` over all decisions (NaN where
    either is constant)."""
    n, sx, sy, sxx, syy, sxy, _ = (float(v) for v in a["moments"])
    vx, vy = sxx / n - (sx / n) ** 2, syy / n - (sy / n) ** 2
    if vx <= 0 or vy <= 1e-300:
        return math.nan
    return (sxy / n - sx * sy / n**2) / math.sqrt(vx * vy)


def sign_agreement(a: dict[str, np.ndarray]) -> dict | None:
    """The agreement of Lambda with STO (``eq:sto``, ``sign(Lambda_STO) = -sign(n_theta
    S_np)``) over all decisions: ``fraction`` = agree / (agree + disagree), the decisions
    where STO has a sign (``undetermined``: ``n_theta S_np = 0`` or ``Lambda = 0``; each
    trajectory's first decision, where ``n_theta = 0``), with the counts; None for arrays
    made before the counts were kept."""
    if "sign_STO" not in a:
        return None
    agree, disagree, zero = (int(v) for v in np.asarray(a["sign_STO"]))
    return {"fraction": agree / max(agree + disagree, 1), "agree": agree,
            "disagree": disagree, "undetermined": zero, "n": agree + disagree + zero}


def map_correlation(a: dict[str, np.ndarray], b: dict[str, np.ndarray], name: str) -> float:
    """Pearson correlation of two evaluations' maps ``name`` over the bins both draw (NaN
    with fewer than 3, or different bins)."""
    (ma, ea), (mb, eb) = map_mean(a, name), map_mean(b, name)
    if any(not np.allclose(x, y) for x, y in zip(ea, eb, strict=True)):
        return math.nan
    ok = np.isfinite(ma) & np.isfinite(mb)
    if ok.sum() < 3 or ma[ok].std() == 0 or mb[ok].std() == 0:
        return math.nan
    return float(np.corrcoef(ma[ok], mb[ok])[0, 1])


class DecisionRecorder:
    """Streams the decisions of strategy block 0 of an evaluation into a
    :class:`DecisionStats` (a recorder of
    :func:`~swimrl.evaluation.rollout.evaluate_shared`)."""

    def __init__(self) -> None:
        self.stats = DecisionStats()
        self.chunks = 0

    @staticmethod
    def sample_swimmers(n_decisions: int, n_flows: int, n_swimmers: int) -> int:
        """Swimmers of each flow of the first chunk (``n_flows`` flows of ``n_swimmers``)
        whose every :data:`SAMPLE_EVERY`-th decision goes into the sample."""
        per_chunk = max(1, n_decisions // SAMPLE_EVERY) * n_flows
        return max(1, min(n_swimmers, math.ceil(SAMPLE_SIZE / per_chunk)))

    def start(self, env, block: int, n_blocks: int) -> None:
        self._block, self._lam_max = block, env.params.shape_factor_max
        self._keep = self.sample_swimmers(env.params.n_decisions, env.batch_size[0], block)

    def __call__(self, i: int, td) -> None:
        sig = td.get("signals")[:, : self._block]
        lam = td.get("action")[:, : self._block, 0].clamp(-self._lam_max, self._lam_max)
        self.stats.add(sig, lam)
        if self.chunks == 0 and i % SAMPLE_EVERY == 0:
            self.stats.sample.append((sig[:, : self._keep].reshape(-1, 5).float().numpy(),
                                      lam[:, : self._keep].reshape(-1).float().numpy()))

    def finish(self, r_hat: torch.Tensor) -> None:
        self.chunks += 1
