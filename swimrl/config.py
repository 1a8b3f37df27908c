"""Each command's Hydra ``DictConfig`` -> typed objects (the paper's figures map theirs in
:mod:`swimrl.paper.config` with the functions of this module).

Every ``*_config`` function only maps the config keys onto the typed objects of the library
(:class:`~swimrl.env.EnvParams`, :class:`~swimrl.flows.stochastic.StochasticSpec`,
:class:`~swimrl.rl.plan.TrainSettings`, ...); their constructors check every value and raise
one :class:`~swimrl.errors.ConfigError` naming the key, the value and the allowed range. A
command therefore validates its whole config once, before any compute, and the library
never sees a ``DictConfig``. ``record`` (the resolved config as plain containers) goes into
the result files.

One mapping: :func:`from_node` builds a dataclass from the config groups that hold its
fields, by field name, each number converted to the type its field declares; the fields
named otherwise in the yaml (``spinup.time`` -> ``spinup_time``) or built from several keys
are passed to it. Every key is read as it is: the yaml holds every value that runs (a
dataclass default is read from the yaml by :mod:`swimrl.conf_values`), and the keys an old
checkpoint lacks are upgraded in :mod:`swimrl.runs.checkpoint`, not here.
"""

from __future__ import annotations

import dataclasses
import math
import typing
from collections.abc import Mapping
from pathlib import Path

from omegaconf import DictConfig, OmegaConf

from swimrl.actuation import ActuationSpec
from swimrl.analysis.distill import DistillSettings
from swimrl.analysis.fit_minimal import FitConfig, read_coefficients
from swimrl.analysis.gain_scan import GainScanConfig
from swimrl.env import EnvParams
from swimrl.errors import ConfigError, as_float, number_type, one_of, require
from swimrl.evaluation.compare import CompareConfig, strategy_variants
from swimrl.evaluation.rollout import EvalConfig
from swimrl.flows.analytic import GYROTAXIS_UNITS
from swimrl.flows.build import FlowSpec
from swimrl.flows.dns.params import DNSParams
from swimrl.flows.dns.run import DNSRun
from swimrl.flows.labels import ku_name
from swimrl.flows.registry import flow_dimension, flow_entry, flow_names
from swimrl.physics.body import body
from swimrl.physics.body2d import DERIVED_NAMES, RULE_TERM_NAMES, SIGNAL_NAMES
from swimrl.policies.baselines import StrategySpec
from swimrl.policies.networks import ModelSpec
from swimrl.policies.optimised import RULE_COEFFS, preset_coefficients, resolve_coefficients
from swimrl.policies.steering import parse_table
from swimrl.rl.plan import LossSettings, OptimSettings, TrainConfig, TrainSettings
from swimrl.runs.spec import EvalSizes, RunSpec
from swimrl.runtime import Runtime
from swimrl.task import RewardSpec, TaskSpec

#: ``${flow_tag:${flow}}`` -> ``ku1e7`` (:func:`~swimrl.flows.labels.ku_name`) for the
#: stochastic flow, else its name (run directories)
OmegaConf.register_new_resolver("flow_tag", ku_name, replace=True)
#: ``${ku:${flow.kubo}}`` -> ``0.1``, ``1``, ``10``, ``1e7``: the same label without its ``ku``
#: (``ku${ku:${flow.kubo}}``: names of policies and records per Ku)
OmegaConf.register_new_resolver("ku", lambda kubo: ku_name(float(kubo)).removeprefix("ku"),
                                replace=True)



def all_signals(flow) -> list[str]:
    """``${all_signals:${flow}}`` (``conf/signals/all.yaml``): every signal of the flow's
    dimension (:data:`~swimrl.physics.body2d.SIGNAL_NAMES` or
    :data:`~swimrl.physics.body3d.SIGNAL_NAMES_3D`); the 2D set for a flow name that is
    not registered (the flow's own check names it)."""
    node = OmegaConf.to_container(flow, resolve=True) if isinstance(flow, DictConfig) else flow
    if str(node.get("name")) not in flow_names():
        return list(SIGNAL_NAMES)
    try:
        dim = flow_dimension(node)
    except (ConfigError, KeyError, TypeError, ValueError):
        return list(SIGNAL_NAMES)
    return list(body(dim).signal_names)


OmegaConf.register_new_resolver("all_signals", all_signals, replace=True)


def all_invariant_signals(flow) -> list[str]:
    """``${all_invariant_signals:${flow}}`` (``conf/signals/all_invariant.yaml``): every signal
    of the flow's dimension (:func:`all_signals`) and the frame-invariant ``lever`` and
    ``torque`` (:data:`~swimrl.physics.body2d.DERIVED_NAMES`)."""
    return [*all_signals(flow), *DERIVED_NAMES]


OmegaConf.register_new_resolver("all_invariant_signals", all_invariant_signals, replace=True)


def rule_term_signals(flow) -> list[str]:
    """``${rule_term_signals:${flow}}`` (``conf/signals/rule_terms.yaml``): the set of
    :func:`all_invariant_signals` and the optimised rule's STO and stabilising terms
    (:data:`~swimrl.physics.body2d.RULE_TERM_NAMES`)."""
    return [*all_invariant_signals(flow), *RULE_TERM_NAMES]


OmegaConf.register_new_resolver("rule_term_signals", rule_term_signals, replace=True)


def _int(value):
    """``value`` as an int when it is a whole number (else unchanged, for the check to name;
    None stays None)."""
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


def _typed(value, hint):
    """``value`` as the field annotation ``hint`` declares: ints and floats (optional ones,
    tuples of them) converted where they are numbers, anything else as it is."""
    kind, is_tuple = number_type(hint)
    if value is None or kind is None:
        return tuple(value) if is_tuple and value is not None else value
    convert = _int if kind is int else _float
    return tuple(convert(v) for v in value) if is_tuple else convert(value)


def from_node(cls, groups: Mapping[str, DictConfig], **given):
    """The dataclass ``cls`` from the config ``groups`` (``{"train.": cfg.train}``; the key
    prefix names the group in messages): each constructor field not in ``given`` is read from
    the first group holding a key of its name, converted as its annotation says
    (:func:`_typed`); ``given`` fields are passed as they are. A field no group holds is a
    :class:`~swimrl.errors.ConfigError` (the yaml shows every value)."""
    hints = typing.get_type_hints(cls)
    values = dict(given)
    for f in dataclasses.fields(cls):
        if not f.init or f.name in given:
            continue
        group = next((g for g in groups.values() if f.name in g), None)
        if group is None:
            keys = " or ".join(f"{prefix}{f.name}" for prefix in groups)
            raise ConfigError(f"{keys} is missing: allowed a config that holds it")
        values[f.name] = _typed(group[f.name], hints[f.name])
    return cls(**values)


def record_of(cfg: DictConfig) -> dict:
    """The resolved config as plain containers (written into result files), without the
    ``hydra`` node a composed config may carry."""
    keys = [k for k in cfg if k != "hydra"]
    return OmegaConf.to_container(OmegaConf.masked_copy(cfg, keys), resolve=True)


def runtime(cfg: DictConfig) -> Runtime:
    """``device``, ``dtype``, ``threads``, ``kernel``."""
    return Runtime.from_names(cfg.device, cfg.dtype, _int(cfg.threads), cfg.kernel)


def gyrotaxis_numbers(swimmer: DictConfig, flow: str) -> dict:
    r"""``swim_speed`` and ``bottom_heaviness`` from ``swimmer.phi`` $= v_s/u_0$ and
    ``swimmer.psi`` $= B\omega_0$ where set (each replaces the key it determines), on a flow
    that defines them (:data:`~swimrl.flows.analytic.GYROTAXIS_UNITS`: Taylor-Green,
    $v_s/u_\mathrm{rms} = 2\sqrt2\,\Phi$, $B/\tau_K = \Psi/2$); ConfigError otherwise."""
    out = {}
    for key, field, index, scale in (("phi", "swim_speed", 0, 1.0),
                                     ("psi", "bottom_heaviness", 1, -1.0)):
        value = swimmer.get(key)
        if value is None:
            continue
        require(flow in GYROTAXIS_UNITS, f"swimmer.{key}", value,
                f"null for flow={flow} (defined for flow={'|'.join(GYROTAXIS_UNITS)})")
        number = as_float(f"swimmer.{key}", value, lambda v: v > 0, "> 0")
        out[field] = number * GYROTAXIS_UNITS[flow][index] ** scale
    return out


def env_params(cfg: DictConfig) -> EnvParams:
    """``swimmer.*``, ``episode.*``, ``signals.names``, ``task.*``, ``reward.*`` and
    ``actuation.*``."""
    return from_node(EnvParams, {"swimmer.": cfg.swimmer, "episode.": cfg.episode},
                     **gyrotaxis_numbers(cfg.swimmer, str(cfg.flow.name)),
                     signals=tuple(cfg.signals.names),
                     task=from_node(TaskSpec, {"task.": cfg.task}),
                     reward=from_node(RewardSpec, {"reward.": cfg.reward}),
                     actuation=from_node(ActuationSpec, {"actuation.": cfg.actuation}))


def flow_spec(flow: DictConfig, rt: Runtime) -> FlowSpec:
    """The ``flow`` group (``flow=<name>``, any flow of :mod:`swimrl.flows.registry`): its
    spec from the ``flow.*`` keys by field name, the fields its entry makes from several
    keys (``given``) from the node as plain containers."""
    entry = flow_entry(str(flow.name))
    given = {}
    if entry.given is not None:
        given = entry.given(OmegaConf.to_container(flow, resolve=True), rt.device, rt.dtype)
    return from_node(entry.spec, {"flow.": flow}, **given)


def eval_sizes(node: DictConfig) -> EvalSizes:
    """``eval.*``."""
    return from_node(EvalSizes, {"eval.": node})


def eval_setup(cfg: DictConfig) -> RunSpec:
    """Physics, flow, runtime, evaluation sizes and seed of any evaluating command."""
    params = env_params(cfg)
    rt = runtime(cfg)
    return from_node(RunSpec, {"": cfg}, flow=flow_spec(cfg.flow, rt), params=params,
                     runtime=rt, sizes=eval_sizes(cfg.eval), record=record_of(cfg))


def strategy_spec(node: DictConfig, dim: int | None = None) -> StrategySpec:
    """The ``strategy`` group (each strategy's yaml holds its own fields only); ``dim``: the
    flow's dimension (``strategy=optimised``: a preset must be of the flow's signals)."""
    if node.name == "naive":
        return StrategySpec("naive", shape_factor=_float(node.shape_factor))
    if node.name == "minimal":
        return StrategySpec("minimal", coeffs=tuple(_float(node[k]) for k in ("c1", "c2", "c3",
                                                                               "c4")))
    if node.name == "hand_rule":
        return StrategySpec("hand_rule", threshold=_float(node.threshold))
    if node.name == "table":
        return StrategySpec("table", table=parse_table(node.table))
    if node.name == "optimised":
        if dim is None:
            raise ValueError("strategy=optimised needs the flow's dimension")
        given = {k: node.get(k) for k in RULE_COEFFS}
        return StrategySpec("optimised", coeffs=resolve_coefficients(node.get("preset"), given,
                                                                     dim))
    return StrategySpec(str(node.name))


def eval_config(cfg: DictConfig) -> EvalConfig:
    """``swimrl-eval`` (``conf/evaluate.yaml``)."""
    setup = eval_setup(cfg)
    return from_node(EvalConfig, {"": cfg}, setup=setup,
                     strategy=strategy_spec(cfg.strategy, setup.dimension))


def compare_config(cfg: DictConfig) -> CompareConfig:
    """``swimrl-compare`` and ``swimrl-naive-scan`` (``conf/compare.yaml``)."""
    setup = eval_setup(cfg)
    c = cfg.compare
    minimal = tuple(_float(c.minimal[k]) for k in ("c1", "c2", "c3", "c4"))
    variants = strategy_variants(
        list(c.strategies),
        [_float(x) for x in c.naive_shape_factors],
        minimal,
        [str(p) for p in (c.policies or [])],
        [read_coefficients(p) for p in (c.minimal_fits or [])],
        [tuple(_float(x) for x in pair) for pair in c.sto_amplitudes],
        [(str(p), preset_coefficients(str(p), setup.dimension, "compare.optimised_presets"))
         for p in c.optimised_presets],
        [str(t) for t in (c.tables or [])],
        _float(c.hand_rule_threshold),
    )
    return from_node(CompareConfig, {"compare.": c, "": cfg}, setup=setup, variants=variants)


def fit_config(cfg: DictConfig) -> FitConfig:
    """``swimrl-fit-minimal`` (``conf/fit_minimal.yaml``)."""
    return from_node(FitConfig, {"fit.": cfg.fit}, eval=eval_config(cfg))


def gain_scan_config(cfg: DictConfig) -> GainScanConfig:
    """``swimrl-gain-scan`` (``conf/gain_scan.yaml``)."""
    ev = eval_config(cfg)
    return from_node(GainScanConfig, {"": cfg}, setup=ev.setup, policy=ev.policy,
                     overwrite=ev.overwrite)


@dataclasses.dataclass(frozen=True)
class DistillConfig:
    """``swimrl-distill`` (``conf/distill.yaml``): the teacher and the episodes it swims
    (``eval``), the student's network (``model``) and the fit (``settings``)."""

    eval: EvalConfig
    model: ModelSpec
    settings: DistillSettings


def distill_config(cfg: DictConfig) -> DistillConfig:
    """``swimrl-distill``: a baseline teacher (not ``strategy=policy``) and ``distill.*``."""
    ev = eval_config(cfg)
    require(ev.strategy.name != "policy", "strategy", ev.strategy.name,
            "a baseline (a rule to distil), not policy")
    act = ev.setup.params.actuation
    require(not (act.steers and act.directions == "discrete"), "actuation.directions",
            act.directions, "continuous (the student is a TanhNormal actor)")
    return DistillConfig(ev, model_spec(cfg.model),
                         from_node(DistillSettings, {"distill.": cfg.distill}))


def model_spec(node: DictConfig) -> ModelSpec:
    """``model.*``."""
    return from_node(ModelSpec, {"model.": node})


def train_config(cfg: DictConfig) -> TrainConfig:
    """``swimrl-train`` (``conf/train.yaml`` and a ``train_preset``)."""
    t = cfg.train
    reward_scale = None if t.reward_scale in (None, "auto") else _float(t.reward_scale)
    return from_node(
        TrainConfig, {"": cfg},
        spec=eval_setup(cfg),
        train=from_node(TrainSettings, {"train.": t}, reward_scale=reward_scale),
        loss=from_node(LossSettings, {"loss.": cfg.loss}),
        optim=from_node(OptimSettings, {"optim.": cfg.optim}),
        model=model_spec(cfg.model),
        eval_flow=eval_flow_spec(cfg),
    )


def eval_flow_spec(cfg: DictConfig) -> FlowSpec | None:
    """``eval_flow.*``: the training flow with these keys replaced (None if there are none)."""
    extra = cfg.eval_flow
    if not extra:
        return None
    for key in extra:
        one_of("eval_flow key", str(key), tuple(str(k) for k in cfg.flow if k != "name"))
    return flow_spec(OmegaConf.merge(cfg.flow, extra), runtime(cfg))


def dns_runtime(cfg: DictConfig) -> Runtime:
    """``device``, ``dtype``, ``threads`` of ``swimrl-dns`` (which integrates no swimmers:
    the default kernel)."""
    return Runtime.from_names(cfg.device, cfg.dtype, _int(cfg.threads))


def dns_run(cfg: DictConfig) -> DNSRun:
    """``swimrl-dns`` (``conf/dns.yaml``); a relative ``store.path`` is taken from the launch
    directory."""
    from hydra.utils import to_absolute_path

    rt = dns_runtime(cfg)
    params = DNSParams.from_mapping(
        {**OmegaConf.to_container(cfg.dns), "device": str(rt.device),
         "dtype": str(rt.dtype).replace("torch.", "")}
    )
    return from_node(
        DNSRun, {"store.": cfg.store, "": cfg},
        params=params,
        init_kind=cfg.init.kind,
        init_energy=_float(cfg.init.energy),
        init_k_peak=_float(cfg.init.k_peak),
        spinup_time=_float(cfg.spinup.time),
        measure_time=_float(cfg.spinup.measure_time),
        path=Path(to_absolute_path(str(cfg.store.path))),
    )
