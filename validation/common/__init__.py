"""Pieces every command family shares: tables and documents, the Dask executor, folder locks,
plotting, interrupt handling, and the closed forms the solvers are checked against."""
