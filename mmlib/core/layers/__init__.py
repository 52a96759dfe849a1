"""Thin layers over any filter or estimator: strong tracking (``strong_tracking``), innovation-covariance
adaptation (``adaptive``), observation bootstrapping (``bootstrap``), the IMM whose modes' noise levels a
controller sets each step (``adaptive_imm``) and the fuzzy controller of those levels (``fuzzy_noise``).  Each
wraps a filter of :class:`mmlib.core.protocols.Filter` and is one itself (or, for ``adaptive_imm`` and
``fuzzy_noise``, wraps an IMM and is an :class:`mmlib.core.protocols.Estimator`)."""
__all__: list[str] = []      # a package: its modules are the API


def __getattr__(name: str) -> object:
    """A submodule, imported on first access: ``import mmlib.core; mmlib.core.models`` works as it did when
    ``mmlib/__init__.py`` imported the library eagerly (issue 25), whatever was imported before."""
    import importlib
    import importlib.util
    if name.isidentifier() and not name.startswith("__") and importlib.util.find_spec(f"{__name__}.{name}"):
        return importlib.import_module(f"{__name__}.{name}")
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
