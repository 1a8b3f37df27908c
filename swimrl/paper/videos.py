r"""The paper's supplemental videos (MP4, Matplotlib + the ffmpeg of ``imageio-ffmpeg``).

* :func:`video_trajectories` (videos 1-4): a few swimmers of each strategy over the evolving
  vorticity of their flow (tiled periodically), inset: their mean distance from the start;
  each swimmer's head a dot coloured by the shape factor ``Lambda`` it holds (where the
  record has it: the stochastic flows' records do, the DNS replay record does not).
* :func:`video_cloud` (videos 6-9): the displacements of all recorded swimmers (a dispersion
  cloud from the origin), inset: the ensemble-mean distance from the start; the shape
  read-out per strategy, ``<Lambda>`` and ``P(Lambda > 0)`` (prolate) at each frame.

Each video's last frame is also written as a PNG still (``stills``: committed in
``docs/figures/videos/``; the MP4s are not).

Both take the arrays of :func:`swimrl.paper.evaluations.ku_record` (or of the DNS
replay record, :func:`swimrl.paper.dns_replay.dns_record`) and return what they drew;
``flow`` is the Kubo number or a label (``"DNS"``), ``unit`` the length unit of the positions.
:func:`build_videos` makes all ten.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from swimrl.analysis.plots import pyplot
from swimrl.flows.labels import ku_display, ku_name

from .dns_replay import dns_record, shipped_before_pending
from .evaluations import KUS, RECORD_STRATEGIES, ku_record
from .settings import FiguresConfig
from .style import COLORS


def _writer(fps: int):
    import imageio_ffmpeg
    import matplotlib

    matplotlib.rcParams["animation.ffmpeg_path"] = imageio_ffmpeg.get_ffmpeg_exe()
    from matplotlib.animation import FFMpegWriter

    return FFMpegWriter(fps=fps, codec="libx264", bitrate=900,
                        extra_args=["-pix_fmt", "yuv420p"])


def _distance_inset(fig, ax, t: np.ndarray, dist: np.ndarray, unit: str):
    """Inset of ``dist`` ``(3, frames)`` against ``t``; returns the moving markers."""
    ins = ax.inset_axes([0.02, 0.72, 0.28, 0.26])
    marks = []
    for j, name in enumerate(RECORD_STRATEGIES):
        ins.plot(t, dist[j], color=COLORS[name], lw=1)
        (m,) = ins.plot(t[:1], dist[j, :1], "o", color=COLORS[name], ms=3)
        marks.append(m)
    ins.set_xlabel(r"$t/\tau_K$", fontsize=6, labelpad=0)
    ins.set_ylabel(f"$|x-x_0|/{unit}$", fontsize=6, labelpad=0)
    ins.tick_params(labelsize=5)
    ins.patch.set_alpha(0.85)
    return marks


def video_trajectories(rec: dict, flow: float | str, path: Path, fps: int = 8,
                       unit: str = r"\ell_f", still: Path | None = None) -> dict:
    """Videos 1-5 from ``rec['traj_abs']`` and ``rec['vorticity']``."""
    from matplotlib.animation import FuncAnimation

    plt = pyplot()

    traj, vort, box = rec["traj_abs"], rec["vorticity"], float(rec["box"])
    n = min(traj.shape[2], vort.shape[0])
    t = rec["time"][:: max(1, (rec["time"].size - 1) // max(1, n - 1))][:n]
    pts = traj[:, :, :n].reshape(-1, 2)
    lo, hi = pts.min(0) - 0.1 * box, pts.max(0) + 0.1 * box  # 1 l_f in the stochastic box
    start = np.floor(lo / box) * box
    reps = np.ceil((hi - start) / box).astype(int)
    extent = [start[0], start[0] + reps[0] * box, start[1], start[1] + reps[1] * box]
    dist = np.linalg.norm(traj[:, :, :n] - traj[:, :, :1], axis=-1).mean(1)
    fig, ax = plt.subplots(figsize=(5.6, 5.6))
    vmax = float(np.abs(vort).max())
    im = ax.imshow(np.tile(vort[0], (reps[1], reps[0])), origin="lower", extent=extent,
                   cmap="RdBu_r", vmin=-vmax, vmax=vmax, interpolation="nearest")
    lines = [[ax.plot([], [], color=COLORS[name], lw=1.2, label=name if i == 0 else None)[0]
              for i in range(traj.shape[1])] for name in RECORD_STRATEGIES]
    ax.plot(traj[:, :, 0, 0].ravel(), traj[:, :, 0, 1].ravel(), "r*", ms=5)  # own starts
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_aspect("equal")
    ax.set_xlabel(f"$x/{unit}$")
    ax.set_ylabel(f"$y/{unit}$")
    ax.legend(fontsize=7, loc="lower right")
    fig.colorbar(im, ax=ax, shrink=0.7, label=r"$\omega\tau_K$")
    marks = _distance_inset(fig, ax, t, dist, unit)
    lam = rec.get("traj_lambda")
    heads = None
    if lam is not None:
        heads = ax.scatter(traj[:, :, 0, 0].ravel(), traj[:, :, 0, 1].ravel(),
                           c=lam[:, :, 0].ravel(), cmap="coolwarm", vmin=-1, vmax=1, s=22,
                           edgecolors=[COLORS[name] for name in RECORD_STRATEGIES
                                       for _ in range(traj.shape[1])], linewidths=1.2,
                           zorder=5)
        fig.colorbar(heads, ax=ax, orientation="horizontal", location="top", shrink=0.45,
                     pad=0.02, aspect=30, label=r"$\Lambda$ (head dots)")
    title = ax.set_title("", fontsize=9)
    fig.tight_layout()

    def frame(f: int):
        im.set_data(np.tile(vort[f], (reps[1], reps[0])))
        for j, row in enumerate(lines):
            for i, line in enumerate(row):
                line.set_data(traj[j, i, : f + 1, 0], traj[j, i, : f + 1, 1])
            marks[j].set_data(t[f: f + 1], dist[j, f: f + 1])
        if heads is not None:
            heads.set_offsets(traj[:, :, f].reshape(-1, 2))
            heads.set_array(lam[:, :, f].ravel())
        title.set_text(f"{ku_display(flow)}, t = {t[f]:.0f} $\\tau_K$")

    _save(fig, FuncAnimation(fig, frame, frames=n), path, fps, still, lambda: frame(n - 1))
    return {"frames": n, "extent": extent, "distance": dist[:, -1].tolist()}


def video_cloud(rec: dict, flow: float | str, path: Path, fps: int = 8,
                unit: str = r"\ell_f", still: Path | None = None) -> dict:
    """Videos 6-10 from ``rec['cloud']`` (``(3, S, frames, 2)``)."""
    from matplotlib.animation import FuncAnimation

    plt = pyplot()

    cloud = rec["cloud"]
    n = cloud.shape[2]
    t = rec["time"][:: max(1, (rec["time"].size - 1) // max(1, n - 1))][:n]
    dist = np.linalg.norm(cloud, axis=-1).mean(1)
    r = float(np.abs(cloud).max()) * 1.05 + 1e-9
    fig, ax = plt.subplots(figsize=(5.6, 5.6))
    dots = [ax.plot([], [], ".", ms=2, color=COLORS[name], alpha=0.6, label=name)[0]
            for name in RECORD_STRATEGIES]
    ax.plot(0, 0, "r*", ms=8)
    ax.set_xlim(-r, r)
    ax.set_ylim(-r, r)
    ax.set_aspect("equal")
    ax.set_xlabel(f"$\\Delta x/{unit}$")
    ax.set_ylabel(f"$\\Delta y/{unit}$")
    ax.legend(fontsize=7, loc="lower right", markerscale=4)
    marks = _distance_inset(fig, ax, t, dist, unit)
    lam = rec.get("cloud_lambda")
    readout = None
    if lam is not None:
        readout = ax.text(0.98, 0.98, "", transform=ax.transAxes, ha="right", va="top",
                          fontsize=7, family="monospace",
                          bbox={"facecolor": "white", "alpha": 0.85, "lw": 0})
    title = ax.set_title("", fontsize=9)
    fig.tight_layout()

    def frame(f: int):
        for j, d in enumerate(dots):
            d.set_data(cloud[j, :, f, 0], cloud[j, :, f, 1])
            marks[j].set_data(t[f: f + 1], dist[j, f: f + 1])
        if readout is not None:
            readout.set_text("\n".join(
                f"{name:>5}: <Λ> {lam[j, :, f].mean():+.2f}, P(Λ>0) {(lam[j, :, f] > 0).mean():.2f}"
                for j, name in enumerate(RECORD_STRATEGIES)))
        title.set_text(f"{ku_display(flow)}, {cloud.shape[1]} swimmers per strategy, "
                       f"t = {t[f]:.0f} $\\tau_K$")

    _save(fig, FuncAnimation(fig, frame, frames=n), path, fps, still, lambda: frame(n - 1))
    return {"frames": n, "mean_distance": dist[:, -1].tolist()}


def build_videos(cfg: FiguresConfig) -> dict:
    """Supplemental videos 1-4 (trajectories) and 6-9 (clouds) into ``<out>/../videos``, and
    5 and 10 in the DNS from its replay record."""
    out, where, stills = {}, Path(cfg.out).parent / "videos", Path(cfg.out) / "videos"
    for i, kubo in enumerate(KUS):
        rec = ku_record(cfg, kubo)
        name = f"video{i + 1}_{ku_name(kubo)}"
        out[i + 1] = video_trajectories(rec, kubo, where / f"{name}.mp4",
                                        still=stills / f"{name}.png")
        name = f"video{i + 6}_{ku_name(kubo)}_cloud"
        out[i + 6] = video_cloud(rec, kubo, where / f"{name}.mp4", still=stills / f"{name}.png")
    if cfg.dns is None:
        rec, why = None, "no dns.* records configured"
    elif stale := shipped_before_pending(cfg.dns):
        rec, why = None, stale
    else:
        rec, why = dns_record(cfg, cfg.dns)
    if rec is None:
        out["pending"] = f"videos 5, 10: {why}"
    else:
        out[5] = video_trajectories(rec, "DNS", where / "video5_dns.mp4", unit="L",
                                    still=stills / "video5_dns.png")
        out[10] = video_cloud(rec, "DNS", where / "video10_dns_cloud.mp4", unit="L",
                              still=stills / "video10_dns_cloud.png")
    return out


def _save(fig, anim, path: Path, fps: int, still: Path | None = None,
          last=None) -> None:
    """The MP4 at ``path``; with ``still``, the last frame (``last()`` draws it) as a PNG."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    anim.save(str(path), writer=_writer(fps), dpi=100)  # even pixel sizes (yuv420p)
    if still is not None:
        last()
        Path(still).parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(still, dpi=80)
    pyplot().close(fig)
