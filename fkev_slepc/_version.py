"""The package version (archived with every run); imports nothing, so any module may import it."""

__version__ = "0.1.0"
