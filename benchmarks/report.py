"""Targets and ratios from ``benchmarks/results/benchmarks.json``.

    python -m benchmarks.report          # prints the README's benchmark table (Markdown)

One place computes every ratio the README and the appendix "Performance" show, from the
stored rows of one ``python -m benchmarks.run``.  A ratio is ``peer time / trackcore
time`` (above 1: trackcore is faster).  Where the two were timed in the same repetitions
(interleaved) the ratio of every repetition is formed and the median, minimum and maximum
over repetitions are given; for rows stored without repetition order (earlier runs) the
range is the conservative ``[min(peer)/max(ours), max(peer)/min(ours)]``.

A target is *met* when the median ratio reaches it and *met in every repetition* when the
minimum does too.
"""
from __future__ import annotations

import json
from pathlib import Path
from statistics import median

RESULTS = Path(__file__).resolve().parent / "results" / "benchmarks.json"


def load(path=RESULTS) -> dict:
    return json.loads(Path(path).read_text())


def rows(data, workload, implementation=None):
    return [r for r in data["results"] if r["workload"] == workload
            and (implementation is None or r["implementation"] == implementation)]


def row(data, workload, implementation, size=None):
    for r in rows(data, workload, implementation):
        if size is None or r["size"] == size:
            return r
    raise KeyError((workload, implementation, size))


def seconds(r) -> float:
    return next(v for k, v in r.items() if k.startswith("seconds_per_"))


class Ratio:
    """A ratio with its median, minimum and maximum over repetitions."""

    def __init__(self, med, lo, hi, paired=True):
        self.median, self.min, self.max, self.paired = med, lo, hi, paired

    def __format__(self, spec):
        spec = spec or ".3g"

        def f(v):
            return f"{v:,.0f}" if v >= 1000 else format(v, spec)

        return f"{f(self.median)}x [{f(self.min)}-{f(self.max)}]"

    def verdict(self, target):
        if self.min >= target:
            return "met in every repetition"
        if self.median >= target:
            return "met (not in every repetition)"
        return "NOT met"


def ratio(ours, peer) -> Ratio:
    """Peer over trackcore from two rows (see the module notes)."""
    if "ratio_to_trackcore" in peer and ours["implementation"] == "trackcore":
        s = peer["ratio_to_trackcore"]
        return Ratio(s["median"], s["min"], s["max"])
    if "ratio_to_trackcore_kernels" in peer and ours["implementation"] == "trackcore_kernels":
        s = peer["ratio_to_trackcore_kernels"]
        return Ratio(s["median"], s["min"], s["max"])
    to = ours.get("trials") or [seconds(ours)]
    tp = peer.get("trials") or [seconds(peer)]
    if ours.get("trials_order") == peer.get("trials_order") == "repetition":
        n = min(len(to), len(tp))
        r = [tp[i] / to[i] for i in range(n)]
        return Ratio(median(r), min(r), max(r))
    return Ratio(seconds(peer) / seconds(ours), min(tp) / max(to), max(tp) / min(to),
                 paired=False)


def series_ratios(data, workload, peer):
    """``{size: Ratio}`` of the peer against trackcore over a scaling series (sizes where
    the peer ran)."""
    out = {}
    for r in rows(data, workload, peer):
        out[r["size"]] = ratio(row(data, workload, "trackcore", r["size"]), r)
    return dict(sorted(out.items()))


def worst(ratios):
    """The ratio of the size whose minimum is smallest, and that size."""
    size = min(ratios, key=lambda k: ratios[k].min)
    return ratios[size], size


#: (SciPy path, trackcore path, label) of the Marcum comparisons
MARCUM_PAIRS = (
    ("scipy_ncx2_sf", "trackcore_q1", "Q1 vs ncx2.sf"),
    ("scipy_ncx2_sf_ufunc", "trackcore_q1", "Q1 vs the bare sf ufunc (_ncx2_sf)"),
    ("scipy_ncx2_cdf", "trackcore_q1_complement", "1 - Q1 vs ncx2.cdf"),
    ("scipy_chndtr", "trackcore_q1_complement", "1 - Q1 vs special.chndtr"),
)


def target_rows(data):
    """``(workload, peer, Ratio or value, target text, verdict)`` for every target."""
    out = []

    def add(label, peer, value, target, kind="x"):
        if kind == "none":
            out.append((label, peer, value, "none", ""))
        elif kind == "x":
            out.append((label, peer, value, f">= {target:g}x", value.verdict(target)))
        elif kind == "below":
            out.append((label, peer, value, f"< {target:g}",
                        "met" if value < target else "NOT met"))
        else:
            out.append((label, peer, value, f">= {target:g}",
                        "met" if value >= target else "NOT met"))

    kf = rows(data, "kf_cv4")
    if kf:
        add("KF 4-state, 1000 runs x 100 steps (kalman_filter_batch)", "filterpy",
            ratio(row(data, "kf_cv4", "trackcore_batch"), row(data, "kf_cv4", "filterpy")), 50)
    if rows(data, "imm_3models"):
        add("IMM 3 models, 200 x 100", "filterpy",
            ratio(row(data, "imm_3models", "trackcore"), row(data, "imm_3models", "filterpy")),
            100)
    for N, target in ((1000, 30), (100000, 10)):
        if rows(data, "bootstrap_pf", "trackcore_kernel"):
            add(f"bootstrap PF kernel, N = {N:.0e}".replace("e+0", "e"), "Stone Soup",
                ratio(row(data, "bootstrap_pf", "trackcore_kernel", N),
                      row(data, "bootstrap_pf", "stonesoup", N)), target)
    tp = rows(data, "bootstrap_pf_two_processes")
    if tp:
        add("PF, two processes, N = 1e5 (M particle-updates/s, CPU time)", "",
            tp[0]["particle_updates_per_second"] / 1e6, 25, kind="abs")
    if rows(data, "smc_phd"):
        add("SMC-PHD, 3 targets, 3000 particles, 10 clutter", "Stone Soup (likelihood corrected)",
            ratio(row(data, "smc_phd", "trackcore_kernel"), row(data, "smc_phd", "stonesoup")),
            50)
        add("SMC-PHD mean cardinality difference", "abs(trackcore - Stone Soup)",
            abs(row(data, "smc_phd", "trackcore_kernel")["mean_cardinality_difference"]), 0.1,
            kind="below")
    if rows(data, "jpda_close"):
        add("JPDA, 8 close targets, 10 clutter, whole step", "Stone Soup JPDA",
            ratio(row(data, "jpda_close", "trackcore", 8),
                  row(data, "jpda_close", "stonesoup_JPDA", 8)), 10)
        for T in (3, 5, 8):
            add(f"JPDA, {T} close targets, whole step (public functions)",
                "Stone Soup JPDAwithEHM2",
                ratio(row(data, "jpda_close", "trackcore", T),
                      row(data, "jpda_close", "stonesoup_JPDAwithEHM2", T)), 10)
        for T in (3, 5, 8):
            add(f"JPDA, {T} close targets, whole step (tracker kernels)",
                "Stone Soup JPDAwithEHM2",
                ratio(row(data, "jpda_close", "trackcore_kernels", T),
                      row(data, "jpda_close", "stonesoup_JPDAwithEHM2", T)), 10)
        for T in (3, 5, 8):
            add(f"JPDA marginals alone, {T} close targets (same hypotheses)",
                "Stone Soup EHM2 (TrackClusterer + EHMTree)",
                ratio(row(data, "jpda_close_marginals", "trackcore", T),
                      row(data, "jpda_close_marginals", "stonesoup_EHM2_core", T)), None,
                kind="none")
        for scene, text in (("chain", "chain of targets"), ("overlap", "fully overlapping")):
            s = series_ratios(data, f"jpda_{scene}", "stonesoup_JPDAwithEHM2")
            if s:
                w, size = worst(s)
                sizes = sorted(r["size"] for r in rows(data, f"jpda_{scene}", "trackcore"))
                peer = sorted(s)
                cover = (f"T = {sizes[0]}-{sizes[-1]}" if peer[-1] == sizes[-1] else
                         f"T = {sizes[0]}-{sizes[-1]}, Stone Soup run at T <= {peer[-1]}")
                add(f"JPDA {text} ({cover}): smallest ratio (T = {size})",
                    "Stone Soup JPDAwithEHM2", w, 1)
    if rows(data, "marcum_array"):
        for key, how in (("marcum_array", "per element, SNR 0-40 dB"),
                         ("marcum_scalar", "per scalar call, SNR 0-40 dB")):
            for peer, ours, text in MARCUM_PAIRS:
                if not rows(data, key, peer):
                    continue
                s = {r["size"]: ratio(row(data, key, ours, r["size"]), r)
                     for r in rows(data, key, peer)}
                w, size = worst(s)
                add(f"Marcum {text}, {how}: smallest ratio ({size:g} dB)", "scipy", w, 1)
    if rows(data, "hpda_rank_probabilities"):
        add("HPDA rank probabilities, m <= 500 (us per (l, m) pair)", "",
            seconds(row(data, "hpda_rank_probabilities", "trackcore")) * 1e6, 1.0, kind="below")
    return out


def _fmt(value):
    if isinstance(value, Ratio):
        return format(value, ".3g")
    return f"{value:.3g}"


def runs(data):
    """``[(workload keys, measured)]`` of the runs whose rows the file holds, oldest first
    (``measured``: commit, date and load average at the start of that run)."""
    out = {}
    for r in data["results"]:
        m = r.get("measured", {})
        out.setdefault((m.get("commit"), m.get("date")), (set(), m))[0].add(r.get("key"))
    return sorted(out.values(), key=lambda v: v[1].get("date") or "")


def readme_table(data) -> str:
    import textwrap

    m = data["machine"]
    parts = []
    for keys, meas in runs(data):
        load = f"1-minute load average {meas['load_average_1_5_15min'][0]:.1f} at the start"
        if meas.get("commit") == m["commit"] and meas.get("date") == m["date"]:
            load += f", {m['load_average_at_end_1_5_15min'][0]:.1f} at the end"
        parts.append(f"the {', '.join(sorted(keys))} workloads at commit {meas['commit']} "
                     f"({meas['date']}; {load})")
    intro = (
        "Measured with `python -m benchmarks.run` on the 2-core development machine, shared "
        f"with other jobs: {'; '.join(parts)}. Times are process CPU time (see "
        "`benchmarks/README.md`). Each ratio is the peer's time over trackcore's: the "
        "median over interleaved repetitions, with the smallest and largest repetition in "
        "brackets; a target is met when the median reaches it.")
    lines = [
        textwrap.fill(intro, 95, break_on_hyphens=False),
        "",
        "| workload | against | measured | target | verdict |",
        "|---|---|---|---|---|",
    ]
    for label, peer, value, target, verdict in target_rows(data):
        lines.append(f"| {label} | {peer} | {_fmt(value)} | {target} | {verdict} |")
    return "\n".join(lines)


def readme_notes(data) -> str:
    """The README's paragraph on JPDA and the sentence on Marcum Q per scalar call, with
    the numbers of the stored run."""
    import textwrap

    from .bench_association import EHM2_BUDGET_S

    choice = {r["size"]: r for r in rows(data, "jpda_choice", "net_over_enumeration")}
    small = choice["1-100"]
    over = series_ratios(data, "jpda_overlap", "stonesoup_JPDAwithEHM2")
    big = max(over)
    top = max(r["size"] for r in rows(data, "jpda_overlap", "trackcore"))
    t_peer = seconds(row(data, "jpda_overlap", "stonesoup_JPDAwithEHM2", big))
    t_top = seconds(row(data, "jpda_overlap", "trackcore", top))
    pub = seconds(row(data, "jpda_close", "trackcore", 3))
    ker = seconds(row(data, "jpda_close", "trackcore_kernels", 3))
    scal = {peer: worst({r["size"]: ratio(row(data, "marcum_scalar", ours, r["size"]), r)
                         for r in rows(data, "marcum_scalar", peer)})[0]
            for peer, ours, _ in MARCUM_PAIRS if rows(data, "marcum_scalar", peer)}
    jpda = (
        "JPDA is exact in both libraries. trackcore's `jpda_marginals` enumerates the "
        "feasible joint events when the whole validation matrix (not each cluster) has at "
        "most 100 combinations of per-target choices (the product over targets of 1 + "
        "gated measurements), and otherwise runs a hypothesis net (one node per subset of "
        "the frontier between processed and unprocessed elements, forward and backward "
        "weights, the connected components of the validation graph one after the other), "
        "the idea of Stone Soup's `JPDAwithEHM2` compiled with numba, in scaled arithmetic "
        "where a layer-by-layer certificate shows that no term can underflow and in log "
        "space otherwise. The enumeration is kept on the small problems so that their "
        "results stay bit for bit the same, not because it is faster: there the net takes "
        f"{small['median']:.2f} of its time (median over {len(small['problems'])} random "
        "problems). Stone Soup's Kalman predictions are LRU-cached, so its caches are "
        "cleared before every timed call, outside the timing, and both libraries get a "
        "warm-up call. The close-target and chain scenes are cheap for both nets; when every "
        "gate holds every measurement the cost of any exact method grows exponentially, "
        f"and Stone Soup was not run beyond the first size where one call took more than "
        f"{EHM2_BUDGET_S:g} s (T = {big}, {t_peer:.3g} s): above T = {big} \"ahead\" is an "
        f"inference (trackcore's {t_top:.3g} s at T = {top} is below Stone Soup's time at "
        f"T = {big}), not a measurement. With three close targets the argument checks and "
        "Python calls of the public `kf_predict` and `mahalanobis_gate`, once per target, "
        f"are {100 * (pub - ker) / pub:.0f} % of trackcore's step; the \"tracker kernels\" "
        "rows run the same step the way trackcore's JPDA tracker does.")
    marcum = (
        f"Per scalar call the {scal['scipy_ncx2_sf'].median:.0f}x against `ncx2.sf` "
        "measures the Python machinery of SciPy's distribution object; against its bare "
        f"ufuncs trackcore is {scal['scipy_ncx2_sf_ufunc']:.3g} (`_ncx2_sf`) and "
        f"{scal['scipy_chndtr']:.3g} (`chndtr`) faster (at the SNR with the smallest "
        "ratio).")
    return (textwrap.fill(jpda, 95, break_on_hyphens=False) + "\n\n"
            + textwrap.fill(marcum, 95, break_on_hyphens=False))


def main() -> int:
    data = load()
    print(readme_table(data))
    print()
    print(readme_notes(data))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
