"""Sweeps and Monte Carlo runs of a scene on Dask: the engine, the results table, the plots."""
