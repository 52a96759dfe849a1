"""The estimation core, paper-agnostic: quadrature rules (``rules``), one generic filter recursion with one
Kalman update (``filters``), thin layers over any filter (``layers``), the single-model and IMM estimators
and the batched driver (``estimation``, with pluggable ``mixing``), dynamics and measurement models
(``models``, ``gnss``), zero-order Takagi-Sugeno inference (``fuzzy``) and the batched small-matrix kernels
(``linalg``).  The interfaces every piece must provide are ``typing.Protocol``\\ s (``protocols``).

Nothing here imports the experiment layer (``mmlib.experiment``) or the paper set-ups (``mmlib.papers``).
"""
__all__: list[str] = []      # a package: its modules are the API


def __getattr__(name: str) -> object:
    """A submodule, imported on first access: ``import mmlib.core; mmlib.core.models`` works as it did when
    ``mmlib/__init__.py`` imported the library eagerly (issue 25), whatever was imported before."""
    import importlib
    import importlib.util
    if name.isidentifier() and not name.startswith("__") and importlib.util.find_spec(f"{__name__}.{name}"):
        return importlib.import_module(f"{__name__}.{name}")
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
