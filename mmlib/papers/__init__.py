"""One module per replicated paper: its set-up, numbered deviations and experiments.

Notebooks call these; tests import them to check the paper-level claims
(e.g. that two algorithms coincide under the paper's set-up)."""
