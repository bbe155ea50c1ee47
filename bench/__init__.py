"""Benchmarks: each module prints a table. Run them all with `make bench`."""
