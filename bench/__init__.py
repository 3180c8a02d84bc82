"""Benchmarks: `python -m bench NAME [options]`, run from the repository root."""
