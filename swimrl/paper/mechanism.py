r"""What the smart swimmers do: Figs. ku0.1 (Lambda against ``n_theta S_np``), kuInf (Lambda over
``(n_r, S_np, omega)`` and the S_nn statistic) and ku_pattern (the policy maps at each Ku).

The statistics are those of every decision of ``map_flows`` x ``map_swimmers`` swimmers
(>= 4e4 trajectories, 8e7 decisions per Ku) for each of the protocol's training seeds
(``<curves>/ku<KU>_seed<k>/policy.pt``, ``figures.map_seeds``), streamed into histograms as
the evaluation runs (:class:`DecisionStats`, :class:`DecisionRecorder`), so that no decision
is stored:

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

The histograms stay in the cache; each figure's record (``<records>/<figure>.json``) holds
per seed the per-flow R_hat, the sample counts, the S_nn statistic, the correlations and the
agreement with STO, and across seeds the correlation of their maps. The maps drawn are the
first seed's. A field added to this code after a record was made is added to that record
(:func:`extend_record`) from the cached (else re-simulated) evaluation, with how far the
re-simulation's per-flow R_hat lie from the record's; no other field changes.

Fig. kuInf (b), (c) weight each bin's colour by its occupancy (:func:`occupancy_weight`,
:data:`OCCUPANCY_DECADES`): full colour for a bin holding at least the uniform share
(``1 / bins``) of its panel's decisions, fading to white over two decades below it.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np
import torch

from swimrl.analysis.plots import pyplot
from swimrl.analysis.policy_maps import SIGNAL
from swimrl.evaluation.rollout import evaluate_shared
from swimrl.flows.labels import ku_display, ku_name
from swimrl.runs.records import write_json

from .records import (
    KUS,
    RECORD_STRATEGIES,
    Evaluation,
    FiguresConfig,
    actor,
    cache_inputs,
    cached,
    check_record,
    eval_setup,
    figure_record,
    flow_summary,
    ku_evaluation,
    ku_record,
    plain,
    record_sizes,
    run_policy,
)
from .style import COLORS, LABEL, save, sizes_title

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
#: Fig. kuInf (b), (c): a bin's colour weight is ``1 + log10(share / uniform) / DECADES``
#: clipped to ``[0, 1]`` (``share``: its fraction of the panel's decisions, ``uniform = 1 /
#: bins``), the colour mixed with white by that weight: full colour at the uniform share or
#: above, white at ``10**-DECADES`` of it or below (and where fewer than MIN_COUNT decisions).
OCCUPANCY_DECADES = 2.0


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


def extend_record(cfg: FiguresConfig, rec: dict, edit: Callable[[dict], None]) -> dict:
    """``rec`` (a figure record as read or made by :func:`figure_record`) with ``edit``'s
    additions, written back (``<records>/<figure>.json``) where they change it; ``edit``
    adds fields and must change none (checked: every value of ``rec`` is kept)."""
    new = json.loads(json.dumps(rec))
    edit(new)
    new = plain(new)
    if new == rec:
        return rec
    lost = _changed(rec, new)
    if lost:
        raise AssertionError(f"extend_record changed {lost}: it may only add fields")
    path = Path(cfg.records) / f"{rec['figure']}.json"
    check_record(path, new)
    write_json(new, path)
    return new


def _changed(old, new, key: str = "") -> str | None:
    """The first entry of ``old`` that ``new`` does not keep as it was (None: only added)."""
    if isinstance(old, dict) and isinstance(new, dict):
        for k, v in old.items():
            if k not in new:
                return f"{key}.{k} (removed)"
            found = _changed(v, new[k], f"{key}.{k}")
            if found:
                return found
        return None
    return None if old == new else key


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


# -- the evaluations ---------------------------------------------------------------------------
def map_evaluation(cfg: FiguresConfig, kubo: float, seed: int) -> Evaluation:
    """The protocol's run at ``kubo``, training seed ``seed``, on ``map_flows`` x
    ``map_swimmers`` (group ``statistics``)."""
    return Evaluation(f"{ku_name(kubo)}_seed{seed}", "statistics",
                      eval_setup(cfg, kubo, cfg.map_flows, cfg.map_swimmers),
                      {"smart": run_policy(cfg, kubo, seed)})


def map_record(cfg: FiguresConfig, ev: Evaluation) -> dict[str, np.ndarray]:
    """The :class:`DecisionStats` arrays of ``ev``'s smart swimmers and their ``per_flow``
    R_hat (cached)."""
    policy = ev.actors["smart"]

    def compute() -> dict[str, np.ndarray]:
        rec = DecisionRecorder()
        (m,) = evaluate_shared(ev.setup, [actor(policy, ev.setup.params)],
                               desc=f"{ev.key} decisions", recorder=rec)
        return {**rec.stats.arrays(), "per_flow": np.asarray(m["per_flow"])}

    return cached(cfg, f"decisions_{ev.key}",
                  {**cache_inputs(cfg, ev.setup, [policy]), "maps": repr(MAPS),
                   "snn_bins": SNN_BINS, "sample": [SAMPLE_EVERY, SAMPLE_SIZE],
                   "counts": ["sign_STO"]}, compute)


def map_values(cfg: FiguresConfig, ev: Evaluation) -> dict:
    """A statistics evaluation's entry of a record: per-flow R_hat, the counts, the S_nn
    statistic, the correlation of Lambda with ``n_theta S_np`` and the mean ``|Lambda|``."""
    a = map_record(cfg, ev)
    n = int(a["moments"][0])
    return {"per_flow": {"smart": a["per_flow"].tolist()},
            "counts": {"trajectories": ev.setup.sizes.n_flows * ev.setup.sizes.n_swimmers,
                       "decisions": n},
            "derived": {**flow_summary({"smart": a["per_flow"]}), "snn": snn_statistic(a),
                        "corr_Lambda_ntheta_Snp": correlation(a),
                        "mean_abs_Lambda": float(a["moments"][6] / max(n, 1)),
                        "sign_STO": sign_agreement(a)}}


def add_sign_agreement(cfg: FiguresConfig, evaluations: list[Evaluation]) -> Callable[[dict],
                                                                                        None]:
    """An :func:`extend_record` edit: :func:`sign_agreement` into each statistics
    evaluation of a record made before it was kept (``derived.sign_STO``, from the cached or
    re-simulated evaluation, with ``resimulated``: the largest difference of its per-flow
    R_hat from the record's and whether its decision count is the record's)."""
    def edit(rec: dict) -> None:
        for ev in evaluations:
            e = rec["evaluations"][ev.key]
            if e["derived"].get("sign_STO") is not None:
                continue
            a = map_record(cfg, ev)
            diff = np.abs(np.asarray(a["per_flow"]) - np.asarray(e["per_flow"]["smart"]))
            e["derived"]["sign_STO"] = {
                **sign_agreement(a),
                "resimulated": {"per_flow_max_abs_diff": float(diff.max()),
                                "same_decisions": int(a["moments"][0])
                                == e["counts"]["decisions"]}}

    return edit


def seed_evaluations(cfg: FiguresConfig, kubo: float) -> list[Evaluation]:
    return [map_evaluation(cfg, kubo, s) for s in cfg.map_seeds]


def per_seed(rec: dict, kubo: float, seeds: tuple[int, ...]) -> dict:
    """Per seed the S_nn statistic, the correlation and the counts of a record's statistics
    evaluations at ``kubo``, with the mean and std over seeds."""
    out: dict = {}
    for s in seeds:
        e = rec["evaluations"][f"{ku_name(kubo)}_seed{s}"]
        out[str(s)] = {"p_pos_given_low": e["derived"]["snn"]["p_pos_given_low"],
                       "p_neg_given_high": e["derived"]["snn"]["p_neg_given_high"],
                       "corr_Lambda_ntheta_Snp": e["derived"]["corr_Lambda_ntheta_Snp"],
                       "R_hat": e["derived"]["mean"]["smart"], **e["counts"]}
    keys = ["p_pos_given_low", "p_neg_given_high", "corr_Lambda_ntheta_Snp", "R_hat"]
    signs = [rec["evaluations"][f"{ku_name(kubo)}_seed{s}"]["derived"].get("sign_STO")
             for s in seeds]
    if all(signs):  # records made before the agreement with STO was kept have none
        for s, sign in zip(seeds, signs, strict=True):
            out[str(s)]["sign_agreement_STO"] = sign["fraction"]
        keys.append("sign_agreement_STO")
    for key in keys:
        v = np.array([out[str(s)][key] for s in seeds], dtype=float)
        out[f"{key}_mean"] = float(v.mean())
        out[f"{key}_std"] = float(v.std(ddof=1)) if v.size > 1 else 0.0
    return out


def map_correlations(cfg: FiguresConfig, kubo: float) -> dict[str, dict[str, float]]:
    """Correlation of the seeds' maps (``n_theta``, ``omega``) at ``kubo``, pair by pair."""
    arrays = {s: map_record(cfg, map_evaluation(cfg, kubo, s)) for s in cfg.map_seeds}
    seeds = list(arrays)
    return {name: {f"{a}-{b}": map_correlation(arrays[a], arrays[b], name)
                   for i, a in enumerate(seeds) for b in seeds[i + 1:]}
            for name in ("n_theta", "omega")}


def _seed_line(rec: dict, kubo: float, seeds: tuple[int, ...], key: str,
               percent: bool = False, digits: int = 0) -> str:
    """``seed 0: 81%, seed 1: 83%, ...``: a per-seed value of :func:`per_seed` (``digits``
    after the point of a percentage)."""
    d = per_seed(rec, kubo, seeds)

    def fmt(v) -> str:
        if v is None or not math.isfinite(v):
            return "n/a"
        return f"{100 * v:.{digits}f}%" if percent else f"{v:.2f}"

    return ", ".join(f"seed {s}: {fmt(d[str(s)][key])}" for s in seeds)


# -- Fig. ku0.1 ------------------------------------------------------------------------------
def fig_ku01(traj: np.ndarray, smart: dict[str, np.ndarray], sto_sig: np.ndarray,
             sto_lam: np.ndarray, path: Path, title: str = "") -> dict:
    """(a) trajectories ``traj`` ``(3, n, N+1, 2)`` from the origin; (b) Lambda against
    ``n_theta S_np`` for smart (its :class:`DecisionStats` arrays: the sample, the
    correlation and the agreement with STO over all decisions) and STO (recorded
    decisions), the quadrants of STO's sign shaded; inset: smart's
    ``<Lambda | n_theta, S_np>``."""
    plt = pyplot()
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.8))
    for j, name in enumerate(RECORD_STRATEGIES):
        for i, x in enumerate(traj[j]):
            a.plot(x[:, 0], x[:, 1], color=COLORS[name], lw=0.8, label=name if i == 0 else None)
    a.plot(0, 0, "r*", ms=10)
    a.set_aspect("equal")
    a.set_xlabel(r"$\Delta x/\ell_f$")
    a.set_ylabel(r"$\Delta y/\ell_f$")
    a.set_title("(a) trajectories from the start point, Ku = 0.1", fontsize=9)
    a.legend(fontsize=8)
    rng = np.random.default_rng(0)
    out = {"corr_smart": correlation(smart), "sign_smart": sign_agreement(smart)}
    sto = {"sig": sto_sig.reshape(-1, 5), "lam": sto_lam.ravel()}
    for name, sig, lam in (("smart", smart["sample_signals"], smart["sample_Lambda"]),
                           ("STO", sto["sig"], sto["lam"])):
        x = sig[:, SIGNAL["n_theta"]] * sig[:, SIGNAL["S_np"]]
        pick = rng.choice(x.size, min(x.size, 20000), replace=False)
        b.scatter(x[pick], lam[pick], s=1, color=COLORS[name], alpha=0.3, label=name,
                  rasterized=True)
    x = sto["sig"][:, SIGNAL["n_theta"]] * sto["sig"][:, SIGNAL["S_np"]]
    out["corr_STO"] = (float(np.corrcoef(x, sto["lam"])[0, 1])
                       if x.std() > 0 and sto["lam"].std() > 0 else float("nan"))
    # the quadrants where sign(Lambda) = sign(Lambda_STO) = -sign(n_theta S_np)
    b.axhline(0, color="0.6", lw=0.5, zorder=0)
    b.axvline(0, color="0.6", lw=0.5, zorder=0)
    xl, yl = b.get_xlim(), b.get_ylim()
    for (x0, x1), (y0, y1) in (((xl[0], 0), (0, yl[1])), ((0, xl[1]), (yl[0], 0))):
        b.fill_between([x0, x1], y0, y1, color=COLORS["STO"], alpha=0.08, lw=0, zorder=0)
    b.set_xlim(xl)
    b.set_ylim(yl)
    b.set_xlabel(r"$n_\theta S_{np}\tau_K$")
    b.set_ylabel(r"$\Lambda$")
    sign = out["sign_smart"]
    agree = (f"; shaded: sign(Λ) = sign(Λ_STO), smart: {100 * sign['fraction']:.1f}% of "
             f"its {sign['agree'] + sign['disagree']:.2g} decisions" if sign else "")
    b.set_title(f"(b) shape factor against $n_\\theta S_{{np}}${agree}", fontsize=8)
    b.legend(fontsize=8, markerscale=8, loc="lower left")
    ins = b.inset_axes([0.63, 0.56, 0.34, 0.34])
    mean, edges = map_mean(smart, "inset")
    im = ins.pcolormesh(edges[0], edges[1], mean.T, cmap="coolwarm", vmin=-1, vmax=1)
    ins.set_xlabel(r"$n_\theta$", fontsize=7, labelpad=0)
    ins.set_ylabel(r"$S_{np}\tau_K$", fontsize=7, labelpad=0)
    ins.tick_params(labelsize=6)
    fig.colorbar(im, ax=b, shrink=0.8, label=r"$\langle\Lambda\rangle$ (inset, smart)")
    fig.suptitle(title, fontsize=8)
    fig.tight_layout()
    save(fig, path)
    out["inset"] = mean
    return out


def _ku01_values(cfg: FiguresConfig, ev: Evaluation) -> dict:
    if ev.group == "statistics":
        return map_values(cfg, ev)
    d = ku_record(cfg, ev.kubo)
    sig, lam = d["sto_signals"].reshape(-1, 5), d["sto_Lambda"].ravel()
    x = sig[:, SIGNAL["n_theta"]] * sig[:, SIGNAL["S_np"]]
    corr = float(np.corrcoef(x, lam)[0, 1]) if x.std() > 0 and lam.std() > 0 else math.nan
    per = {n: d["per_flow"][j].tolist() for j, n in enumerate(ev.actors)}
    return {"per_flow": per, "counts": {"sto_decisions": int(lam.size)},
            "derived": {**flow_summary(per, [("smart", "STO")]), "corr_STO": corr}}


def build_ku01(cfg: FiguresConfig) -> dict:
    kubo = 0.1
    stats = seed_evaluations(cfg, kubo)
    traj_ev = replace(ku_evaluation(cfg, kubo), options={"n_traj": cfg.n_traj})
    rec = figure_record(cfg, "ku0.1", [*stats, traj_ev], lambda ev: _ku01_values(cfg, ev),
                        lambda r: {"per_seed": per_seed(r, kubo, cfg.map_seeds)})
    add = add_sign_agreement(cfg, stats)

    def edit(r: dict) -> None:
        add(r)
        r["derived"]["per_seed"] = per_seed(r, kubo, cfg.map_seeds)

    rec = extend_record(cfg, rec, edit)
    d = ku_record(cfg, kubo)
    seed0 = cfg.map_seeds[0]
    mf, ms = record_sizes(rec, "statistics")
    tf, ts = record_sizes(rec, "trajectories")
    agree = _seed_line(rec, kubo, cfg.map_seeds, "sign_agreement_STO", True, 1)
    corr = _seed_line(rec, kubo, cfg.map_seeds, "corr_Lambda_ntheta_Snp")
    duration = rec["params"]["duration"]
    out = fig_ku01(d["traj"], map_record(cfg, stats[0]), d["sto_signals"], d["sto_Lambda"],
                   cfg.out / "ku0.1.png",
                   f"Ku = 0.1; (a) shipped policy ku0.1, {sizes_title(tf, ts, duration)};\n"
                   f"(b) the protocol's run seed {seed0} on {mf} flows x {ms} swimmers "
                   f"(inset: its map; scatter: a sample of its first 10 flows);\n"
                   f"sign(Λ) = sign(Λ_STO) in every decision where STO has a sign: {agree}; "
                   f"corr(Λ, $n_\\theta S_{{np}}$): {corr}")
    out["record"] = str(cfg.records / "ku0.1.json")
    return out


# -- Fig. kuInf and the S_nn statistic -------------------------------------------------------
def occupancy_weight(counts: np.ndarray, decades: float = OCCUPANCY_DECADES,
                     min_count: int = MIN_COUNT) -> np.ndarray:
    """The colour weight of each bin of a map (:data:`OCCUPANCY_DECADES`): ``1 +
    log10(share / uniform) / decades`` clipped to ``[0, 1]``, ``share`` the bin's fraction of
    the map's decisions and ``uniform = 1 / bins``; 0 where fewer than ``min_count``."""
    c = np.asarray(counts, dtype=float)
    share = c / max(c.sum(), 1.0)
    with np.errstate(divide="ignore"):
        w = 1 + np.log10(share * c.size) / decades
    w = np.clip(np.nan_to_num(w, neginf=0.0), 0.0, 1.0)
    w[c < max(1, min_count)] = 0.0
    return w


def occupancy_rule(bins: int, decades: float = OCCUPANCY_DECADES,
                   min_count: int = MIN_COUNT) -> dict:
    """The colour rule of Fig. kuInf (b), (c) as its record states it."""
    return {"weight": f"clip(1 + log10(share * {bins * bins}) / {decades:g}, 0, 1); colour "
                      "= weight * colormap(<Lambda>) + (1 - weight) * white",
            "share": "the bin's fraction of the panel's decisions",
            "full_colour_share": 1 / bins**2, "white_share": 10**-decades / bins**2,
            "min_count": min_count}


def _draw_weighted(fig, ax, mean: np.ndarray, weight: np.ndarray, edges: list[np.ndarray]):
    """``mean`` ``(x, y)`` in coolwarm on ``[-1, 1]`` mixed with white by ``weight``."""
    from matplotlib import cm, colors

    cmap, norm = pyplot().get_cmap("coolwarm"), colors.Normalize(-1, 1)
    rgb = cmap(norm(np.nan_to_num(mean)))[..., :3]
    w = np.where(np.isfinite(mean), weight, 0.0)[..., None]
    rgb = w * rgb + (1 - w) * 1.0
    ax.imshow(np.swapaxes(rgb, 0, 1), origin="lower", aspect="auto", interpolation="nearest",
              extent=[edges[0][0], edges[0][-1], edges[1][0], edges[1][-1]])
    return fig.colorbar(cm.ScalarMappable(norm, cmap), ax=ax,
                        label=r"$\langle\Lambda\rangle$ (full colour)")


def fig_ku_inf(smart: dict[str, np.ndarray], path: Path, title: str = "",
               statistic: str = "", sample: str = "") -> dict:
    """(a) Lambda over (n_r, S_np, omega) (the sample; ``sample``: where it comes from, in
    its title); (b, c) ``<Lambda | S_np, omega>`` for ``n_r >= 0.8`` and ``n_r <= -0.8``,
    each bin's colour weighted by its occupancy (:func:`occupancy_weight`); the S_nn
    statistic (``statistic``: as the record states it per seed; default: of ``smart``)
    under the title."""
    from matplotlib.ticker import MaxNLocator

    plt = pyplot()
    s, lam = smart["sample_signals"].reshape(-1, 5), smart["sample_Lambda"].ravel()
    fig = plt.figure(figsize=(15, 5.4))
    grid = fig.add_gridspec(1, 3, width_ratios=[1.1, 1, 1], left=0.01, right=0.97, top=0.8,
                            bottom=0.12, wspace=0.22)
    ax = fig.add_subplot(grid[0], projection="3d")
    n_drawn = min(lam.size, 8000)
    pick = np.random.default_rng(0).choice(lam.size, n_drawn, replace=False)
    sc = ax.scatter(s[pick, 0], s[pick, 3], s[pick, 4], c=lam[pick], cmap="coolwarm", vmin=-1,
                    vmax=1, s=2)
    ax.set_box_aspect(None, zoom=0.9)  # room for the z label inside the figure
    ax.set_xticks([-1, 0, 1])
    for axis in (ax.yaxis, ax.zaxis):
        axis.set_major_locator(MaxNLocator(5))
    ax.set_xlabel(r"$n_r$", labelpad=0)
    ax.set_ylabel(r"$S_{np}\tau_K$", labelpad=0)
    ax.set_zlabel(r"$\omega\tau_K$", labelpad=0)
    ax.tick_params(labelsize=7, pad=0)
    ax.set_title(f"(a) {n_drawn} decisions at random of a sample of {lam.size}"
                 + (f"\n{sample}" if sample else ""), fontsize=8)
    fig.colorbar(sc, ax=ax, shrink=0.55, label=r"$\Lambda$", pad=0.04)
    out = {"snn": snn_statistic(smart), "a": {"drawn": n_drawn, "sample": int(lam.size)},
           "occupancy": {}}
    for i, (label, name) in enumerate(((r"$n_r \geq 0.8$", "omega_nr_pos"),
                                       (r"$n_r \leq -0.8$", "omega_nr_neg"))):
        a = fig.add_subplot(grid[1 + i])
        mean, edges = map_mean(smart, name)
        counts = np.asarray(smart[f"map_{name}_count"])
        weight = occupancy_weight(counts)
        _draw_weighted(fig, a, mean, weight, edges)
        a.set_xlabel(r"$S_{np}\tau_K$")
        a.set_ylabel(r"$\omega\tau_K$")
        # two significant digits: the exact count follows chaotic float32 trajectories and
        # differs between machines (docs/reliability.md); the record holds the total count
        n = int(counts.sum())
        full = float(counts[weight >= 1].sum() / max(n, 1))
        faint = float(counts[weight < 0.5].sum() / max(n, 1))
        a.set_title(f"({'bc'[i]}) {label}, {n:.2g} decisions; full colour: bins holding "
                    f"≥ 1/{counts.size}\nof them (together {100 * full:.0f}%); under half "
                    f"colour: bins holding {100 * faint:.1f}%", fontsize=8)
        out["bc"[i]] = mean
        out["occupancy"]["bc"[i]] = {"full_colour": full, "under_half": faint,
                                     "weight": weight}
    if not statistic:
        st = out["snn"]
        statistic = (f"P(Λ>0 | lowest 1% of S_nn) = {100 * st['p_pos_given_low']:.0f}%, "
                     f"P(Λ<0 | highest 1%) = {100 * st['p_neg_given_high']:.0f}%")
    rule = (f"(b), (c): a bin's colour fades to white with its share of the panel's decisions: "
            f"weight = clip(1 + log10(share x bins) / {OCCUPANCY_DECADES:g}, 0, 1), full at "
            f"the uniform share, white at 1/{10**OCCUPANCY_DECADES:g} of it or with < "
            f"{MIN_COUNT} decisions")
    fig.suptitle(f"{title}\nS_nn statistic: {statistic} (paper: 82%)\n{rule}", fontsize=8)
    save(fig, path)
    return out


def sample_statement(cfg: FiguresConfig, ev: Evaluation) -> tuple[str, dict]:
    """Where the sample of an evaluation's decisions (Fig. kuInf (a)) comes from: a title
    line and the record's entry."""
    sz, params = ev.setup.sizes, ev.setup.params
    flows = min(sz.flows_per_batch, sz.n_flows)
    keep = DecisionRecorder.sample_swimmers(params.n_decisions, flows, sz.n_swimmers)
    per_swimmer = math.ceil(params.n_decisions / SAMPLE_EVERY)
    return (f"(every {SAMPLE_EVERY}th decision of swimmers 1-{keep} of flows 1-{flows})",
            {"policy": ev.actors["smart"], "flows": flows, "swimmers_per_flow": keep,
             "every": SAMPLE_EVERY, "sample": keep * flows * per_swimmer, "drawn":
             min(keep * flows * per_swimmer, 8000)})


def build_ku_inf(cfg: FiguresConfig) -> dict:
    kubo = 1e7
    stats = seed_evaluations(cfg, kubo)
    rec = figure_record(cfg, "kuInf", stats, lambda ev: map_values(cfg, ev),
                        lambda r: {"per_seed": per_seed(r, kubo, cfg.map_seeds)})
    line, entry = sample_statement(cfg, stats[0])
    bins = MAPS["omega_nr_pos"][3]

    def drawn(r: dict) -> None:
        r["derived"]["drawn"] = {"seed": cfg.map_seeds[0], "a": entry,
                                 "bc_colour": occupancy_rule(bins)}

    rec = extend_record(cfg, rec, drawn)
    flows, swimmers = record_sizes(rec, "statistics")
    low = _seed_line(rec, kubo, cfg.map_seeds, "p_pos_given_low", True)
    high = _seed_line(rec, kubo, cfg.map_seeds, "p_neg_given_high", True)
    n = rec["evaluations"][stats[0].key]["counts"]["decisions"]
    out = fig_ku_inf(map_record(cfg, stats[0]), cfg.out / "kuInf.png",
                     f"smart, Ku = $10^7$: the protocol's run seed {cfg.map_seeds[0]} "
                     f"({stats[0].actors['smart']}) drawn; "
                     f"{sizes_title(flows, swimmers, rec['params']['duration'])} "
                     f"({n:.2g} decisions) per seed",
                     f"P(Λ>0 | lowest 1% of S_nn) {low}; P(Λ<0 | highest 1%) {high}", line)
    out["record"] = str(cfg.records / "kuInf.json")
    return out


# -- Fig. ku_pattern -------------------------------------------------------------------------
def fig_ku_pattern(records: dict[float, dict[str, np.ndarray]], path: Path,
                   title: str = "") -> dict:
    """``<Lambda | S_np, n_theta>`` (top) and ``<Lambda | S_np, omega>`` (bottom) per Ku, from
    each Ku's :class:`DecisionStats` arrays."""
    plt = pyplot()
    kus = sorted(records)
    fig, axes = plt.subplots(2, len(kus), figsize=(3.3 * len(kus), 6.4), squeeze=False,
                             layout="constrained")
    out = {}
    for i, kubo in enumerate(kus):
        for row, other in enumerate(("n_theta", "omega")):
            mean, edges = map_mean(records[kubo], other)
            a = axes[row, i]
            im = a.pcolormesh(edges[0], edges[1], mean.T, cmap="coolwarm", vmin=-1, vmax=1)
            a.set_xlabel(LABEL["S_np"])
            a.set_ylabel(LABEL[other])
            a.set_title(f"({'abcdefgh'[row * 4 + i] if len(kus) == 4 else ''}) "
                        f"{ku_display(kubo)}", fontsize=9)
            out[(kubo, other)] = mean
    fig.colorbar(im, ax=axes, shrink=0.6, label=r"$\langle\Lambda\rangle$")
    fig.suptitle(title, fontsize=8)
    save(fig, path)
    return out


def build_ku_pattern(cfg: FiguresConfig) -> dict:
    evs = [ev for k in KUS for ev in seed_evaluations(cfg, k)]

    def derive(r: dict) -> dict:
        return {ku_name(k): {"per_seed": per_seed(r, k, cfg.map_seeds),
                             "map_correlation": map_correlations(cfg, k)} for k in KUS}

    rec = figure_record(cfg, "ku_pattern", evs, lambda ev: map_values(cfg, ev), derive)
    flows, swimmers = record_sizes(rec, "statistics")
    seed0 = cfg.map_seeds[0]
    corr = "; ".join(
        f"{ku_display(k)}: " + ", ".join(f"{v:.2f}" for v in
                                          rec["derived"][ku_name(k)]["map_correlation"]
                                          ["omega"].values() if v is not None)
        for k in KUS)
    out = fig_ku_pattern({k: map_record(cfg, map_evaluation(cfg, k, seed0)) for k in KUS},
                         cfg.out / "ku_pattern.png",
                         f"smart, the protocol's runs seed {seed0}; "
                         f"{sizes_title(flows, swimmers, rec['params']['duration'])} per Ku;\n"
                         f"correlation of the seeds' <Λ|S_np, ω> maps (pairs of seeds "
                         f"{', '.join(map(str, cfg.map_seeds))}): {corr}")
    out["record"] = str(cfg.records / "ku_pattern.json")
    return out
