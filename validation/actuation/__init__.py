"""``demes actuate`` and ``demes calibrate``: voltage sweeps, their closed forms and the fit to
the experiment."""
