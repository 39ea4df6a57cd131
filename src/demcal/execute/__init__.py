"""Executors: run virtual tests locally (process pool, one batched engine) or on Dask."""
