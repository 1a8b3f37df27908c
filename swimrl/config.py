"""The only module that reads a Hydra config: each command's ``DictConfig`` -> typed objects.

Every ``*_config`` function maps the config keys onto the typed objects of the library
(:class:`~swimrl.env.EnvParams`, :class:`~swimrl.flows.build.StochasticSpec`,
:class:`~swimrl.rl.plan.TrainSettings`, ...), whose constructors check every value and raise
one :class:`~swimrl.errors.ConfigError` naming the key, the value and the allowed range. A
command therefore validates its whole config once, before any compute, and the library
never sees a ``DictConfig``. ``record`` (the resolved config as plain containers) goes into
the result files.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

from omegaconf import DictConfig, ListConfig, OmegaConf

from swimrl.analysis.figures.records import FIGURES, DNSFiguresConfig, FiguresConfig
from swimrl.analysis.fit_minimal import FitConfig, read_coefficients
from swimrl.analysis.gain_scan import GainScanConfig
from swimrl.env import EnvParams
from swimrl.errors import as_bool, as_float, as_int, one_of
from swimrl.evaluation.compare import CompareConfig, strategy_variants
from swimrl.evaluation.rollout import EvalConfig, EvalSetup, EvalSizes
from swimrl.flows.build import (
    FLOWS,
    FlowSpec,
    LiveDNSSpec,
    StochasticSpec,
    StoredRunSpec,
    live_dns_params,
)
from swimrl.flows.dns.params import DNSParams
from swimrl.flows.dns.run import DNSRun
from swimrl.flows.labels import flow_tag, kubo_label
from swimrl.policies.baselines import StrategySpec
from swimrl.policies.networks import ModelSpec
from swimrl.rl.plan import LossSettings, OptimSettings, TrainConfig, TrainSettings
from swimrl.runtime import Runtime

#: ``${flow_tag:${flow}}`` -> ``ku10.0`` for the stochastic flow, else its name (run directories)
OmegaConf.register_new_resolver(
    "flow_tag", lambda flow: flow_tag(flow.name, flow.get("kubo")), replace=True)
#: ``${ku:${flow.kubo}}`` -> ``0.1``, ``1``, ``10``, ``1e7`` (names of policies and records per Ku)
OmegaConf.register_new_resolver("ku", kubo_label, replace=True)


def _int(value):
    """``value`` as an int when it is a whole number (else unchanged, for the check to name)."""
    if isinstance(value, bool):
        return value
    try:
        f = float(value)
    except (TypeError, ValueError):
        return value
    return int(f) if math.isfinite(f) and f == int(f) else value


def _float(value):
    """``value`` as a float when it is a number (else unchanged, for the check to name)."""
    if isinstance(value, bool):
        return value
    try:
        return float(value)
    except (TypeError, ValueError):
        return value


def _optional(value, convert):
    return None if value is None else convert(value)


def record_of(cfg: DictConfig) -> dict:
    """The resolved config as plain containers (written into result files), without the
    ``hydra`` node a composed config may carry."""
    keys = [k for k in cfg if k != "hydra"]
    return OmegaConf.to_container(OmegaConf.masked_copy(cfg, keys), resolve=True)


def runtime(cfg: DictConfig) -> Runtime:
    """``device``, ``dtype``, ``threads``, ``kernel``."""
    return Runtime.from_names(
        cfg.device, cfg.dtype, _optional(cfg.get("threads"), _int), cfg.get("kernel", "auto")
    )


def env_params(cfg: DictConfig) -> EnvParams:
    """``swimmer.*``, ``episode.*`` and ``signals.names``."""
    return EnvParams(
        swim_speed=_float(cfg.swimmer.swim_speed),
        rot_diffusion=_float(cfg.swimmer.rot_diffusion),
        duration=_float(cfg.episode.duration),
        update_interval=_float(cfg.episode.update_interval),
        dt=_float(cfg.episode.dt),
        shape_factor_max=_float(cfg.swimmer.shape_factor_max),
        signals=tuple(cfg.signals.names),
    )


def flow_spec(flow: DictConfig, rt: Runtime) -> FlowSpec:
    """The ``flow`` group (``flow=stochastic | dns_replay | dns``)."""
    one_of("flow.name", flow.name, FLOWS)
    if flow.name == "stochastic":
        return StochasticSpec(
            kubo=_float(flow.kubo),
            n_modes=_int(flow.n_modes),
            n_grid=_int(flow.n_grid),
            spacing=_float(flow.spacing),
            basis=flow.get("basis", "redrawn"),
            basis_seed=_int(flow.get("basis_seed", 0)),
            amplitudes=flow.get("amplitudes", "stationary"),
            velocity_scale=flow.get("velocity_scale", "total"),
        )
    if flow.name == "dns_replay":
        paths = flow.path if isinstance(flow.path, ListConfig | list | tuple) else [flow.path]
        decode_n = flow.get("decode_n", None)
        return StoredRunSpec(
            tuple(Path(str(p)) for p in paths),
            allow_incomplete=as_bool("flow.allow_incomplete", flow.get("allow_incomplete", False)),
            decode_n=None if decode_n is None else _int(decode_n),
            flows_per_start=_int(flow.get("flows_per_start", 1)),
        )
    return LiveDNSSpec(
        dns=live_dns_params(OmegaConf.to_container(flow.dns), rt.device, rt.dtype),
        spinup_time=_float(flow.spinup.time),
        measure_time=_float(flow.spinup.measure_time),
        interval_tau_k=_float(flow.interval_tau_k),
    )


def eval_sizes(node: DictConfig) -> EvalSizes:
    """``eval.*``."""
    return EvalSizes(
        n_flows=_int(node.n_flows),
        n_swimmers=_int(node.n_swimmers),
        flows_per_batch=_int(node.flows_per_batch),
        progress=as_bool("eval.progress", node.progress),
        record=_int(node.get("record", 0)),
    )


def eval_setup(cfg: DictConfig) -> EvalSetup:
    """Physics, flow, runtime, evaluation sizes and seed of any evaluating command."""
    params = env_params(cfg)
    rt = runtime(cfg)
    return EvalSetup(
        flow=flow_spec(cfg.flow, rt),
        params=params,
        runtime=rt,
        sizes=eval_sizes(cfg.eval),
        seed=as_int("seed", cfg.seed, low=0),
        record=record_of(cfg),
    )


def strategy_spec(node: DictConfig) -> StrategySpec:
    """The ``strategy`` group."""
    if node.name == "naive":
        return StrategySpec("naive", shape_factor=_float(node.shape_factor))
    if node.name == "minimal":
        return StrategySpec("minimal", coeffs=tuple(_float(node[k]) for k in ("c1", "c2", "c3",
                                                                               "c4")))
    return StrategySpec(str(node.name))


def eval_config(cfg: DictConfig) -> EvalConfig:
    """``swimrl-eval`` (``conf/evaluate.yaml``)."""
    policy = cfg.get("policy")
    return EvalConfig(
        setup=eval_setup(cfg),
        strategy=strategy_spec(cfg.strategy),
        policy=None if policy is None else str(policy),
        overwrite=as_bool("overwrite", cfg.overwrite),
    )


def compare_config(cfg: DictConfig) -> CompareConfig:
    """``swimrl-compare`` and ``swimrl-naive-scan`` (``conf/compare.yaml``)."""
    setup = eval_setup(cfg)
    c = cfg.compare
    minimal = tuple(_float(c.minimal[k]) for k in ("c1", "c2", "c3", "c4"))
    variants = strategy_variants(
        list(c.strategies),
        [_float(x) for x in c.naive_shape_factors],
        minimal,
        [str(p) for p in (c.get("policies") or [])],
        [read_coefficients(p) for p in (c.get("minimal_fits") or [])],
    )
    for v in variants:
        v.strategy.check_bound(setup.params.shape_factor_max)
    return CompareConfig(
        setup=setup,
        variants=variants,
        shared_flows=as_bool("compare.shared_flows", c.get("shared_flows", False)),
        overwrite=as_bool("overwrite", cfg.overwrite),
        resume=as_bool("compare.resume", c.get("resume", False)),
    )


def fit_config(cfg: DictConfig) -> FitConfig:
    """``swimrl-fit-minimal`` (``conf/fit_minimal.yaml``)."""
    return FitConfig(eval=eval_config(cfg), sample_every=_int(cfg.fit.sample_every))


def gain_scan_config(cfg: DictConfig) -> GainScanConfig:
    """``swimrl-gain-scan`` (``conf/gain_scan.yaml``)."""
    ev = eval_config(cfg)
    return GainScanConfig(setup=ev.setup, policy=ev.policy,
                          gains=tuple(_float(g) for g in cfg.gains), overwrite=ev.overwrite)


def figures_config(cfg: DictConfig) -> FiguresConfig:
    """``swimrl-figures`` (``conf/figures.yaml``); paths are taken from the launch directory."""
    from hydra.utils import to_absolute_path

    rt = runtime(cfg)
    spec = flow_spec(cfg.flow, rt)
    one_of("flow.name", cfg.flow.name, ("stochastic",))
    only = cfg.get("only")
    if only is not None:
        one_of("only", str(only), FIGURES)
    f = cfg.figures
    return FiguresConfig(
        out=Path(to_absolute_path(str(cfg.out))),
        cache=Path(to_absolute_path(str(cfg.cache))),
        runtime=rt,
        params=env_params(cfg),
        flow=spec,
        only=None if only is None else str(only),
        n_flows=as_int("figures.n_flows", f.n_flows),
        n_swimmers=as_int("figures.n_swimmers", f.n_swimmers),
        n_traj=as_int("figures.n_traj", f.n_traj),
        robust_flows=as_int("figures.robust_flows", f.robust_flows),
        robust_swimmers=as_int("figures.robust_swimmers", f.robust_swimmers),
        seed=as_int("seed", cfg.seed, low=0),
        policies=str(cfg.policies),
        results=Path(to_absolute_path(str(cfg.results))),
        curves=Path(to_absolute_path(str(cfg.curves))),
        fits=Path(to_absolute_path(str(cfg.fits))),
        ablation=Path(to_absolute_path(str(cfg.ablation))),
        dns=None if cfg.get("dns") is None else dns_figures_config(cfg.dns, to_absolute_path),
        progress=as_bool("progress", cfg.progress),
    )


def dns_figures_config(node: DictConfig, absolute) -> DNSFiguresConfig:
    """``dns.*`` of ``conf/figures.yaml`` (paths from the launch directory)."""
    decode_n = node.get("decode_n")
    return DNSFiguresConfig(
        store=Path(absolute(str(node.store))), record=Path(absolute(str(node.record))),
        transfer=Path(absolute(str(node.transfer))), checks=Path(absolute(str(node.checks))),
        policy=str(node.policy), trained=str(node.trained),
        curve=None if node.get("curve") is None else Path(absolute(str(node.curve))),
        n_swimmers=as_int("dns.n_swimmers", node.n_swimmers, low=1),
        n_traj=as_int("dns.n_traj", node.n_traj, low=1),
        decode_n=None if decode_n is None else as_int("dns.decode_n", decode_n, low=8),
        glyph_window=as_float("dns.glyph_window", node.glyph_window, lambda v: v > 0, "> 0"),
        glyph_every=as_float("dns.glyph_every", node.glyph_every, lambda v: v > 0, "> 0"),
    )


def _from_node(cls, node: DictConfig, **given):
    """Dataclass ``cls`` from the keys of ``node`` with its field names (numbers converted as
    the field's type says); ``given`` fields are passed as they are."""
    values = dict(given)
    for f in dataclasses.fields(cls):
        if f.init and f.name not in given and f.name in node:
            v = node[f.name]
            if v is not None and f.type.startswith(("int", "float")):
                v = _int(v) if f.type.startswith("int") else _float(v)
            values[f.name] = v
    return cls(**values)


def train_config(cfg: DictConfig) -> TrainConfig:
    """``swimrl-train`` (``conf/train.yaml`` and a ``train_preset``)."""
    t, model = cfg.train, cfg.model
    reward_scale = None if t.reward_scale in (None, "auto") else _float(t.reward_scale)
    return TrainConfig(
        evaluation=eval_setup(cfg),
        train=_from_node(TrainSettings, t, reward_scale=reward_scale),
        loss=_from_node(LossSettings, cfg.loss),
        optim=_from_node(OptimSettings, cfg.optim),
        model=ModelSpec(
            hidden=tuple(_int(h) for h in model.hidden),
            activation=str(model.activation),
            init_std=_float(model.init_std),
            min_std=_float(model.min_std),
        ),
        resume=cfg.resume,
        overwrite=cfg.overwrite,
        eval_flow=eval_flow_spec(cfg),
    )


def eval_flow_spec(cfg: DictConfig) -> FlowSpec | None:
    """``eval_flow.*``: the training flow with these keys replaced (None if there are none)."""
    extra = cfg.get("eval_flow")
    if not extra:
        return None
    for key in extra:
        one_of("eval_flow key", str(key), tuple(str(k) for k in cfg.flow if k != "name"))
    return flow_spec(OmegaConf.merge(cfg.flow, extra), runtime(cfg))


def dns_run(cfg: DictConfig) -> DNSRun:
    """``swimrl-dns`` (``conf/dns.yaml``); a relative ``store.path`` is taken from the launch
    directory."""
    from hydra.utils import to_absolute_path

    rt = runtime(cfg)
    params = DNSParams.from_mapping(
        {**OmegaConf.to_container(cfg.dns), "device": str(rt.device),
         "dtype": str(rt.dtype).replace("torch.", "")}
    )
    store = cfg.store
    return DNSRun(
        params=params,
        seed=as_int("seed", cfg.seed, low=0),
        init_kind=str(cfg.init.kind),
        init_energy=_float(cfg.init.energy),
        init_k_peak=_float(cfg.init.k_peak),
        spinup_time=_float(cfg.spinup.time),
        measure_time=_float(cfg.spinup.measure_time),
        path=Path(to_absolute_path(str(store.path))),
        n_times=_int(store.n_times),
        interval_tau_k=_float(store.interval_tau_k),
        chunk_times=_int(store.chunk_times),
        overwrite=as_bool("store.overwrite", store.overwrite),
        extend=as_bool("store.extend", store.get("extend", False)),
        checkpoint_seconds=_float(store.checkpoint_seconds),
        diag_every=_int(store.diag_every),
        max_steps=_optional(cfg.get("max_steps"), _int),
        progress=as_bool("progress", cfg.progress),
    )
