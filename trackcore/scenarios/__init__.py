"""trackcore.scenarios: the simulated worlds of the chapters: truth, measurements, clutter and
Monte Carlo trial functions for each paper's experiments.

The book's appendix "Design of trackcore" places this layer among the others.

Every public name in a module's ``__all__`` is re-exported here.
"""
from .._autoexport import export_modules

__all__ = export_modules(__name__, __path__, globals())
