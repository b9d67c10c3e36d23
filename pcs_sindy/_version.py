"""The package version: one place, read by the package root, the model files and the build."""

__version__ = "0.2.0.dev0"
