"""Thin layers over any filter or estimator: strong tracking (``strong_tracking``), innovation-covariance
adaptation (``adaptive``), observation bootstrapping (``bootstrap``) and the IMM whose modes' noise levels a
controller sets each step (``adaptive_imm``).  Each wraps a filter of :class:`mmlib.core.protocols.Filter` and
is one itself (or, for ``adaptive_imm``, wraps an IMM and is an :class:`mmlib.core.protocols.Estimator`)."""
