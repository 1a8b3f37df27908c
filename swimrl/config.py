"""Validated physical and episode parameters, built from the Hydra config before any compute.

All times in the config are in units of ``tau_K`` and speeds in units of ``u_rms`` of the
flow in use; :class:`EnvParams` keeps them dimensionless and the environment converts with
the flow's own ``tau_K`` and ``u_rms``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import torch

from swimrl.signals import SIGNAL_NAMES, signal_indices

SHAPE_FACTOR_LIMIT = 1.0
STRATEGIES = ("naive", "sto", "minimal", "policy")
FLOWS = ("stochastic", "dns_replay", "dns")


class ConfigError(ValueError):
    """A config value outside its allowed range (message names key, value and range)."""


def _check(cond: bool, key: str, value, allowed: str) -> None:
    if not cond:
        raise ConfigError(f"{key}={value!r} is invalid: allowed {allowed}")


def _ratio(num: float, den: float, key: str, what: str) -> int:
    """Integer ``num/den``, or a ConfigError naming ``key``."""
    r = num / den
    k = round(r)
    if k < 1 or abs(r - k) > 1e-6 * max(1.0, r):
        raise ConfigError(f"{key}: {what} = {r:.6g} must be a positive integer")
    return k


@dataclass(frozen=True)
class EnvParams:
    """Swimmer and episode parameters (dimensionless: times / tau_K, speeds / u_rms)."""

    swim_speed: float = 0.707
    rot_diffusion: float = 0.0
    duration: float = 200.0
    update_interval: float = 0.1
    dt: float = 0.01
    shape_factor_max: float = 0.98
    signals: tuple[str, ...] = SIGNAL_NAMES
    n_substeps: int = field(init=False)
    n_decisions: int = field(init=False)

    def __post_init__(self) -> None:
        _check(self.swim_speed >= 0, "swimmer.swim_speed", self.swim_speed, ">= 0 (units u_rms)")
        _check(self.rot_diffusion >= 0, "swimmer.rot_diffusion", self.rot_diffusion, ">= 0")
        _check(self.dt > 0, "episode.dt", self.dt, "> 0 (units tau_K)")
        _check(self.update_interval > 0, "episode.update_interval", self.update_interval, "> 0")
        _check(
            self.update_interval <= self.duration,
            "episode.update_interval",
            self.update_interval,
            f"<= episode.duration={self.duration}",
        )
        _check(
            0 < self.shape_factor_max < SHAPE_FACTOR_LIMIT,
            "episode.shape_factor_max",
            self.shape_factor_max,
            "in (0, 1)",
        )
        signal_indices(self.signals)
        object.__setattr__(
            self,
            "n_substeps",
            _ratio(self.update_interval, self.dt, "episode.dt", "update_interval/dt"),
        )
        object.__setattr__(
            self,
            "n_decisions",
            _ratio(
                self.duration,
                self.update_interval,
                "episode.update_interval",
                "duration/update_interval",
            ),
        )

    @classmethod
    def from_cfg(cls, cfg) -> EnvParams:
        """Build from the ``swimmer``, ``episode`` and ``signals`` config groups."""
        return cls(
            swim_speed=float(cfg.swimmer.swim_speed),
            rot_diffusion=float(cfg.swimmer.rot_diffusion),
            duration=float(cfg.episode.duration),
            update_interval=float(cfg.episode.update_interval),
            dt=float(cfg.episode.dt),
            shape_factor_max=float(cfg.episode.shape_factor_max),
            signals=tuple(cfg.signals.names),
        )


def resolve_device(device: str) -> torch.device:
    """``cpu``, ``cuda`` or ``cuda:N``; a clear error if CUDA is asked for but absent."""
    try:
        dev = torch.device(device)
    except RuntimeError:
        dev = None
    if dev is None or dev.type not in ("cpu", "cuda"):
        raise ConfigError(f"device={device!r} is invalid: allowed 'cpu', 'cuda', 'cuda:N'")
    if dev.type == "cuda" and not torch.cuda.is_available():
        raise ConfigError(f"device={device!r} is invalid: CUDA is not available on this machine")
    return dev


def resolve_dtype(name: str) -> torch.dtype:
    """``float32`` (default) or ``float64``."""
    table = {"float32": torch.float32, "float64": torch.float64}
    _check(name in table, "dtype", name, "'float32' or 'float64'")
    return table[name]


def validate_flow_cfg(flow) -> None:
    """Checks of the ``flow`` group common to all backends (more checks in each backend)."""
    _check(flow.name in FLOWS, "flow.name", flow.name, f"one of {list(FLOWS)}")
    if flow.name == "stochastic":
        _check(float(flow.kubo) > 0, "flow.kubo", flow.kubo, "> 0 (e.g. 0.1, 1, 10, 1e7)")
        _check(int(flow.n_modes) >= 1, "flow.n_modes", flow.n_modes, "integer >= 1")
        n = int(flow.n_grid)
        _check(n >= 4 and n % 2 == 0, "flow.n_grid", flow.n_grid, "even integer >= 4")
        _check(float(flow.spacing) > 0, "flow.spacing", flow.spacing, "> 0 (units ell_f)")
    if flow.name == "dns":
        from swimrl.flows.dns import DNSParams

        DNSParams.from_mapping(dict(flow.dns))  # raises DNSParamError naming the key
        for key in ("spinup_time", "measure_time", "snapshot_tau_k"):
            _check(float(flow[key]) > 0, f"flow.{key}", flow[key], "> 0")
        _check(
            float(flow.measure_time) <= float(flow.spinup_time),
            "flow.measure_time",
            flow.measure_time,
            f"<= flow.spinup_time={flow.spinup_time}",
        )
    if flow.name == "dns_replay":
        path = Path(str(flow.path))
        _check(
            (path / "zarr.json").exists() or (path / ".zgroup").exists(),
            "flow.path",
            str(flow.path),
            "a DNS store made by swimrl-dns (see docs/dns.md)",
        )
