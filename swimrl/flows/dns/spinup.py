r"""Spin-up to a statistically steady state, and the reference scales measured over its end.

A run is stepped for ``steps = max(1, round(time / dt))`` solver steps; over the last
``measure_steps = min(steps, max(1, round(measure_time / dt)))`` of them, every
``sample_every`` steps, the energy $E$ and enstrophy $Z$ are sampled (averaged over the
realisations) and time-averaged:

$$
u_\mathrm{rms} = \langle\boldsymbol u\cdot\boldsymbol u\rangle^{1/2} = \langle 2E\rangle^{1/2},
\qquad
\tau_K = \langle\partial_i u_j\,\partial_i u_j\rangle^{-1/2} = \langle 2Z\rangle^{-1/2}
$$

(2D: $\langle\partial_i u_j\,\partial_i u_j\rangle = \langle\omega^2\rangle$). ``swimrl-dns``
(:mod:`swimrl.flows.dns.run`) and the live DNS flow (:class:`swimrl.flows.dns.sources.LiveDNS`)
use the same schedule and meter.
"""

from __future__ import annotations

from dataclasses import dataclass

from swimrl.flows.dns import diagnostics as diag
from swimrl.flows.dns.stepper import DNS


@dataclass(frozen=True)
class SpinupSchedule:
    """Step counts of a spin-up of ``time`` with its final ``measure_time`` measured."""

    steps: int
    measure_steps: int
    sample_every: int

    @classmethod
    def from_times(
        cls, time: float, measure_time: float, dt: float, sample_every: int | None = None
    ) -> SpinupSchedule:
        """Steps ``round(time / dt)`` and ``round(measure_time / dt)``; ``sample_every``
        defaults to 1/50 of the measurement window."""
        steps = max(1, round(time / dt))
        measure = min(steps, max(1, round(measure_time / dt)))
        every = max(1, measure // 50) if sample_every is None else int(sample_every)
        return cls(steps, measure, every)

    def measures(self, step: int) -> bool:
        """Whether the state after solver step ``step`` is sampled."""
        in_window = self.steps - self.measure_steps < step <= self.steps
        return in_window and step % self.sample_every == 0


def energy_sample(dns: DNS) -> dict[str, float]:
    r"""$\langle\boldsymbol u\cdot\boldsymbol u\rangle = 2E$ and
    $\langle\mathbb A:\mathbb A\rangle = 2Z$ of the current state, averaged over realisations."""
    s = diag.scalar_summary(dns.grid, dns.params, dns.state.omega_hat)
    return {"u2": float((2 * s["energy"]).mean()), "grad2": float((2 * s["enstrophy"]).mean())}


@dataclass
class ScaleMeter:
    r"""Running sums of $\langle\boldsymbol u\cdot\boldsymbol u\rangle$ and
    $\langle\mathbb A:\mathbb A\rangle$ samples $\to$ $u_\mathrm{rms}$ and $\tau_K$."""

    u2: float = 0.0
    grad2: float = 0.0
    count: float = 0.0

    def add(self, u2: float, grad2: float) -> None:
        """One sample."""
        self.u2 += u2
        self.grad2 += grad2
        self.count += 1

    def scales(self) -> dict[str, float]:
        r"""``u_rms`` $= (\sum u_2/n)^{1/2}$, ``tau_k`` $= (\sum \mathrm{grad}_2/n)^{-1/2}$
        ($u_2$, $\mathrm{grad}_2$ the samples, $n$ their count)."""
        c = max(self.count, 1.0)
        return {"u_rms": (self.u2 / c) ** 0.5, "tau_k": (self.grad2 / c) ** -0.5}


def spin_up(dns: DNS, schedule: SpinupSchedule) -> dict[str, float]:
    """Step ``dns`` through the whole spin-up; returns the measured ``u_rms`` and ``tau_k``."""
    meter = ScaleMeter()
    for _ in range(schedule.steps):
        dns.step()
        if schedule.measures(dns.state.step):
            meter.add(**energy_sample(dns))
    if meter.count == 0:  # measurement window shorter than the sampling interval
        meter.add(**energy_sample(dns))
    return meter.scales()
