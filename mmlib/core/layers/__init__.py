"""Thin layers over any filter or estimator: strong tracking (``strong_tracking``), innovation-covariance
adaptation (``adaptive``), observation bootstrapping (``bootstrap``), the IMM whose modes' noise levels a
controller sets each step (``adaptive_imm``) and the fuzzy controller of those levels (``fuzzy_noise``).  Each
wraps a filter of :class:`mmlib.core.protocols.Filter` and is one itself (or, for ``adaptive_imm`` and
``fuzzy_noise``, wraps an IMM and is an :class:`mmlib.core.protocols.Estimator`)."""
from mmlib.core._lazy import lazy_attributes

__all__: list[str] = []      # a package: its modules are the API


__getattr__, __dir__ = lazy_attributes(__name__, globals())     # its submodules, on access
