"""Many scenes per run: every scene under some folders reconstructed on a Dask cluster."""
