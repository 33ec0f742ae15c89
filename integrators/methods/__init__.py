"""The built-in integrators, one module per method (or per library adapter's methods).

Every module here registers what it defines (``@register``); the framework they build on (interface, registry,
drivers, tableaux, compositions, Gauss collocation) lives one level up in ``foucault_bench.integrators``.
``integrators.registry.discover_built_ins`` imports every module of this package.
"""
