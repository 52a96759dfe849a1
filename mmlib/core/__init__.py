"""The estimation core, paper-agnostic: quadrature rules (``rules``), one generic filter recursion with one
Kalman update (``filters``), thin layers over any filter (``layers``), the single-model and IMM estimators
and the batched driver (``estimation``, with pluggable ``mixing``), dynamics and measurement models
(``models``, ``gnss``), zero-order Takagi-Sugeno inference (``fuzzy``) and the batched small-matrix kernels
(``linalg``).  The interfaces every piece must provide are ``typing.Protocol``\\ s (``protocols``).

Nothing here imports the experiment layer (``mmlib.experiment``) or the paper set-ups (``mmlib.papers``).
"""
from mmlib.core._lazy import lazy_attributes

__all__: list[str] = []      # a package: its modules are the API


__getattr__, __dir__ = lazy_attributes(__name__, globals())     # its submodules, on access
