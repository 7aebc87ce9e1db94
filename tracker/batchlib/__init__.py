"""Internals of :mod:`tracker.batch`: geometry, the vectorised finder, the Dask backend."""
