"""Tables of the appendix "Performance" (book/appendix/performance.ipynb), built from the
stored rows of ``benchmarks/results/benchmarks.json`` with the accessors of
:mod:`benchmarks.report`. Private to that page: it formats, it measures nothing.
"""
from __future__ import annotations

from .report import ratio, row, rows, seconds

ACCURACY_HEADERS = ("targets x measurements", "clutter density", "events", "net arithmetic",
                    "net: largest relative error", "enumeration: largest relative error")


def accuracy_rows(results):
    """Rows of the JPDA accuracy table from the ``jpda_accuracy`` rows of trackcore."""
    return [(f"{r['targets']} x {r['measurements']}", f"{r['lam']:g}",
             f"{r['feasible_events']:,}",
             "scaled" if r["net_scaled_certified"] else "log space",
             f"{r['net_max_rel_error']:.1e}", f"{r['enumeration_max_rel_error']:.1e}")
            for r in results]


CLOSE_HEADERS = ("T", "m", "feasible events", "trackcore method", "trackcore step (ms)",
                 "tracker kernels (ms)", "EHM2 step (ms)", "JPDA step (ms)",
                 "trackcore marginals (us)", "EHM2 core (ms)", "marginals ratio")


def close_rows(data, sizes=(3, 5, 8)):
    """Rows of the "close targets" JPDA table: trackcore's whole step (public functions
    and tracker kernels), Stone Soup's JPDAwithEHM2 and JPDA steps, and the marginals
    alone against Stone Soup's EHM2 core, at each number of targets in ``sizes``."""
    out = []
    for T in sizes:
        ours = row(data, "jpda_close", "trackcore", T)
        kern = row(data, "jpda_close", "trackcore_kernels", T)
        ehm2 = row(data, "jpda_close", "stonesoup_JPDAwithEHM2", T)
        brute = row(data, "jpda_close", "stonesoup_JPDA", T)
        marg = row(data, "jpda_close_marginals", "trackcore", T)
        core = row(data, "jpda_close_marginals", "stonesoup_EHM2_core", T)
        out.append((T, ours["measurements"], f"{ours['feasible_events']:,}", ours["method"],
                    f"{seconds(ours) * 1e3:.2f}", f"{seconds(kern) * 1e3:.2f}",
                    f"{seconds(ehm2) * 1e3:.1f}", f"{seconds(brute) * 1e3:.0f}",
                    f"{seconds(marg) * 1e6:.0f}", f"{seconds(core) * 1e3:.2f}",
                    format(ratio(marg, core), ".3g")))
    return out


SERIES_HEADERS = ("scene", "T", "m", "feasible events", "method", "trackcore (s)",
                  "EHM2 (s)", "ratio")


def series_rows(data, ratios_by_scene):
    """Rows of the scaling-series table: for each scene (``"chain"``, ``"overlap"``) and
    each size trackcore ran, its time and, where Stone Soup's JPDAwithEHM2 ran
    (``ratios_by_scene[scene]``: ``{size: Ratio}``), the peer's time and the ratio."""
    out = []
    for scene, ratios in ratios_by_scene.items():
        for r in sorted(rows(data, f"jpda_{scene}", "trackcore"), key=lambda r: r["size"]):
            T = r["size"]
            peer = (f"{seconds(row(data, f'jpda_{scene}', 'stonesoup_JPDAwithEHM2', T)):.3g}"
                    if T in ratios else "not run")
            out.append((scene, T, r["measurements"], f"{r['feasible_events']:.3g}",
                        r["method"], f"{seconds(r):.3g}", peer,
                        format(ratios[T], ".3g") if T in ratios else ""))
    return out


MARCUM_SCALAR_HEADERS = ("SNR (dB)", "marcum_q1 (us)", "ncx2.sf (us)", "ratio",
                         "_ncx2_sf (us)", "ratio", "marcum_q1_complement (us)",
                         "chndtr (us)", "ratio")


def marcum_scalar_rows(data):
    """Rows of the per-scalar-call Marcum table, one per SNR (dB)."""
    out = []
    for r in sorted(rows(data, "marcum_scalar", "scipy_ncx2_sf"), key=lambda r: r["size"]):
        db = r["size"]
        ours = row(data, "marcum_scalar", "trackcore_q1", db)
        bare = row(data, "marcum_scalar", "scipy_ncx2_sf_ufunc", db)
        comp = row(data, "marcum_scalar", "trackcore_q1_complement", db)
        chn = row(data, "marcum_scalar", "scipy_chndtr", db)
        out.append((f"{db:g}", f"{seconds(ours) * 1e6:.2f}", f"{seconds(r) * 1e6:.1f}",
                    format(ratio(ours, r), ".3g"), f"{seconds(bare) * 1e6:.2f}",
                    format(ratio(ours, bare), ".3g"), f"{seconds(comp) * 1e6:.2f}",
                    f"{seconds(chn) * 1e6:.2f}", format(ratio(comp, chn), ".3g")))
    return out


def label_size(label: str) -> str:
    """The size or SNR in the last parentheses of a target row's label, without its
    ``T = `` prefix or `` dB`` suffix: ``"JPDA chain (T = 40)"`` gives ``"40"``."""
    if "(" not in label or ")" not in label.rsplit("(", 1)[1]:
        raise ValueError(f"label has no parenthesised size: {label!r}")
    return label.rsplit("(", 1)[1].split(")")[0].removeprefix("T = ").removesuffix(" dB")
