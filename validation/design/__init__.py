"""``demes sweep``: a design study over a grid of scene fields, on a Dask cluster, resumably."""
