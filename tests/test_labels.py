"""The one Ku label format (swimrl.flows.labels), the one strategy label (StrategyLabel) and the
one atomic write (swimrl.runs.atomic)."""

from __future__ import annotations

import os

import pytest
from omegaconf import OmegaConf

import swimrl.config  # noqa: F401  (registers the ${flow_tag:...} and ${ku:...} resolvers)
from swimrl.flows.labels import ku_display, ku_name, ku_number, parse_ku_name
from swimrl.policies.baselines import StrategyLabel
from swimrl.runs.atomic import atomic_write, atomic_write_text, temp_path


@pytest.mark.parametrize(("kubo", "name", "shown"), [
    (0.1, "ku0.1", "Ku = 0.1"), (1.0, "ku1", "Ku = 1"), (10, "ku10", "Ku = 10"),
    (1e7, "ku1e7", "Ku = 1e+07"), (1e-5, "ku1e-5", "Ku = 1e-05"),
    (2.5e12, "ku2.5e12", "Ku = 2.5e+12")])
def test_ku_labels_and_their_parser(kubo, name, shown):
    assert (ku_name(kubo), ku_display(kubo)) == (name, shown)
    assert ku_name({"name": "stochastic", "kubo": kubo}) == name
    assert ku_number(kubo) == f"{kubo:g}" and ku_display(kubo, "=") == f"Ku={kubo:g}"
    # the one parser reads the label back, and every older form of it
    for text in (name, name.upper(), f"ku{kubo:g}", f"ku{float(kubo)}", f"ku{kubo!r}"):
        assert parse_ku_name(text) == pytest.approx(kubo), text
    assert ku_name(parse_ku_name(name)) == name


def test_ku_label_edges():
    assert ku_name({"name": "dns"}) == "dns" and ku_name("dns_replay") == "dns_replay"
    assert ku_display({"name": "stochastic", "kubo": 1e7}, "=") == "Ku=1e+07"
    assert ku_display({"name": "dns"}) == "dns" and ku_display("stored") == "stored"
    assert ku_display(0.1) == "Ku = 0.1"
    for text in ("ku1e7", "ku1e+07", "ku10000000", "ku10000000.0", "ku1E7", "KU1e7"):
        assert parse_ku_name(text) == 1e7
    assert parse_ku_name("ku10.0") == 10 and parse_ku_name("ku.5") == 0.5
    for text in ("ku10_seed0", "dns", "ku", "kuinf", "ku-1", "ku1_0", "policy(ku10)", "10",
                 "1e7", "Ku = 10"):
        assert parse_ku_name(text) is None, text


@pytest.mark.parametrize(("kubo", "name"), [(0.1, "ku0.1"), (1, "ku1"), (10.0, "ku10"),
                                            (1e7, "ku1e7"), ("1e7", "ku1e7")])
def test_ku_resolvers_of_the_configs(kubo, name):
    """``${flow_tag:${flow}}`` (run directories) and ``ku${ku:${flow.kubo}}`` give the label."""
    cfg = OmegaConf.create({"flow": {"name": "stochastic", "kubo": kubo},
                            "dir": "x_${flow_tag:${flow}}_seed0", "policy": "ku${ku:${flow.kubo}}",
                            "dns": {"name": "dns_replay"}, "other": "${flow_tag:${dns}}"})
    assert (cfg.dir, cfg.policy, cfg.other) == (f"x_{name}_seed0", name, "dns_replay")


def test_strategy_label_round_trip():
    assert StrategyLabel.naive(0.98).label == "naive(+0.98)"
    assert StrategyLabel.naive(-0.5).label == "naive(-0.50)" and str(StrategyLabel("sto")) == "sto"
    assert StrategyLabel.policy("pretrained/ku10").label == "policy(pretrained/ku10)"
    assert StrategyLabel.minimal().label == "minimal"
    assert StrategyLabel.minimal("ku1e7").label == "minimal(ku1e7)"
    assert StrategyLabel.minimal_coeffs([1, 0.5, 1e-7, -2.0]).label == "minimal(1,0.5,1e-07,-2)"
    for text in ("sto", "naive(+0.98)", "minimal(ku1e7)", "minimal(1,0,0,0)", "policy(a/b(c))"):
        assert StrategyLabel.parse(text).label == text
    assert StrategyLabel.parse("naive(+0.98)") == StrategyLabel("naive", "+0.98")
    assert StrategyLabel.parse("naive(+0.98)").numbers == (0.98,)
    assert StrategyLabel.parse("runs/naive(x)") == StrategyLabel("runs/naive(x)")
    assert StrategyLabel.parse("policy(pretrained/ku10/)").kubo == 10
    assert StrategyLabel.parse("minimal(ku0.1)").kubo == 0.1 and StrategyLabel("ku1").kubo == 1
    assert StrategyLabel.parse("policy(runs/ku10_seed0)").kubo is None


def test_atomic_write(tmp_path):
    path = tmp_path / "a" / "r.json"
    with pytest.raises(FileNotFoundError):
        atomic_write_text(path, "x")
    assert atomic_write_text(path, "Λ ±\n", make_dirs=True) == path
    assert path.read_bytes() == "Λ ±\n".encode()
    atomic_write(path, lambda fh: fh.write(b"new"))
    assert path.read_bytes() == b"new"
    assert temp_path(path) == path.with_name(f".r.json.{os.getpid()}.tmp")

    def fail(fh):
        fh.write(b"part")
        raise RuntimeError("killed")

    with pytest.raises(RuntimeError):
        atomic_write(path, fail)
    assert path.read_bytes() == b"new" and sorted(p.name for p in path.parent.iterdir()) == [
        "r.json"]
    link = tmp_path / "link.json"
    link.symlink_to(path)
    atomic_write(link, b"via link")
    assert link.is_symlink() and path.read_bytes() == b"via link"
    atomic_write(os.devnull, b"to a device")  # not a regular file: written directly
