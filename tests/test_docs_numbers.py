"""Numbers on the results and beyond-the-paper pages against the committed records they cite.

Each check recomputes a quoted number or table row from the JSON records under
``docs/results/`` (the ``comparison.json`` of ``swimrl-compare``, the runs' ``metrics.json``),
rounds it as the page prints it, and asserts that the page says exactly that. The pages are
compared with their whitespace collapsed (a sentence may wrap) and without the ``**`` of bold
cells. A number changed on a page, or a record rerun with other results, fails here until the
two agree again. JSON only; well under a second.
"""

from __future__ import annotations

import json
import re
from functools import cache
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
RESULTS = DOCS / "results"
BEYOND = RESULTS / "beyond"
MINUS = "\u2212"


@cache
def page(name: str) -> str:
    """A page's text, whitespace collapsed and bold markers removed."""
    text = (ROOT / name).read_text(encoding="utf-8").replace("**", "")
    return " ".join(text.split())


@cache
def record(rel: str) -> dict:
    return json.loads((RESULTS / rel).read_text(encoding="utf-8"))


def rows(rel: str) -> dict[str, dict]:
    return {r["label"]: r for r in record(rel)["rows"]}


def span(values, fmt: str = ".3f", sep: str = "-") -> str:
    """``lo-hi`` as printed (one value if both round alike)."""
    lo, hi = format(min(values), fmt), format(max(values), fmt)
    return lo if lo == hi else f"{lo}{sep}{hi}"


def signed(x: float, fmt: str = ".2f") -> str:
    return format(x, "+" + fmt).replace("-", MINUS)


def paired_sem(a, b) -> tuple[float, float]:
    """Mean and SEM over flows of the per-flow difference ``a - b``."""
    d = np.asarray(a, float) - np.asarray(b, float)
    return float(d.mean()), float(d.std(ddof=1) / np.sqrt(d.size))


def paired_cell(a, b) -> str:
    """``<a - b> ± SEM`` over flows as a table cell: signed, three decimals, a true minus."""
    mean, sem = paired_sem(a, b)
    return f"{signed(mean, '.3f')} ± {sem:.3f}"


# -- point-to-point navigation (docs/beyond/target.md) -----------------------------------------
TARGET = "docs/beyond/target.md"
KUS = {"10": "10", "1e7": "1e7"}


def target(ku: str, dist: int) -> dict[str, dict]:
    return rows(f"beyond/target/ku{ku}_D{dist}/comparison.json")


def kind(label: str) -> str:
    if label == "sto":
        return "sto"
    if label.startswith("naive"):
        return "naive"
    if "pretrained/" in label:
        return "displacement"
    return "warm" if "_warm_" in label else "trained"


def of_kind(r: dict[str, dict], k: str) -> list[dict]:
    return [row for label, row in r.items() if kind(label) == k]


def half(row: dict) -> float | None:
    return row["arrival_time_half"]


def times(rs: list[dict]) -> str:
    """The table's ``t½ / RMST`` cell of one or several rows."""
    halves = [half(r) for r in rs]
    h = "—" if any(x is None for x in halves) else span(halves, ".0f")
    return f"{h} / {span([r['arrival_time_rmst_mean'] for r in rs], '.0f')}"


def target_row(ku: str, dist: int) -> str:
    r = target(ku, dist)
    sto, disp = of_kind(r, "sto")[0], of_kind(r, "displacement")[0]
    best = max(of_kind(r, "naive"), key=lambda x: x["arrival_mean"])
    shape = f"{float(best['label'][6:-1]):g}"
    cells = [f"{ku}, {dist}",
             f"{sto['arrival_mean']:.3f} ± {sto['arrival_sem']:.3f} ({times([sto])})",
             f"{best['arrival_mean']:.3f} ± {best['arrival_sem']:.3f} (Λ = {shape})",
             f"{disp['arrival_mean']:.3f} ± {disp['arrival_sem']:.3f} ({times([disp])})"]
    for k in ("trained", "warm"):
        rs = of_kind(r, k)
        cells.append(" / ".join(f"{x['arrival_mean']:.3f}" for x in rs) + f" ({times(rs)})")
    return "| " + " | ".join(cells) + " |"


@pytest.mark.parametrize("ku", list(KUS))
@pytest.mark.parametrize("dist", [10, 20, 40])
def test_target_table_rows_are_the_records(ku, dist):
    assert target_row(ku, dist) in page(TARGET)


def policies(ku: str, dist: int) -> list[dict]:
    r = target(ku, dist)
    return of_kind(r, "displacement") + of_kind(r, "trained") + of_kind(r, "warm")


def test_target_error_bars():
    """The SEM range over flows of every policy's arrival fraction, per Ku, all D."""
    sem = {ku: [p["arrival_sem"] for d in (10, 20, 40) for p in policies(ku, d)] for ku in KUS}
    text = (f"(± {span(sem['10'])} for the Ku = 10 policies, {span(sem['1e7'])} at "
            f"Ku = 1e7.)")
    assert text in page(TARGET)


def test_target_gain_over_sto_and_half_time():
    """At D = 20: the trained and warm-started seeds against target-STO (paired), and the
    time by which half of them arrived."""
    parts, halves = [], []
    for ku, name in (("10", "Ku = 10"), ("1e7", "Ku = 1e7")):
        r = target(ku, 20)
        seeds = of_kind(r, "trained") + of_kind(r, "warm")
        gain = [s["arrival_minus_first"] for s in seeds]
        sems = [s["arrival_minus_first_sem"] for s in seeds]
        parts.append(f"{signed(min(gain))} to {signed(max(gain))} ({name}, ± {span(sems, '.2f')})")
        halves += [half(s) for s in seeds]
    sto10 = half(of_kind(target("10", 20), "sto")[0])
    sto1e7 = half(of_kind(target("1e7", 20), "sto")[0])
    assert sto1e7 is None  # fewer than half of target-STO's swimmers arrive within T
    text = (f"at D = 20 by {parts[0]} and {parts[1]}, and sooner (t½ {span(halves, '.0f')} τ_K "
            f"against {sto10:.0f} and more than T)")
    assert text in page(TARGET)


def test_target_saturation_of_seed_0():
    """Seed 0 at 5.12e7 and 1e8 frames, paired per flow (the record that replaced a number
    that lived only in git history)."""
    rel = "beyond/saturation/target_ku10_seed0/comparison.json"
    r = rows(rel)
    early = next(x for label, x in r.items() if "policy_51200000" in label)
    final = next(x for label, x in r.items() if label.endswith("target_ku10_seed0/policy.pt)"))
    mean, sem = paired_sem(final["arrival_per_flow"], early["arrival_per_flow"])
    assert f"differ by {signed(mean, '.3f')} ± {sem:.3f} in arrival" in page(TARGET)
    assert "saturation/target_ku10_seed0/comparison.json" in page(TARGET)
    assert "0.826" not in page(TARGET)  # a number with no committed record


def test_target_headline_in_readme_and_overview():
    r = target("10", 20)

    def pct(rs: list[dict]) -> str:
        return span([100 * x["arrival_mean"] for x in rs], ".0f")

    sto, disp = of_kind(r, "sto")[0], of_kind(r, "displacement")[0]
    trained, warm = pct(of_kind(r, "trained")), pct(of_kind(r, "warm"))
    readme = page("README.md")
    assert (f"`T` {trained} % of the time (three seeds) against target-STO's {pct([sto])} %"
            in readme)
    assert f"with its frame turned to the target, {pct([disp])} %" in readme
    assert f"they keep its {warm} %" in readme
    assert (f"arrive within T {trained} % of the time against target-STO's {pct([sto])} %; "
            f"warm-started from the displacement policy they keep its {warm} %"
            in page("docs/beyond/index.md"))


# -- the cost of shape (docs/beyond/energy.md) ------------------------------------------------
ENERGY = "docs/beyond/energy.md"
WEIGHT = re.compile(r"_w(?P<w>[0-9.]+)_seed(?P<seed>\d)")


def by_weight(rel: str) -> dict[str, list[dict]]:
    """Policy rows per energy weight (``0``: the protocol's runs), in seed order."""
    out: dict[str, list[dict]] = {}
    for label, row in rows(rel).items():
        if not label.startswith("policy("):
            continue
        m = WEIGHT.search(label)
        out.setdefault(m.group("w") if m else "0", []).append(row)
    return out


def energy_table_row(rel: str, w: str) -> str:
    ws = by_weight(rel)
    seeds, base = ws[w], ws["0"]
    e_mean = np.mean([s["energy_mean"] for s in seeds])
    last = f"{e_mean:.3f}"
    if w != "0":
        change = 100 * (e_mean / np.mean([s["energy_mean"] for s in base]) - 1)
        last += f" ({format(change, '.1f').replace('-', MINUS)} %)"
    cells = [f"w = {w}"] + [" / ".join(f"{s[k]:.3f}" for s in seeds)
                            for k in ("R_hat_mean", "ratio_to_first", "energy_mean")] + [last]
    return "| " + " | ".join(cells) + " |"


@pytest.mark.parametrize("ku", list(KUS))
@pytest.mark.parametrize("w", ["0", "0.1", "0.3", "1"])
def test_energy_table_rows_are_the_records(ku, w):
    assert energy_table_row(f"beyond/energy/ku{ku}/comparison.json", w) in page(ENERGY)


def test_energy_w03_against_w0_at_ku10():
    """Every w = 0.3 seed's drag saving and where its R̂ lies against the w = 0 seeds'."""
    ws = by_weight("beyond/energy/ku10/comparison.json")
    r0 = [s["R_hat_mean"] for s in ws["0"]]
    e0 = np.mean([s["energy_mean"] for s in ws["0"]])
    r3 = [s["R_hat_mean"] for s in ws["0.3"]]
    saving = [100 * (1 - s["energy_mean"] / e0) for s in ws["0.3"]]
    lo, hi = round(min(r0), 3), round(max(r0), 3)
    inside = [i for i, r in enumerate(r3) if lo <= round(r, 3) <= hi]
    below = [(i, lo - round(r, 3)) for i, r in enumerate(r3) if round(r, 3) < lo]
    assert inside == [0, 2] and len(below) == 1 and not any(round(r, 3) > hi for r in r3), (
        "the w = 0.3 seeds moved against the w = 0 range: rewrite the sentence")
    (seed, gap), = below
    text = (f"at w = 0.3 every seed spends {span(saving, '.1f')} % less work against drag than "
            f"the w = 0 mean, with R̂ {span(r3)} against the w = 0 seeds' {span(r0)} (seeds 0 "
            f"and 2 inside that range, seed {seed} {gap:.3f} below it; the mean "
            f"{np.mean(r3):.3f} against {np.mean(r0):.3f})")
    assert text in page(ENERGY)


def test_energy_sto_family_against_the_policies_at_ku10():
    """The narrowed claim: no STO-family amplitude reaches the w = 0.3 policies' R̂ at their
    work, and the page says the family is all that was tried."""
    ws = by_weight("beyond/energy/ku10/comparison.json")
    family = rows("beyond/energy_baselines/ku10/comparison.json")
    e_max = max(s["energy_mean"] for s in ws["0.3"])
    r_min = min(s["R_hat_mean"] for s in ws["0.3"])
    assert all(f["R_hat_mean"] < r_min for f in family.values() if f["energy_mean"] <= e_max)
    drop = family["sto(+0.98,-0.00)"]
    assert (f"the family's best is {drop['R_hat_mean']:.3f} against "
            f"{np.mean([s['R_hat_mean'] for s in ws['0.3']]):.2f} for the `w = 0.3` policies at "
            f"Ê {np.mean([s['energy_mean'] for s in ws['0.3']]):.2f}") in page(ENERGY)
    assert "So no STO-family heuristic reaches the trained policies' saving" in page(ENERGY)


def test_energy_100_flows_w03_against_the_family():
    rel = "beyond/energy_100flows/ku1e7/comparison.json"
    w3 = by_weight(rel)["0.3"]
    drop = rows(rel)["sto(+0.98,-0.00)"]
    text = (f"({drop['R_hat_mean']:.3f} at Ê {drop['energy_mean']:.2f} against "
            f"{span([s['R_hat_mean'] for s in w3])} for w = 0.3 at Ê "
            f"{span([s['energy_mean'] for s in w3], '.2f')})")
    assert text in page(ENERGY)


def test_energy_100_flows_table_rows_are_the_records():
    rel = "beyond/energy_100flows/ku1e7/comparison.json"
    for w, seeds in by_weight(rel).items():
        cells = " | ".join(" / ".join(f"{s[k]:.3f}" for s in seeds)
                           for k in ("R_hat_mean", "ratio_to_first", "energy_mean"))
        assert f"| w = {w} | {cells} |" in page(ENERGY), w


# -- three dimensions (docs/beyond/three_d.md) ------------------------------------------------
THREE_D = "docs/beyond/three_d.md"


def test_three_d_training_time():
    runs = sorted((RESULTS / "three_d" / "runs").glob("ku*_seed*/metrics.json"))
    assert len(runs) == 6
    hours = [json.loads(p.read_text())["training"]["wall_s"] / 3600 for p in runs]
    text = f"(1e8 frames each, {span(hours, '.2f')} h each on one CPU thread"
    assert text in page(THREE_D)
    assert f"the study's six runs: {span(hours, '.2f')} h" in page("docs/performance.md")


@pytest.mark.parametrize("ku", ["1", "10"])
def test_three_d_comparison_rows_are_the_records(ku):
    r = rows(f"three_d/compare/ku{ku}/comparison.json")
    sto, naive = r["sto"], r["naive(+0.98)"]
    seeds = [x for label, x in r.items() if label.startswith("policy(")]
    sem = span([s["ratio_sem"] for s in seeds])
    text = (f"| {ku} | {sto['R_hat_mean']:.3f} ± {sto['R_hat_sem']:.3f} | "
            f"{naive['ratio_to_first']:.3f} ± {naive['ratio_sem']:.3f} | "
            + " / ".join(f"{s['ratio_to_first']:.3f}" for s in seeds) + f" (± {sem}) |")
    assert text in page(THREE_D)


# -- docs/results.md: the baselines and the naive scan ---------------------------------------
RESULTS_MD = "docs/results.md"
KU_DIRS = ("0.1", "1", "10", "1e7")


def paired_ratio(a, b) -> tuple[float, float]:
    """``mean(a) / mean(b)`` over flows and its delta-method SEM."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    ma, mb, n = a.mean(), b.mean(), a.size
    c = np.cov(a, b)
    var = (c[0, 0] / mb**2 - 2 * ma * c[0, 1] / mb**3 + ma**2 * c[1, 1] / mb**4) / n
    return float(ma / mb), float(np.sqrt(var))


@pytest.mark.parametrize("ku", KU_DIRS)
def test_baselines_table_rows_are_the_records(ku):
    """The 20 x 500 baselines: the sto and naive rows of smart_ku_sweep's comparisons."""
    rec = record(f"smart_ku_sweep/ku{ku}/comparison.json")
    assert (rec["n_flows"], rec["n_swimmers"], rec["seed"]) == (20, 500, 0)
    r = rows(f"smart_ku_sweep/ku{ku}/comparison.json")
    sto, naive = r["sto"], r["naive(+0.98)"]
    ratio, sem = paired_ratio(sto["per_flow"], naive["per_flow"])
    text = (f"| {ku} | {naive['R_hat_mean']:.3f} ± {naive['R_hat_sem']:.3f} | "
            f"{sto['R_hat_mean']:.3f} ± {sto['R_hat_sem']:.3f} | {ratio:.2f} ± {sem:.2f} | "
            f"{naive['R_hat_std']:.3f} / {sto['R_hat_std']:.3f} |")
    assert text in page(RESULTS_MD)


@pytest.mark.parametrize("ku", KU_DIRS)
def test_naive_scan_rows_are_the_record(ku):
    rel = f"referee_items/naive_scan/ku{ku}/comparison.json"
    assert (record(rel)["n_flows"], record(rel)["n_swimmers"]) == (20, 200)
    scan = sorted(record(rel)["rows"], key=lambda x: float(x["label"][6:-1]))
    text = f"| R̂, Ku = {ku} | " + " | ".join(f"{x['R_hat_mean']:.3f}" for x in scan) + " |"
    assert text in page(RESULTS_MD)
    assert f"naive_scan/ku{ku}/comparison.json" in page(RESULTS_MD)


def test_no_table_cites_outputs_instead_of_a_record():
    """The two tables that pointed at ``outputs/`` now cite their committed records."""
    text = page(RESULTS_MD)
    assert "smart_ku_sweep/ku0.1/comparison.md" in text
    assert "full tables in `comparison.md` of each run" not in text


def test_gyrotaxis_trapping_table_is_the_record():
    """docs/beyond/gyrotaxis.md's trapping map: each cell's trapped fraction and <v_z>/v_s
    (the page's minus sign) and the condition's mark, from trapping.json."""
    text = page("docs/beyond/gyrotaxis.md")
    points = record("gyrotaxis/trapping/trapping.json")["points"]
    for phi in sorted({p["phi"] for p in points}):
        cells = []
        for p in sorted((p for p in points if p["phi"] == phi), key=lambda p: p["psi"]):
            vz = f"{p['vertical_velocity']:+.2f}".replace("-", MINUS)
            cells.append(f"{p['trapped']:.2f} ({vz})" + (" T" if p["predicted"] else ""))
        assert f"| {phi:g} | " + " | ".join(cells) + " |" in text, phi


def test_gyrotaxis_comparison_rows_are_the_records():
    """docs/beyond/gyrotaxis.md's Φ = 0.3, Ψ = 1 table: means, SEMs, the paired difference to
    the searched table and the trapped fraction, from the two comparison.json records."""
    text = page("docs/beyond/gyrotaxis.md")
    table = "table(dduldurudrrd)"
    for kind, rows_of in (("continuous", {"hand_rule": "hand rule",
                                          "policy(docs/results/gyrotaxis/ppo/cont_psi1_seed0)":
                                          "PPO continuous, seed 0",
                                          "policy(docs/results/gyrotaxis/ppo/cont_psi1_seed1)":
                                          "PPO continuous, seed 1",
                                          "policy(docs/results/gyrotaxis/ppo/cont_psi1_seed2)":
                                          "PPO continuous, seed 2"}),
                          ("discrete", {"policy(docs/results/gyrotaxis/ppo/disc_psi1_seed0)":
                                        "PPO 12 states, seeds 0, 1, 2"})):
        got = rows(f"gyrotaxis/compare_psi1_{kind}/comparison.json")
        ref = np.asarray(got[table]["per_flow"])
        for label, name in rows_of.items():
            r = got[label]
            d = np.asarray(r["per_flow"]) - ref
            sem = d.std(ddof=1) / np.sqrt(len(d))
            diff = f"{d.mean():+.3f} ± {sem:.3f}".replace("-", MINUS)
            each = " (each)" if "seeds" in name else ""
            cells = (f"| {name} | {r['R_hat_mean']:.3f} ± {r['R_hat_sem']:.3f}{each} | {diff} | "
                     f"{r['trapped_mean']:.2f} |")
            assert cells in text, cells


def test_gyrotaxis_stochastic_rows_are_the_records():
    """docs/beyond/gyrotaxis.md's table in the stochastic flow, from its two records."""
    text = page("docs/beyond/gyrotaxis.md")
    names = {("shape", "naive(+0.00)"): "naive sphere (Λ = 0, k = up)",
             ("shape", "naive(-0.98)"): "naive, Λ = −0.98 (oblate)",
             ("shape", "naive(+0.98)"): "naive, Λ = +0.98 (prolate)",
             ("shape", "sto"): "STO in the vertical frame",
             ("shape", "policy(docs/results/gyrotaxis/ppo/stochastic_shape_seed0)"):
                 "PPO, shape only",
             ("steer", "hand_rule"): "hand rule (steering)",
             ("steer", "policy(docs/results/gyrotaxis/ppo/stochastic_steer_seed0)"):
                 "PPO, steering"}
    for (kind, label), name in names.items():
        r = rows(f"gyrotaxis/compare_stochastic_{kind}/comparison.json")[label]
        cells = (f"| {name} | {r['R_hat_mean']:.3f} ± {r['R_hat_sem']:.3f} | "
                 f"{r['trapped_mean']:.2f} |")
        assert cells in text, cells


def test_learner_ablation_comparison_rows_are_the_record():
    """docs/results/learner_ablation/README.md's held-out table: R̂ ± SEM and the paired ratio
    to STO of each row, from compare_seed1000000/comparison.json."""
    text = page("docs/results/learner_ablation/README.md")
    got = rows("learner_ablation/compare_seed1000000/comparison.json")
    base = "policy(docs/results/learner_ablation/"
    names = {"optimised(ku10_3d)": "optimised rule (`ku10_3d`)",
             f"{base}distilled_ku10_3d)": "the rule distilled (`swimrl-distill`)",
             f"{base}warm_terms_std02_ku10_seed0)": "PPO from the distilled rule, 3e7",
             f"{base}terms_std02_const_ku10_seed0)": "`terms_std02_const`, 3e7",
             f"{base}terms_std02_ku10_seed0)": "`terms_std02`, 3e7"}
    sto = got["sto"]
    assert f"| STO | {sto['R_hat_mean']:.3f} ± {sto['R_hat_sem']:.3f} | 1 |" in text
    for label, name in names.items():
        r = got[label]
        cells = (f"| {name} | {r['R_hat_mean']:.3f} ± {r['R_hat_sem']:.3f} | "
                 f"{r['ratio_to_first']:.3f} ± {r['ratio_sem']:.3f} |")
        assert cells in text, cells


def test_learner_ablation_noisy_rule_numbers_are_the_record():
    """The noisy rule's R̂ per sigma quoted in the ablation README, from noisy_rule.json."""
    text = page("docs/results/learner_ablation/README.md")
    r = {row["sigma"]: row for row in record("learner_ablation/noisy_rule.json")["rows"]}
    assert f"R̂ {r[0.0]['R_hat_mean']:.3f} ± {r[0.0]['R_hat_sem']:.3f} at σ = 0" in text
    mid = ", ".join(f"{r[s]['R_hat_mean']:.3f}" for s in (0.2, 0.35, 0.5))
    assert f"{mid} and {r[1.0]['R_hat_mean']:.3f} ± {r[1.0]['R_hat_sem']:.3f} at σ = 0.2" in text


def test_learner_ablation_arm_rows_are_their_metrics():
    """Every arm of the learner ablation's first table: its final held-out R̂ ± SEM and its
    training wall time, from the arm's metrics.json."""
    text = page("docs/results/learner_ablation/README.md")
    arms = re.findall(r"\| \[([^\]]+)\]\((\w+)/\) \| [^|]+ \| [^|]+ \| (\d+) s \| "
                      r"([0-9.]+ ± [0-9.]+) \|", text)
    assert len(arms) >= 10
    for _, run, wall, cell in arms:
        m = json.loads((RESULTS / "learner_ablation" / run / "metrics.json").read_text())
        assert cell == f"{m['R_hat_mean']:.3f} ± {m['R_hat_sem']:.3f}", run
        assert int(wall) == round(m["training"]["wall_s"]), run


def test_learner_ablation_gain_split_is_the_record():
    """The swimming/advection table of the ablation README: R̂, Ŝ, R̂ − Ŝ per strategy and the
    paired differences to the rule, recomputed from gain_split_{3d,2d}/comparison.json."""
    text = page("docs/results/learner_ablation/README.md")

    def fmt(v: float, signed: bool = False) -> str:
        return (f"{v:+.3f}" if signed else f"{v:.3f}").replace("-", "−")

    for dim, rule in (("3d", "optimised(ku10_3d)"), ("2d", "optimised(ku10_2d)")):
        got = rows(f"learner_ablation/gain_split_{dim}/comparison.json")

        def parts(r):
            return (r["per_flow"], r["swimming_per_flow"],
                    list(np.subtract(r["per_flow"], r["swimming_per_flow"])))

        ref = parts(got[rule])
        for label, r in got.items():
            p = parts(r)
            cells = (f"| {fmt(np.mean(p[0]))} | {fmt(np.mean(p[1]))} | "
                     f"{fmt(np.mean(p[2]), True)} | ")
            if label != rule:
                cells += " | ".join(paired_cell(a, b) for a, b in zip(ref, p, strict=True)) + " |"
            assert cells in text, (label, cells)


def test_learner_ablation_asymmetric_critic_is_the_record():
    """The asymmetric-critic table: R̂ ± SEM, the ratio to STO and the paired differences to
    the rule in R̂, Ŝ and R̂ − Ŝ, from the runs' metrics.json and gain_split_3d."""
    text = page("docs/results/learner_ablation/README.md")
    got = rows("learner_ablation/gain_split_3d/comparison.json")
    rule, sto = got["optimised(ku10_3d)"], got["sto"]
    ref = np.asarray(rule["per_flow"]), np.asarray(rule["swimming_per_flow"])

    for seed in (0, 1, 2):
        m = record(f"learner_ablation/cflow_terms_std02_const_ku10_seed{seed}/metrics.json")
        r, s = np.asarray(m["per_flow"]), np.asarray(m["swimming_per_flow"])
        ratio = r.sum() / np.sum(sto["per_flow"])
        cells = (f"| {seed} | {m['R_hat_mean']:.3f} ± {m['R_hat_sem']:.3f} | {ratio:.3f} | "
                 f"{paired_cell(ref[0], r)} | {paired_cell(ref[1], s)} | "
                 f"{paired_cell(ref[0] - ref[1], r - s)} |")
        assert cells in text, cells


def test_learner_ablation_asymmetric_critic_probe_is_the_record():
    """corr(Λ, Λ*) of the asymmetric critic's seeds in the arm table (real-flow states, then
    isotropic ones: the row's last two cells), from probe_cflow/probe.json."""
    lines = (RESULTS / "learner_ablation" / "README.md").read_text(encoding="utf-8").splitlines()
    got = {(r["policy"].rstrip("/").rsplit("/", 1)[-1], r["states"]): r["corr_star"]
           for r in record("learner_ablation/probe_cflow/probe.json")["rows"]}
    for seed in (0, 1):
        run = f"cflow_terms_std02_const_ku10_seed{seed}"
        row = next(line for line in lines if f"]({run}/)" in line)
        assert row.endswith(f"| {got[(run, 'flows')]:.2f} | {got[(run, 'gaussian')]:.2f} |"), row


def test_asymmetric_critic_test_flows_are_the_record():
    """cflow_test_seed0/README.md: R̂, the ratio to STO and the paired difference to the rule
    on the test flows, from the comparisons (STO's per-flow values equal the rule's record)."""
    text = page("docs/results/learner_ablation/cflow_test_seed0/README.md")
    rule = rows("optimised_rules/ku10_3d/test_seed0/comparison.json")
    ref = rule["optimised(ku10_3d)"]
    assert (f"| optimised rule `ku10_3d` | {ref['R_hat_mean']:.3f} ± {ref['R_hat_sem']:.3f} | "
            f"{ref['ratio_to_first']:.3f} ± {ref['ratio_sem']:.3f} |") in text
    for seed in (0, 1, 2):
        got = rows(f"learner_ablation/cflow_test_seed0/seed{seed}/comparison.json")
        assert got["sto"]["per_flow"] == rule["sto"]["per_flow"]
        p = next(r for label, r in got.items() if label.startswith("policy"))
        diff = paired_cell(p["per_flow"], ref["per_flow"])
        cells = (f"| {p['R_hat_mean']:.3f} ± {p['R_hat_sem']:.3f} | "
                 f"{p['ratio_to_first']:.3f} ± {p['ratio_sem']:.3f} | {diff} |")
        assert cells in text, cells


def test_critic3d_test_flows_are_the_record():
    """critic3d/README.md: every policy's R̂ ± SEM, ratio to STO and paired difference to the
    rule on the test flows, from its comparison paired with the rule's record (Ku = 10, 1)."""
    from swimrl.evaluation.statistics import paired_ratio

    text = page("docs/results/critic3d/README.md")
    checked = 0
    for ku, tests in ((10, "ku10_1e8_test_seed0"), (1, "ku1_test_seed0")):
        rule = rows(f"optimised_rules/ku{ku}_3d/test_seed0/comparison.json")
        sto, ref = (np.asarray(rule[k]["per_flow"]) for k in ("sto", f"optimised(ku{ku}_3d)"))
        ratio, sem = paired_ratio(ref, sto)
        assert f"| {ref.mean():.3f} ± {rule[f'optimised(ku{ku}_3d)']['R_hat_sem']:.3f} | " \
               f"{ratio:.3f} ± {sem:.3f} |" in text
        for path in sorted((RESULTS / "critic3d" / tests).rglob("comparison.json")):
            for label, r in rows(str(path.relative_to(RESULTS))).items():
                p = np.asarray(r["per_flow"])
                ratio, sem = paired_ratio(p, sto)
                diff = paired_cell(p, ref)
                cells = (f"| {p.mean():.3f} ± {r['R_hat_sem']:.3f} | {ratio:.3f} ± {sem:.3f} | "
                         f"{diff} |")
                assert cells in text, (label, cells)
                checked += 1
    assert checked >= 3


def test_critic3d_probe_is_the_record():
    """critic3d/README.md: corr(Λ, Λ*) on real-flow / isotropic states of the 1e8 policies
    (each row's last cell), from probe_ku10/probe.json and probe_ku1/probe.json."""
    lines = (RESULTS / "critic3d" / "README.md").read_text(encoding="utf-8").splitlines()
    for probe, runs, prefix in (
            ("probe_ku10", {0: "ku10_1e8_test_seed0/seeds01/", 1: "ku10_1e8_test_seed0/seeds01/",
                            2: "ku10_1e8_test_seed0/seed2/"},
             "learner_ablation/cflow1e8_terms_std02_const_ku10_seed"),
            ("probe_ku1", {0: "ku1_test_seed0/"}, "critic3d/ku1_1e8_seed")):
        got = {(r["policy"].rstrip("/").rsplit("/", 1)[-1], r["states"]): r["corr_star"]
               for r in record(f"critic3d/{probe}/probe.json")["rows"]}
        for seed, link in runs.items():
            run = (prefix + str(seed)).rsplit("/", 1)[-1]
            row = next(line for line in lines if line.startswith(f"| [seed {seed}]({link}"))
            want = f"| {got[(run, 'flows')]:.2f} / {got[(run, 'gaussian')]:.2f} |"
            assert row.endswith(want), (row, want)


def test_critic3d_snapshot_selection_is_the_record():
    """critic3d/selection_seed2000000/README.md: each seed's row of the five snapshots'
    validation R̂ ± SEM, in the order of its comparison."""
    text = page("docs/results/critic3d/selection_seed2000000/README.md")
    for seed in (0, 1, 2):
        got = record(f"critic3d/selection_seed2000000/seed{seed}/comparison.json")["rows"]
        assert [r["label"].rsplit("_", 1)[-1] for r in got] == [
            "83951616.pt)", "87949312.pt)", "91947008.pt)", "95944704.pt)", "99942400.pt)"]
        cells = " | ".join(f"{r['R_hat_mean']:.3f} ± {r['R_hat_sem']:.3f}" for r in got)
        assert f"| {seed} | {cells} |" in text, cells
