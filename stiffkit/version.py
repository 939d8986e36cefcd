"""The package version (one place; pyproject.toml and meson.build carry the same)."""

__version__ = "0.1.0"
