"""swimrl: shape-changing microswimmers navigating 2D flows, with TorchRL.

Physics spec: Qiu, Piro, Biferale, Cencini, Mehlig & Gustavsson, *Adaptive shape control for
microswimmer navigation in turbulence*, arXiv:2603.08201.

The names below are the public API, importable from ``swimrl`` directly::

    from swimrl import EnvParams, Runtime, StochasticSpec, build_env, load_policy

    params = EnvParams()                          # the paper's swimmer and episode
    runtime = Runtime.from_names("cpu", "float32", threads=1)
    env = build_env(StochasticSpec(kubo=10.0), params, runtime, n_flows=2,
                    n_swimmers=100, seed=0)
    td = env.rollout(params.n_decisions, load_policy("pretrained/ku10", params))
    print(env.score(td[..., -1]["next"]).mean())  # R_hat, eq. (6) of the paper

``import swimrl`` stays light (no torch): each name is imported from its module on first
use.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

__version__ = "0.1.0"

#: Public name -> the module that defines it, in the order of the API reference: the
#: environment, flows, physics, policies, evaluation, training, errors.
_EXPORTS: dict[str, str] = {
    # environment (swimrl.env, swimrl.task, swimrl.runtime)
    "SwimmerEnv": "swimrl.env.core",
    "build_env": "swimrl.env.build",
    "EnvParams": "swimrl.env.params",
    "TaskSpec": "swimrl.task",
    "RewardSpec": "swimrl.task",
    "Runtime": "swimrl.runtime",
    # flows
    "StochasticSpec": "swimrl.flows.stochastic",
    "StoredRunSpec": "swimrl.flows.dns.flow",
    "LiveDNSSpec": "swimrl.flows.dns.flow",
    "build_flow": "swimrl.flows.build",
    "GriddedFlow": "swimrl.flows.base",
    "CHANNELS": "swimrl.flows.base",
    # physics
    "Body": "swimrl.physics.body",
    "body": "swimrl.physics.body",
    "SIGNAL_NAMES": "swimrl.physics.body2d",
    "compute_signals": "swimrl.physics.body2d",
    "swimmer_rhs": "swimrl.physics.swimmer",
    "heun_step": "swimrl.physics.swimmer",
    "drag_factor": "swimrl.physics.energy",
    # policies
    "load_policy": "swimrl.runs.policy_files",
    "StrategySpec": "swimrl.policies.baselines",
    "build_strategy": "swimrl.policies.baselines",
    "NaiveShape": "swimrl.policies.baselines",
    "ShortTimeOptimal": "swimrl.policies.baselines",
    "MinimalModel": "swimrl.policies.baselines",
    # evaluation
    "RunSpec": "swimrl.runs.spec",
    "EvalSizes": "swimrl.runs.spec",
    "evaluate": "swimrl.evaluation.rollout",
    "evaluate_shared": "swimrl.evaluation.rollout",
    "CompareConfig": "swimrl.evaluation.compare",
    "compare": "swimrl.evaluation.compare",
    # training
    "TrainConfig": "swimrl.rl.plan",
    "train": "swimrl.rl.run",
    # errors
    "ConfigError": "swimrl.errors",
}

__all__ = [
    "__version__",
    "SwimmerEnv",
    "build_env",
    "EnvParams",
    "TaskSpec",
    "RewardSpec",
    "Runtime",
    "StochasticSpec",
    "StoredRunSpec",
    "LiveDNSSpec",
    "build_flow",
    "GriddedFlow",
    "CHANNELS",
    "Body",
    "body",
    "SIGNAL_NAMES",
    "compute_signals",
    "swimmer_rhs",
    "heun_step",
    "drag_factor",
    "load_policy",
    "StrategySpec",
    "build_strategy",
    "NaiveShape",
    "ShortTimeOptimal",
    "MinimalModel",
    "RunSpec",
    "EvalSizes",
    "evaluate",
    "evaluate_shared",
    "CompareConfig",
    "compare",
    "TrainConfig",
    "train",
    "ConfigError",
]

if TYPE_CHECKING:  # for type checkers and the API reference; at run time: __getattr__
    from swimrl.env.build import build_env
    from swimrl.env.core import SwimmerEnv
    from swimrl.env.params import EnvParams
    from swimrl.errors import ConfigError
    from swimrl.evaluation.compare import CompareConfig, compare
    from swimrl.evaluation.rollout import evaluate, evaluate_shared
    from swimrl.flows.base import CHANNELS, GriddedFlow
    from swimrl.flows.build import build_flow
    from swimrl.flows.dns.flow import LiveDNSSpec, StoredRunSpec
    from swimrl.flows.stochastic import StochasticSpec
    from swimrl.physics.body import Body, body
    from swimrl.physics.body2d import SIGNAL_NAMES, compute_signals
    from swimrl.physics.energy import drag_factor
    from swimrl.physics.swimmer import heun_step, swimmer_rhs
    from swimrl.policies.baselines import (
        MinimalModel,
        NaiveShape,
        ShortTimeOptimal,
        StrategySpec,
        build_strategy,
    )
    from swimrl.rl.plan import TrainConfig
    from swimrl.rl.run import train
    from swimrl.runs.policy_files import load_policy
    from swimrl.runs.spec import EvalSizes, RunSpec
    from swimrl.runtime import Runtime
    from swimrl.task import RewardSpec, TaskSpec


def __getattr__(name: str):
    """Import a public name from its module on first use (:data:`_EXPORTS`)."""
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'swimrl' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_EXPORTS))
