"""Provenance: the code version covers the plug-ins' sources (named in a matrix or loaded from entry points)."""

from __future__ import annotations

from foucault_bench.bench import provenance
from foucault_bench.integrators import registry


def test_an_entry_point_plugin_source_enters_the_code_version(tmp_path, monkeypatch):
    module = tmp_path / "my_plugin_integrator.py"
    module.write_text("ORDER = 2\n", encoding="utf-8")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setattr(registry, "ENTRY_POINT_MODULES", ["my_plugin_integrator"])  # as if loaded from one

    assert module in provenance.plugin_sources()
    before = provenance.code_version.__wrapped__()
    module.write_text("ORDER = 3\n", encoding="utf-8")  # the plug-in changed: its stored rows must not be reused
    assert provenance.code_version.__wrapped__() != before


def test_a_plugin_package_enters_with_all_its_modules_and_a_module_once(tmp_path, monkeypatch):
    package = tmp_path / "plugin_package"
    package.mkdir()
    (package / "__init__.py").write_text("from plugin_package import stepper\n", encoding="utf-8")
    (package / "stepper.py").write_text("X = 1\n", encoding="utf-8")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setattr(registry, "ENTRY_POINT_MODULES", [])
    assert provenance.plugin_sources(["plugin_package", "plugin_package"]) == [package / "__init__.py",
                                                                                package / "stepper.py"]
    before = provenance.code_version.__wrapped__(("plugin_package",))
    (package / "stepper.py").write_text("X = 2\n", encoding="utf-8")
    assert provenance.code_version.__wrapped__(("plugin_package",)) != before
