"""How the figures look: the strategies' colours, the signals' axis labels, the sizes line of
a title, and how a figure is drawn (:func:`~swimrl.analysis.plots.pyplot`) and written
(:func:`save`).

Colours: smart orange, naive (``Lambda = 0.98``) black, STO green (the paper's).
"""

from __future__ import annotations

from pathlib import Path

from swimrl.analysis.plots import pyplot

COLORS = {"smart": "tab:orange", "naive": "k", "STO": "tab:green"}
LABEL = {"n_r": r"$n_r$", "n_theta": r"$n_\theta$", "S_nn": r"$S_{nn}\tau_K$",
         "S_np": r"$S_{np}\tau_K$", "omega": r"$\omega\tau_K$"}


def save(fig, path: Path) -> None:
    """Write ``fig`` to ``path`` (its directory made first) and close it."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    pyplot().close(fig)


def sizes_title(flows: int, swimmers: int, duration: float) -> str:
    """The sizes of an evaluation as a title says them (``duration``: ``T / tau_K``)."""
    return f"{flows} flow(s) x {swimmers} swimmers, T = {float(duration):g} $\\tau_K$"


def shown(path: Path) -> str:
    """``path`` relative to the working directory where it lies below it."""
    try:
        return str(Path(path).resolve().relative_to(Path.cwd()))
    except ValueError:
        return str(path)
