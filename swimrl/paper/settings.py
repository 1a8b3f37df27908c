"""What ``swimrl-figures`` draws, where, and how large: :class:`FiguresConfig` and the DNS
figure's :class:`DNSFiguresConfig` (the values: ``conf/figures.yaml``, read by :mod:`.config`),
the figure names (:data:`FIGURES`, :data:`RECORDED`), and how a figure names its input files
(:func:`portable`; :func:`under_shipped_before`: the policies shipped before the paper-budget
runs, no figure input).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from swimrl.env import EnvParams
from swimrl.errors import ConfigError, as_bool, as_float, as_int, keep_number_types, one_of
from swimrl.flows.stochastic import StochasticSpec
from swimrl.runtime import Runtime

#: The figures, in build order (the keys of :data:`swimrl.paper.build.BUILDERS`).
FIGURES = ("swimmer", "smartPerformance", "ku0.1", "kuInf", "ku_pattern", "trainingCurves",
           "ablation", "robustness-noise", "robustness", "dnsFlow", "videos", "beyondTarget",
           "beyondTargetPaths", "beyondEnergy", "threeDKu", "threeDPaths", "threeDMaps",
           "threeDCurves", "seedSpread")
#: The figures that keep a record ``<records>/<figure>.json`` (:func:`.records.figure_record`).
RECORDED = ("smartPerformance", "ku0.1", "kuInf", "ku_pattern", "ablation", "robustness-noise",
            "robustness")
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
    :mod:`.beyond_target`, :mod:`.beyond_energy`)."""
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


def under_shipped_before(path: Path | str) -> bool:
    """Whether ``path`` lies in a ``shipped_before/`` directory (:data:`SHIPPED_BEFORE`)."""
    return SHIPPED_BEFORE in Path(str(path)).parts
