"""The book's figure style and recurring plots.

Every notebook calls :func:`use_book_style` in its hidden first cell.
"""
from __future__ import annotations

import matplotlib

__all__ = ["use_book_style", "BOOK_COLORS"]

BOOK_COLORS = ("#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#F0E442", "#000000")


def use_book_style() -> None:
    """Apply the book's matplotlib style (colour-blind-safe palette, readable sizes)."""
    from cycler import cycler

    matplotlib.rcParams.update({
        "figure.figsize": (7.0, 4.2),
        "figure.dpi": 100,
        "savefig.dpi": 150,
        "axes.grid": True,
        "grid.alpha": 0.3,
        "axes.spines.top": False,
        "axes.spines.right": False,
        "axes.prop_cycle": cycler(color=list(BOOK_COLORS)),
        "font.size": 10,
        "axes.titlesize": 11,
        "legend.fontsize": 9,
        "legend.frameon": False,
        "image.cmap": "viridis",
    })
