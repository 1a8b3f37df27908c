r"""Figures of vertical migration in the Taylor-Green flow (``docs/beyond/gyrotaxis.md``).

    python -m swimrl.analysis.gyrotaxis_figures trajectories OUT.png LABEL=TRAJ.npz [...]
    python -m swimrl.analysis.gyrotaxis_figures policy-map OUT.png RUN [--psi 1 --phi 0.3]

* ``trajectories``: the recorded swimmers of ``swimrl-eval ... eval.record=n``
  (``trajectories.npz``, :mod:`swimrl.evaluation.trajectories`) over the flow's streamlines
  $\psi = (U/k)\sin kx\sin ky$, one panel per record;
* ``policy-map``: the direction $\boldsymbol k_a$ a steering policy chooses (its angle from
  the vertical, clockwise positive: towards $+x$) over the heading angle $\varphi$ from the
  vertical and the vorticity $\omega\tau_K$, for a policy trained on
  ``signals=heading_vorticity`` (with ``task=vertical``: $n_r = \cos\varphi$,
  $n_\theta = -\sin\varphi$) or ``signals=state12``.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np
import torch

from swimrl.actuation import ActuationSpec
from swimrl.env import EnvParams
from swimrl.evaluation.trajectories import load_trajectories
from swimrl.physics.body import observable
from swimrl.physics.body2d import Body2D
from swimrl.physics.gyrotaxis import axis_directions
from swimrl.runs.policy_files import load_file, resolve_policy_file
from swimrl.runs.policy_files import load_policy as _load_policy
from swimrl.task import TaskSpec

from .plots import pyplot


def plot_trajectories(records: list[tuple[str, Path]], out: Path, max_swimmers: int = 6,
                      until: float = 40.0) -> None:
    """One panel per ``(label, trajectories.npz)``: the first ``max_swimmers`` recorded
    swimmers of the first flow over the Taylor-Green streamlines (amplitude and wavenumber
    from the record's config), from the start to ``until`` ($\tau_K$); each panel's title
    gives their $\\langle v_z\rangle/v_s$ over the whole episode's window."""
    plt = pyplot()
    fig, axes = plt.subplots(1, len(records), figsize=(3.6 * len(records), 4.6), squeeze=False)
    for ax, (label, path) in zip(axes[0], records, strict=True):
        rec = load_trajectories(path)
        flow = rec["config"]["flow"]
        k = float(flow.get("wavenumber", 1.0))
        keep = rec["time"] <= until
        pos = rec["position"][0, 0, :max_swimmers][:, keep]        # (n, t, 2)
        lo, hi = np.nanmin(pos, axis=(0, 1)), np.nanmax(pos, axis=(0, 1))
        pad = math.pi / k
        x = np.linspace(lo[0] - pad, hi[0] + pad, 300)
        y = np.linspace(lo[1] - pad, hi[1] + pad, 300)
        xx, yy = np.meshgrid(x, y)
        ax.contour(xx, yy, np.sin(k * xx) * np.sin(k * yy), levels=np.linspace(-0.9, 0.9, 7),
                   colors="0.75", linewidths=0.6)
        for i in range(pos.shape[0]):
            ax.plot(pos[i, :, 0], pos[i, :, 1], lw=0.9)
            ax.plot(pos[i, 0, 0], pos[i, 0, 1], "k.", ms=4)
        vz = rec["R_hat"][0, 0, :max_swimmers].mean()
        ax.set(title=f"{label}\n<v_z>/v_s of these: {vz:.2f}", xlabel="x", ylabel="y (up)",
               aspect="equal")
        ax.set_xlim(lo[0] - pad, hi[0] + pad)
    fig.tight_layout()
    fig.savefig(out, dpi=120)
    plt.close(fig)


def direction_map(run: str, phi: np.ndarray, omega: np.ndarray) -> np.ndarray:
    r"""The angle of $\boldsymbol k_a$ from the vertical (towards $+x$ positive) that the
    steering policy ``run`` chooses at heading angles ``phi`` and vorticities ``omega``
    (``omega tau_K``), ``(len(omega), len(phi))``."""
    data = load_file(resolve_policy_file(run), map_location="cpu")
    names = tuple(str(s) for s in data["signals"])
    cfg = data.get("config") or {}
    act = cfg.get("actuation") or {}
    params = EnvParams(signals=names, bottom_heaviness=1.0, task=TaskSpec(name="vertical"),
                       actuation=ActuationSpec(name=str(act.get("name", "steer")),
                                               directions=str(act.get("directions",
                                                                      "continuous"))))
    policy = _load_policy(run, params)
    pp, ww = np.meshgrid(phi, omega)
    sig = torch.zeros(pp.size, 5, dtype=torch.float32)
    sig[:, 0] = torch.as_tensor(np.cos(pp).ravel())
    sig[:, 1] = torch.as_tensor(-np.sin(pp).ravel())
    sig[:, 4] = torch.as_tensor(ww.ravel())
    obs = observable(Body2D(), sig, names)
    from tensordict import TensorDict
    with torch.no_grad():
        action = policy(TensorDict({"observation": obs}, batch_size=[len(obs)]))["action"]
    if action.dtype == torch.int64:
        action = axis_directions(2)[action.reshape(-1)]
    a = action.reshape(len(sig), -1)[:, -2:].double()
    return torch.atan2(a[:, 0], a[:, 1]).numpy().reshape(pp.shape)


def plot_policy_map(run: str, out: Path, title: str = "") -> None:
    """:func:`direction_map` over $\\varphi\\in[-\\pi, \\pi]$, $\\omega\\tau_K\\in[-2, 2]$, with
    the 12 states' vorticity edges $\\pm 2/3$."""
    plt = pyplot()
    phi = np.linspace(-math.pi, math.pi, 181)
    omega = np.linspace(-2.0, 2.0, 161)
    m = direction_map(run, phi, omega)
    fig, ax = plt.subplots(figsize=(5.6, 4.2))
    im = ax.pcolormesh(np.degrees(phi), omega, np.degrees(m), cmap="twilight", vmin=-180,
                       vmax=180, shading="auto")
    for w in (-2 / 3, 2 / 3):
        ax.axhline(w, color="w", lw=0.8, ls="--")
    ax.set(xlabel="heading from the vertical φ (deg, + towards +x)", ylabel="ω τ_K",
           title=title or "direction chosen")
    fig.colorbar(im, label="k_a from the vertical (deg, + towards +x)")
    fig.tight_layout()
    fig.savefig(out, dpi=120)
    plt.close(fig)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(prog="python -m swimrl.analysis.gyrotaxis_figures",
                                 description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="what", required=True)
    t = sub.add_parser("trajectories")
    t.add_argument("out", type=Path)
    t.add_argument("records", nargs="+", help="LABEL=trajectories.npz")
    t.add_argument("--swimmers", type=int, default=6)
    t.add_argument("--until", type=float, default=40.0, help="the time drawn, tau_K")
    p = sub.add_parser("policy-map")
    p.add_argument("out", type=Path)
    p.add_argument("run")
    p.add_argument("--title", default="")
    args = ap.parse_args(argv)
    if args.what == "trajectories":
        recs = []
        for r in args.records:
            label, sep, path = r.partition("=")
            if not sep:
                ap.error(f"records: {r!r} is not LABEL=trajectories.npz")
            recs.append((label, Path(path)))
        plot_trajectories(recs, args.out, args.swimmers, args.until)
    else:
        plot_policy_map(args.run, args.out, args.title)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
