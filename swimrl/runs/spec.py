r"""A run's spec: the flow, the swimmer and episode, the runtime, the sizes and the seed that
a training and every evaluation of it are made with (:class:`RunSpec`), and the evaluation
sizes ``eval.*`` (:class:`EvalSizes`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from swimrl.conf_values import yaml_value
from swimrl.env import EnvParams
from swimrl.errors import ConfigError, as_bool, as_int, keep_number_types, one_of, require
from swimrl.flows.build import FlowSpec
from swimrl.flows.registry import flow_dimension, flow_entry
from swimrl.physics.body import body, observable_names, signal_indices
from swimrl.runtime import Runtime


@dataclass(frozen=True)
class EvalSizes:
    """``eval.*``: flows, swimmers per flow, flows simulated at once, progress bar, and the
    number of swimmers per flow whose every decision is recorded (``record``, 0: none; see
    :mod:`swimrl.evaluation.trajectories`).

    Parameters
    ----------
    n_flows
        Flow realisations (paper: 100).
    n_swimmers
        Swimmers per flow (paper: 1000), from uniformly random starts.
    flows_per_batch
        Realisations simulated at once (one chunk; memory ~16 MB each at the paper's grid).
    progress
        A tqdm bar over the decisions.
    record
        Swimmers per flow whose every decision goes to ``trajectories.npz``.
    """

    n_flows: int
    n_swimmers: int
    flows_per_batch: int
    progress: bool
    record: int = yaml_value("evaluate", "eval.record")

    def __post_init__(self) -> None:
        as_bool("eval.progress", self.progress)
        for key in ("n_flows", "n_swimmers", "flows_per_batch"):
            as_int(f"eval.{key}", getattr(self, key))
        require(as_int("eval.record", self.record, low=0) <= self.n_swimmers, "eval.record",
                self.record, f"an integer in [0, eval.n_swimmers={self.n_swimmers}]")
        keep_number_types(self)


@dataclass(frozen=True)
class RunSpec:
    """Where and how strategies are evaluated; ``record`` (the resolved config) is written
    into the results.

    Parameters
    ----------
    flow
        The flow (:class:`~swimrl.flows.stochastic.StochasticSpec`, a stored or live DNS spec).
    params
        Swimmer, episode, signals, task and reward (:class:`~swimrl.env.EnvParams`).
    runtime
        Device, dtype, threads, kernel (:class:`~swimrl.runtime.Runtime`).
    sizes
        Flows, swimmers, chunking (:class:`EvalSizes`).
    seed
        Chunk ``c`` of the flows is drawn from ``SeedSequence([seed, c])``: the same seed
        gives every strategy the same flows and starts.
    record
        The resolved config, copied into every result.
    """

    flow: FlowSpec
    params: EnvParams
    runtime: Runtime
    sizes: EvalSizes
    seed: int
    record: dict

    def __post_init__(self) -> None:
        object.__setattr__(self, "seed", as_int("seed", self.seed, low=0))
        names = observable_names(body(self.dimension))
        try:
            signal_indices(self.params.signals, names)
        except ConfigError as err:
            raise ConfigError(f"{err} (flow={self.flow.name} is {self.dimension}D)") from None
        if self.params.bottom_heaviness is not None:
            require(self.runtime.kernel != "fused", "kernel", self.runtime.kernel,
                    "'auto', 'eager' or 'compiled' for a gyrotactic swimmer "
                    "(swimmer.bottom_heaviness set): the fused kernels have no torque")
        kernels = flow_entry(self.flow.name).kernels
        if kernels is not None:
            one_of("kernel", self.runtime.kernel, kernels)

    @property
    def dimension(self) -> int:
        """2 or 3, the flow's (:func:`~swimrl.flows.registry.flow_dimension`)."""
        return flow_dimension(self.flow)

    def resized(self, n_flows: int, n_swimmers: int) -> RunSpec:
        """The same setup with ``n_flows x n_swimmers`` and no progress bar."""
        sizes = EvalSizes(n_flows, n_swimmers, min(self.sizes.flows_per_batch, n_flows), False, 0)
        return replace(self, sizes=sizes)
