"""One source per value: the yaml (``conf/``) shows every value that runs.

Every typed config that :mod:`swimrl.config` builds either has no default for a field the
yaml sets, or reads its default from the yaml (:func:`swimrl.conf_values.yaml_value`); so
do the keyword defaults of the library calls that stand for a config group
(``StochasticFlow(...)``, ``tanh_normal_actor(...)``, ``strategy_variants(...)``). Here: no
default is written in Python where a yaml key stands for it, and each one read is the value
the yaml composes for its key in every command's config that maps it (the right file, the
right key). A default no yaml key stands for fails here too.
"""

from __future__ import annotations

import ast
import dataclasses
import inspect
import textwrap

import pytest
import torch
from hydra import compose, initialize_config_module
from omegaconf import OmegaConf

import swimrl.config
from swimrl.actuation import ActuationSpec
from swimrl.analysis.distill import DistillSettings
from swimrl.analysis.fit_minimal import FitConfig
from swimrl.analysis.gain_scan import GainScanConfig
from swimrl.conf_values import yaml_value
from swimrl.config import DistillConfig, eval_config, strategy_spec
from swimrl.env import EnvParams, SwimmerEnv
from swimrl.errors import ConfigError
from swimrl.evaluation.compare import CompareConfig, strategy_variants
from swimrl.evaluation.rollout import EvalConfig
from swimrl.flows.analytic import ABCSpec, LinearSpec, TaylorGreenSpec
from swimrl.flows.dns.flow import LiveDNSSpec, StoredRunSpec
from swimrl.flows.dns.params import DNSParams
from swimrl.flows.dns.run import DNSRun
from swimrl.flows.stochastic import StochasticFlow, StochasticSpec
from swimrl.flows.stochastic3d import Stochastic3DSpec, StochasticFlow3D
from swimrl.paper.settings import DNSFiguresConfig, FiguresConfig
from swimrl.policies.baselines import StrategySpec
from swimrl.policies.networks import ModelSpec, make_mlp, tanh_normal_actor, value_critic
from swimrl.rl.plan import LossSettings, OptimSettings, TrainConfig, TrainSettings
from swimrl.runs.spec import EvalSizes, RunSpec
from swimrl.runtime import Runtime
from swimrl.task import RewardSpec, TaskSpec

#: The commands that evaluate swimmers in a flow (``conf/<name>.yaml``).
EVALUATING = ("evaluate", "train", "compare", "naive_scan", "fit_minimal", "gain_scan")
#: ... and the figures, which share the flow, swimmer, episode and runtime groups.
WITH_FLOW = (*EVALUATING, "figures")
#: The typed configs without a default: the yaml holds every value.
NO_DEFAULTS = (RunSpec, EvalConfig, TrainSettings, LossSettings, OptimSettings, ModelSpec,
               TrainConfig, FitConfig, GainScanConfig, FiguresConfig, DNSFiguresConfig,
               DistillSettings, DistillConfig)
_ABSENT = object()


def _compose(name: str, *overrides: str):
    with initialize_config_module("swimrl.conf", version_base="1.3"):
        return compose(config_name=name, overrides=list(overrides))


def defaults(obj) -> dict[str, object]:
    """``name -> default`` of a dataclass's constructor fields, or of a callable's keyword
    parameters."""
    if dataclasses.is_dataclass(obj):
        out = {}
        for f in dataclasses.fields(obj):
            if f.init and f.default is not dataclasses.MISSING:
                out[f.name] = f.default
            elif f.init and f.default_factory is not dataclasses.MISSING:
                out[f.name] = f.default_factory()
        return out
    return {name: p.default for name, p in inspect.signature(obj).parameters.items()
            if p.default is not inspect.Parameter.empty}


def _plain(value):
    """Containers as lists, torch dtypes by name."""
    if isinstance(value, tuple | list):
        return [_plain(v) for v in value]
    if isinstance(value, torch.dtype):
        return str(value).replace("torch.", "")
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: _plain(getattr(value, f.name)) for f in dataclasses.fields(value)
                if f.init}
    return value


def assert_defaults_are_the_yaml(obj, cfg, prefix: str = "", keys: dict | None = None,
                                 library_only: tuple[str, ...] = ()) -> None:
    """Every default of ``obj`` equals the composed value of its key in ``cfg``: ``prefix +
    name`` unless ``keys`` names it otherwise; ``library_only``: keyword arguments of a
    library call that no config sets (a generator, ...)."""
    keys = keys or {}
    for name, default in defaults(obj).items():
        if name in library_only:
            continue
        key = keys.get(name, prefix + name)
        value = OmegaConf.select(cfg, key, default=_ABSENT)
        assert value is not _ABSENT, (
            f"{obj.__qualname__}.{name} has a default but no yaml key {key}")
        if OmegaConf.is_config(value):
            value = OmegaConf.to_container(value)
        assert _plain(default) == _plain(value), (
            f"{obj.__qualname__}.{name} = {default!r} but the yaml's {key} = {value!r}")


def written_defaults(obj) -> dict[str, ast.expr]:
    """``name -> expression`` of the defaults as the source of ``obj`` writes them."""
    node = ast.parse(textwrap.dedent(inspect.getsource(obj))).body[0]
    if isinstance(node, ast.ClassDef):
        return {s.target.id: s.value for s in node.body
                if isinstance(s, ast.AnnAssign) and s.value is not None}
    args = node.args
    positional = [*args.posonlyargs, *args.args]
    return {**dict(zip([a.arg for a in positional[len(positional) - len(args.defaults):]],
                       args.defaults, strict=True)),
            **{a.arg: d for a, d in zip(args.kwonlyargs, args.kw_defaults, strict=True) if d}}


def reads_the_yaml(expr: ast.expr) -> bool:
    """The expression calls ``yaml_value`` (``field(default=yaml_value(...))`` included)."""
    return any(isinstance(n, ast.Call) and isinstance(n.func, ast.Name)
               and n.func.id == "yaml_value" for n in ast.walk(expr))


#: Everything whose defaults stand for yaml keys ...
READ = (StochasticSpec, StoredRunSpec, LiveDNSSpec, StochasticFlow.__init__, DNSParams, DNSRun,
        EnvParams, SwimmerEnv.__init__, TaskSpec, RewardSpec, Runtime, Runtime.from_names,
        EvalSizes, CompareConfig, strategy_variants, make_mlp, tanh_normal_actor, value_critic,
        Stochastic3DSpec, LinearSpec, ABCSpec, TaylorGreenSpec, ActuationSpec)
#: ... but these, written in Python: library-only keywords (no config sets them), torch
#: dtypes (the yaml's ``dtype`` is a name), and EnvParams's task and reward (``TaskSpec()``,
#: ``RewardSpec()``, whose own defaults are read).
WRITTEN = {
    "StochasticFlow.__init__": ("dtype", "generator"),
    "SwimmerEnv.__init__": ("generator", "ic_blocks", "body"),
    # signals: the 2D set SIGNAL_NAMES (conf/signals/all.yaml gives the flow's dimension's set,
    # an interpolation; test_swimmer_episode_signals_and_runtime checks it composes to this)
    "EnvParams": ("task", "reward", "signals", "actuation"),
    "make_mlp": ("out_gain", "device", "dtype"),
    "tanh_normal_actor": ("device", "dtype"),
    "value_critic": ("device", "dtype"),
}


@pytest.mark.parametrize("obj", READ, ids=lambda o: o.__qualname__)
def test_defaults_are_read_from_the_yaml_not_written(obj):
    written = written_defaults(obj)
    allowed = WRITTEN.get(obj.__qualname__, ())
    literal = sorted(name for name in defaults(obj)
                     if name not in allowed and not reads_the_yaml(written[name]))
    assert literal == [], f"{obj.__qualname__}: defaults not read by yaml_value: {literal}"


def test_yaml_value_reads_one_file_as_hydra_does():
    """Numbers as Hydra parses them (``1.0e-4``: a float), lists as tuples, interpolations
    unresolved, a missing key named."""
    nu = yaml_value("solver/dns", "dns.nu")
    assert type(nu) is float and nu == _compose("dns").dns.nu
    assert type(yaml_value("solver/dns", "dns.n")) is int
    assert (yaml_value("signals/nr_nth_snp", "names")
            == tuple(_compose("evaluate", "signals=nr_nth_snp").signals.names))
    assert yaml_value("signals/all", "names") == "${all_signals:${flow}}"
    assert yaml_value("dns", "store.path") == "data/dns/dns_n${dns.n}_seed${seed}.zarr"
    with pytest.raises(KeyError, match="conf/evaluate.yaml has no key 'eval.absent'"):
        yaml_value("evaluate", "eval.absent")


def test_every_typed_config_of_swimrl_config_is_covered():
    """The dataclasses :mod:`swimrl.config` maps are all checked below."""
    mapped = {v for v in vars(swimrl.config).values() if dataclasses.is_dataclass(v)}
    covered = {*NO_DEFAULTS, StochasticSpec, StoredRunSpec, LiveDNSSpec, DNSParams, EnvParams,
               Runtime, EvalSizes, CompareConfig, StrategySpec, DNSRun, TaskSpec, RewardSpec,
               ActuationSpec}
    assert mapped <= covered, sorted(c.__name__ for c in mapped - covered)


@pytest.mark.parametrize("cls", NO_DEFAULTS, ids=lambda c: c.__name__)
def test_configs_whose_yaml_holds_every_value_have_no_defaults(cls):
    assert defaults(cls) == {}


@pytest.mark.parametrize("name", WITH_FLOW)
def test_stochastic_flow(name):
    """``conf/flow/stochastic.yaml``: StochasticSpec and StochasticFlow's keywords (library
    calls), device and dtype from the runtime keys."""
    cfg = _compose(name)
    assert cfg.flow.name == "stochastic"
    assert_defaults_are_the_yaml(StochasticSpec, cfg, "flow.")
    assert_defaults_are_the_yaml(StochasticFlow, cfg, "flow.",
                                 keys={"device": "device", "dtype": "dtype"},
                                 library_only=("generator",))


@pytest.mark.parametrize("flow,spec", [("stochastic3d", Stochastic3DSpec),
                                       ("linear", LinearSpec), ("abc", ABCSpec),
                                       ("taylor_green", TaylorGreenSpec)])
def test_registered_point_flows(flow, spec):
    """``conf/flow/<name>.yaml`` of the flows evaluated at points: their specs' defaults."""
    cfg = _compose("evaluate", f"flow={flow}")
    if flow == "stochastic3d":
        assert_defaults_are_the_yaml(spec, cfg, "flow.")
        assert_defaults_are_the_yaml(StochasticFlow3D.__init__, cfg, "flow.",
                                     keys={"device": "device"},
                                     library_only=("dtype", "generator"))
    else:
        got = {k: _plain(v) for k, v in defaults(spec).items()}
        assert got == {k: _plain(v) for k, v in OmegaConf.to_container(cfg.flow).items()}


def test_replayed_and_live_dns_flows():
    """``conf/flow/dns_replay.yaml``, ``conf/flow/dns.yaml`` (its solver: conf/solver/dns.yaml)."""
    replay = _compose("evaluate", "flow=dns_replay")
    assert_defaults_are_the_yaml(StoredRunSpec, replay, "flow.")
    live = _compose("evaluate", "flow=dns")
    assert_defaults_are_the_yaml(LiveDNSSpec, live, "flow.")
    assert_defaults_are_the_yaml(DNSParams, live, "flow.dns.",
                                 keys={"device": "device", "dtype": "dtype"})


@pytest.mark.parametrize("name", WITH_FLOW)
def test_swimmer_episode_signals_and_runtime(name):
    cfg = _compose(name)
    swimmer = {k: f"swimmer.{k}" for k in ("swim_speed", "rot_diffusion", "shape_factor_max",
                                           "bottom_heaviness")}
    assert_defaults_are_the_yaml(EnvParams, cfg, "episode.",
                                 keys={**swimmer, "signals": "signals.names", "task": "task",
                                       "reward": "reward", "actuation": "actuation"})
    assert_defaults_are_the_yaml(TaskSpec, cfg, "task.")
    assert_defaults_are_the_yaml(ActuationSpec, cfg, "actuation.")
    assert_defaults_are_the_yaml(RewardSpec, cfg, "reward.")
    # threads differs between commands (evaluate: all cores, train: 1): no default
    for runtime in (Runtime, Runtime.from_names):
        assert "threads" not in defaults(runtime)
        assert_defaults_are_the_yaml(runtime, cfg)
    assert_defaults_are_the_yaml(SwimmerEnv.__init__, cfg, library_only=("generator", "ic_blocks",
                                                                       "body"))


@pytest.mark.parametrize("name", EVALUATING)
def test_evaluation_sizes(name):
    assert_defaults_are_the_yaml(EvalSizes, _compose(name), "eval.")


@pytest.mark.parametrize("strategy", ["sto", "naive", "minimal", "policy"])
def test_strategy_fields_are_those_of_its_yaml(strategy):
    """A strategy's yaml holds its own fields; StrategySpec's defaults (None) stand for the
    fields of the other strategies."""
    node = _compose("evaluate", f"strategy={strategy}").strategy
    spec = strategy_spec(node)
    assert defaults(StrategySpec) == {"shape_factor": None, "coeffs": None, "amplitudes": None,
                                      "threshold": None, "table": None}
    assert spec.shape_factor == node.get("shape_factor")
    coeffs = [node.get(k) for k in ("c1", "c2", "c3", "c4")]
    assert spec.coeffs == (None if coeffs[0] is None else tuple(coeffs))


@pytest.mark.parametrize("name", ["compare", "naive_scan"])
def test_comparison(name):
    cfg = _compose(name)
    assert_defaults_are_the_yaml(CompareConfig, cfg, "compare.", keys={"overwrite": "overwrite"})


def test_strategy_variants_keywords_are_compare_yaml():
    """``strategy_variants(...)``'s keywords (library calls) are ``conf/compare.yaml``'s
    (``swimrl-naive-scan`` sets its own shape factors)."""
    cfg = _compose("compare")
    got = defaults(strategy_variants)
    assert _plain(got["naive_shape_factors"]) == list(cfg.compare.naive_shape_factors)
    assert _plain(got["minimal"]) == [cfg.compare.minimal[k] for k in ("c1", "c2", "c3", "c4")]
    assert _plain(got["policies"]) == list(cfg.compare.policies) == []
    assert _plain(got["minimal_fits"]) == list(cfg.compare.minimal_fits) == []
    assert _plain(got["sto_amplitudes"]) == list(cfg.compare.sto_amplitudes) == []


def test_network_keywords_are_the_model_yaml():
    """``make_mlp``, ``tanh_normal_actor``, ``value_critic`` (library calls): ``model.*`` of
    ``conf/train.yaml`` (the default preset)."""
    cfg = _compose("train")
    for fn in (make_mlp, tanh_normal_actor, value_critic):
        assert_defaults_are_the_yaml(fn, cfg, "model.",
                                     library_only=("out_gain", "device", "dtype"))


def test_dns_run():
    """``conf/dns.yaml``: DNSRun (``store.*`` and the top-level keys) and DNSParams
    (``dns.*``, device and dtype at the top level)."""
    cfg = _compose("dns")
    store = {k: f"store.{k}" for k in ("n_times", "interval_tau_k", "chunk_times", "overwrite",
                                       "extend", "checkpoint_seconds", "diag_every")}
    assert_defaults_are_the_yaml(DNSRun, cfg, keys=store)
    assert_defaults_are_the_yaml(DNSParams, cfg, "dns.",
                                 keys={"device": "device", "dtype": "dtype"})


def test_a_key_missing_from_the_yaml_is_named_not_defaulted():
    cfg = _compose("evaluate", "~flow.basis")
    with pytest.raises(ConfigError, match=r"^flow\.basis is missing"):
        eval_config(cfg)
