"""Validation: how the solvers are compared, the reports, and the ``demes`` command line."""
