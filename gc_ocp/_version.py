"""The package version (one place; read by pyproject and written into every fit.json)."""

__version__ = "0.1.0"
