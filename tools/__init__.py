"""Developer tools, apart from the benchmarks: mutation testing (mutants.py, mutants.toml) and render hashes."""
