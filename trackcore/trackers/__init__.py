"""trackcore.trackers: complete trackers built from the layers below: IMM-PDAF, the HPDA
particle filter, the clustering hybrid, SMC-PHD, the SPRT discriminator, the
track-before-detect particle filters and the feature-aided JPDA tracker.

The book's appendix "Design of trackcore" places this layer among the others.

Every public name in a module's ``__all__`` is re-exported here.
"""
from .._autoexport import export_modules

__all__ = export_modules(__name__, __path__, globals())
