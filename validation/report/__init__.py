"""``demes validate``: the core comparison of DR with the FEM reference (plan, runner, analysis,
report) and the studies plugged into it (:mod:`validation.report.studies`)."""
