"""trackcore.filters: Kalman and extended Kalman filters, IMM, particle-filter steps.

Every public name in a module's ``__all__`` is re-exported here.
"""
from .._autoexport import export_modules

__all__ = export_modules(__name__, __path__, globals())
