"""The registry's table: one entry per ``conf/flow/<name>.yaml``, defined with its flow."""

import importlib
from importlib.resources import files

from swimrl.flows.registry import BUILTIN_FLOWS, flow_names


def test_the_table_is_conf_flow():
    """Every ``conf/flow/<name>.yaml`` is one flow of :data:`BUILTIN_FLOWS`, and no more."""
    yamls = {p.name.removesuffix(".yaml") for p in files("swimrl.conf").joinpath("flow").iterdir()
             if p.name.endswith(".yaml")}
    assert set(BUILTIN_FLOWS) == yamls
    assert set(flow_names()) >= yamls


def test_each_entry_lives_with_its_flow():
    """``flow=<name>``: its spec, its builder and its entry ``<NAME>_ENTRY`` in one module,
    ``swimrl.flows.<name>`` (the DNS flows: ``swimrl.flows.dns.flow``; the analytic flows:
    ``swimrl.flows.analytic``)."""
    shared = {"dns_replay": "swimrl.flows.dns.flow", "dns": "swimrl.flows.dns.flow",
              "linear": "swimrl.flows.analytic", "abc": "swimrl.flows.analytic",
              "taylor_green": "swimrl.flows.analytic"}
    for name, entry in BUILTIN_FLOWS.items():
        module = shared.get(name, f"swimrl.flows.{name}")
        assert entry.name == name
        assert entry.spec.__module__ == entry.build.__module__ == module
        assert getattr(importlib.import_module(module), f"{name.upper()}_ENTRY") is entry
