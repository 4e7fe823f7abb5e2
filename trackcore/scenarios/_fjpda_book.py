"""Private presentation helpers of the feature-JPDA chapter's notebooks (004): verdict
bookkeeping, table rows and the track panels of the Fig 6-8 redraws.

They hold no algorithm: each turns results the notebooks computed into a verdict word, a
table row or a drawing, so that the notebooks show the experiment and not the plumbing.
This module is private (not re-exported, not part of the public API); tested in
``tests/test_fjpda_book.py``.
"""
from __future__ import annotations

import numpy as np

from ..core.validation import as_int

__all__: list[str] = []  # private: nothing is re-exported

#: the track states drawn solid and counted as reported in the redraws
REPORTED = ("confirmed", "memory")


def overall(verdicts, better="FJPDA better", worse="JPDA better"):
    """The chapter's scene rule over ``{scene: verdict}``: ``("reproduced", better,
    worse)`` when FJPDA is better in at least one scene and worse in none, else
    ``("not reproduced", ...)``; ``better`` and ``worse`` list the scenes."""
    if not isinstance(verdicts, dict):
        raise TypeError(f"verdicts must be a dict of scene -> verdict, got {verdicts!r}")
    b = [s for s, v in verdicts.items() if v == better]
    w = [s for s, v in verdicts.items() if v == worse]
    return ("reproduced" if b and not w else "not reproduced"), b, w


def paired_row(c, diff_fmt=".3g"):
    """``(mean A, mean B, difference [CI], "A better / B better", verdict)`` of a
    paired comparison (``trackcore.experiments.fjpda_readings.compare``)."""
    return (
        f"{c.mean_a:.3g}",
        f"{c.mean_b:.3g}",
        format(c.diff, diff_fmt),
        f"{c.a_better} / {c.b_better}",
        c.verdict,
    )


def first_differing(a, b, key, n):
    """The first index ``i < n`` with ``key(a[i]) != key(b[i])``, or ``None``."""
    n = as_int(n, "n", minimum=1)
    return next((i for i in range(n) if key(a[i]) != key(b[i])), None)


def reported_ids(report):
    return {s.tid for s in report.tracks if s.status in REPORTED}


def first_frame_apart(reps_a, reps_b, start=0):
    """The first frame from ``start`` whose reported track IDs differ between two
    report sequences, else the last frame."""
    if len(reps_a) != len(reps_b):
        raise ValueError(
            f"reps_a and reps_b must have the same length, got {len(reps_a)} "
            f"and {len(reps_b)}"
        )
    return next(
        (
            k
            for k in range(start, len(reps_a))
            if reported_ids(reps_a[k]) != reported_ids(reps_b[k])
        ),
        len(reps_a) - 1,
    )


def describe(name, reps, k):
    """One line: the reported tracks of frame ``k``."""
    tr = [s for s in reps[k].tracks if s.status in REPORTED]
    return f"{name}: {len(tr)} reported track(s) at frame {k}, IDs {[s.tid for s in tr]}"


def track_panel(ax, frame, reports, k, title, corner, trail=20):
    """Draw frame ``k`` (a 240 x 320 grey image) in a 200 x 100 px window from
    ``corner``: each track's last ``trail`` positions and its gate (solid when
    reported, dotted when tentative), reported tracks labelled by ID."""
    import matplotlib.pyplot as plt

    colors = plt.cm.tab10.colors
    ax.imshow(frame, cmap="gray", vmin=0, vmax=255, extent=(-0.5, 319.5, 239.5, -0.5))
    hist = {}
    for r in reports[max(0, k - trail) : k + 1]:
        for s in r.tracks:
            if s.status in REPORTED:
                hist.setdefault(s.tid, []).append((s.x, s.y))
    for tid, pts in hist.items():
        p = np.array(pts)
        ax.plot(p[:, 0], p[:, 1], color=colors[tid % 10], lw=1)
    for s in reports[k].tracks:
        col, solid = colors[s.tid % 10], s.status in REPORTED
        xy = (s.x - s.gate_x, s.y - s.gate_y)
        ax.add_patch(
            plt.Rectangle(
                xy, 2 * s.gate_x, 2 * s.gate_y, fill=False, ec=col,
                ls="-" if solid else ":", lw=1.2,
            )
        )  # fmt: skip
        if solid:
            ax.text(s.x + s.gate_x + 1, s.y - s.gate_y, str(s.tid), color=col, fontsize=9)
    c0, r0 = min(max(corner[0], 0), 120), min(max(corner[1], 0), 140)
    ax.set_xlim(c0, c0 + 200)
    ax.set_ylim(r0 + 100, r0)
    ax.grid(False)
    ax.set_title(title, fontsize=9)
    ax.set_xlabel("x (px)")
    ax.set_ylabel("y (px)")


def interval_ends(d):
    """``(value, lo, hi)`` of a difference: an interval estimate's ends, or the value
    three times where no interval exists (a ``NoInterval`` or a plain number)."""
    if hasattr(d, "lo") and hasattr(d, "hi"):
        return float(d.value), float(d.lo), float(d.hi)
    v = float(d)
    if not np.isfinite(v):
        raise ValueError(f"d must be an interval estimate or a finite number, got {d!r}")
    return v, v, v


def tsi_scan(points, sprite, masks=None):
    """The detections of one scripted frame: centroids ``points`` (x, y px), each with
    silhouette ``sprite`` unless ``masks`` (one per point) are given; empty boxes and
    zero areas (the track-management checks of 03 read only centroids and silhouettes)."""
    from ..detection.image import ImageDetections

    z = np.array(points, float).reshape(-1, 2)
    masks = [sprite] * len(z) if masks is None else list(masks)
    if len(masks) != len(z):
        raise ValueError(f"masks must hold one silhouette per point: {len(z)} points, "
                         f"{len(masks)} masks")
    return ImageDetections(
        z, np.zeros((len(z), 4), np.int64), np.zeros(len(z), np.int64), masks, masks
    )


def tsi_panel(ax, prev, points, report, tracks, gate=8.0, size=95):
    """Draw one frame of the TSI walk-through: the stored measurements ``prev`` with
    their ``gate`` px circles, the frame's measurements ``points``, and each track of
    ``report`` with its velocity arrow (from ``tracks``, the tracker's tracks) and its
    ``"<id>: <status>"`` label, in a ``size`` px square window (y down)."""
    import matplotlib.pyplot as plt

    prev, p = np.asarray(prev, float).reshape(-1, 2), np.array(points, float)
    for q in prev:
        ax.add_patch(plt.Circle(q, gate, fill=False, ls=":", color="0.5"))
    ax.plot(prev[:, 0], prev[:, 1], "s", mfc="none", color="0.5", label="stored")
    ax.plot(p[:, 0], p[:, 1], "o", color="C0", label="measurements")
    velocity = {t.tid: t.x[2:] for t in tracks}
    for s in report.tracks:
        v = velocity[s.tid]
        ax.annotate("", (s.x, s.y), (s.x - v[0], s.y - v[1]),
                    arrowprops={"arrowstyle": "->", "color": "C3"})
        ax.text(s.x + 2, s.y - 3, f"{s.tid}: {s.status}", color="C3", fontsize=9)
    ax.set_xlabel("x (px)")
    ax.set_xlim(0, size)
    ax.set_ylim(size, 0)


def tsi_log_row(k, report, stored):
    """``(frame k, "<id> <status>, ..." or "none", stored measurements)``."""
    tracks = ", ".join(f"{s.tid} {s.status}" for s in report.tracks) or "none"
    return (as_int(k, "k", minimum=0), tracks, as_int(stored, "stored", minimum=0))


def state_diagram(ax, nodes, edges, note, alert=("deleted",)):
    """Draw a state machine: ``nodes`` ``{name: (x, y)}`` in axes units (the names in
    ``alert`` shaded red), ``edges`` ``(from, to, label, rad, dy)`` arrows (``rad`` the
    arc's curvature, ``dy`` a vertical offset) and a centred ``note`` below them."""
    missing = {n for a, b, *_ in edges for n in (a, b)} - set(nodes)
    if missing:
        raise ValueError(f"edges name states that are not nodes: {sorted(missing)}")
    for n, (x0, y0) in nodes.items():
        fc = "#f4cccc" if n in alert else "0.92"
        ax.text(x0, y0, n, ha="center", va="center", fontsize=10,
                bbox={"boxstyle": "round", "fc": fc, "ec": "k"})
    for a, b, label, rad, dy in edges:
        (x0, y0), (x1, y1) = nodes[a], nodes[b]
        arrow = {"arrowstyle": "->", "connectionstyle": f"arc3,rad={rad}",
                 "shrinkA": 28, "shrinkB": 28}
        ax.annotate("", (x1, y1 + dy), (x0, y0 + dy), arrowprops=arrow)
        ax.text((x0 + x1) / 2, (y0 + y1) / 2 + dy + 0.07 * np.sign(rad or 1), label,
                ha="center", fontsize=9)
    ax.text(0.5, 0.25, note, ha="center", fontsize=9)
    ax.set_xlim(0, 1)
    ax.set_ylim(0, 0.8)
    ax.axis("off")
