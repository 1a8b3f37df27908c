"""The evaluations the figures are drawn from, and the cache that keeps their arrays.

An :class:`Evaluation` is strategies on shared flows (common random numbers) of one setup
(:func:`eval_setup`), each actor a policy spec or a baseline label (:func:`actor`).
Evaluations go through the one rollout loop; their arrays (trajectories, clouds, the per-flow
R_hat) are cached under ``cache/`` as ``.npz`` files keyed by a hash of their inputs
(:func:`cached`, :func:`cache_inputs`: the setup, the policy file's bytes,
:data:`CACHE_VERSION`), so a second build only draws. The cache is a pure cache: deleting it
changes no number. Every Ku record (:func:`ku_record`) holds the strategies in the order of
:data:`RECORD_STRATEGIES` (smart, naive, STO) along its first axis. :func:`flow_summary` and
:func:`per_flow_values` make an evaluation's numbers from its per-flow R_hat (mean, std over
flows, paired ratios), as a figure record (:mod:`.records`) holds them.

Units: lengths in ``l_f``, times in ``tau_K``, signals in ``tau_K`` units.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable, Iterable, Mapping
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np

from swimrl.env import EnvParams, build_env
from swimrl.evaluation.rollout import chunk_seed, evaluate_shared
from swimrl.evaluation.statistics import mean_std_sem, paired_ratio
from swimrl.evaluation.trajectories import TrajectoryRecorder
from swimrl.flows.labels import ku_display, ku_name
from swimrl.policies.baselines import StrategyLabel, StrategySpec
from swimrl.runs.policy_files import load_policy, resolve_policy_file, sha256_file
from swimrl.runs.records import read_npz, write_npz
from swimrl.runs.spec import EvalSizes, RunSpec

from .settings import FiguresConfig, portable

#: Bump when a cached array's meaning changes.
CACHE_VERSION = 2
KUS = (0.1, 1.0, 10.0, 1e7)
#: Decisions between video frames (4 tau_K at T_u = 0.1 tau_K: 51 frames over T = 200 tau_K).
FRAME_EVERY = 40
#: The strategies of a record (:func:`ku_record`), in the order of its first axis, by the
#: names the figures show (the keys of :data:`~swimrl.paper.style.COLORS`).
RECORD_STRATEGIES = ("smart", "naive", "STO")


def is_policy(actor_name: str) -> bool:
    """Whether an actor name is a policy spec (a file), not a baseline label."""
    return "/" in actor_name and not actor_name.startswith(("naive", "minimal", "sto"))


# -- cache and evaluations -------------------------------------------------------------------
def cached(cfg: FiguresConfig, name: str, inputs: dict,
           compute: Callable[[], dict[str, np.ndarray]]) -> dict[str, np.ndarray]:
    """``compute()`` once per distinct ``inputs``: stored as ``cache/<name>-<hash>.npz``."""
    text = json.dumps({"v": CACHE_VERSION, **inputs}, sort_keys=True, default=str)
    path = Path(cfg.cache) / f"{name}-{hashlib.sha256(text.encode()).hexdigest()[:12]}.npz"
    if path.exists():
        return read_npz(path)
    data = compute()
    write_npz(data, path)
    return data


def eval_setup(cfg: FiguresConfig, kubo: float, n_flows: int, n_swimmers: int,
               **params) -> RunSpec:
    """The evaluation of ``n_flows`` x ``n_swimmers`` at ``kubo`` in chunks of
    ``figures.flows_per_batch`` flows (``params``: fields of ``cfg.params`` changed)."""
    sizes = EvalSizes(n_flows, n_swimmers, min(cfg.flows_per_batch, n_flows), cfg.progress,
                      n_swimmers)
    return RunSpec(flow=replace(cfg.flow, kubo=float(kubo)),
                     params=replace(cfg.params, **params) if params else cfg.params,
                     runtime=cfg.runtime, sizes=sizes, seed=cfg.seed, record={})


def smart_policy(cfg: FiguresConfig, kubo: float) -> str:
    """The shipped smart policy trained at ``kubo`` (a policy spec)."""
    return f"{cfg.policies}/{ku_name(kubo)}"


def run_policy(cfg: FiguresConfig, kubo: float, seed: int) -> str:
    """The policy of the protocol's run at ``kubo`` with training seed ``seed`` (a path, as
    :func:`~.settings.portable` names it)."""
    return portable(Path(cfg.curves) / f"{ku_name(kubo)}_seed{seed}" / "policy.pt")


def cache_inputs(cfg: FiguresConfig, setup: RunSpec, actors: list[str]) -> dict:
    """What an evaluation of ``actors`` on ``setup`` depends on (the cache key)."""
    files = {a: sha256_file(resolve_policy_file(a))[:16] for a in actors if is_policy(a)}
    return {"flow": asdict(setup.flow), "params": asdict(setup.params),
            "sizes": [setup.sizes.n_flows, setup.sizes.n_swimmers,
                      setup.sizes.flows_per_batch], "seed": setup.seed,
            "dtype": str(cfg.runtime.dtype), "actors": actors, "files": files}


def actor(name: str, params: EnvParams):
    """The strategy of an actor name (a :class:`~swimrl.policies.baselines.StrategyLabel`):
    ``naive`` (``Lambda = 0.98``), ``sto``, ``naive(L)``, ``minimal(c1,c2,c3,c4)``, or a
    policy spec (loaded)."""
    label = StrategyLabel.parse(name)
    if label.name == "naive":
        return StrategySpec("naive", shape_factor=label.numbers[0] if label.arg else 0.98)
    if label == StrategyLabel("sto"):
        return StrategySpec("sto")
    if label.name == "minimal" and label.arg:
        return StrategySpec("minimal", coeffs=label.numbers)
    return load_policy(name, params)


def record_strategies(setup: RunSpec, actors: list[str], desc: str,
                      field_every: int = 0) -> dict[str, np.ndarray]:
    """Every decision of every swimmer of ``actors`` (policy specs, ``naive``, ``sto``,
    ``naive(L)``) sharing the flows of ``setup``: the recorder's arrays."""
    rec = TrajectoryRecorder(setup.sizes.n_swimmers, field_every)
    evaluate_shared(setup, [actor(a, setup.params) for a in actors], desc=desc, recorder=rec)
    return rec.arrays()


@dataclass(frozen=True)
class Evaluation:
    """One evaluation of a figure record: strategies on shared flows (common random
    numbers), each with ``setup.sizes.n_swimmers`` swimmers."""

    key: str
    """Its name in the record (``ku10``, ``duration=50``, ``ku1e7_seed0``)."""
    group: str
    """The evaluations of a record with one size (``sweep``, ``statistics``,
    ``trajectories``)."""
    setup: RunSpec
    actors: Mapping[str, str] = field(default_factory=dict)
    """Name shown -> actor name (:func:`actor`), in the order of the strategy blocks."""
    options: Mapping[str, object] = field(default_factory=dict)
    """Other inputs its recorded values depend on (``{"n_traj": 8}``: the STO decisions of
    ku0.1's correlation), recorded in its setup."""

    @property
    def kubo(self) -> float:
        return float(self.setup.flow.kubo)


def ku_evaluation(cfg: FiguresConfig, kubo: float) -> Evaluation:
    """Smart (shipped policy), naive and STO at ``kubo`` on ``n_flows`` x ``n_swimmers``:
    the evaluation of :func:`ku_record`."""
    return Evaluation(ku_name(kubo), "trajectories",
                      eval_setup(cfg, kubo, cfg.n_flows, cfg.n_swimmers),
                      {"smart": smart_policy(cfg, kubo), "naive": "naive", "STO": "sto"})


def frame_lambda(lam: np.ndarray) -> np.ndarray:
    """``Lambda`` ``(F, K, S, N)`` at the video frames ``0, m, 2m, ..., N`` (``m`` =
    :data:`FRAME_EVERY`): the shape held from each frame on (the last decision's at
    ``t = T``), ``(K, F, S, frames)``."""
    n = lam.shape[-1]
    idx = np.minimum(np.arange(0, n + 1, FRAME_EVERY), n - 1)
    return np.swapaxes(lam[..., idx], 0, 1)


def ku_record(cfg: FiguresConfig, kubo: float) -> dict[str, np.ndarray]:
    """Smart (shipped policy), naive and STO at ``kubo`` on shared flows (cached):
    ``final`` ``(3, F S, 2)`` displacements, ``R_hat`` ``(3, F S)``, ``per_flow`` ``(3, F)``,
    ``traj`` ``(3, n_traj, N+1, 2)`` displacements, STO's signals and Lambda for the first
    ``n_traj`` swimmers of each flow (``sto_signals``, ``sto_Lambda``); for the videos,
    ``cloud`` ``(3, F S, frames, 2)`` displacements and ``traj_abs`` ``(3, n_traj, frames,
    2)`` unwrapped positions in flow 0 every :data:`FRAME_EVERY` decisions, with that flow's
    ``vorticity`` ``(frames, n/4, n/4)`` and ``box``; the shape factors at those frames:
    ``traj_lambda`` ``(3, n_traj, frames)``, ``cloud_lambda`` ``(3, F S, frames)``."""
    ev = ku_evaluation(cfg, kubo)
    setup, actors = ev.setup, list(ev.actors.values())

    def compute() -> dict[str, np.ndarray]:
        a = record_strategies(setup, actors, ku_display(kubo, "="), FRAME_EVERY)
        disp = a["position"] - a["position"][..., :1, :]  # (F, K, S, N+1, 2)
        per = np.swapaxes(disp, 0, 1)  # (K, F, S, N+1, 2)
        k, f, s = per.shape[:3]
        nt = min(cfg.n_traj, s)
        r_hat = np.swapaxes(a["R_hat"], 0, 1)  # (K, F, S)
        lam = frame_lambda(a["Lambda"])  # (K, F, S, frames)
        return {"final": per[..., -1, :].reshape(k, f * s, 2),
                "R_hat": r_hat.reshape(k, f * s), "per_flow": r_hat.mean(-1),
                "traj": per[:, 0, :nt], "time": a["time"],
                "sto_signals": a["signals"][:, 2, :nt].reshape(-1, *a["signals"].shape[3:]),
                "sto_Lambda": a["Lambda"][:, 2, :nt].reshape(f * nt, -1),
                "cloud": per[..., ::FRAME_EVERY, :].reshape(k, f * s, -1, 2),
                "traj_abs": np.swapaxes(a["position"], 0, 1)[:, 0, :nt, ::FRAME_EVERY],
                "traj_lambda": lam[:, 0, :nt], "cloud_lambda": lam.reshape(k, f * s, -1),
                "vorticity": a["vorticity"], "box": a["box"]}

    inputs = {**cache_inputs(cfg, setup, actors), "frames": FRAME_EVERY, "n_traj": cfg.n_traj,
              "frame_lambda": 1}
    return cached(cfg, f"ku_{ku_name(kubo)}", inputs, compute)


def flow_vorticity(setup: RunSpec) -> np.ndarray:
    """``omega tau_K`` on the grid, ``(n, n)`` (``[y, x]``), of flow 0 of ``setup`` at
    ``t = 0``: the realisation its evaluation starts in (same seed, same draws)."""
    n_c = min(setup.sizes.flows_per_batch, setup.sizes.n_flows)
    env = build_env(setup.flow, setup.params, setup.runtime, n_c, 1,
                   chunk_seed(setup.seed, 0))
    env.reset()
    return (env.flow.grid_fields()[0, ..., 4] * env.tau_k).cpu().double().numpy()


def per_flow_record(cfg: FiguresConfig, setup: RunSpec, actors: list[str]) -> np.ndarray:
    """Per-flow R_hat ``(len(actors), F)`` of ``actors`` on the shared flows of ``setup``
    (cached: evaluations with the same inputs are made once, whichever figure asks)."""
    def compute() -> dict[str, np.ndarray]:
        plain = replace(setup, sizes=replace(setup.sizes, record=0))
        metrics = evaluate_shared(plain, [actor(a, plain.params) for a in actors],
                                  desc=f"{ku_display(setup.flow.kubo, '=')} "
                                       + "+".join(actors))
        return {"per_flow": np.asarray([m["per_flow"] for m in metrics])}

    return cached(cfg, "per_flow", cache_inputs(cfg, setup, actors), compute)["per_flow"]


def flow_summary(per_flow: Mapping[str, Iterable[float]],
                 ratios: Iterable[tuple[str, str]] = ()) -> dict:
    """Over flows: each strategy's mean, std (``ddof = 1``; the paper's error bars) and
    SEM; for each ``(a, b)`` of ``ratios`` the paired ratio ``<a>/<b>`` with its
    delta-method SEM (:func:`~swimrl.evaluation.statistics.paired_ratio`)."""
    arr = {k: np.asarray(list(v), dtype=float) for k, v in per_flow.items()}
    stats = {k: mean_std_sem(v) for k, v in arr.items()}
    out: dict = {"mean": {k: s[0] for k, s in stats.items()},
                 "std": {k: s[1] for k, s in stats.items()},
                 "sem": {k: s[2] for k, s in stats.items()}}
    if ratios:
        out["ratio"] = {}
        for a, b in ratios:
            r, sem = paired_ratio(arr[a], arr[b])
            out["ratio"][f"{a}/{b}"] = {"value": r, "sem": sem}
    return out


def per_flow_values(cfg: FiguresConfig, ev: Evaluation,
                    ratios: Iterable[tuple[str, str]] = (("smart", "STO"),)) -> dict:
    """An evaluation's entry of a record from its per-flow R_hat (:func:`per_flow_record`):
    ``per_flow`` and ``derived`` (:func:`flow_summary`)."""
    per = per_flow_record(cfg, ev.setup, list(ev.actors.values()))
    values = {name: per[j].tolist() for j, name in enumerate(ev.actors)}
    ratios = [(a, b) for a, b in ratios if a in values and b in values]
    return {"per_flow": values, "derived": flow_summary(values, ratios)}


def flow_stats(per: np.ndarray, names: tuple[str, ...] = RECORD_STRATEGIES) -> tuple[dict, dict]:
    """Mean and std over flows (last axis) of ``per`` ``(..., len(names), F)``, by name."""
    mean = {n: per[:, j].mean(-1) for j, n in enumerate(names)}
    std = {n: per[:, j].std(-1, ddof=1) if per.shape[-1] > 1 else 0 * per[:, j, 0]
           for j, n in enumerate(names)}
    return mean, std
