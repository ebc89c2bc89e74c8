"""The package's version, in a module of its own so that any layer (the generated code's headers in
export/, the playground's /api/health) can name it without importing the whole package."""

__version__ = "0.1.0"
