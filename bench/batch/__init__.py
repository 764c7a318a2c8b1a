"""The machinery of a batch of runs: executors (local processes or a Dask cluster), the
batch runner that appends each finished row to its table, progress lines and bars."""
