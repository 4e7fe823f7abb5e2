"""The book's figure style, recurring plots and results tables.

Every notebook calls :func:`use_book_style` in its hidden first cell. The style draws
figures 7.5 in wide at 150 dpi with 9-10 pt text, so that at the book's rendered column
width the text stays at least 9 pt; multi-panel figures stack panels rather than widen.
Results tables are shown with :func:`results_table` (Markdown, rendered as an HTML
table by the book and by JupyterLab).
"""
from __future__ import annotations

import matplotlib
import numpy as np

from .core.validation import as_array

__all__ = ["use_book_style", "BOOK_COLORS", "BOOK_WIDTH", "plot_rmse_vs_time",
           "plot_tracks_2d", "plot_count_vs_scan", "plot_consistency", "paper_vs_ours_table",
           "results_table", "integer_ticks"]

BOOK_WIDTH = 7.5
"""Figure width in inches that renders at the book's column width without shrinking text."""

BOOK_COLORS = ("#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#F0E442", "#000000")


def _use_inline_backend_in_kernel() -> None:
    """Inside a Jupyter kernel, draw figures inline whatever ``MPLBACKEND`` says.

    With a non-interactive backend (e.g. ``MPLBACKEND=Agg`` in a CI shell) ``plt.show()``
    would produce no output and the stored figures would no longer match a fresh run.
    """
    try:
        from IPython import get_ipython
    except ImportError:  # pragma: no cover - IPython is a dependency of the book
        return
    shell = get_ipython()
    if shell is not None and getattr(shell, "kernel", None) is not None:
        shell.run_line_magic("matplotlib", "inline")


def use_book_style() -> None:
    """Apply the book's matplotlib style (colour-blind-safe palette, readable sizes).

    In a Jupyter kernel this also selects the inline backend, so notebooks render
    their figures the same way on every machine.

    Examples
    --------
    >>> import matplotlib
    >>> from trackcore.plotting import use_book_style
    >>> with matplotlib.rc_context():          # restore the caller's style afterwards
    ...     use_book_style()
    ...     matplotlib.rcParams["figure.dpi"], matplotlib.rcParams["figure.figsize"][0]
    ...
    (150.0, 7.5)
    """
    from cycler import cycler

    _use_inline_backend_in_kernel()
    matplotlib.rcParams.update({
        "figure.figsize": (BOOK_WIDTH, 4.0),
        "figure.dpi": 150,
        "savefig.dpi": 150,
        "axes.grid": True,
        "grid.alpha": 0.3,
        "axes.spines.top": False,
        "axes.spines.right": False,
        "axes.prop_cycle": cycler(color=list(BOOK_COLORS)),
        "font.size": 10,
        "axes.titlesize": 10,
        "axes.labelsize": 10,
        "xtick.labelsize": 9,
        "ytick.labelsize": 9,
        "legend.fontsize": 9,
        "legend.frameon": False,
        "image.cmap": "viridis",
    })


# --------------------------------------------------------------------------- recurring plots
# Each function draws on a given ``matplotlib.axes.Axes`` and returns it, so a
# notebook controls the figure layout and ends the cell with ``plt.show()``.


def _as_float_array(x, name, ndim=None):
    return as_array(x, name, ndim=ndim)


def _check_ax(ax):
    if not hasattr(ax, "plot") or not hasattr(ax, "set_xlabel"):
        raise TypeError(f"ax must be a matplotlib Axes, got {type(ax).__name__}")


def plot_rmse_vs_time(ax, t, curves, shade=None, *, xlabel="time [s]", ylabel="RMSE [m]",
                      shade_label="manoeuvre", styles=None):
    """RMSE (or any error) curves against time, with optional shaded windows.

    ``curves`` maps a legend label to an array of ``len(t)`` values; ``shade`` is a
    list of ``(start, stop)`` time intervals (e.g. manoeuvres) drawn as grey
    bands; ``styles`` optionally maps a label to ``Axes.plot`` keyword arguments.

    Examples
    --------
    >>> import numpy as np
    >>> from matplotlib.figure import Figure
    >>> from trackcore.plotting import plot_rmse_vs_time
    >>> ax = Figure().add_subplot()
    >>> t = np.arange(5.0)
    >>> ax = plot_rmse_vs_time(ax, t, {"CV": t + 1.0, "IMM": 0.5 * t + 1.0}, shade=[(1.0, 2.0)])
    >>> [line.get_label() for line in ax.get_lines()]
    ['CV', 'IMM']
    """
    _check_ax(ax)
    t = _as_float_array(t, "t", ndim=1)
    if not isinstance(curves, dict) or not curves:
        raise TypeError("curves must be a non-empty dict {label: values}")
    if styles is not None and not isinstance(styles, dict):
        raise TypeError(f"styles must be a dict {{label: Axes.plot keywords}}, "
                        f"got {type(styles).__name__}")
    styles = styles or {}
    intervals = []
    if shade is not None:
        try:
            intervals = [(float(a), float(b)) for a, b in shade]
        except (TypeError, ValueError):
            raise TypeError("shade must be a list of (start, stop) pairs of numbers") from None
    first = True
    for a, b in intervals:
        if not (np.isfinite(a) and np.isfinite(b) and a <= b):
            raise ValueError(f"shade intervals must be finite (start, stop) with start <= stop, "
                             f"got {(a, b)}")
        ax.axvspan(a, b, color="0.85", zorder=0, label=shade_label if first else None)
        first = False
    for label, values in curves.items():
        v = _as_float_array(values, f"curves[{label!r}]", ndim=1)
        if v.shape != t.shape:
            raise ValueError(f"curves[{label!r}] must have shape {t.shape}, got {v.shape}")
        ax.plot(t, v, label=label, **styles.get(label, {}))
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.legend()
    return ax


def plot_tracks_2d(ax, truth, estimates, measurements=None, *, units="m"):
    """Plan view of true trajectories, estimated tracks and (optionally) measurements.

    ``truth`` and each estimate are ``(n_steps, n)`` state arrays (``[x, y, ...]``)
    or lists of them (one per target); ``estimates`` may also be a dict
    ``{label: array or list}``.  ``measurements`` is a list of ``(m, 2)`` Cartesian
    scans (``m = 0`` allowed) or one ``(M, 2)`` array, drawn as small dots.

    Examples
    --------
    >>> import numpy as np
    >>> from matplotlib.figure import Figure
    >>> from trackcore.plotting import plot_tracks_2d
    >>> truth = np.column_stack([np.arange(5.0), np.zeros(5)])
    >>> ax = plot_tracks_2d(Figure().add_subplot(), truth, {"KF": truth + 0.1},
    ...                     measurements=[np.array([[1.0, 0.2]]), np.zeros((0, 2))])
    >>> ax.get_xlabel(), ax.get_ylabel()
    ('x [m]', 'y [m]')
    """
    _check_ax(ax)

    def track(a, name):
        arr = _as_float_array(a, name, ndim=2)
        if arr.shape[1] < 2:
            raise ValueError(f"{name} must be an (n_steps, n) state array with n >= 2 "
                             f"([x, y, ...]), got shape {arr.shape}")
        return arr

    def tracks(obj, name):
        if isinstance(obj, (list, tuple)):
            return [track(a, f"{name}[{i}]") for i, a in enumerate(obj)]
        return [track(obj, name)]

    if measurements is not None:
        if isinstance(measurements, (list, tuple)):
            scans = []
            for k, z in enumerate(measurements):
                zk = _as_float_array(z, f"measurements[{k}]", ndim=(1, 2))
                if zk.size and zk.shape[-1] != 2:
                    raise ValueError(f"measurements[{k}] must be (m, 2) Cartesian points, "
                                     f"got shape {zk.shape}")
                scans.append(zk.reshape(-1, 2))
            pts = np.concatenate(scans) if scans else np.zeros((0, 2))
        else:
            pts = _as_float_array(measurements, "measurements", ndim=2)
        if pts.shape[1] != 2:
            raise ValueError(f"measurements must be (m, 2) Cartesian points, got {pts.shape}")
        ax.plot(pts[:, 0], pts[:, 1], ".", color="0.6", ms=2, label="measurements", zorder=1)
    for i, tr in enumerate(tracks(truth, "truth")):
        ax.plot(tr[:, 0], tr[:, 1], "-", color="k", lw=1.5, label="truth" if i == 0 else None)
        ax.plot(tr[:1, 0], tr[:1, 1], "o", color="k", ms=4)
    est = estimates if isinstance(estimates, dict) else {"estimate": estimates}
    for j, (label, obj) in enumerate(est.items()):
        color = BOOK_COLORS[j % len(BOOK_COLORS)]
        for i, tr in enumerate(tracks(obj, f"estimates[{label!r}]")):
            ax.plot(tr[:, 0], tr[:, 1], "--", color=color, lw=1.2, label=label if i == 0 else None)
    ax.set_xlabel(f"x [{units}]")
    ax.set_ylabel(f"y [{units}]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.legend()
    return ax


def plot_count_vs_scan(ax, scans, mean_counts, truth, *, ylabel="number of targets"):
    """Mean estimated target count per scan for each method against the true count.

    Examples
    --------
    >>> import numpy as np
    >>> from matplotlib.figure import Figure
    >>> from trackcore.plotting import plot_count_vs_scan
    >>> ax = plot_count_vs_scan(Figure().add_subplot(), np.arange(4),
    ...                         {"PHD": [0.9, 1.8, 2.1, 2.0]}, truth=[1, 2, 2, 2])
    >>> [line.get_label() for line in ax.get_lines()]
    ['truth', 'PHD']
    """
    _check_ax(ax)
    k = _as_float_array(scans, "scans", ndim=1)
    tr = _as_float_array(truth, "truth", ndim=1)
    if tr.shape != k.shape:
        raise ValueError(f"truth must have shape {k.shape}, got {tr.shape}")
    if not isinstance(mean_counts, dict) or not mean_counts:
        raise TypeError("mean_counts must be a non-empty dict {label: values}")
    ax.step(k, tr, where="mid", color="k", lw=1.5, label="truth")
    for label, values in mean_counts.items():
        v = _as_float_array(values, f"mean_counts[{label!r}]", ndim=1)
        if v.shape != k.shape:
            raise ValueError(f"mean_counts[{label!r}] must have shape {k.shape}, got {v.shape}")
        ax.plot(k, v, label=label)
    ax.set_xlabel("scan")
    ax.set_ylabel(ylabel)
    ax.legend()
    return ax


def plot_consistency(ax, t, values, bounds, label="NEES", *, xlabel="time [s]"):
    """Run-averaged NEES/NIS against time with its chi-square acceptance band.

    ``bounds`` is ``(lower, upper)`` as returned by
    :func:`trackcore.metrics.chi2_bounds`; the fraction of points inside the
    band is added to the legend.

    Examples
    --------
    >>> import numpy as np
    >>> from matplotlib.figure import Figure
    >>> from trackcore.metrics import chi2_bounds
    >>> from trackcore.plotting import plot_consistency
    >>> ax = plot_consistency(Figure().add_subplot(), np.arange(4.0), [3.9, 4.2, 6.0, 4.1],
    ...                       chi2_bounds(4, 50))
    >>> ax.get_legend().get_texts()[0].get_text()
    '3.25-4.82 acceptance band'
    """
    _check_ax(ax)
    t = _as_float_array(t, "t", ndim=1)
    v = _as_float_array(values, "values", ndim=1)
    if v.shape != t.shape:
        raise ValueError(f"values must have shape {t.shape}, got {v.shape}")
    try:
        lo, hi = (float(b) for b in bounds)
    except (TypeError, ValueError):
        raise TypeError("bounds must be a (lower, upper) pair of numbers") from None
    if not lo <= hi:
        raise ValueError(f"bounds must satisfy lower <= upper, got {(lo, hi)}")
    inside = float(np.mean((v >= lo) & (v <= hi))) if v.size else float("nan")
    ax.axhspan(lo, hi, color=BOOK_COLORS[2], alpha=0.15,
               label=f"{lo:.2f}-{hi:.2f} acceptance band")
    ax.plot(t, v, color=BOOK_COLORS[0], label=f"{label} ({100 * inside:.0f} % inside)")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(f"average {label}")
    ax.legend()
    return ax


def paper_vs_ours_table(rows, headers=("quantity", "paper", "this book"), *, floatfmt=".3g"):
    """A Markdown table comparing the paper's numbers with ours (no pandas needed).

    ``rows`` is a sequence of equal-length sequences; floats are formatted with
    ``floatfmt``, ``None`` becomes an em dash, other values use ``str``.  Print the
    result in a notebook cell, or wrap it in ``IPython.display.Markdown``.

    Examples
    --------
    >>> from trackcore.plotting import paper_vs_ours_table
    >>> print(paper_vs_ours_table([["RMSE [m]", 12.0, 12.345], ["track loss", None, 0.02]]))
    | quantity   | paper | this book |
    | ---------- | ----- | --------- |
    | RMSE [m]   | 12    | 12.3      |
    | track loss | —     | 0.02      |
    """
    headers = [str(h) for h in headers]
    if isinstance(rows, (str, bytes)) or not hasattr(rows, "__iter__"):
        raise TypeError("rows must be a sequence of row sequences")

    def fmt(v):
        if v is None:
            return "\u2014"
        if isinstance(v, (float, np.floating)):
            return format(float(v), floatfmt)
        return str(v).replace("|", "\\|")

    body = []
    for i, row in enumerate(rows):
        if isinstance(row, (str, bytes)) or not hasattr(row, "__len__"):
            raise TypeError(f"rows[{i}] must be a sequence, got {type(row).__name__}")
        if len(row) != len(headers):
            raise ValueError(f"rows[{i}] has {len(row)} cells, expected {len(headers)} "
                             f"(one per header)")
        body.append([fmt(v) for v in row])
    widths = [max([len(h)] + [len(r[j]) for r in body]) for j, h in enumerate(headers)]
    lines = ["| " + " | ".join(h.ljust(w) for h, w in zip(headers, widths)) + " |",
             "| " + " | ".join("-" * w for w in widths) + " |"]
    lines += ["| " + " | ".join(c.ljust(w) for c, w in zip(r, widths)) + " |" for r in body]
    return "\n".join(lines)


def results_table(rows, headers, *, floatfmt=".3g", align=None):
    """A results table for display in a notebook: returns an ``IPython.display.Markdown``
    object (the book renders it as an HTML table; nbval checks its text).

    ``rows`` and ``headers`` are as in :func:`paper_vs_ours_table`; cells may hold
    strings (e.g. a formatted :class:`trackcore.stats.Estimate`), numbers or ``None``.
    ``align`` is an optional string of ``l``/``r``/``c``, one per column (default: left
    for the first column, right for the others).

    Examples
    --------
    >>> from trackcore.plotting import results_table
    >>> table = results_table([["IMM", "0.090 [0.077, 0.105]", 50]],
    ...                       ["filter", "RMSE [m]", "runs"])
    >>> print(table.data)
    | filter | RMSE [m]             | runs |
    | :-- | --: | --: |
    | IMM    | 0.090 [0.077, 0.105] | 50   |
    """
    from IPython.display import Markdown

    text = paper_vs_ours_table(rows, headers, floatfmt=floatfmt)
    n = len(headers)
    if align is None:
        align = "l" + "r" * (n - 1)
    if not isinstance(align, str) or len(align) != n or set(align) - set("lrc"):
        raise ValueError(f"align must be a string of l/r/c with one letter per column ({n})")
    marks = {"l": ":--", "r": "--:", "c": ":-:"}
    lines = text.split("\n")
    lines[1] = "| " + " | ".join(marks[a] for a in align) + " |"
    return Markdown("\n".join(lines))


def integer_ticks(ax, axis="x"):
    """Put ticks on whole numbers only (scan or frame axes). Returns ``ax``.

    Examples
    --------
    >>> from matplotlib.figure import Figure
    >>> from trackcore.plotting import integer_ticks
    >>> ax = Figure().add_subplot()
    >>> _ = ax.plot([0.0, 3.0], [0.0, 1.0])
    >>> integer_ticks(ax).get_xticks().tolist()
    [-1.0, 0.0, 1.0, 2.0, 3.0, 4.0]
    """
    from matplotlib.ticker import MaxNLocator

    _check_ax(ax)
    if axis not in ("x", "y", "both"):
        raise ValueError(f"axis must be 'x', 'y' or 'both', got {axis!r}")
    if axis in ("x", "both"):
        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    if axis in ("y", "both"):
        ax.yaxis.set_major_locator(MaxNLocator(integer=True))
    return ax
