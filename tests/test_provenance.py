"""Provenance: the code version covers the plug-ins' sources, entry-point plug-ins included."""

from __future__ import annotations

from importlib.metadata import EntryPoint

from foucault_bench.bench.run import provenance


def test_an_entry_point_plugin_source_enters_the_code_version(tmp_path, monkeypatch):
    module = tmp_path / "my_plugin_integrator.py"
    module.write_text("ORDER = 2\n", encoding="utf-8")
    monkeypatch.syspath_prepend(str(tmp_path))
    advertised = [EntryPoint(name="mine", value="my_plugin_integrator:Mine", group=provenance.PLUGIN_ENTRY_POINT_GROUP)]
    monkeypatch.setattr(provenance, "entry_points", lambda group: advertised if group == advertised[0].group else [])

    assert module in provenance.plugin_sources()
    before = provenance.code_version.__wrapped__()
    module.write_text("ORDER = 3\n", encoding="utf-8")  # the plug-in changed: its stored rows must not be reused
    assert provenance.code_version.__wrapped__() != before
    monkeypatch.setattr(provenance, "entry_points", lambda group: [])
    assert provenance.code_version.__wrapped__() != before  # and without it the version differs too


def test_a_named_plugin_module_enters_the_code_version_once(tmp_path, monkeypatch):
    module = tmp_path / "named_plugin.py"
    module.write_text("X = 1\n", encoding="utf-8")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setattr(provenance, "entry_points", lambda group: [])
    assert provenance.plugin_sources(["named_plugin", "named_plugin"]) == [module]
    assert provenance.code_version.__wrapped__(("named_plugin",)) != provenance.code_version.__wrapped__()
