"""The DNS replay record of Fig. dnsFlow (a), (d), (e) and videos 5, 10: smart (``dns.policy``),
naive, STO and the DNS-trained policy (``dns.trained``) from the same start time and initial
conditions in a held-out stored DNS run (:func:`make_record`, :func:`dns_record`), and its
table (:func:`replay_summary`, :func:`replay_markdown`).

The replay record (``record``) is made once from a finished stored run when that run exists
(``swimrl-dns seed=...``; the stores are too large to commit) and is then read from the
committed ``.npz``: a fresh clone draws the figure and the videos without the store. The
record keeps what it was made with (policy, store, sizes, seed, episode); a record made with
other settings is not used (delete it to remake it). Lengths are in units of the DNS box
``L`` (``reference_distance`` too).

No input of the DNS figure may lie under ``shipped_before/`` (the policies shipped before the
paper-budget runs): :func:`shipped_before_inputs` names those of ``dns.*`` that do,
:func:`shipped_before_pending` says why the records are then not drawn and how to remake them
(:data:`REMAKE`).
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np

from swimrl.analysis.policy_maps import lambda_maps
from swimrl.flows.dns.flow import StoredRunSpec
from swimrl.flows.dns.store import store_status
from swimrl.runs.policy_files import resolve_policy_file
from swimrl.runs.records import markdown_table, read_npz, write_npz
from swimrl.runs.spec import EvalSizes, RunSpec

from .dns_transfer import sample_std
from .evaluations import FRAME_EVERY, record_strategies
from .settings import DNSFiguresConfig, FiguresConfig, portable, under_shipped_before

#: How the DNS records are remade with the current policies (``{store}``, ``{record}``,
#: ``{transfer}``: the ``dns.*`` paths).
REMAKE = ("swimrl-dns seed=2 (the held-out store {store}; docs/dns.md), then rm {record} and "
          "swimrl-figures only=dnsFlow dns.policy=pretrained/ku10 (and dns.policy=pretrained/ku10 "
          "in conf/figures.yaml); the transfer: swimrl-dns -m seed=3,4,5 and the swimrl-compare "
          "loop of docs/results.md, Fig. dnsFlow, into {transfer}/seed<s>")


def shipped_before_inputs(dns: DNSFiguresConfig) -> list[str]:
    """The ``dns.*`` inputs under ``shipped_before/`` (``KEY=VALUE``)."""
    keys = ("policy", "trained", "store", "record", "transfer", "checks")
    named = [(k, getattr(dns, k)) for k in keys if getattr(dns, k) is not None]
    named += [("trained_seeds", t) for t in dns.trained_seeds]
    named += [("curves", c) for c in dns.curves]
    return [f"dns.{k}={v}" for k, v in named if under_shipped_before(v)]


def shipped_before_pending(dns: DNSFiguresConfig) -> str:
    """Why the DNS records are not drawn and how to remake them ("" where no input is under
    ``shipped_before/``)."""
    inputs = shipped_before_inputs(dns)
    if not inputs:
        return ""
    return (f"{', '.join(inputs)} under shipped_before/: the replay record and the transfer "
            "comparisons were made with the earlier policies; remake them: "
            + REMAKE.format(store=portable(dns.store), record=portable(dns.record),
                            transfer=portable(dns.transfer)))


def replay_strategies(policy: str, trained: str) -> list[str]:
    """The replay record's strategies, in its order: smart, naive, STO, the DNS-trained one."""
    return [policy, "naive", "sto", trained]


# -- the replay record ---------------------------------------------------------------------------
def record_inputs(cfg: FiguresConfig, dns: DNSFiguresConfig) -> dict[str, str]:
    """What a replay record depends on, as strings (kept in the record, compared on load)."""
    return {"policy": dns.policy, "trained": dns.trained, "store": Path(dns.store).name,
            "n_swimmers": str(dns.n_swimmers),
            "n_traj": str(dns.n_traj), "decode_n": str(dns.decode_n), "seed": str(cfg.seed),
            "params": json.dumps(dataclasses.asdict(cfg.params), sort_keys=True, default=str)}


def make_record(cfg: FiguresConfig, dns: DNSFiguresConfig) -> dict[str, np.ndarray]:
    """Smart (``dns.policy``), naive and STO from the same start time and initial conditions
    in ``dns.store``: clouds and trajectories every :data:`FRAME_EVERY` decisions, the
    vorticity of the run at those times, and smart's first ``n_traj`` swimmers at every
    decision (position, orientation, Lambda). Lengths in units of the box."""
    spec = StoredRunSpec((Path(dns.store),), decode_n=dns.decode_n)
    sizes = EvalSizes(1, dns.n_swimmers, 1, cfg.progress, dns.n_swimmers)
    setup = RunSpec(flow=spec, params=cfg.params, runtime=cfg.runtime, sizes=sizes,
                      seed=cfg.seed, record={})
    a = record_strategies(setup, replay_strategies(dns.policy, dns.trained), "DNS", FRAME_EVERY)
    box = float(a["box"])
    maps = {}  # the DNS-trained policy's maps (d), (e), as float32
    for other, (mean, (x, y)) in lambda_maps(a["signals"][0, 3], a["Lambda"][0, 3]).items():
        maps[f"map_{other}"] = mean.astype(np.float32)
        maps[f"map_{other}_x"], maps[f"map_{other}_y"] = x, y
    pos = np.swapaxes(a["position"], 0, 1)[:3, 0] / box  # (3, S, N+1, 2)
    disp = pos - pos[..., :1, :]
    nt = min(dns.n_traj, pos.shape[1])
    return {
        "cloud": disp[..., ::FRAME_EVERY, :].astype(np.float32),
        "traj_abs": pos[:, :nt, ::FRAME_EVERY].astype(np.float32),
        "smart_path": pos[0, :nt].astype(np.float32),
        "smart_theta": np.swapaxes(a["theta"], 0, 1)[0, 0, :nt].astype(np.float32),
        "smart_Lambda": np.swapaxes(a["Lambda"], 0, 1)[0, 0, :nt].astype(np.float32),
        "R_hat": np.swapaxes(a["R_hat"], 0, 1)[:, 0],
        "vorticity": a["vorticity"].astype(np.float16),
        "field_time": a["field_time"],
        "time": a["time"], "tau_K": a["tau_K"], "box": np.asarray(1.0),
        "reference_distance": np.asarray(float(a["reference_distance"]) / box),
        "box_dns": np.asarray(box), "update_interval": a["update_interval"],
        **{f"input_{k}": np.asarray(v) for k, v in record_inputs(cfg, dns).items()},
        **maps,
    }


def dns_record(cfg: FiguresConfig, dns: DNSFiguresConfig) -> tuple[dict | None, str]:
    """``(record, "")``: the committed record, made from ``dns.store`` first if it is missing;
    ``(None, why)`` when it is missing and cannot be made (no finished store, no policy) or
    was made with other inputs."""
    path = Path(dns.record)
    if not path.exists():
        status = store_status(dns.store) if Path(dns.store).exists() else None
        if status != "complete":
            return None, (f"no replay record {path} and no finished store {dns.store} "
                          f"(status {status}) to make it from")
        for key, spec in (("dns.policy", dns.policy), ("dns.trained", dns.trained)):
            try:
                if "/" in spec:  # a policy file (not a baseline such as naive(-0.5))
                    resolve_policy_file(spec)
            except (FileNotFoundError, ValueError) as err:
                return None, f"no replay record {path}: {key}={spec!r} ({err})"
        write_npz(make_record(cfg, dns), path)
    out = read_npz(path)
    made = {k[6:]: str(v) for k, v in out.items() if k.startswith("input_")}
    differ = sorted(k for k, v in record_inputs(cfg, dns).items() if made.get(k) != v)
    if differ:
        return None, (f"{path} was made with other {', '.join(differ)} (delete it to remake it "
                      "from the store)")
    out["vorticity"] = out["vorticity"].astype(np.float32)
    return out, ""


def replay_summary(rec: dict) -> dict[str, dict]:
    """The replay record's strategies (:func:`replay_strategies`): ``R_hat`` (mean, SEM over
    swimmers) and the mean distance from the start after ``T`` in box units (``R_hat`` times
    the reference distance ``v_s T``)."""
    names = replay_strategies(str(rec["input_policy"]), str(rec["input_trained"]))
    ref = float(rec["reference_distance"])
    out = {}
    for name, r in zip(names, np.asarray(rec["R_hat"], dtype=float), strict=True):
        out[name] = {"R_hat": float(r.mean()), "R_hat_sem": sample_std(r) / math.sqrt(r.size),
                     "distance_L": float(r.mean() * ref), "n_swimmers": int(r.size)}
    return out


def replay_markdown(summary: dict[str, dict], store: str) -> str:
    """The replay record's table (the numbers of videos 5, 10)."""
    rows = [[k, f"{v['R_hat']:.3f} ± {v['R_hat_sem']:.3f}", f"{v['distance_L']:.2f}",
             str(v["n_swimmers"])] for k, v in summary.items()]
    return (f"Replay record (videos 5, 10; Fig. dnsFlow(a)): held-out run {store}, one start "
            "time, the same initial conditions for every strategy; ± SEM over swimmers.\n\n"
            + markdown_table(["strategy", "R̂", "mean distance after T / L", "swimmers"], rows))
