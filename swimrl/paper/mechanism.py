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
* a sample of decisions (every :data:`SAMPLE_EVERY`-th decision of the first flow chunk,
  about :data:`SAMPLE_SIZE`) for the scatter plots.

The histograms stay in the cache; each figure's record (``<records>/<figure>.json``) holds
per seed the per-flow R_hat, the sample counts, the S_nn statistic and the correlations, and
across seeds the correlation of their maps. The maps drawn are the first seed's.
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import torch

from swimrl.analysis.plots import pyplot
from swimrl.analysis.policy_maps import SIGNAL
from swimrl.evaluation.rollout import evaluate_shared
from swimrl.flows.labels import ku_display, ku_name

from .records import (
    KUS,
    RECORD_STRATEGIES,
    Evaluation,
    FiguresConfig,
    actor,
    cache_inputs,
    cached,
    eval_setup,
    figure_record,
    flow_summary,
    ku_evaluation,
    ku_record,
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
        if keep:
            self.sample.append((sig.float().numpy(), lam.float().numpy()))

    def arrays(self) -> dict[str, np.ndarray]:
        """Everything as arrays (the cached form; :func:`map_mean`, :func:`snn_statistic`,
        :func:`correlation` read it)."""
        out: dict[str, np.ndarray] = {"snn_hist": self.snn, "moments": self.moments,
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

    def start(self, env, block: int, n_blocks: int) -> None:
        self._block, self._lam_max = block, env.params.shape_factor_max
        per_chunk = max(1, env.params.n_decisions // SAMPLE_EVERY) * env.batch_size[0]
        self._keep = max(1, min(block, math.ceil(SAMPLE_SIZE / per_chunk)))

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
                   "snn_bins": SNN_BINS, "sample": [SAMPLE_EVERY, SAMPLE_SIZE]}, compute)


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
                        "mean_abs_Lambda": float(a["moments"][6] / max(n, 1))}}


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
    for key in ("p_pos_given_low", "p_neg_given_high", "corr_Lambda_ntheta_Snp", "R_hat"):
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
               percent: bool = False) -> str:
    """``seed 0: 81%, seed 1: 83%, ...``: a per-seed value of :func:`per_seed`."""
    d = per_seed(rec, kubo, seeds)

    def fmt(v) -> str:
        if v is None or not math.isfinite(v):
            return "n/a"
        return f"{100 * v:.0f}%" if percent else f"{v:.2f}"

    return ", ".join(f"seed {s}: {fmt(d[str(s)][key])}" for s in seeds)


# -- Fig. ku0.1 ------------------------------------------------------------------------------
def fig_ku01(traj: np.ndarray, smart: dict[str, np.ndarray], sto_sig: np.ndarray,
             sto_lam: np.ndarray, path: Path, title: str = "") -> dict:
    """(a) trajectories ``traj`` ``(3, n, N+1, 2)`` from the origin; (b) Lambda against
    ``n_theta S_np`` for smart (its :class:`DecisionStats` arrays: the sample, the
    correlation over all decisions) and STO (recorded decisions); inset: smart's
    ``<Lambda | n_theta, S_np>``."""
    plt = pyplot()
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.6))
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
    out = {"corr_smart": correlation(smart)}
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
    b.set_xlabel(r"$n_\theta S_{np}\tau_K$")
    b.set_ylabel(r"$\Lambda$")
    b.set_title("(b) shape factor against $n_\\theta S_{np}$", fontsize=9)
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
    d = ku_record(cfg, kubo)
    seed0 = cfg.map_seeds[0]
    mf, ms = record_sizes(rec, "statistics")
    tf, ts = record_sizes(rec, "trajectories")
    corr = _seed_line(rec, kubo, cfg.map_seeds, "corr_Lambda_ntheta_Snp")
    duration = rec["params"]["duration"]
    out = fig_ku01(d["traj"], map_record(cfg, stats[0]), d["sto_signals"], d["sto_Lambda"],
                   cfg.out / "ku0.1.png",
                   f"Ku = 0.1; (a) shipped policy ku0.1, {sizes_title(tf, ts, duration)};\n"
                   f"(b) the protocol's run seed {seed0} on {mf} flows x {ms} swimmers "
                   f"(inset: its map); corr(Λ, $n_\\theta S_{{np}}$) per seed: {corr}")
    out["record"] = str(cfg.records / "ku0.1.json")
    return out


# -- Fig. kuInf and the S_nn statistic -------------------------------------------------------
def fig_ku_inf(smart: dict[str, np.ndarray], path: Path, title: str = "",
               statistic: str = "") -> dict:
    """(a) Lambda over (n_r, S_np, omega) (the sample); (b, c) ``<Lambda | S_np, omega>``
    for ``n_r >= 0.8`` and ``n_r <= -0.8``; the S_nn statistic (``statistic``: as the
    record states it per seed; default: of ``smart``) under the title."""
    plt = pyplot()
    s, lam = smart["sample_signals"].reshape(-1, 5), smart["sample_Lambda"].ravel()
    fig = plt.figure(figsize=(14, 4.3))
    ax = fig.add_subplot(1, 3, 1, projection="3d")
    pick = np.random.default_rng(0).choice(lam.size, min(lam.size, 8000), replace=False)
    sc = ax.scatter(s[pick, 0], s[pick, 3], s[pick, 4], c=lam[pick], cmap="coolwarm", vmin=-1,
                    vmax=1, s=2)
    ax.set_xlabel(r"$n_r$")
    ax.set_ylabel(r"$S_{np}\tau_K$")
    ax.set_zlabel(r"$\omega\tau_K$")
    ax.set_title("(a)", fontsize=9)
    fig.colorbar(sc, ax=ax, shrink=0.6, label=r"$\Lambda$", pad=0.1)
    out = {"snn": snn_statistic(smart)}
    for i, (label, name) in enumerate(((r"$n_r \geq 0.8$", "omega_nr_pos"),
                                       (r"$n_r \leq -0.8$", "omega_nr_neg"))):
        a = fig.add_subplot(1, 3, 2 + i)
        mean, edges = map_mean(smart, name)
        im = a.pcolormesh(edges[0], edges[1], mean.T, cmap="coolwarm", vmin=-1, vmax=1)
        fig.colorbar(im, ax=a, label=r"$\langle\Lambda\rangle$")
        a.set_xlabel(r"$S_{np}\tau_K$")
        a.set_ylabel(r"$\omega\tau_K$")
        # two significant digits: the exact count follows chaotic float32 trajectories and
        # differs between machines (docs/reliability.md); the record holds the total count
        n = int(smart[f"map_{name}_count"].sum())
        a.set_title(f"({'bc'[i]}) {label}, {n:.2g} decisions", fontsize=9)
        out["bc"[i]] = mean
    if not statistic:
        st = out["snn"]
        statistic = (f"P(Λ>0 | lowest 1% of S_nn) = {100 * st['p_pos_given_low']:.0f}%, "
                     f"P(Λ<0 | highest 1%) = {100 * st['p_neg_given_high']:.0f}%")
    fig.suptitle(f"{title}\nS_nn statistic: {statistic} (paper: 82%)", fontsize=8)
    fig.tight_layout()
    save(fig, path)
    return out


def build_ku_inf(cfg: FiguresConfig) -> dict:
    kubo = 1e7
    stats = seed_evaluations(cfg, kubo)
    rec = figure_record(cfg, "kuInf", stats, lambda ev: map_values(cfg, ev),
                        lambda r: {"per_seed": per_seed(r, kubo, cfg.map_seeds)})
    flows, swimmers = record_sizes(rec, "statistics")
    low = _seed_line(rec, kubo, cfg.map_seeds, "p_pos_given_low", True)
    high = _seed_line(rec, kubo, cfg.map_seeds, "p_neg_given_high", True)
    n = rec["evaluations"][stats[0].key]["counts"]["decisions"]
    out = fig_ku_inf(map_record(cfg, stats[0]), cfg.out / "kuInf.png",
                     f"smart, Ku = $10^7$, the protocol's run seed {cfg.map_seeds[0]} "
                     f"(maps); {sizes_title(flows, swimmers, rec['params']['duration'])} "
                     f"({n:.2g} decisions) per seed",
                     f"P(Λ>0 | lowest 1% of S_nn) {low}; P(Λ<0 | highest 1%) {high}")
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
