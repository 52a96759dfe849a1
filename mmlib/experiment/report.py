"""Where the verdict rule and the output writing live, under the name the papers, notebooks and tests import.

The one verdict rule (the comparison rows, :class:`~mmlib.experiment.verdicts.Verdict` and the claim vocabulary
:class:`~mmlib.experiment.verdicts.ClaimVerdict`) is :mod:`mmlib.experiment.verdicts`; writing results files, text
files and figures atomically (``write_results``, ``provenance``, ``save_figure``) is :mod:`mmlib.experiment.writing`;
the results contract and its one reader are :mod:`mmlib.experiment.results`.  This module re-exports their public
names, so that ``report.make_row(...)``, ``report.Claims()`` or ``report.NOT_REPLICABLE`` read as before; new code
may import from either.  (The names are documented once, in their own modules.)
"""
from __future__ import annotations

# re-exported: the results contract
from mmlib.experiment.results import read_results, results_schema, validate_results  # noqa: F401
# re-exported: the verdict rule
from mmlib.experiment.verdicts import (CLAIM_VERDICTS, CONTRADICTED, COST_MARGIN, HOLDS, INCONCLUSIVE,  # noqa: F401
                                       ISOLATED, JOINT_ALPHA, NEGLIGIBLE, NOT_ASSESSABLE, NOT_REPLICABLE,
                                       NOT_REPRODUCED, NOT_REPRODUCED_EXACT, NOT_SUPPORTED, PAPER_ERROR_ASSUMPTION,
                                       PARTLY, QUALITATIVE, RELATIVE_BAND, REPRODUCED, REPRODUCED_EXACT,
                                       ROUNDOFF_OPS, SIGMA_FACTOR, VERDICTS, ClaimVerdict, Claims, JointTest,
                                       Judgement, Part, PartVerdict, Row, Verdict, analytic_row, claim_category,
                                       claim_verdict, exact_part, exact_row, identity_floor,
                                       is_reproduced, joint_test, joint_tests, judge, make_row, part,
                                       printed_half_unit, ratio_part, standardized_distance, verdict,
                                       verdict_category, RECONSTRUCTION, qualified, format_pm)
# re-exported: writing the outputs
from mmlib.experiment.writing import (atomic_write_text, git_commit, provenance, save_figure,  # noqa: F401
                                      write_results)

__all__: list[str] = []
