"""The test suite as a package, so that pytest puts the repository root on sys.path, not tests/ itself:
folders named like the package's parts (tests/distributed/, tests/trace/) would otherwise stand in for
Dask's `distributed` where it is not installed, or sit beside the standard library's `trace`.
Helpers are imported as `tests.clitools`, `tests.reference.whitted`, ..."""
