"""PPO training pipeline: end to end, checkpoint/resume, config errors, sweeps (tiny sizes)."""

from __future__ import annotations

import copy
import json
import math
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import torch
from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

from swimrl.config import eval_config, train_config
from swimrl.errors import ConfigError
from swimrl.evaluation.rollout import actor_for, evaluate
from swimrl.rl.builders import auto_reward_scale, make_env
from swimrl.rl.plan import EVAL_SEED_OFFSET, make_plan
from swimrl.rl.run import train as _train
from swimrl.rl.trainer import PPOTrainer
from swimrl.runs.layout import RunLayout
from swimrl.runs.policy_files import load_file

from .conftest import SMALL

# 2 flows x 4 swimmers, episodes of N = 20 decisions, batches of L = 10: 4 updates
TINY = SMALL + [
    "train.compile=false",
    "train.n_flows=2",
    "train.n_swimmers=4",
    "train.rollout_length=10",
    "train.total_frames=320",
    "train.minibatch_size=40",
    "train.eval_every=2",
    "train.eval_flows=1",
    "train.eval_swimmers=4",
    "train.checkpoint_every=1",
    "train.progress=false",
    "eval.n_flows=2",
    "eval.n_swimmers=4",
]


def train(cfg, out):
    """``swimrl-train`` on a composed config."""
    return _train(train_config(cfg), out)


def _env(c, plan):
    """The training env of the typed config ``c``."""
    return make_env(c.spec.flow, c.params, c.runtime, c.train, c.loss, plan.train_seed)


def validate_train_cfg(cfg):
    """The plan of a composed training config (all checks first)."""
    return make_plan(train_config(cfg))


@pytest.fixture
def train_cfg(compose_cfg):
    def _cfg(*overrides):
        return compose_cfg(TINY + list(overrides), name="train")

    return _cfg


def scalars(run_dir) -> dict[str, list[tuple[int, float]]]:
    ea = EventAccumulator(str(RunLayout(run_dir).tb / "ppo"))
    ea.Reload()
    return {t: [(e.step, e.value) for e in ea.Scalars(t)] for t in ea.Tags()["scalars"]}


@pytest.mark.parametrize("anneal", ["linear", "none"])
def test_ppo_end_to_end(train_cfg, tmp_path, anneal):
    cfg = train_cfg("train.compare_baselines=true", f"optim.anneal={anneal}")
    metrics = train(cfg, tmp_path)
    assert math.isfinite(metrics["R_hat_mean"]) and metrics["R_hat_mean"] > 0
    assert metrics["seed"] == EVAL_SEED_OFFSET and metrics["strategy"] == "policy"
    assert metrics["training"]["updates"] == 4 and metrics["training"]["frames"] == 320
    on_disk = json.loads((tmp_path / "metrics.json").read_text())
    assert on_disk["R_hat_mean"] == metrics["R_hat_mean"]
    assert (tmp_path / "policy.pt").is_file() and RunLayout(tmp_path).checkpoint.is_file()
    assert list((tmp_path / "tb" / "ppo").glob("events.out.tfevents.*"))
    s = scalars(tmp_path)
    assert "train/loss_entropy" not in s  # entropy_coeff = 0: no Monte-Carlo entropy sample
    for tag in (
        "train/loss_objective",
        "train/loss_critic",
        "train/kl_approx",
        "train/clip_fraction",
        "train/lr_actor",
        "train/lr_critic",
        "policy/std",
        "time/frames_per_s",
    ):
        assert len(s[tag]) == 4 and all(math.isfinite(v) for _, v in s[tag]), tag
    assert [step for step, _ in s["train/loss_critic"]] == [80, 160, 240, 320]
    assert [step for step, _ in s["eval/R_hat"]] == [0, 160, 320]  # initial policy first
    # each evaluated policy is kept (to choose one on a validation seed afterwards)
    kept = sorted((tmp_path / "policies").glob("policy_*.pt"), key=lambda p: p.stat().st_mtime)
    assert [p.name for p in kept] == ["policy_0.pt", "policy_160.pt", "policy_320.pt"]
    last, final = load_file(kept[-1]), load_file(tmp_path / "policy.pt")
    assert all(torch.equal(last["actor"][k], v) for k, v in final["actor"].items())
    # the committed-record form of the curves: one CSV row per logged step, same values
    import csv

    rows = list(csv.DictReader((tmp_path / "curves.csv").open()))
    assert [int(r["frames"]) for r in rows] == [0, 80, 160, 240, 320]
    evals = [(int(r["frames"]), float(r["eval/R_hat"])) for r in rows if r["eval/R_hat"]]
    assert evals == [(st, pytest.approx(v, rel=1e-5)) for st, v in s["eval/R_hat"]]
    assert "train/R_hat" in s  # episodes of 20 decisions finish every other batch
    # train.compare_baselines: STO, naive and the policy on the final evaluation's flows
    rec = json.loads((tmp_path / "comparison.json").read_text())
    assert [r["label"] for r in rec["rows"]] == ["sto", "naive(+0.98)", f"policy({tmp_path})"]
    assert rec["seed"] == metrics["seed"]
    assert rec["rows"][2]["per_flow"] == metrics["per_flow"]  # same flows, same policy
    assert (tmp_path / "comparison.md").read_text().startswith("Ku = ")
    lr = [v for _, v in s["train/lr_actor"]]
    lr0 = cfg.optim.lr_actor
    factor = (lambda u: 1 - u / 4) if anneal == "linear" else (lambda u: 1.0)
    assert lr == pytest.approx([lr0 * factor(u) for u in range(4)], rel=1e-5)


def test_validation_precedes_compute(train_cfg, tmp_path, monkeypatch):
    import swimrl.env.build

    def boom(*a, **k):
        raise AssertionError("flow built before validation")

    monkeypatch.setattr(swimrl.env.build, "build_flow", boom)
    with pytest.raises(ValueError, match="train.rollout_length"):
        train(train_cfg("train.rollout_length=0"), tmp_path)
    assert not (tmp_path / "tb").exists()


@pytest.mark.parametrize(
    ("override", "key"),
    [
        ("train.rollout_length=0", "train.rollout_length"),
        ("train.rollout_length=2.5", "train.rollout_length"),
        ("train.total_frames=40", "train.total_frames"),
        ("train.minibatch_size=100", "train.minibatch_size"),
        ("train.minibatches_per_epoch=3", "train.minibatches_per_epoch"),
        ("train.epochs=0", "train.epochs"),
        ("train.n_swimmers=0", "train.n_swimmers"),
        ("train.reward_scale=-1", "train.reward_scale"),
        ("train.eval_every=-1", "train.eval_every"),
        ("loss.clip_epsilon=0", "loss.clip_epsilon"),
        ("loss.gamma=1.5", "loss.gamma"),
        ("loss.loss_critic_type=huber", "loss.loss_critic_type"),
        ("optim.lr_actor=0", "optim.lr_actor"),
        ("optim.anneal=cosine", "optim.anneal"),
        ("model.hidden=[]", "model.hidden"),
        ("model.activation=gelu", "model.activation"),
        ("flow.kubo=0", "flow.kubo"),
        ("episode.dt=0.03", "episode.dt"),
        ("swimmer.swim_speed=-1", "swimmer.swim_speed"),
        ("signals.names=[n_r,foo]", "signals.names"),
        ("eval.n_flows=0", "eval.n_flows"),
        ("train.init_policy=no/such/policy", "train.init_policy"),
        ("train.init_policy=pretrained/ku10 model.hidden=[32]", "train.init_policy"),
        ("train.init_policy=pretrained/ku10 signals=nth_snp", "train.init_policy"),
        ("train.actor_frozen_updates=-1", "train.actor_frozen_updates"),
        ("train.actor_frozen_updates=4", "train.actor_frozen_updates"),
    ],
)
def test_bad_config_names_the_key(train_cfg, override, key):
    with pytest.raises(ValueError) as err:
        validate_train_cfg(train_cfg(*override.split()))
    msg = str(err.value)
    assert key in msg and "\n" not in msg


def test_warm_start_keeps_the_actor_while_the_critic_learns_alone(train_cfg, tmp_path):
    """``train.init_policy``: the run starts from the policy's actor weights; for
    ``train.actor_frozen_updates`` updates they stay exactly as loaded (actor rate 0) while
    the critic learns, then the actor trains."""
    from swimrl.runs.policy_files import resolve_policy_file

    warm = ["train.init_policy=pretrained/ku10", "train.actor_frozen_updates=2",
            "train.eval_every=0"]
    init = load_file(resolve_policy_file("pretrained/ku10"))["actor"]
    assert train(train_cfg(*warm, "train.stop_after_updates=2"), tmp_path) is None
    ck = load_file(RunLayout(tmp_path).checkpoint)
    assert ck["counters"]["updates"] == 2
    assert all(torch.equal(ck["actor"][k], v) for k, v in init.items())
    fresh = PPOTrainer(train_config(train_cfg(*warm)), make_plan(train_config(train_cfg(*warm))),
                       tmp_path / "fresh")
    assert any(not torch.equal(ck["critic"][k], v)
               for k, v in fresh.critic.state_dict().items())  # the critic learnt
    fresh.close()
    train(train_cfg(*warm, "resume=true"), tmp_path)
    after = load_file(RunLayout(tmp_path).checkpoint)["actor"]
    assert any(not torch.equal(after[k], v) for k, v in init.items())  # then the actor


def test_plan_and_reward_scale(train_cfg):
    plan = validate_train_cfg(train_cfg("train.total_frames=330"))
    assert (plan.n_updates, plan.total_frames, plan.rollout_steps) == (4, 320, 10)
    assert plan.minibatches_per_epoch == 2 and plan.frames_per_episode == 4 * 20
    env = _env(train_config(train_cfg()), plan)
    base = env.base_env
    scale = auto_reward_scale(base, 0.99)
    # (1 - gamma) / (v_s T_u), flow units: v_s = 0.707 u_rms, T_u = 0.1 tau_K
    assert scale == pytest.approx(0.01 / (0.707 * base.flow.u_rms * 0.1 * base.flow.tau_k))
    td = env.rollout(3, break_when_any_done=False)
    d = torch.cat(
        [torch.zeros_like(td["next", "distance"][..., :1, :]), td["next", "distance"]], -2
    )
    assert torch.allclose(td["next", "reward"], scale * d.diff(dim=-2), atol=1e-6)


def _snapshot(trainer: PPOTrainer) -> dict:
    return {
        "actor": copy.deepcopy(trainer.actor.state_dict()),
        "critic": copy.deepcopy(trainer.critic.state_dict()),
        "optim": [copy.deepcopy(o.state_dict()) for o in trainer.optimizers],
        "sched": [copy.deepcopy(s.state_dict()) for s in trainer.schedulers],
        "counters": dict(trainer.counters),
        "torch_rng": torch.get_rng_state().clone(),
        "env_rng": trainer.swimmer_env.generator.get_state().clone(),
    }


def _assert_same(a, b) -> None:
    if isinstance(a, torch.Tensor):
        assert torch.equal(a, b)
    elif isinstance(a, dict):
        assert a.keys() == b.keys()
        for k in a:
            _assert_same(a[k], b[k])
    elif isinstance(a, list | tuple):
        assert len(a) == len(b)
        for x, y in zip(a, b, strict=True):
            _assert_same(x, y)
    else:
        assert a == b


def test_kill_and_resume_round_trip(train_cfg, tmp_path, monkeypatch):
    """A crash after update 3 (checkpoint of update 2 kept, stray .tmp left as by kill -9)
    resumes from update 2 with identical state and finishes the remaining updates."""
    saved = {}
    original_save, original_update = PPOTrainer.save_checkpoint, PPOTrainer.update

    def spy_save(self):
        path = original_save(self)
        saved[self.counters["updates"]] = _snapshot(self)
        return path

    def crashing_update(self, data):
        if self.counters["updates"] == 2:
            self.run.checkpoint.with_suffix(".pt.tmp").write_bytes(b"partial")
            raise KeyboardInterrupt("simulated kill")
        return original_update(self, data)

    monkeypatch.setattr(PPOTrainer, "save_checkpoint", spy_save)
    monkeypatch.setattr(PPOTrainer, "update", crashing_update)
    with pytest.raises(KeyboardInterrupt):
        train(train_cfg(), tmp_path)
    assert sorted(saved) == [1, 2] and not (tmp_path / "metrics.json").exists()
    assert load_file(RunLayout(tmp_path).checkpoint)["counters"]["updates"] == 2
    monkeypatch.setattr(PPOTrainer, "update", original_update)

    # a new run in a dir with a checkpoint needs resume=true; the config must match
    with pytest.raises(FileExistsError, match="resume=true"):
        train(train_cfg(), tmp_path)
    with pytest.raises(ConfigError, match="loss.gamma"):
        train(train_cfg("resume=true", "loss.gamma=0.9"), tmp_path)

    # restore reproduces the state at the checkpoint exactly
    cfg = train_cfg("resume=true")
    c = train_config(cfg)
    trainer = PPOTrainer(c, make_plan(c), tmp_path)
    trainer.restore(RunLayout(tmp_path).checkpoint)
    _assert_same(_snapshot(trainer), saved[2])

    # resuming continues at update 3, never redoes 1-2, and finishes
    saved.clear()
    metrics = train(cfg, tmp_path)
    assert sorted(saved) == [3, 4]
    assert metrics["training"]["updates"] == 4 and metrics["training"]["frames"] == 320
    steps = [s for s, _ in scalars(tmp_path)["train/loss_objective"]]
    assert sorted(set(steps)) == [80, 160, 240, 320]
    assert saved[4]["sched"][0]["last_epoch"] == 4

    # a finished run is never silently overwritten; resume=true on it does nothing
    before = (tmp_path / "metrics.json").read_text()
    with pytest.raises(FileExistsError, match="overwrite=true"):
        train(train_cfg(), tmp_path)
    assert train(train_cfg("resume=true"), tmp_path) is None
    assert (tmp_path / "metrics.json").read_text() == before


def test_constant_rate_run_extended_to_a_larger_budget(train_cfg, tmp_path):
    """A finished constant-rate run, copied without its results and resumed with twice the
    budget, ends with the weights of the longer run stopped at the same update and resumed
    (nothing in a constant-rate run depends on its budget); with linear rates (whose schedule
    depends on the budget), or a smaller budget, the change is refused."""
    import shutil

    short, extended, straight = tmp_path / "short", tmp_path / "extended", tmp_path / "straight"
    train(train_cfg("optim.anneal=none", "train.total_frames=160", "train.eval_every=0"), short)
    shutil.copytree(short, extended)
    for name in ("metrics.json", "policy.pt"):
        (extended / name).unlink()
    longer = train_cfg("optim.anneal=none", "train.total_frames=320", "train.eval_every=0",
                       "resume=true")
    m = train(longer, extended)
    assert m["training"]["updates"] == 4 and m["training"]["frames"] == 320
    stopped = train_cfg("optim.anneal=none", "train.total_frames=320", "train.eval_every=0",
                        "train.stop_after_updates=2")
    assert train(stopped, straight) is None
    train(longer, straight)
    a, b = (load_file(RunLayout(d).checkpoint) for d in (extended, straight))
    _assert_same(a["actor"], b["actor"])
    _assert_same(a["critic"], b["critic"])
    # a shorter budget, or a linear schedule, is a different training trajectory
    linear = tmp_path / "linear"
    train(train_cfg("optim.anneal=linear", "train.total_frames=160", "train.eval_every=0"),
          linear)
    (linear / "metrics.json").unlink()
    with pytest.raises(ConfigError, match="train.total_frames: 160 -> 320"):
        train(train_cfg("optim.anneal=linear", "train.total_frames=320", "resume=true"), linear)
    (extended / "metrics.json").unlink()
    with pytest.raises(ConfigError, match="train.total_frames: 320 -> 160"):
        train(train_cfg("optim.anneal=none", "train.total_frames=160", "resume=true"), extended)


def test_stop_after_updates_then_resume(train_cfg, tmp_path):
    import shutil

    from swimrl.runs.curves import read_curves_csv

    assert train(train_cfg("train.stop_after_updates=3", "train.eval_every=0"), tmp_path) is None
    assert load_file(RunLayout(tmp_path).checkpoint)["counters"]["updates"] == 3
    first = read_curves_csv(tmp_path / "curves.csv")
    assert sorted(first) == [80, 160, 240]
    # resumed from its committed record (checkpoint + curves.csv, the event files gone): the
    # curve keeps the rows before the checkpoint
    shutil.rmtree(tmp_path / "tb")
    m = train(train_cfg("resume=true", "train.eval_every=0"), tmp_path)
    assert m["training"]["updates"] == 4
    rows = read_curves_csv(tmp_path / "curves.csv")
    assert sorted(rows) == [80, 160, 240, 320]
    assert all(rows[s] == first[s] for s in (80, 160, 240))
    # overwrite: a shorter run leaves none of the old run's records behind
    (tmp_path / "comparison.json").write_text("{}")
    again = train(train_cfg("overwrite=true", "train.eval_every=0", "train.total_frames=160"),
                  tmp_path)
    assert again["training"]["updates"] == 2
    assert sorted(read_curves_csv(tmp_path / "curves.csv")) == [80, 160]
    assert not (tmp_path / "comparison.json").exists()


def test_training_and_evaluation_flows_differ(train_cfg):
    from swimrl.evaluation.rollout import chunk_seed

    plan = validate_train_cfg(train_cfg("seed=3"))
    assert plan.eval_seed == 3 + EVAL_SEED_OFFSET
    eval_seeds = {chunk_seed(s, c) for s in (0, 1, 2, 3, plan.eval_seed) for c in range(100)}
    assert plan.train_seed not in eval_seeds


def _cli(args, cwd, timeout=240):
    cmd = [sys.executable, "-m", "swimrl.cli.train", *args]
    return subprocess.run(cmd, capture_output=True, text=True, cwd=cwd, timeout=timeout)


@pytest.mark.slow  # a two-job Hydra sweep with the joblib launcher, in subprocesses (~35 s)
def test_cli_multirun_joblib(tmp_path):
    sweep = tmp_path / "sweep"
    out = _cli(
        [
            "-m",
            *TINY,
            "train.eval_every=0",
            "seed=0,1",
            "hydra/launcher=joblib",
            "hydra.launcher.n_jobs=2",
            f"hydra.sweep.dir={sweep}",
        ],
        tmp_path,
    )
    assert out.returncode == 0, out.stderr[-3000:]
    runs = sorted(p.parent.name for p in sweep.rglob("metrics.json"))
    assert runs == ["0", "1"]
    seeds = {json.loads((sweep / r / "metrics.json").read_text())["config"]["seed"] for r in runs}
    assert seeds == {0, 1}
    table = subprocess.run(
        [sys.executable, "-m", "swimrl.cli.table", str(sweep), "--csv", str(tmp_path / "t.csv")],
        capture_output=True,
        text=True,
    )
    assert table.returncode == 0, table.stderr
    assert table.stdout.startswith("| run | seed | strategy |")
    assert (tmp_path / "t.csv").read_text().startswith("run,seed,strategy,R_hat_mean")


@pytest.mark.slow  # a two-job Hydra sweep with the submitit_local launcher (~30 s)
def test_cli_multirun_submitit_local(tmp_path):
    sweep = tmp_path / "sweep"
    out = _cli(
        [
            "-m",
            *TINY,
            "train.eval_every=0",
            "flow.kubo=1,10",
            "hydra/launcher=submitit_local",
            "hydra.launcher.timeout_min=5",
            f"hydra.sweep.dir={sweep}",
        ],
        tmp_path,
        timeout=400,
    )
    assert out.returncode == 0, out.stderr[-3000:]
    kubo = sorted(
        json.loads(p.read_text())["config"]["flow"]["kubo"] for p in sweep.rglob("metrics.json")
    )
    assert kubo == [1, 10]


def test_slurm_launcher_preset_composes():
    from hydra import compose, initialize_config_module

    with initialize_config_module("swimrl.conf", version_base="1.3"):
        cfg = compose(
            "train",
            overrides=["hydra/launcher=slurm", "train_preset=paper"],
            return_hydra_config=True,
        )
    launcher = cfg.hydra.launcher
    assert launcher._target_.endswith("SlurmLauncher")
    assert launcher.cpus_per_task == 1 and launcher.max_num_timeout >= 1
    assert cfg.train.total_frames == 5000 * 10 * 2000  # paper: 5000 episodes of 10 swimmers
    assert (cfg.optim.lr_actor, cfg.optim.lr_critic) == (4e-4, 8e-5)
    plan = validate_train_cfg(cfg)
    assert plan.n_updates == 20000 and plan.gradient_steps_per_update == 800


def test_bigbatch_preset_extends_default():
    """``train_preset=bigbatch``: the default sizes, loss and learning rates, annealed."""
    from hydra import compose, initialize_config_module

    with initialize_config_module("swimrl.conf", version_base="1.3"):
        default = compose("train")
        big = compose("train", overrides=["train_preset=bigbatch", "train.total_frames=1e7"])
    assert (big.train.n_flows, big.train.n_swimmers) == (64, 8)
    assert (big.optim.anneal, default.optim.anneal) == ("linear", "none")
    assert big.train.rollout_length == 100 and big.train.minibatch_size == 2560
    for key in ("optim.lr_actor", "optim.lr_critic", "loss.entropy_coeff", "loss.gae_lambda"):
        sect, k = key.split(".")
        assert big[sect][k] == default[sect][k], key
    plan = validate_train_cfg(big)
    assert plan.n_updates == 10_000_000 // 51200 and plan.gradient_steps_per_update == 80


def test_long_floor_preset_is_long_with_a_sigma_bound():
    """``train_preset=long_floor`` (``long_floor05``): ``long`` (1e8 frames, linear decay) with
    ``sigma >= 0.3`` (``0.5``)."""
    from hydra import compose, initialize_config_module

    with initialize_config_module("swimrl.conf", version_base="1.3"):
        long = compose("train", overrides=["train_preset=long"])
        floor = compose("train", overrides=["train_preset=long_floor"])
    assert floor.model.min_std == 0.3 and long.model.min_std == 1e-4
    assert train_config(floor).model.min_std == 0.3
    floor.model.min_std = long.model.min_std
    assert floor == long
    with initialize_config_module("swimrl.conf", version_base="1.3"):
        floor05 = compose("train", overrides=["train_preset=long_floor05"])
    assert floor05.model.min_std == 0.5 and train_config(floor05).model.min_std == 0.5
    floor05.model.min_std = long.model.min_std
    assert floor05 == long


def test_critic3d_preset_is_the_ablations_asymmetric_critic_arm():
    """``train_preset=critic3d`` composes exactly the overrides the learner ablation's
    asymmetric-critic runs used on ``wide3d`` (continued to 1e8 frames), so its records are
    the preset's; a signals set on the command line still wins."""
    from hydra import compose, initialize_config_module

    arm = ["train_preset=wide3d", "signals=rule_terms", "model.min_std=0.2",
           "optim.anneal=none", "train.critic_flow=true", "train.total_frames=100000000",
           "train.eval_every=61"]
    base = ["flow=stochastic3d", "flow.kubo=10"]
    with initialize_config_module("swimrl.conf", version_base="1.3"):
        preset = compose("train", overrides=[*base, "train_preset=critic3d"])
        ablation = compose("train", overrides=base + arm)
        wide3d = compose("train", overrides=[*base, "train_preset=wide3d"])
        other = compose("train", overrides=[*base, "train_preset=critic3d", "signals=all"])
    assert preset == ablation and preset != wide3d
    assert train_config(preset).record == train_config(ablation).record
    assert train_config(preset).train.critic_flow and not train_config(wide3d).train.critic_flow
    assert train_config(other).spec.params.signals != train_config(preset).spec.params.signals
    assert validate_train_cfg(preset).n_updates == 1525


@pytest.mark.slow  # two DNS runs, then PPO on one, evaluated on the other (~11-17 s)
def test_training_in_a_stored_dns_run(compose_cfg, tmp_path):
    """``swimrl-train flow=dns_replay``: PPO on a (tiny) stored DNS run, swimmers in its units,
    flows sharing starts; evaluated on another run that training never saw (``eval_flow``)."""
    from hydra import compose, initialize_config_module

    from swimrl.config import dns_run
    from swimrl.flows.dns.run import run_dns
    from swimrl.flows.dns.sources import DNSStore

    stores = {seed: tmp_path / f"run{seed}.zarr" for seed in (0, 1)}
    for seed, store in stores.items():
        with initialize_config_module("swimrl.conf", version_base="1.3"):
            dns_cfg = compose(config_name="dns", overrides=[
                "dns.n=32", "dns.nu=5e-3", "dns.dt=4e-3", "spinup.time=0.2",
                "spinup.measure_time=0.1", "store.n_times=40", "store.diag_every=5",
                "progress=false", "threads=1", f"seed={seed}", f"store.path={store}"])
        run_dns(dns_run(dns_cfg))
    s = DNSStore(stores[0])
    tiny = [o for o in TINY if not o.startswith("flow.")]
    cfg = compose_cfg(tiny + ["flow=dns_replay", f"flow.path={stores[0]}", "train.eval_every=0",
                              "flow.flows_per_start=2", f"+eval_flow.path=[{stores[1]}]"],
                      name="train")
    tc = train_config(cfg)
    assert tc.spec.flow.paths == (stores[0],) and tc.held_out.flow.paths == (stores[1],)
    metrics = train(cfg, tmp_path / "run")
    assert math.isfinite(metrics["R_hat_mean"]) and metrics["training"]["frames"] == 320
    assert metrics["flow_stats"]["u_rms"] > 0 and s.n_times == 40
    assert metrics["config"]["flow"]["name"] == "dns_replay"
    assert metrics["flow_store"]["path"] == str(stores[1].resolve())  # the held-out run
    with pytest.raises(ConfigError, match="eval_flow key"):
        train_config(compose_cfg(tiny + ["flow=dns_replay", f"flow.path={stores[0]}",
                                         "+eval_flow.bogus=1"], name="train"))


def test_resume_a_checkpoint_written_before_the_key_renames(compose_cfg, tmp_path):
    """``checkpoints/last.pt`` of a run stopped after update 2 by the code before the config
    keys were renamed (``episode.shape_factor_max`` then): resuming it with the same settings
    finishes the run with the held-out R_hat that code reached, to float32 round-off (since
    then the flow redraw sums over the retained modes instead of full FFTs: the same draws,
    fields equal to a few float32 ulps, tests/test_flow_stochastic.py)."""
    data = Path(__file__).parent / "data" / "legacy_checkpoint"
    expected = json.loads((data / "expected.json").read_text())
    assert load_file(data / "last.pt")["config"]["episode"]["shape_factor_max"] == 0.95
    # the keys renamed since: episode.shape_factor_max, and train.frames_per_batch = F S L
    # stated as train.rollout_length = L (2 flows x 4 swimmers x 10 decisions)
    overrides = [o.replace("episode.shape_factor_max", "swimmer.shape_factor_max")
                 .replace("train.frames_per_batch=80", "train.rollout_length=10")
                 for o in expected["overrides"]]
    overrides += ["optim.anneal=linear", "train.compile=false"]  # that code's defaults
    RunLayout(tmp_path).checkpoint.parent.mkdir(parents=True)
    shutil.copy(data / "last.pt", RunLayout(tmp_path).checkpoint)
    with pytest.raises(ConfigError, match="swimmer.shape_factor_max"):
        train(compose_cfg([*overrides, "resume=true", "swimmer.shape_factor_max=0.9"],
                          name="train"), tmp_path)
    metrics = train(compose_cfg([*overrides, "resume=true"], name="train"), tmp_path)
    assert metrics["training"]["updates"] == 4
    assert metrics["per_flow"] == pytest.approx(expected["per_flow"], rel=1e-5, abs=0)


def _one_minibatch(trainer: PPOTrainer):
    """A fixed minibatch: one collected batch of the trainer's env, with GAE."""
    from swimrl.rl.builders import make_collector

    t = trainer.cfg.train
    collector = make_collector(trainer.env, trainer.actor, t, t.frames_per_batch, "cpu")
    data = next(iter(collector))
    collector.shutdown()
    with torch.no_grad():
        data = trainer.gae(data)
    return data.select(*trainer._loss_keys(data), strict=False).reshape(-1)[:40]


def _loss_and_grads(trainer: PPOTrainer, fn, batch):
    for p in [*trainer.actor.parameters(), *trainer.critic.parameters()]:
        p.grad = None
    out = fn(batch)
    grads = [p.grad.clone() for p in [*trainer.actor.parameters(), *trainer.critic.parameters()]]
    return out, grads


@pytest.mark.parametrize(
    "entropy_coeff", [0.0, pytest.param(0.005, marks=pytest.mark.slow)])  # 0.005: ~20 s
def test_compiled_update_matches_eager(train_cfg, tmp_path, entropy_coeff):
    """``train.compile=true`` (torch.compile of loss + backward) gives the eager loss terms
    and gradients on a fixed minibatch, to float32 round-off."""
    c = train_config(train_cfg("train.compile=true", f"loss.entropy_coeff={entropy_coeff}"))
    trainer = PPOTrainer(c, make_plan(c), tmp_path)
    batch = _one_minibatch(trainer)
    compiled = trainer._compiled_loss_backward()
    assert compiled is not trainer._loss_backward  # the compiled path is taken
    if entropy_coeff > 0:  # the entropy's reparameterised sample: same RNG state for both
        torch.manual_seed(7)
    eager_out, eager_grads = _loss_and_grads(trainer, trainer._loss_backward, batch)
    if entropy_coeff > 0:
        torch.manual_seed(7)
    comp_out, comp_grads = _loss_and_grads(trainer, compiled, batch)
    keys = ["loss_objective", "loss_critic"] + (["loss_entropy"] if entropy_coeff else [])
    assert ("loss_entropy" in eager_out.keys(include_nested=False)) == (entropy_coeff > 0)
    for k in keys:
        torch.testing.assert_close(comp_out[k], eager_out[k], rtol=1e-5, atol=1e-6)
    for g_c, g_e in zip(comp_grads, eager_grads, strict=True):
        torch.testing.assert_close(g_c, g_e, rtol=1e-4, atol=1e-6)
    assert any(bool(g.abs().sum() > 0) for g in eager_grads)


def test_resumed_run_continues_compiled(train_cfg, tmp_path, monkeypatch):
    """A run stopped and resumed with ``train.compile=true`` trains the resumed updates
    through the compiled loss (and finishes)."""
    opts = ("train.compile=true", "train.eval_every=0")
    assert train(train_cfg("train.stop_after_updates=2", *opts), tmp_path) is None
    used = []
    original = PPOTrainer._compiled_loss_backward

    def spy(self):
        fn = original(self)
        used.append(fn is not self._loss_backward)
        return fn

    monkeypatch.setattr(PPOTrainer, "_compiled_loss_backward", spy)
    m = train(train_cfg("resume=true", *opts), tmp_path)
    assert m["training"]["updates"] == 4 and used == [True]  # built once, on the first update


def test_update_takes_the_minibatches_of_a_fresh_permutation_per_epoch(train_cfg, tmp_path):
    """``PPOTrainer.update`` equals the textbook loop (per epoch a fresh ``randperm``,
    minibatch k = the samples ``perm[k mb : (k + 1) mb]``, one loss + backward, clipping and
    an Adam step each): the same parameters after two updates, bit for bit."""
    from swimrl.rl.builders import make_collector

    c = train_config(train_cfg("train.compile=false"))
    fast = PPOTrainer(c, make_plan(c), tmp_path / "a")
    ref = PPOTrainer(c, make_plan(c), tmp_path / "b")
    collector = make_collector(fast.env, fast.actor, c.train, 2 * c.train.frames_per_batch, "cpu")
    batches = [b.clone() for b in collector]
    collector.shutdown()

    def reference_update(t: PPOTrainer, data) -> None:
        with torch.no_grad():
            data = t.gae(data)
        flat = data.select(*t._loss_keys(data), strict=False).reshape(-1)
        mb = c.train.minibatch_size
        for _ in range(c.train.epochs):
            perm = torch.randperm(flat.numel())
            for k in range(t.plan.minibatches_per_epoch):
                t._loss_backward(flat[perm[k * mb : (k + 1) * mb]])
                for net in (t.actor, t.critic):
                    torch.nn.utils.clip_grad_norm_(list(net.parameters()),
                                                   float(c.optim.max_grad_norm))
                for opt in t.optimizers:
                    opt.step()
                    opt.zero_grad(set_to_none=True)
        for sch in t.schedulers:
            sch.step()

    for i, data in enumerate(batches):
        torch.manual_seed(100 + i)
        stats = fast.update(data.clone())
        torch.manual_seed(100 + i)
        reference_update(ref, data.clone())
        assert all(torch.isfinite(v) for v in stats.values())
    for net_a, net_b in ((fast.actor, ref.actor), (fast.critic, ref.critic)):
        for p_a, p_b in zip(net_a.parameters(), net_b.parameters(), strict=True):
            assert torch.equal(p_a, p_b)
    assert any(not torch.equal(p, q) for p, q in
               zip(fast.actor.parameters(),
                   PPOTrainer(c, make_plan(c), tmp_path / "c").actor.parameters(), strict=True))


def _params_after_updates(c, run_dir, batches) -> list[torch.Tensor]:
    """Actor and critic parameters after one :meth:`PPOTrainer.update` per batch (the
    minibatch order seeded per update)."""
    device = c.runtime.device
    t = PPOTrainer(c, make_plan(c), run_dir)
    for i, data in enumerate(batches):
        torch.manual_seed(100 + i)
        stats = t.update(data.clone().to(device))
        assert all(torch.isfinite(v) for v in stats.values())
    return [p.detach().cpu().clone() for p in (*t.actor.parameters(), *t.critic.parameters())]


def _batches(c, tmp_path, n: int = 3) -> list:
    from swimrl.rl.builders import make_collector

    t = PPOTrainer(c, make_plan(c), tmp_path / "collect")
    collector = make_collector(t.env, t.actor, c.train, n * c.train.frames_per_batch,
                               c.runtime.device)
    batches = [b.clone() for b in collector]
    collector.shutdown()
    return batches


def test_compiled_updates_give_the_eager_parameters(train_cfg, tmp_path):
    """``train.compile=true`` (the CPU path): the parameters after three whole updates (GAE,
    4 epochs of minibatch steps, clipping, Adam) equal the eager ones to float32 round-off,
    and the updates moved them."""
    eager = train_config(train_cfg("train.compile=false"))
    batches = _batches(eager, tmp_path)
    ref = _params_after_updates(eager, tmp_path / "eager", batches)
    comp = _params_after_updates(train_config(train_cfg("train.compile=true")),
                                 tmp_path / "compiled", batches)
    init = _params_after_updates(eager, tmp_path / "init", [])
    for p_c, p_e in zip(comp, ref, strict=True):
        torch.testing.assert_close(p_c, p_e, rtol=1e-4, atol=1e-5)
    assert max(float((p - q).abs().max()) for p, q in zip(ref, init, strict=True)) > 1e-3


@pytest.mark.gpu
@pytest.mark.parametrize("compile_", ["false", "true"])
def test_cuda_graphed_updates_give_the_eager_parameters(train_cfg, tmp_path, compile_):
    """``train.cudagraphs=true`` on CUDA (the whole gradient step and the GAE captured in CUDA
    graphs, optionally compiled): the parameters after six updates (past the graphs' warm-up
    steps) equal those of the eager CUDA update to float32 round-off."""
    opts = ("device=cuda", "kernel=eager")
    eager = train_config(train_cfg("train.compile=false", *opts))
    batches = _batches(eager, tmp_path, n=6)
    ref = _params_after_updates(eager, tmp_path / "eager", batches)
    graphed = train_config(train_cfg(f"train.compile={compile_}", "train.cudagraphs=true", *opts))
    got = _params_after_updates(graphed, tmp_path / "graphed", batches)
    for p_g, p_e in zip(got, ref, strict=True):
        torch.testing.assert_close(p_g, p_e, rtol=1e-4, atol=1e-5)


def test_cudagraphs_on_the_cpu_is_refused(train_cfg):
    """``train.cudagraphs=true`` with ``device=cpu``: one line naming the key, before compute."""
    with pytest.raises(ConfigError, match=r"train\.cudagraphs=True.*device=cpu"):
        train_config(train_cfg("train.cudagraphs=true"))


def _parallel(compose_cfg, *overrides):
    """``train_preset=parallel`` at its own sizes, on the test's small grid and episode."""
    return compose_cfg(SMALL + ["train_preset=parallel", "train.progress=false",
                                "train.eval_flows=1", "train.eval_swimmers=4",
                                "eval.n_flows=1", "eval.n_swimmers=8", *overrides],
                       name="train")


def test_parallel_preset_is_long_floor05_with_the_swimmer_parallel_layout():
    """``train_preset=parallel``: long_floor05 (budget, decay, sigma bound, loss) with 64 x 64
    swimmers per env step, rollouts of 16, minibatches of 8192 and sqrt-scaled rates."""
    from hydra import compose, initialize_config_module

    with initialize_config_module("swimrl.conf", version_base="1.3"):
        par = compose("train", overrides=["train_preset=parallel"])
        ref = compose("train", overrides=["train_preset=long_floor05"])
    c = train_config(par)
    plan = make_plan(c)
    assert c.train.n_flows * c.train.n_swimmers == 4096 and plan.rollout_steps == 16
    assert plan.gradient_steps_per_update == 32 and c.train.epochs == 4
    assert (plan.lr_actor, plan.lr_critic) == pytest.approx(
        (3e-3 * math.sqrt(8192 / 2560), 1e-3 * math.sqrt(8192 / 2560)), rel=1e-12)
    assert c.train.frames_per_batch == 64 * 64 * 16
    for key in ("n_flows", "n_swimmers", "rollout_length", "minibatch_size", "eval_every"):
        par.train[key] = ref.train[key]
    par.optim.lr_scale = ref.optim.lr_scale
    assert par == ref


def test_parallel_layout_env_specs(compose_cfg):
    """The layout's training env (4096 swimmers in 64 flows) passes TorchRL's spec check."""
    from torchrl.envs.utils import check_env_specs

    c = train_config(_parallel(compose_cfg))
    env = _env(c, make_plan(c))
    assert tuple(env.batch_size) == (64, 64)
    check_env_specs(env)


@pytest.mark.slow  # two compiled updates at the parallel layout's own sizes (~28 s)
def test_parallel_layout_two_updates_then_resume(compose_cfg, tmp_path):
    """Smoke run of the layout on the CPU (its sizes, compiled loss): one update, stopped;
    ``resume=true`` continues it with the second update of the same layout and finishes."""
    opts = ("train.total_frames=131072", "train.eval_every=1")
    assert train(_parallel(compose_cfg, "train.stop_after_updates=1", *opts), tmp_path) is None
    ck = load_file(RunLayout(tmp_path).checkpoint)
    assert ck["counters"]["updates"] == 1 and ck["config"]["train"]["n_swimmers"] == 64
    m = train(_parallel(compose_cfg, "resume=true", *opts), tmp_path)
    assert m["training"]["updates"] == 2 and m["training"]["frames"] == 131072
    curve = scalars(tmp_path)["eval/R_hat"]
    assert [step for step, _ in curve] == [0, 65536, 131072]


def test_a_checkpoint_config_from_before_rollout_length_upgrades_to_the_same_batch():
    """A stored config with ``train.frames_per_batch`` (the input before
    ``train.rollout_length``) and without ``optim.lr_scale`` upgrades to today's keys with the
    same batch and the rates as they were given; composing it again gives the same plan."""
    from hydra import compose, initialize_config_module
    from omegaconf import OmegaConf

    from swimrl.runs.checkpoint import upgrade_config

    with initialize_config_module("swimrl.conf", version_base="1.3"):
        now = OmegaConf.to_container(compose("train", overrides=["train_preset=parallel"]),
                                     resolve=True)
    old = copy.deepcopy(now)
    old["train"]["frames_per_batch"] = old["train"].pop("rollout_length") * 64 * 64
    old["optim"] = {k: v for k, v in old["optim"].items()
                    if k not in ("lr_scale", "lr_reference_minibatch")}
    old["optim"].update(lr_actor=5.4e-3, lr_critic=1.8e-3)
    new = upgrade_config(old)
    assert new["train"] == now["train"]
    assert (new["optim"]["lr_scale"], new["optim"]["lr_actor"]) == ("none", 5.4e-3)
    tc = train_config(OmegaConf.create(new))
    plan = make_plan(tc)
    assert (tc.train.frames_per_batch, plan.rollout_steps) == (65536, 16)
    assert (plan.lr_actor, plan.lr_critic) == (5.4e-3, 1.8e-3)


def test_a_policy_that_senses_its_shape_trains_and_evaluates(train_cfg, tmp_path, compose_cfg):
    """``signals=all_shape`` (the five signals and the shape held) with the shape-change cost:
    training writes a six-input policy, and ``swimrl-eval`` rebuilds its observation."""
    out = tmp_path / "run"
    train(train_cfg("signals=all_shape", "reward.shape_change_weight=1"), out)
    assert load_file(out / "policy.pt")["signals"] == ["n_r", "n_theta", "S_nn", "S_np",
                                                        "omega", "Lambda"]
    c = eval_config(compose_cfg(SMALL + ["strategy=policy", f"policy={out}", "eval.n_flows=1",
                                         "eval.n_swimmers=4", "signals=all_shape"]))
    m = evaluate(c.setup, actor_for(c.strategy, c.policy, c.setup.params), "policy")
    assert m["shape_change_mean"] >= 0 and math.isfinite(m["R_hat_mean"])


def test_a_3d_policy_trains_and_evaluates_on_the_invariant_signals(compose_cfg, tmp_path):
    """``signals=all_invariant`` in 3D: the seven signals and the derived lever and torque are
    observed in training, saved with the policy and read back by its evaluation."""
    over = ["flow=stochastic3d", "flow.kubo=10", "signals=all_invariant"]
    tiny = [o for o in TINY if not o.startswith("flow.")]
    cfg = compose_cfg(tiny + over, name="train")
    metrics = train(cfg, tmp_path)
    assert math.isfinite(metrics["R_hat_mean"])
    policy = torch.load(tmp_path / "policy.pt", map_location="cpu", weights_only=False)
    assert policy["signals"] == ["n_r", "S_nn", "S_np1", "S_np2", "omega_n", "omega_p1",
                                 "omega_p2", "lever", "torque"]
    assert policy["model"]["n_obs"] == 9
    ev = eval_config(compose_cfg([*over, "strategy=policy", f"policy={tmp_path}",
                                  "episode.duration=2.0", "eval.n_flows=2",
                                  "eval.n_swimmers=4", "eval.progress=false", "threads=1"]))
    out = evaluate(ev.setup, actor_for(ev.strategy, ev.policy, ev.setup.params), "policy")
    assert math.isfinite(out["R_hat_mean"])


@pytest.mark.parametrize("flow, first", [("flow=stochastic", ["n_r", "n_theta"]),
                                         ("flow=stochastic3d", ["n_r", "S_nn"])])
def test_rule_terms_signal_set_adds_the_rules_terms(compose_cfg, flow, first):
    """``signals=rule_terms``: the flow's signals, ``lever``, ``torque`` and the optimised
    rule's two terms, which an env of either dimension observes."""
    cfg = compose_cfg([flow, "signals=rule_terms"], name="train")
    names = list(cfg.signals.names)
    assert names[:2] == first and names[-4:] == ["lever", "torque", "sto_term", "stab_term"]
    from swimrl.physics.body import body, observable_names
    dim = 3 if "3d" in flow else 2
    assert set(names) <= set(observable_names(body(dim)))


def test_asymmetric_critic_reads_the_flow_and_the_actor_does_not(train_cfg, tmp_path):
    """``train.critic_flow=true``: the critic's input is the observation and (u_r, u_perp)/v_s
    (two more), the actor's the observation alone; the run trains, resumes and writes a
    policy file that evaluates like any other."""
    cfg = train_cfg("train.critic_flow=true", "train.eval_every=0", "train.stop_after_updates=2")
    assert train(cfg, tmp_path) is None
    trainer = PPOTrainer(train_config(cfg), make_plan(train_config(cfg)), tmp_path / "other")
    n_obs = trainer.env.observation_spec["observation"].shape[-1]
    assert list(trainer.critic.in_keys) == ["critic_observation"]
    assert trainer.critic.module[0].in_features == n_obs + 2
    assert list(trainer.actor.in_keys) == ["observation"]
    trainer.close()
    metrics = train(train_cfg("train.critic_flow=true", "train.eval_every=0", "resume=true"),
                    tmp_path)
    assert metrics["training"]["updates"] == 4 and math.isfinite(metrics["R_hat_mean"])
    assert load_file(tmp_path / "policy.pt")["actor"]
