"""``demes solve`` and ``demes gallery``: states on nested meshes with their discretisation error,
other stable states, and both solvers on one discrete problem over built-in outlines."""
