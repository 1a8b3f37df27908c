"""What the figures are drawn from: their configuration (:class:`FiguresConfig`,
:class:`DNSFiguresConfig`), the evaluation records and the cache that keeps them.

Evaluations go through the one rollout loop with a
:class:`~swimrl.evaluation.trajectories.TrajectoryRecorder`; their arrays are cached under
``cache/`` as ``.npz`` files keyed by a hash of their inputs (the setup, the policy file's
bytes, :data:`CACHE_VERSION`), so a second build only draws. Every record holds the
strategies in the order of :data:`RECORD_STRATEGIES` (smart, naive, STO) along its first
axis.

Units: lengths in ``l_f``, times in ``tau_K``, signals in ``tau_K`` units.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np

from swimrl.env import EnvParams, SwimmerEnv
from swimrl.errors import as_bool, as_float, as_int, keep_number_types, one_of
from swimrl.evaluation.records import read_npz, write_npz
from swimrl.evaluation.rollout import EvalSetup, EvalSizes, chunk_seed, evaluate_shared
from swimrl.evaluation.trajectories import TrajectoryRecorder
from swimrl.flows.build import StochasticSpec
from swimrl.flows.labels import ku_display, ku_name
from swimrl.policies.baselines import StrategyLabel, StrategySpec
from swimrl.policies.files import load_policy, resolve_policy_file
from swimrl.runtime import Runtime

#: The figures, in build order (the keys of :data:`swimrl.analysis.figures.build.BUILDERS`).
FIGURES = ("swimmer", "smartPerformance", "ku0.1", "kuInf", "ku_pattern", "trainingCurves",
           "ablation", "robustness-noise", "robustness", "dnsFlow", "videos")
#: Bump when a cached array's meaning changes.
CACHE_VERSION = 1
KUS = (0.1, 1.0, 10.0, 1e7)
#: Decisions between video frames (4 tau_K at T_u = 0.1 tau_K: 51 frames over T = 200 tau_K).
FRAME_EVERY = 40
#: The strategies of a record (:func:`ku_record`), in the order of its first axis, by the
#: names the figures show (the keys of :data:`~swimrl.analysis.figures.style.COLORS`).
RECORD_STRATEGIES = ("smart", "naive", "STO")


@dataclass(frozen=True)
class DNSFiguresConfig:
    """Where the DNS figure's records are (``dns.*`` of ``conf/figures.yaml``, which holds the
    values)."""

    store: Path
    """A held-out stored run to replay when ``record`` does not exist yet."""
    record: Path
    """The committed replay record (``.npz``)."""
    transfer: Path
    """Directory searched for ``comparison.json`` (one per held-out realisation)."""
    checks: Path
    """``dns_checks.json`` of ``swimrl-dns-plots`` (pooled PDFs)."""
    policy: str
    """The smart policy of (a) and the videos (the paper's video 5: trained at Ku = 10)."""
    trained: str
    """The policy trained in the DNS: the dotted line of (c) and the maps of (d), (e)."""
    curve: Path | None
    """``curves.csv`` of its training run: (f), its evaluation R_hat against frames."""
    n_swimmers: int
    """Swimmers per strategy."""
    n_traj: int
    """Trajectories drawn."""
    decode_n: int | None
    """Decode grid of the replay (None: the run's own)."""
    glyph_window: float
    """``tau_K`` of trajectory in (a)."""
    glyph_every: float
    """``tau_K`` between glyphs."""

    def __post_init__(self) -> None:
        for name in ("policy", "trained"):
            object.__setattr__(self, name, str(getattr(self, name)))
        as_int("dns.n_swimmers", self.n_swimmers, low=1)
        as_int("dns.n_traj", self.n_traj, low=1)
        if self.decode_n is not None:
            as_int("dns.decode_n", self.decode_n, low=8)
        as_float("dns.glyph_window", self.glyph_window, lambda v: v > 0, "> 0")
        as_float("dns.glyph_every", self.glyph_every, lambda v: v > 0, "> 0")
        keep_number_types(self)


@dataclass(frozen=True)
class FiguresConfig:
    """``swimrl-figures``: where, which, and how large (the values: ``conf/figures.yaml``)."""

    out: Path
    """Directory of the PNGs (``docs/figures``)."""
    cache: Path
    """Directory of the cached evaluation records."""
    runtime: Runtime
    params: EnvParams
    """Swimmer and episode of every evaluation (the robustness sweeps change one field)."""
    flow: StochasticSpec
    """Flow of every evaluation; ``kubo`` is set per figure."""
    only: str | None
    """One figure (a name of :data:`FIGURES`), or None: all."""
    n_flows: int
    """Flows of each Ku record (final positions, trajectories, policy maps)."""
    n_swimmers: int
    """Swimmers per flow and strategy of each Ku record."""
    n_traj: int
    """Trajectories drawn per strategy."""
    robust_flows: int
    """Flows per point of the robustness sweeps."""
    robust_swimmers: int
    """Swimmers per flow and strategy per point of the robustness sweeps."""
    seed: int
    policies: str
    """Smart policy at Ku: ``<policies>/ku0.1`` ... ``<policies>/ku1e7`` (a policy spec)."""
    results: Path
    """``comparison.json`` records of smartPerformance(a)."""
    curves: Path
    """Searched for ``curves.csv`` (trainingCurves)."""
    fits: Path
    """``ku*/fit.json`` of ``swimrl-fit-minimal`` at each Ku (ablation (b), (c))."""
    ablation: Path
    """Run directories of the signal-ablation multirun (ablation (a))."""
    dns: DNSFiguresConfig | None
    """Records of Fig. dnsFlow and videos 5, 10 (None: not drawn)."""
    progress: bool

    def __post_init__(self) -> None:
        one_of("flow.name", self.flow.name, ("stochastic",))
        if self.only is not None:
            object.__setattr__(self, "only", str(self.only))
            one_of("only", self.only, FIGURES)
        for key in ("n_flows", "n_swimmers", "n_traj", "robust_flows", "robust_swimmers"):
            as_int(f"figures.{key}", getattr(self, key))
        as_int("seed", self.seed, low=0)
        object.__setattr__(self, "policies", str(self.policies))
        as_bool("progress", self.progress)
        keep_number_types(self)


# -- cache and evaluations -------------------------------------------------------------------
def _digest(path: Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()[:16]


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
               **params) -> EvalSetup:
    """The evaluation of ``n_flows`` x ``n_swimmers`` at ``kubo`` (``params``: fields of
    ``cfg.params`` changed)."""
    sizes = EvalSizes(n_flows, n_swimmers, n_flows, cfg.progress, n_swimmers)
    return EvalSetup(flow=replace(cfg.flow, kubo=float(kubo)),
                     params=replace(cfg.params, **params) if params else cfg.params,
                     runtime=cfg.runtime, sizes=sizes, seed=cfg.seed, record={})


def smart_policy(cfg: FiguresConfig, kubo: float) -> str:
    """The shipped smart policy trained at ``kubo`` (a policy spec)."""
    return f"{cfg.policies}/{ku_name(kubo)}"


def cache_inputs(cfg: FiguresConfig, setup: EvalSetup, actors: list[str]) -> dict:
    """What an evaluation of ``actors`` on ``setup`` depends on (the cache key)."""
    files = {a: _digest(resolve_policy_file(a)) for a in actors if "/" in a}
    return {"flow": asdict(setup.flow), "params": asdict(setup.params),
            "sizes": [setup.sizes.n_flows, setup.sizes.n_swimmers], "seed": setup.seed,
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


def record_strategies(setup: EvalSetup, actors: list[str], desc: str,
                      field_every: int = 0) -> dict[str, np.ndarray]:
    """Every decision of every swimmer of ``actors`` (policy specs, ``naive``, ``sto``,
    ``naive(L)``) sharing the flows of ``setup``: the recorder's arrays."""
    rec = TrajectoryRecorder(setup.sizes.n_swimmers, field_every)
    evaluate_shared(setup, [actor(a, setup.params) for a in actors], desc=desc, recorder=rec)
    return rec.arrays()


def ku_record(cfg: FiguresConfig, kubo: float) -> dict[str, np.ndarray]:
    """Smart (shipped policy), naive and STO at ``kubo`` on shared flows (cached):
    ``final`` ``(3, F S, 2)`` displacements, ``R_hat`` ``(3, F S)``, ``traj`` ``(3, n_traj,
    N+1, 2)`` displacements, smart's ``signals`` ``(F S, N, 5)`` and ``Lambda``, STO's for
    the first ``n_traj`` swimmers of each flow (``sto_signals``, ``sto_Lambda``); for the
    videos, ``cloud`` ``(3, F S, frames, 2)`` displacements and ``traj_abs`` ``(3, n_traj,
    frames, 2)`` unwrapped positions in flow 0 every :data:`FRAME_EVERY` decisions, with that
    flow's ``vorticity`` ``(frames, n/4, n/4)`` and ``box``."""
    setup = eval_setup(cfg, kubo, cfg.n_flows, cfg.n_swimmers)
    actors = [smart_policy(cfg, kubo), "naive", "sto"]

    def compute() -> dict[str, np.ndarray]:
        a = record_strategies(setup, actors, ku_display(kubo, "="), FRAME_EVERY)
        disp = a["position"] - a["position"][..., :1, :]  # (F, K, S, N+1, 2)
        per = np.swapaxes(disp, 0, 1)  # (K, F, S, N+1, 2)
        k, f, s = per.shape[:3]
        nt = min(cfg.n_traj, s)
        return {"final": per[..., -1, :].reshape(k, f * s, 2),
                "R_hat": np.swapaxes(a["R_hat"], 0, 1).reshape(k, f * s),
                "traj": per[:, 0, :nt], "time": a["time"],
                "signals": a["signals"][:, 0].reshape(f * s, *a["signals"].shape[3:]),
                "Lambda": a["Lambda"][:, 0].reshape(f * s, -1),
                "sto_signals": a["signals"][:, 2, :nt].reshape(-1, *a["signals"].shape[3:]),
                "sto_Lambda": a["Lambda"][:, 2, :nt].reshape(f * nt, -1),
                "cloud": per[..., ::FRAME_EVERY, :].reshape(k, f * s, -1, 2),
                "traj_abs": np.swapaxes(a["position"], 0, 1)[:, 0, :nt, ::FRAME_EVERY],
                "vorticity": a["vorticity"], "box": a["box"]}

    inputs = {**cache_inputs(cfg, setup, actors), "frames": FRAME_EVERY}
    return cached(cfg, f"ku_{ku_name(kubo)}", inputs, compute)


def flow_vorticity(setup: EvalSetup) -> np.ndarray:
    """``omega tau_K`` on the grid, ``(n, n)`` (``[y, x]``), of flow 0 of ``setup`` at
    ``t = 0``: the realisation its evaluation starts in (same seed, same draws)."""
    n_c = min(setup.sizes.flows_per_batch, setup.sizes.n_flows)
    env = SwimmerEnv.build(setup.flow, setup.params, setup.runtime, n_c, 1,
                           chunk_seed(setup.seed, 0))
    env.reset()
    return (env.flow.grid_fields()[0, ..., 4] * env.tau_k).cpu().double().numpy()


def per_flow_record(cfg: FiguresConfig, name: str, setup: EvalSetup,
                    actors: list[str]) -> np.ndarray:
    """Per-flow R_hat ``(len(actors), F)`` of ``actors`` on the shared flows of ``setup``
    (cached under ``name``)."""
    def compute() -> dict[str, np.ndarray]:
        plain = replace(setup, sizes=replace(setup.sizes, record=0))
        metrics = evaluate_shared(plain, [actor(a, plain.params) for a in actors],
                                  desc="robustness")
        return {"per_flow": np.asarray([m["per_flow"] for m in metrics])}

    return cached(cfg, name, cache_inputs(cfg, setup, actors), compute)["per_flow"]


def flow_stats(per: np.ndarray, names: tuple[str, ...] = RECORD_STRATEGIES) -> tuple[dict, dict]:
    """Mean and std over flows (last axis) of ``per`` ``(..., len(names), F)``, by name."""
    mean = {n: per[:, j].mean(-1) for j, n in enumerate(names)}
    std = {n: per[:, j].std(-1, ddof=1) if per.shape[-1] > 1 else 0 * per[:, j, 0]
           for j, n in enumerate(names)}
    return mean, std
