"""trackcore.detection: detection statistics: Marcum Q and radar detection probability, Wald's
SPRT, image-based detection (background subtraction, patch correlation).

The book's appendix "Design of trackcore" places this layer among the others.

Every public name in a module's ``__all__`` is re-exported here.
"""
from .._autoexport import export_modules

__all__ = export_modules(__name__, __path__, globals())
