"""flowvo's version, in a module of its own so that any module can read it without importing the package's face
(``flowvo/__init__.py``, which hands on the public API)."""

VERSION = "0.1.0"
