"""What a run directory holds: every file's name, once (:class:`RunLayout`)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class RunLayout:
    """Every file of a run directory ``root``, named here once::

        checkpoints/last.pt        checkpoint: the full training state (swimrl.runs.checkpoint)
        checkpoints/prev.pt        prev_checkpoint: the checkpoint before it
        policy.pt                  policy: the final actor + metadata
        policies/policy_<F>.pt     periodic_policy(F): the policy evaluated at F frames
        metrics.json               metrics: a final evaluation (swimrl-eval, swimrl-train)
        curves.csv                 curves: the training curves (swimrl.runs.curves)
        tb/                        tb: TensorBoard event files (tb/ppo/)
        trajectories.npz           trajectories: every decision of recorded swimmers
        comparison.json, .md       comparison, comparison_table (swimrl-compare)
        comparison.partial.json    comparison_partial: an unfinished comparison's chunks
        naive_scan.png             naive_scan_plot
        fit.json                   fit (swimrl-fit-minimal)
        gain_scan.json, .md        gain_scan, gain_scan_table (swimrl-gain-scan)
        .lock                      lock: the one process working here (evaluation.jobs)
    """

    root: Path

    def __post_init__(self) -> None:
        object.__setattr__(self, "root", Path(self.root))

    @property
    def checkpoints(self) -> Path:
        return self.root / "checkpoints"

    @property
    def checkpoint(self) -> Path:
        return self.checkpoints / "last.pt"

    @property
    def prev_checkpoint(self) -> Path:
        return self.checkpoints / "prev.pt"

    @property
    def policy(self) -> Path:
        return self.root / "policy.pt"

    @property
    def policies(self) -> Path:
        return self.root / "policies"

    def periodic_policy(self, frames: int) -> Path:
        return self.policies / f"policy_{frames}.pt"

    @property
    def metrics(self) -> Path:
        return self.root / "metrics.json"

    @property
    def curves(self) -> Path:
        return self.root / "curves.csv"

    @property
    def tb(self) -> Path:
        return self.root / "tb"

    @property
    def trajectories(self) -> Path:
        return self.root / "trajectories.npz"

    @property
    def comparison(self) -> Path:
        return self.root / "comparison.json"

    @property
    def comparison_table(self) -> Path:
        return self.root / "comparison.md"

    @property
    def comparison_partial(self) -> Path:
        return self.root / "comparison.partial.json"

    @property
    def naive_scan_plot(self) -> Path:
        return self.root / "naive_scan.png"

    @property
    def fit(self) -> Path:
        return self.root / "fit.json"

    @property
    def gain_scan(self) -> Path:
        return self.root / "gain_scan.json"

    @property
    def gain_scan_table(self) -> Path:
        return self.root / "gain_scan.md"

    @property
    def lock(self) -> Path:
        return self.root / ".lock"

    @property
    def results(self) -> tuple[Path, ...]:
        """The records whose presence marks a run as finished (one per command)."""
        return (self.metrics, self.comparison, self.fit, self.gain_scan)

    @property
    def training_outputs(self) -> tuple[Path, ...]:
        """What a training run writes (deleted by ``overwrite=true``): directories, then
        files."""
        return (self.checkpoints, self.tb, self.policies, self.policy, self.metrics,
                self.curves, self.comparison, self.comparison_table)
