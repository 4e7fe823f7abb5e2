"""trackcore: the fast, tested tracking package behind trackcore-book.

Layers (a module imports only from layers above it):
``core`` -> ``models`` -> ``filters`` -> ``association`` -> ``detection`` ->
``trackers`` -> ``scenarios``; plus ``metrics``, ``montecarlo`` and ``plotting``.
"""
from . import core

__version__ = "0.1.0"
__all__ = ["core", "__version__"]
