"""``demes bench``: wall time, iterations and throughput of the solvers (not tests)."""
