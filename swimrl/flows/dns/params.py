r"""Parameters of the 2D Navier-Stokes DNS (paper eq. NSE, vorticity form).

$$
\partial_t\omega + \boldsymbol u\cdot\nabla\omega
= \nu\nabla^2\omega - \alpha(-\nabla^2)^{-h}\omega + f
$$

with $\nu$ the viscosity, $\alpha$ the hypo-friction coefficient and $h$ = ``hypo_power``
($h = 0$ is the paper's linear friction $-\alpha\boldsymbol u$), $f$ the white-in-time forcing
that injects energy at the mean rate $\epsilon$, peaked at $|\boldsymbol k| = k_f$ with
Gaussian width ``forcing_width``. The defaults are read from ``conf/solver/dns.yaml`` (``dtype`` and
``device``: ``conf/dns.yaml``; :mod:`swimrl.conf_values`); ``docs/dns.md`` derives them.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields

import torch

from swimrl.conf_values import yaml_value
from swimrl.errors import ConfigError
from swimrl.flows.dns.grid import dealias_cutoff

DTYPES: dict[str, torch.dtype] = {"float32": torch.float32, "float64": torch.float64}


@dataclass(frozen=True)
class DNSParams:
    r"""Physical and numerical parameters; validated on construction.

    Keys: ``n`` grid points per side, ``length`` box side $L$, ``nu`` viscosity, ``alpha``
    hypo-friction coefficient, ``hypo_power`` $h$ in $(-\nabla^2)^{-h}$, ``epsilon`` mean energy
    injection rate, ``k_f`` forcing wavenumber, ``forcing_width`` Gaussian width of the forcing
    spectrum in $|\boldsymbol k|$, ``dt`` time step, ``dtype`` ``"float32"``/``"float64"``,
    ``device`` torch device string, ``cfl_max`` CFL limit of the stepper, ``cfl_every`` steps
    between CFL checks.
    """

    n: int = yaml_value("solver/dns", "dns.n")
    length: float = yaml_value("solver/dns", "dns.length")
    nu: float = yaml_value("solver/dns", "dns.nu")
    alpha: float = yaml_value("solver/dns", "dns.alpha")
    hypo_power: float = yaml_value("solver/dns", "dns.hypo_power")
    epsilon: float = yaml_value("solver/dns", "dns.epsilon")
    k_f: float = yaml_value("solver/dns", "dns.k_f")
    forcing_width: float = yaml_value("solver/dns", "dns.forcing_width")
    dt: float = yaml_value("solver/dns", "dns.dt")
    dtype: str = yaml_value("dns", "dtype")
    device: str = yaml_value("dns", "device")
    cfl_max: float = yaml_value("solver/dns", "dns.cfl_max")
    cfl_every: int = yaml_value("solver/dns", "dns.cfl_every")

    def __post_init__(self) -> None:
        def bad(key: str, rng: str) -> ConfigError:
            return ConfigError(f"dns.{key}={getattr(self, key)!r} is invalid: allowed {rng}")

        def num(key: str) -> float:
            v = getattr(self, key)
            if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
                raise bad(key, "a finite number")
            return float(v)

        if isinstance(self.n, bool) or not isinstance(self.n, int) or self.n < 8 or self.n % 2:
            raise bad("n", "an even integer >= 8")
        if not num("length") > 0:
            raise bad("length", "> 0")
        if not num("nu") >= 0:
            raise bad("nu", ">= 0")
        if not num("alpha") >= 0:
            raise bad("alpha", ">= 0")
        if not 0 <= num("hypo_power") <= 8:
            raise bad("hypo_power", "in [0, 8]")
        if not num("epsilon") >= 0:
            raise bad("epsilon", ">= 0")
        k_max = 2 * math.pi * dealias_cutoff(self.n) / self.length
        k_min = 2 * math.pi / self.length
        if not k_min <= num("k_f") <= k_max:
            raise bad("k_f", f"in [{k_min:.4g}, {k_max:.4g}] (box wavenumber .. k_max)")
        if not 0 < num("forcing_width") <= num("k_f"):
            raise bad("forcing_width", f"in (0, k_f={self.k_f}]")
        if not num("dt") > 0:
            raise bad("dt", "> 0")
        if self.dtype not in DTYPES:
            raise bad("dtype", f"one of {sorted(DTYPES)}")
        try:
            dev = torch.device(self.device)
        except (RuntimeError, TypeError) as err:
            raise bad("device", "a torch device string such as 'cpu' or 'cuda:0'") from err
        if dev.type == "cuda" and not torch.cuda.is_available():
            raise bad("device", "'cpu' here (CUDA is not available)")
        if not 0 < num("cfl_max") <= 1.35:
            raise bad("cfl_max", "in (0, 1.35] (RK4 stability bound 2.83*3/(2 pi))")
        if isinstance(self.cfl_every, bool) or not isinstance(self.cfl_every, int):
            raise bad("cfl_every", "an integer >= 1")
        if self.cfl_every < 1:
            raise bad("cfl_every", "an integer >= 1")

    @property
    def torch_dtype(self) -> torch.dtype:
        """Real torch dtype of the run."""
        return DTYPES[self.dtype]

    def replace(self, **changes) -> DNSParams:
        """A validated copy with ``changes`` applied."""
        return DNSParams(**{**asdict(self), **changes})

    def to_dict(self) -> dict:
        """Plain ``dict`` of all keys (JSON-serialisable)."""
        return asdict(self)

    @classmethod
    def from_mapping(cls, cfg) -> DNSParams:
        """Build from a mapping (e.g. a Hydra ``DictConfig`` node); unknown keys are an error."""
        names = {f.name for f in fields(cls)}
        data = dict(cfg)
        unknown = sorted(set(data) - names)
        if unknown:
            raise ConfigError(f"dns.{unknown[0]} is not a DNS parameter: allowed {sorted(names)}")
        return cls(**data)
