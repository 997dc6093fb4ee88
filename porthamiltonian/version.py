"""The package version (one place: the package, the results files and the caches read it)."""

__version__ = "0.1.0"
