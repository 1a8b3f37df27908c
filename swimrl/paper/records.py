"""What the figures are drawn from: their configuration (:class:`FiguresConfig`,
:class:`DNSFiguresConfig`), the figure records, the evaluations and the cache that keeps them.

**Figure records** (:func:`figure_record`): one JSON file per figure, ``<records>/<figure>.json``
(``docs/results/figures/``, committed), holding every number the figure draws in its titles
and the docs quote, and what they were computed from:

* ``format`` (:data:`RECORD_FORMAT`), ``figure``, ``command`` (the command that makes it);
* ``sizes``: ``{group: {n_flows, n_swimmers, flows_per_batch}}``: the one size of each group
  of evaluations (``sweep``, ``statistics``, ``trajectories``); every evaluation of a group
  has it (a record with mixed sizes is refused);
* ``seed``, ``dtype``, ``params`` (the swimmer and episode of every evaluation,
  :class:`~swimrl.env.EnvParams`), ``sources`` (``{path: sha256}`` of the committed files
  the figure reads besides the policies: comparisons, fits, run directories' records);
* ``evaluations``: ``{key: {group, setup: {flow (with kubo), changed (fields of params
  changed), n_flows, n_swimmers, flows_per_batch, seed}, actors: {name shown: actor},
  files: {actor: sha256 of its policy file}, per_flow: {name: [R_hat of each flow]},
  counts (where the evaluation counts samples), derived}}``;
* ``derived``: the figure's numbers (means, std over flows, paired ratios with their SEM,
  the S_nn statistic per seed, correlations).

A record is read only when it was made for what the config would evaluate now: its format,
sizes, seeds, flows, swimmer and episode, actors, the sha256 of every policy file and of every
source must be the current ones; otherwise it is refused (:class:`~swimrl.errors.ConfigError`,
one line naming the file, the field, the recorded and the current value, and how to remake it:
``figures.refresh=[<figure>]`` or deleting the file), never recomputed or replaced silently.
A missing record (or one named in ``figures.refresh``) is computed through the cached
evaluations and written atomically.

**Cache**: evaluations go through the one rollout loop; their arrays (trajectories, clouds,
the maps' histograms) are cached under ``cache/`` as ``.npz`` files keyed by a hash of their
inputs (the setup, the policy file's bytes, :data:`CACHE_VERSION`), so a second build only
draws. The cache is a pure cache: deleting it changes no number. Every Ku record
(:func:`ku_record`) holds the strategies in the order of :data:`RECORD_STRATEGIES` (smart,
naive, STO) along its first axis.

Units: lengths in ``l_f``, times in ``tau_K``, signals in ``tau_K`` units.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
from collections.abc import Callable, Iterable, Mapping
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np

from swimrl.env import EnvParams, SwimmerEnv
from swimrl.errors import (
    BadFileError,
    ConfigError,
    as_bool,
    as_float,
    as_int,
    keep_number_types,
    one_of,
)
from swimrl.evaluation.rollout import chunk_seed, evaluate_shared
from swimrl.evaluation.statistics import mean_std_sem, paired_ratio
from swimrl.evaluation.trajectories import TrajectoryRecorder
from swimrl.flows.build import StochasticSpec
from swimrl.flows.labels import ku_display, ku_name
from swimrl.policies.baselines import StrategyLabel, StrategySpec
from swimrl.runs.policy_files import load_policy, resolve_policy_file, sha256_file
from swimrl.runs.records import read_npz, write_json, write_npz
from swimrl.runs.spec import EvalSizes, RunSpec
from swimrl.runtime import Runtime

#: The figures, in build order (the keys of :data:`swimrl.paper.build.BUILDERS`).
FIGURES = ("swimmer", "smartPerformance", "ku0.1", "kuInf", "ku_pattern", "trainingCurves",
           "ablation", "robustness-noise", "robustness", "dnsFlow", "videos", "beyondTarget",
           "beyondTargetPaths", "beyondEnergy", "threeDKu", "threeDPaths", "threeDMaps",
           "threeDCurves", "seedSpread")
#: The figures that keep a record ``<records>/<figure>.json`` (:func:`figure_record`).
RECORDED = ("smartPerformance", "ku0.1", "kuInf", "ku_pattern", "ablation", "robustness-noise",
            "robustness")
#: Version of the figure-record format; a record of another version is refused.
RECORD_FORMAT = 1
#: Bump when a cached array's meaning changes.
CACHE_VERSION = 2
KUS = (0.1, 1.0, 10.0, 1e7)
#: Decisions between video frames (4 tau_K at T_u = 0.1 tau_K: 51 frames over T = 200 tau_K).
FRAME_EVERY = 40
#: The strategies of a record (:func:`ku_record`), in the order of its first axis, by the
#: names the figures show (the keys of :data:`~swimrl.paper.style.COLORS`).
RECORD_STRATEGIES = ("smart", "naive", "STO")
#: Directory name of the policies shipped before the paper-budget runs: no figure input.
SHIPPED_BEFORE = "shipped_before"


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
    """The shipped policy trained in the DNS: the maps of (d), (e)."""
    trained_seeds: tuple[str, ...]
    """Every DNS-trained run of the transfer records (policy specs, ``trained`` among them):
    the dotted line of (c) (their mean ratio to STO, band: std over them) and the ratio
    ``policy`` / DNS-trained per held-out realisation with its spread over them."""
    curves: tuple[Path, ...]
    """``curves.csv`` of their training runs: (f), the held-out R_hat against frames."""
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
        object.__setattr__(self, "trained_seeds", tuple(str(t) for t in self.trained_seeds))
        if self.trained not in self.trained_seeds:
            raise ConfigError(f"dns.trained={self.trained!r} is invalid: allowed one of "
                              f"dns.trained_seeds={list(self.trained_seeds)}")
        object.__setattr__(self, "curves", tuple(Path(c) for c in self.curves))
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
    """Directory of the cached evaluation arrays."""
    records: Path
    """Directory of the figure records (``<figure>.json``, committed)."""
    refresh: tuple[str, ...]
    """Figures whose record is remade (replaced) by this build (names of :data:`RECORDED`)."""
    runtime: Runtime
    params: EnvParams
    """Swimmer and episode of every evaluation (the robustness sweeps change one field)."""
    flow: StochasticSpec
    """Flow of every evaluation; ``kubo`` is set per figure."""
    only: str | None
    """One figure (a name of :data:`FIGURES`), or None: all."""
    flows_per_batch: int
    """Flows simulated at once in every evaluation (chunk ``c`` of ``flows_per_batch`` flows
    is seeded with ``(seed, c)``: part of what a record was made for)."""
    n_flows: int
    """Flows of each Ku record (final positions, trajectories, videos)."""
    n_swimmers: int
    """Swimmers per flow and strategy of each Ku record."""
    n_traj: int
    """Trajectories drawn per strategy."""
    map_flows: int
    """Flows per Ku and seed of the mechanism statistics (maps, S_nn statistic)."""
    map_swimmers: int
    """Swimmers per flow of the mechanism statistics."""
    map_seeds: tuple[int, ...]
    """Training seeds of the protocol's runs whose policies the statistics evaluate
    (``<curves>/ku<KU>_seed<k>/policy.pt``); the maps drawn are the first seed's."""
    robust_flows: int
    """Flows per point of the robustness sweeps and of ablation (b)."""
    robust_swimmers: int
    """Swimmers per flow and strategy per point of the robustness sweeps and ablation (b)."""
    noise: tuple[float, ...]
    """``D_r tau_K`` of robustness-noise."""
    durations: tuple[float, ...]
    """``T / tau_K`` of robustness (a)."""
    update_intervals: tuple[float, ...]
    """``T_u / tau_K`` of robustness (b)."""
    swim_speeds: tuple[float, ...]
    """``v_s / u_rms`` of robustness (c)."""
    seed: int
    """Evaluation seed: the protocol's test seed (0), used by no training run."""
    policies: str
    """Smart policy at Ku: ``<policies>/ku0.1`` ... ``<policies>/ku1e7`` (a policy spec)."""
    results: Path
    """``comparison.json`` records of smartPerformance(a) (``<results>/ku<KU>/``), also the
    held-out comparison of the all-signal runs of ablation (a)."""
    curves: Path
    """The protocol's run directories ``ku<KU>_seed<k>``: ``curves.csv`` (trainingCurves) and
    ``policy.pt`` (mechanism statistics)."""
    fits: Path
    """``ku*/fit.json`` of ``swimrl-fit-minimal`` at each Ku (ablation (b), (c))."""
    ablation: Path
    """Run directories of the signal-ablation runs with their held-out comparisons
    ``held_out/<run>/comparison.json`` (ablation (a))."""
    dns: DNSFiguresConfig | None
    """Records of Fig. dnsFlow and videos 5, 10 (None: not drawn)."""
    beyond: Path
    """Comparisons of the tasks beyond the paper (``target/ku<KU>_D<D>/``, ``energy/ku<KU>/``;
    :mod:`.beyond`)."""
    three_d: Path
    """The 3D study's records (``compare/ku<KU>/``, ``paths/ku10_<strategy>/``;
    :mod:`.three_d`)."""
    three_seeds: Path
    """Records of the protocol's three seeds per Ku (``robustness/``, ``ablation_b/``,
    ``minimal_fits/``, ``dns_transfer/``; Fig. seedSpread, :mod:`.seeds`)."""
    progress: bool

    def __post_init__(self) -> None:
        one_of("flow.name", self.flow.name, ("stochastic",))
        if self.only is not None:
            object.__setattr__(self, "only", str(self.only))
            one_of("only", self.only, FIGURES)
        object.__setattr__(self, "records", Path(self.records))
        object.__setattr__(self, "refresh", tuple(str(f) for f in self.refresh or ()))
        for name in self.refresh:
            one_of("figures.refresh", name, RECORDED)
        for key in ("flows_per_batch", "n_flows", "n_swimmers", "n_traj", "map_flows",
                    "map_swimmers", "robust_flows", "robust_swimmers"):
            as_int(f"figures.{key}", getattr(self, key))
        object.__setattr__(self, "map_seeds", tuple(self.map_seeds))
        if not self.map_seeds:
            raise ConfigError("figures.map_seeds=[] is invalid: allowed one seed or more")
        for s in self.map_seeds:
            as_int("figures.map_seeds", s, low=0)
        for key, ok, allowed in (("noise", lambda v: v >= 0, ">= 0"),
                                 ("durations", lambda v: v > 0, "> 0"),
                                 ("update_intervals", lambda v: v > 0, "> 0"),
                                 ("swim_speeds", lambda v: v > 0, "> 0")):
            values = tuple(getattr(self, key))
            if not values:
                raise ConfigError(f"figures.{key}=[] is invalid: allowed one value or more")
            for v in values:
                as_float(f"figures.{key}", v, ok, allowed)
            object.__setattr__(self, key, values)
        as_int("seed", self.seed, low=0)
        object.__setattr__(self, "policies", str(self.policies))
        as_bool("progress", self.progress)
        keep_number_types(self)


# -- files ------------------------------------------------------------------------------------
def portable(path: Path | str) -> str:
    """``path`` relative to the working directory where it lies below it (links kept as
    named), else absolute: how a record names a file, so that a clone elsewhere reads it."""
    p = Path(os.path.abspath(path))
    try:
        return str(p.relative_to(Path(os.path.abspath(Path.cwd()))))
    except ValueError:
        return str(p)


def is_policy(actor_name: str) -> bool:
    """Whether an actor name is a policy spec (a file), not a baseline label."""
    return "/" in actor_name and not actor_name.startswith(("naive", "minimal", "sto"))


def under_shipped_before(path: Path | str) -> bool:
    """Whether ``path`` lies in a ``shipped_before/`` directory (:data:`SHIPPED_BEFORE`)."""
    return SHIPPED_BEFORE in Path(str(path)).parts


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
    :func:`portable` names it)."""
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
    env = SwimmerEnv.build(setup.flow, setup.params, setup.runtime, n_c, 1,
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


# -- figure records ----------------------------------------------------------------------------
def plain(value):
    """``value`` as standard JSON holds it (tuples as lists, paths and dtypes as strings,
    numpy numbers as Python numbers, NaN and infinities as None)."""
    if isinstance(value, Mapping):
        return {str(k): plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple | np.ndarray):
        return [plain(v) for v in (value.tolist() if isinstance(value, np.ndarray) else value)]
    if isinstance(value, bool | type(None) | str | int):
        return value
    if isinstance(value, float | np.floating):
        return float(value) if math.isfinite(value) else None
    if isinstance(value, np.integer):
        return int(value)
    return str(value)


def evaluation_identity(cfg: FiguresConfig, ev: Evaluation) -> dict:
    """What an evaluation of a record is made from: its group, setup (flow with kubo, the
    fields of ``cfg.params`` it changes, sizes, seed), actors and the sha256 of each policy
    file."""
    s = ev.setup
    base, now = asdict(cfg.params), asdict(s.params)
    return plain({
        "group": ev.group,
        "setup": {"flow": asdict(s.flow), "changed": {k: v for k, v in now.items()
                                                      if base[k] != v},
                  "n_flows": s.sizes.n_flows, "n_swimmers": s.sizes.n_swimmers,
                  "flows_per_batch": s.sizes.flows_per_batch, "seed": s.seed,
                  **({"options": dict(ev.options)} if ev.options else {})},
        "actors": dict(ev.actors),
        "files": {a: sha256_file(resolve_policy_file(a)) for a in ev.actors.values()
                  if is_policy(a)},
    })


def record_identity(cfg: FiguresConfig, figure: str, evaluations: list[Evaluation],
                    sources: Iterable[Path] = ()) -> dict:
    """The fields of ``figure``'s record that the config determines (what it is made for):
    every field but the values (``per_flow``, ``counts``, ``derived``)."""
    evals = {ev.key: evaluation_identity(cfg, ev) for ev in evaluations}
    sizes: dict[str, dict] = {}
    for e in evals.values():
        sizes.setdefault(e["group"], {k: e["setup"][k] for k in
                                      ("n_flows", "n_swimmers", "flows_per_batch")})
    return plain({"format": RECORD_FORMAT, "figure": figure,
                  "command": f"swimrl-figures only={figure}", "sizes": sizes,
                  "seed": cfg.seed, "dtype": str(cfg.runtime.dtype),
                  "params": asdict(cfg.params),
                  "sources": {portable(p): sha256_file(p) for p in sorted(sources)},
                  "evaluations": evals})


#: The fields of a record compared with the current config, in the order they are checked.
IDENTITY_FIELDS = ("format", "figure", "sizes", "seed", "dtype", "params", "sources",
                   "evaluations")
#: The fields of an evaluation compared with the current config.
EVALUATION_FIELDS = ("group", "setup", "actors", "files")


def _short(value, width: int = 90) -> str:
    text = json.dumps(value, sort_keys=True) if not isinstance(value, str) else repr(value)
    return text if len(text) <= width else text[: width - 3] + "..."


def _remake(path: Path, figure: str) -> str:
    return f"remake it with figures.refresh=[{figure}] (or delete {path})"


def first_difference(recorded, current, key: str) -> tuple[str, object, object] | None:
    """``(field, recorded value, current value)`` of the first nested entry where the two
    differ (dicts key by key, in the current one's order, then the recorded one's extra
    keys), or None."""
    if isinstance(recorded, dict) and isinstance(current, dict):
        if list(recorded) != list(current) and set(recorded) != set(current):
            missing = [k for k in current if k not in recorded]
            extra = [k for k in recorded if k not in current]
            name = missing[0] if missing else extra[0]
            return (f"{key}.{name}", recorded.get(name, "(absent)"),
                    current.get(name, "(absent)"))
        for k in current:
            found = first_difference(recorded[k], current[k], f"{key}.{k}")
            if found:
                return found
        return None
    return None if recorded == current else (key, recorded, current)


def read_figure_record(path: Path) -> dict:
    """A figure record, checked on its own: readable JSON of :data:`RECORD_FORMAT`, every
    evaluation of its group's size, one per-flow value per flow and strategy (else one
    :class:`~swimrl.errors.BadFileError` / :class:`~swimrl.errors.ConfigError` line)."""
    path = Path(path)
    try:
        rec = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise BadFileError(f"{path}: not a readable figure record ({exc}); allowed: a record "
                           "written by swimrl-figures, or delete it to remake it") from exc
    figure = rec.get("figure", "?") if isinstance(rec, dict) else "?"
    if not isinstance(rec, dict) or rec.get("format") != RECORD_FORMAT:
        got = rec.get("format") if isinstance(rec, dict) else None
        raise ConfigError(f"{path}: format = {got!r} in the record, {RECORD_FORMAT} now; "
                          + _remake(path, figure))
    check_record(path, rec)
    return rec


def check_record(path: Path, rec: dict) -> None:
    """One size per group: each evaluation's sizes are its group's (``sizes``), and it holds
    ``n_flows`` per-flow values of each of its strategies; else one BadFileError line."""
    figure = rec.get("figure", "?")
    sizes = rec.get("sizes") or {}
    for key, ev in (rec.get("evaluations") or {}).items():
        group, setup = ev.get("group"), ev.get("setup") or {}
        if group not in sizes:
            raise BadFileError(f"{path}: evaluations.{key}.group = {group!r} has no sizes "
                               f"(sizes: {sorted(sizes)}); " + _remake(path, figure))
        for k, want in sizes[group].items():
            if setup.get(k) != want:
                raise BadFileError(
                    f"{path}: evaluations.{key}.setup.{k} = {setup.get(k)!r} but "
                    f"sizes.{group}.{k} = {want!r}: mixed sizes in one record; "
                    + _remake(path, figure))
        per = ev.get("per_flow") or {}
        if list(per) != list(ev.get("actors") or {}):
            raise BadFileError(f"{path}: evaluations.{key}.per_flow holds {list(per)}, its "
                               f"actors are {list(ev.get('actors') or {})}; "
                               + _remake(path, figure))
        for name, values in per.items():
            if len(values) != setup.get("n_flows"):
                raise BadFileError(
                    f"{path}: evaluations.{key}.per_flow.{name} holds {len(values)} flows, "
                    f"its setup.n_flows = {setup.get('n_flows')}: mixed sizes in one record; "
                    + _remake(path, figure))


def refuse_stale(path: Path, rec: dict, expected: dict) -> None:
    """ConfigError (one line: file, field, recorded and current value, how to remake it)
    unless ``rec`` was made for ``expected`` (:func:`record_identity`)."""
    def refuse(field_name: str, recorded, current) -> None:
        raise ConfigError(f"{path}: {field_name} = {_short(recorded)} in the record, "
                          f"{_short(current)} now; " + _remake(path, expected["figure"]))

    for name in IDENTITY_FIELDS:
        if name == "evaluations":
            continue
        found = first_difference(rec.get(name), expected[name], name)
        if found:
            refuse(*found)
    have, want = rec.get("evaluations") or {}, expected["evaluations"]
    if list(have) != list(want):
        refuse("evaluations", list(have), list(want))
    for key, ev in want.items():
        for name in EVALUATION_FIELDS:
            found = first_difference(have[key].get(name), ev[name],
                                     f"evaluations.{key}.{name}")
            if found:
                refuse(*found)


def figure_record(cfg: FiguresConfig, figure: str, evaluations: list[Evaluation],
                  compute: Callable[[Evaluation], dict],
                  derive: Callable[[dict], dict] | None = None,
                  sources: Iterable[Path] = ()) -> dict:
    """``figure``'s record ``<records>/<figure>.json``: read and checked against what the
    config evaluates now (:func:`refuse_stale`) where it exists; else (or with ``figure``
    in ``figures.refresh``) made: ``compute(ev)`` gives each evaluation's ``per_flow`` (and
    ``counts``, ``derived``), ``derive(record)`` the figure's ``derived`` numbers; written
    atomically."""
    path = Path(cfg.records) / f"{figure}.json"
    expected = record_identity(cfg, figure, evaluations, sources)
    if path.exists() and figure not in cfg.refresh:
        rec = read_figure_record(path)
        refuse_stale(path, rec, expected)
        return rec
    rec = dict(expected)
    rec["evaluations"] = {ev.key: {**expected["evaluations"][ev.key], **plain(compute(ev))}
                          for ev in evaluations}
    rec["derived"] = plain(derive(rec)) if derive is not None else {}
    check_record(path, rec)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_json(rec, path)
    return rec


def record_sizes(rec: dict, group: str) -> tuple[int, int]:
    """``(n_flows, n_swimmers)`` of a record's group."""
    s = rec["sizes"][group]
    return int(s["n_flows"]), int(s["n_swimmers"])
