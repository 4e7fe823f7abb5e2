"""Association benchmarks.

JPDA, whole association step and marginals alone, trackcore against Stone Soup's ``JPDA``
(brute-force product of the per-track hypotheses) and ``JPDAwithEHM2`` (efficient
hypothesis management, Horridge & Maskell), with the same ``PDAHypothesiser`` model
(``prob_detect``, ``prob_gate``, ``clutter_spatial_density``).  All must give the same
association probabilities (max abs difference < 1e-9) before any time is recorded.

Scenes (4-state CV, position measurements, one scan after a 1 s prediction):

* ``close``: T = 3, 5, 8 targets on a line 12 m apart (gates overlapping their
  neighbours'), 10 clutter detections in the box around them (the wave-1 scenes);
* ``chain``: the same line of T = 2 ... 24 targets with T clutter detections (about 2T
  measurements: 46 at T = 24);
* ``overlap``: T = 2 ... 20 targets within 3 m of each other and T clutter detections
  within 5 m of their centre: every gate holds every measurement (m = 2T; checked).

Paths timed: ``trackcore`` -- the whole step with the public functions a user calls
(``kf_predict``, ``mahalanobis_gate``, Gaussian likelihoods, :func:`jpda_marginals` with
its automatic choice between enumeration and the hypothesis net; the targets are judged
on this path); ``trackcore_kernels`` (close scenes) -- the same step the way trackcore's
JPDA tracker runs it, calling the prediction and gating kernels directly; ``stonesoup_*`` --
``associate`` of each data associator (hypothesis generation included).  Marginals alone:
``jpda_marginals`` (automatic, and forced enumeration) against Stone Soup's
``TrackClusterer`` + ``EHMTree`` on the already generated hypotheses.  Every repetition
times trackcore and the peer back to back (interleaved); the ratio of each repetition is
stored, so every ratio comes with its min-max over repetitions.  Stone Soup's EHM2 is not
run on a scene larger than one where a single call took longer than ``EHM2_BUDGET_S``.

Equal work: Stone Soup's ``KalmanPredictor.predict`` and ``KalmanUpdater.
predict_measurement`` are LRU-cached on their arguments, so repeating ``associate`` on the
same tracks and timestamp would skip the predictions that trackcore redoes.  Every
Stone Soup call is therefore preceded, outside the timed region, by clearing those caches
(:func:`clear_stonesoup_caches`), and both libraries get an untimed warm-up call first.

Choice and accuracy (rows ``jpda_choice`` and ``jpda_accuracy``): the public call with the
enumeration and with the net on random problems binned by the bound ``prod_t (1 +
gated measurements)`` that ``method="auto"`` compares with 100; and the error of both
methods against exact rational arithmetic on all-valid problems with millions of events.

Stone Soup weighs a missed detection by ``1 - P_D P_G`` and a detection by
``P_D N(z; z_hat, S) / lambda``: exactly trackcore's parametric JPDA with detection
probability ``P_D P_G`` and the gate-truncated likelihood ``N / P_G``.

HPDA: :func:`trackcore.association.hpda_log_rank_probabilities` for m = 1..500 (all
``l = 1..m``); time per ``(l, m)`` pair; checked against the closed form
``sum_l P(M_T^l, m) = P_D P_G mu_F(m - 1)`` in log space for every m.
"""
from __future__ import annotations

import datetime
import math
from statistics import median

import numpy as np

from trackcore.association import (
    gate_threshold,
    hpda_log_rank_probabilities,
    jpda_marginals,
    mahalanobis_gate,
)
from trackcore.association.gating import mahalanobis_gate_kernel
from trackcore.core.logmath import logsumexp
from trackcore.filters import kf_predict
from trackcore.filters.kalman import cholesky_lower_kernel, kf_predict_kernel
from trackcore.models import cv_process_noise, cv_transition, position_matrix

from ._common import Stopwatch, record

PD, PG, SPACING = 0.9, 0.99, 12.0
N_CLUTTER = 10
Q_PSD = 0.5
R_VAR = 9.0
P_POS, P_VEL = 25.0, 1.0
CHAIN_SIZES = (2, 4, 6, 8, 10, 12, 16, 20, 24)
OVERLAP_SIZES = (2, 3, 4, 5, 6, 7, 8, 10, 12, 14, 16, 18, 20)
#: a scene larger than one where a single Stone Soup call took longer is not run
EHM2_BUDGET_S = 8.0


def jpda_scene(T: int, seed: int = 0, n_clutter: int = N_CLUTTER):
    """Priors (T, 4) in trackcore order, P0, the scan (m, 2) and the clutter density:
    T targets on a line ``SPACING`` apart, detected with probability ``PD``, and
    ``n_clutter`` uniform clutter detections in the box 30 m around them."""
    rng = np.random.default_rng(seed + 100 * T)
    x0 = np.zeros((T, 4))
    x0[:, 0] = SPACING * np.arange(T)
    x0[:, 2] = 1.0
    P0 = np.diag([P_POS, P_POS, P_VEL, P_VEL])
    F = cv_transition(1.0)
    truth = x0 @ F.T
    det = truth[:, :2] + math.sqrt(R_VAR) * rng.standard_normal((T, 2))
    det = det[rng.random(T) < PD]
    lo = np.array([-30.0, -30.0])
    hi = np.array([SPACING * (T - 1) + 30.0, 30.0])
    clutter = lo + (hi - lo) * rng.random((n_clutter, 2))
    Z = np.ascontiguousarray(np.vstack([det, clutter]))
    lam = n_clutter / float(np.prod(hi - lo))
    return x0, P0, Z, lam


def chain_scene(T: int, seed: int = 0):
    """The line of T targets with T clutter detections (about 2T measurements)."""
    return jpda_scene(T, seed + 7, n_clutter=T)


def overlap_scene(T: int, seed: int = 0):
    """T targets within 3 m of the origin, every one detected, and T clutter detections
    within 5 m of their predicted centre: every gate holds all 2T measurements."""
    rng = np.random.default_rng(seed + 1000 + T)
    r = 3.0 * np.sqrt(rng.random(T))
    phi = 2.0 * np.pi * rng.random(T)
    x0 = np.zeros((T, 4))
    x0[:, 0] = r * np.cos(phi)
    x0[:, 1] = r * np.sin(phi)
    x0[:, 2] = 1.0
    P0 = np.diag([P_POS, P_POS, P_VEL, P_VEL])
    truth = x0 @ cv_transition(1.0).T
    det = truth[:, :2] + math.sqrt(R_VAR) * rng.standard_normal((T, 2))
    rc = 5.0 * np.sqrt(rng.random(T))
    pc = 2.0 * np.pi * rng.random(T)
    clutter = np.column_stack([1.0 + rc * np.cos(pc), rc * np.sin(pc)])
    Z = np.ascontiguousarray(np.vstack([det, clutter]))
    lam = T / (math.pi * 25.0)
    return x0, P0, Z, lam


def _model():
    """The scene's model for trackcore: ``(F, Q, H, R, gamma)``."""
    return (cv_transition(1.0), cv_process_noise(1.0, Q_PSD, kind="cwna"), position_matrix(),
            np.eye(2) * R_VAR, gate_threshold(PG, 2))


def trackcore_hypotheses(x0, P0, Z, lam):
    """Predictions, gates and likelihoods with trackcore's public functions: ``(lik,
    valid)`` in the form Stone Soup's PDAHypothesiser uses (``N / P_G``)."""
    F, Q, H, R, gamma = _model()
    T = x0.shape[0]
    m = Z.shape[0]
    valid = np.zeros((m, T), dtype=bool)
    lik = np.zeros((m, T))
    for t in range(T):
        xp, Pp = kf_predict(x0[t], P0, F, Q)
        S = H @ Pp @ H.T + R
        mask, d2 = mahalanobis_gate(Z, H @ xp, S, gamma)
        valid[:, t] = mask
        lik[:, t] = np.exp(-0.5 * d2) / (2.0 * math.pi * math.sqrt(np.linalg.det(S)))
    return lik / PG, valid


def trackcore_hypotheses_kernels(x0, P0, Z, lam):
    """:func:`trackcore_hypotheses` the way trackcore's JPDA tracker computes them: the
    tracker validated its inputs once and calls the numba kernels directly."""
    F, Q, H, R, gamma = _model()
    T = x0.shape[0]
    m = Z.shape[0]
    valid = np.zeros((m, T), dtype=bool)
    lik = np.zeros((m, T))
    xp = np.empty(4)
    Pp = np.empty((4, 4))
    L = np.zeros((2, 2))
    gmask = np.zeros(m, np.bool_)
    d2 = np.empty(m)
    for t in range(T):
        kf_predict_kernel(x0[t], P0, F, Q, xp, Pp)
        S = H @ Pp @ H.T + R
        cholesky_lower_kernel(S, L)
        mahalanobis_gate_kernel(Z, H @ xp, L, gamma, -1, gmask, d2)
        valid[:, t] = gmask
        lik[gmask, t] = np.exp(-0.5 * d2[gmask]) / (2.0 * math.pi * L[0, 0] * L[1, 1])
    return lik / PG, valid


def trackcore_jpda_kernels(x0, P0, Z, lam):
    """The whole association step as trackcore's JPDA tracker runs it."""
    lik, valid = trackcore_hypotheses_kernels(x0, P0, Z, lam)
    return jpda_marginals(lik, valid, PD * PG, lam)


def trackcore_jpda(x0, P0, Z, lam, method="auto"):
    """The whole association step: predictions, gates, likelihoods, marginals."""
    lik, valid = trackcore_hypotheses(x0, P0, Z, lam)
    # Stone Soup's PDAHypothesiser model: P_D P_G for detection, N / P_G in the gate
    return jpda_marginals(lik, valid, PD * PG, lam, method=method)


def _stonesoup_setup(x0, P0, Z, lam):
    from stonesoup.hypothesiser.probability import PDAHypothesiser
    from stonesoup.models.measurement.linear import LinearGaussian
    from stonesoup.models.transition.linear import (
        CombinedLinearGaussianTransitionModel,
        ConstantVelocity,
    )
    from stonesoup.predictor.kalman import KalmanPredictor
    from stonesoup.types.detection import Detection
    from stonesoup.types.state import GaussianState
    from stonesoup.types.track import Track
    from stonesoup.updater.kalman import KalmanUpdater

    t0 = datetime.datetime(2026, 1, 1)
    t1 = t0 + datetime.timedelta(seconds=1)
    perm = [0, 2, 1, 3]  # trackcore [x, y, vx, vy] -> Stone Soup [x, vx, y, vy]
    tm = CombinedLinearGaussianTransitionModel([ConstantVelocity(Q_PSD), ConstantVelocity(Q_PSD)])
    mm = LinearGaussian(4, (0, 2), np.eye(2) * R_VAR)
    hyp = PDAHypothesiser(KalmanPredictor(tm), KalmanUpdater(mm), clutter_spatial_density=lam,
                          prob_detect=PD, prob_gate=PG)
    tracks = [Track([GaussianState(x[perm].reshape(-1, 1), P0[np.ix_(perm, perm)], timestamp=t0)])
              for x in x0]
    dets = [Detection(z.reshape(-1, 1), timestamp=t1, measurement_model=mm) for z in Z]
    return hyp, tracks, dets, t1


def _stonesoup_betas(assoc, tracks, dets):
    """(m + 1, T) marginals in trackcore's layout from a Stone Soup association."""
    out = np.zeros((len(dets) + 1, len(tracks)))
    index = {id(d): j for j, d in enumerate(dets)}
    for t, track in enumerate(tracks):
        for h in assoc[track]:
            if h:
                out[index[id(h.measurement)] + 1, t] = float(h.probability)
            else:
                out[0, t] = float(h.probability)
    return out


def clear_stonesoup_caches():
    """Clear every LRU cache of Stone Soup's Kalman predictor and updater classes (on the
    methods and on what they wrap), so that the next ``associate`` predicts again."""
    from stonesoup.predictor.kalman import KalmanPredictor
    from stonesoup.updater.kalman import KalmanUpdater

    n = 0
    for cls in (*KalmanPredictor.__mro__, *KalmanUpdater.__mro__):
        for attr in vars(cls).values():
            f = attr
            while f is not None:
                if hasattr(f, "cache_clear"):
                    f.cache_clear()
                    n += 1
                f = getattr(f, "__wrapped__", None)
    return n


def _stonesoup_call(fn):
    """``(CPU s, wall s, result)`` of one Stone Soup call, its caches cleared first
    (outside the timed region)."""
    clear_stonesoup_caches()
    with Stopwatch() as sw:
        res = fn()
    return sw.cpu, sw.wall, res


def _ehm2_core(hypotheses):
    """Stone Soup's EHM2 marginals on already generated hypotheses (clustering, tree,
    posterior): the part of ``JPDAwithEHM2.associate`` that trackcore's net replaces."""
    from stonesoup.dataassociator._ehm import TrackClusterer
    from stonesoup.dataassociator.probability import JPDAwithEHM2

    out = {}
    for cluster in TrackClusterer(hypotheses).clustered_hypotheses:
        out.update(JPDAwithEHM2._get_tree(cluster).get_posterior_hypotheses())
    return out


def _time_calls(fn, min_seconds=0.02, max_calls=2000):
    """(CPU s per call, wall s per call, last result): ``fn`` repeated until at least
    ``min_seconds`` of CPU time."""
    res = fn()                       # warm-up (loads the compiled kernels)
    n = 1
    while True:
        with Stopwatch() as sw:
            for _ in range(n):
                res = fn()
        if sw.cpu >= min_seconds or n >= max_calls:
            return sw.cpu / n, sw.wall / n, res
        n = min(max_calls, max(2 * n, int(n * 1.5 * min_seconds / max(sw.cpu, 1e-6))))


def _ratio_summary(ours, peer):
    """Per-repetition ratios peer/ours (paired, interleaved) with median, min and max."""
    r = [p / o for o, p in zip(ours, peer)]
    return {"median": median(r), "min": min(r), "max": max(r), "per_repetition": r}


def _check(name, beta, ref, what):
    d = float(np.max(np.abs(beta - ref)))
    if not d < 1e-9:
        raise AssertionError(f"JPDA {what}: trackcore and {name} marginals differ by {d:g}")
    return d


def _scene_rows(scene, T, x0, P0, Z, lam, peers, reps, marginals_only=False):
    """Interleaved timing of trackcore and the peers on one scan; rows for each."""
    from stonesoup.dataassociator.probability import JPDA, JPDAwithEHM2

    hyp, tracks, dets, t1 = _stonesoup_setup(x0, P0, Z, lam)
    lik, valid = trackcore_hypotheses(x0, P0, Z, lam)
    if scene == "overlap" and not valid.all():
        raise AssertionError(f"overlap scene T={T}: not every gate holds every measurement")
    beta, n_events = trackcore_jpda(x0, P0, Z, lam)
    enum_product = float(np.prod(1.0 + valid.sum(axis=0)))
    impls = {"stonesoup_JPDA": JPDA(hyp), "stonesoup_JPDAwithEHM2": JPDAwithEHM2(hyp)}
    times = {"trackcore": [], **{k: [] for k in peers}}
    if marginals_only:
        times["trackcore_kernels"] = []
    walls = {k: [] for k in times}
    diffs = {}
    m_times = {"trackcore": [], "stonesoup_EHM2_core": []}
    hypotheses = impls["stonesoup_JPDAwithEHM2"].generate_hypotheses(set(tracks), set(dets), t1) \
        if marginals_only else None
    # untimed warm-up of both libraries (trackcore's is inside _time_calls)
    for name in peers:
        _stonesoup_call(lambda: impls[name].associate(set(tracks), set(dets), t1))
    if marginals_only:
        _ehm2_core(hypotheses)
    for rep in range(reps):
        cpu, wall, (b, _) = _time_calls(lambda: trackcore_jpda(x0, P0, Z, lam))
        times["trackcore"].append(cpu)
        walls["trackcore"].append(wall)
        if marginals_only:
            cpu, wall, (bk, _) = _time_calls(lambda: trackcore_jpda_kernels(x0, P0, Z, lam))
            times["trackcore_kernels"].append(cpu)
            walls["trackcore_kernels"].append(wall)
            if not np.max(np.abs(bk - b)) < 1e-12:
                raise AssertionError(f"JPDA {scene} T={T}: kernel path differs")
        for name in peers:
            cpu, wall, res = _stonesoup_call(
                lambda: impls[name].associate(set(tracks), set(dets), t1))
            times[name].append(cpu)
            walls[name].append(wall)
            diffs[name] = _check(name, b, _stonesoup_betas(res, tracks, dets), f"{scene} T={T}")
        if marginals_only:
            cpu, _, _ = _time_calls(lambda: jpda_marginals(lik, valid, PD * PG, lam))
            m_times["trackcore"].append(cpu)
            with Stopwatch() as sw:
                post = _ehm2_core(hypotheses)
            m_times["stonesoup_EHM2_core"].append(sw.cpu)
    common = {"scene": scene, "targets": T, "measurements": int(Z.shape[0]),
              "feasible_events": _num(n_events), "brute_force_product": enum_product,
              "max_abs_diff": diffs, "method": "enumerate" if enum_product <= 100 else "net",
              "stonesoup_caches": "cleared before every timed call; warm-up call first"}
    rows = [record(f"jpda_{scene}", "trackcore", T, median(times["trackcore"]), unit="scan",
                   trials=times["trackcore"], wall=walls["trackcore"], **common)]
    if marginals_only:
        rows.append(record(f"jpda_{scene}", "trackcore_kernels", T,
                           median(times["trackcore_kernels"]), unit="scan",
                           trials=times["trackcore_kernels"], wall=walls["trackcore_kernels"],
                           **common))
    for name in peers:
        extra = {}
        if marginals_only:
            extra["ratio_to_trackcore_kernels"] = _ratio_summary(times["trackcore_kernels"],
                                                                 times[name])
        rows.append(record(f"jpda_{scene}", name, T, median(times[name]), unit="scan",
                           trials=times[name], wall=walls[name],
                           ratio_to_trackcore=_ratio_summary(times["trackcore"], times[name]),
                           **extra, **common))
    if marginals_only:
        # the enumeration alone on the same matrices, for the record
        cpu_enum, _, (b_enum, _) = _time_calls(
            lambda: jpda_marginals(lik, valid, PD * PG, lam, method="enumerate"))
        ref = {}
        for t, track in enumerate(tracks):
            for h, p in post[track]:
                ref[(t, -1 if not h else dets.index(h.measurement))] = float(p)
        core = np.zeros_like(beta)
        for (t, j), p in ref.items():
            core[j + 1, t] = p
        d = _check("Stone Soup EHMTree", beta, core, f"{scene} T={T} (marginals only)")
        rows.append(record(f"jpda_{scene}_marginals", "trackcore", T, median(m_times["trackcore"]),
                           unit="scan", trials=m_times["trackcore"],
                           enumeration_seconds=cpu_enum, **common))
        rows.append(record(f"jpda_{scene}_marginals", "stonesoup_EHM2_core", T,
                           median(m_times["stonesoup_EHM2_core"]), unit="scan",
                           trials=m_times["stonesoup_EHM2_core"], max_abs_diff_core=d,
                           ratio_to_trackcore=_ratio_summary(m_times["trackcore"],
                                                             m_times["stonesoup_EHM2_core"]),
                           **common))
        if not np.max(np.abs(b_enum - beta)) < 1e-12:
            raise AssertionError(f"JPDA {scene} T={T}: enumeration and net differ")
    return rows


def bench_jpda(targets=(3, 5, 8), chain=CHAIN_SIZES, overlap=OVERLAP_SIZES) -> list[dict]:
    """The close-target scenes (whole step against JPDA and EHM2, and marginals alone
    against EHM2's core), then the chain and fully overlapping scaling series."""
    rows = []
    trackcore_jpda(*jpda_scene(3))  # load the compiled kernels
    trackcore_jpda(*overlap_scene(4))
    for T in targets:
        rows += _scene_rows("close", T, *jpda_scene(T),
                            peers=("stonesoup_JPDA", "stonesoup_JPDAwithEHM2"), reps=5,
                            marginals_only=True)
    for scene, sizes, make in (("chain", chain, chain_scene), ("overlap", overlap, overlap_scene)):
        skip_peer = False
        for T in sizes:
            x0, P0, Z, lam = make(T)
            if skip_peer:
                lik, valid = trackcore_hypotheses(x0, P0, Z, lam)
                cpu = []
                wall = []
                for _ in range(3):
                    c, w, (b, n) = _time_calls(lambda: trackcore_jpda(x0, P0, Z, lam), 0.05, 50)
                    cpu.append(c)
                    wall.append(w)
                rows.append(record(f"jpda_{scene}", "trackcore", T, median(cpu), unit="scan",
                                   trials=cpu, wall=wall, scene=scene, targets=T,
                                   measurements=int(Z.shape[0]), feasible_events=_num(n),
                                   brute_force_product=float(np.prod(1.0 + valid.sum(axis=0))),
                                   method="net", peer_not_run=(
                                       f"a smaller scene took Stone Soup's EHM2 more than "
                                       f"{EHM2_BUDGET_S:g} s per call")))
                continue
            new = _scene_rows(scene, T, x0, P0, Z, lam, peers=("stonesoup_JPDAwithEHM2",),
                              reps=3)
            rows += new
            if max(new[1]["trials"]) > EHM2_BUDGET_S:
                skip_peer = True
    rows += bench_jpda_choice()
    rows += bench_jpda_accuracy()
    return rows


def _num(n):
    """An event count for the JSON file (an int when exact, else a float)."""
    return n if isinstance(n, int) else float(n)


CHOICE_BINS = ((1, 100), (101, 1000), (1001, 10000))
CHOICE_PER_BIN = 20


def bench_jpda_choice(seed: int = 20261201) -> list[dict]:
    """The public ``jpda_marginals`` with ``method="enumerate"`` and ``method="net"`` on
    random problems (m <= 8, T <= 5, Gaussian-like likelihoods), binned by the bound
    ``prod_t (1 + gated measurements)`` that ``method="auto"`` compares with 100: per
    problem the ratio net time / enumeration time (interleaved, 3 repetitions each; the
    median of the three)."""
    rng = np.random.default_rng(seed)
    found = {b: [] for b in CHOICE_BINS}
    jpda_marginals(np.full((2, 2), 0.01), np.ones((2, 2), bool), 0.9, 1e-3, method="net")
    while any(len(v) < CHOICE_PER_BIN for v in found.values()):
        m, T = int(rng.integers(1, 9)), int(rng.integers(1, 6))
        valid = rng.random((m, T)) < rng.uniform(0.2, 0.95)
        P = int(np.prod(1 + valid.sum(axis=0)))
        b = next((b for b in CHOICE_BINS if b[0] <= P <= b[1]), None)
        if b is None or len(found[b]) >= CHOICE_PER_BIN:
            continue
        lik = np.exp(-0.5 * rng.uniform(0.0, 9.2, (m, T))) / (2 * math.pi * 30.0)
        ratios, t_enum, t_net = [], [], []
        for _ in range(3):
            te, _, (be, _) = _time_calls(lambda: jpda_marginals(lik, valid, 0.9, 1e-4,
                                                                method="enumerate"), 0.005)
            tn, _, (bn, _) = _time_calls(lambda: jpda_marginals(lik, valid, 0.9, 1e-4,
                                                                method="net"), 0.005)
            ratios.append(tn / te)
            t_enum.append(te)
            t_net.append(tn)
        if not np.max(np.abs(be - bn)) < 1e-12:
            raise AssertionError("JPDA choice: enumeration and net differ")
        found[b].append({"product": P, "m": m, "T": T, "net_over_enumeration": median(ratios),
                         "enumeration_seconds": median(t_enum), "net_seconds": median(t_net)})
    rows = []
    for b, probs in found.items():
        r = [p["net_over_enumeration"] for p in probs]
        rows.append(record("jpda_choice", "net_over_enumeration", f"{b[0]}-{b[1]}", median(r),
                           unit="ratio", product_range=list(b), problems=probs,
                           median=median(r), min=min(r), max=max(r),
                           enumeration_seconds_median=median(p["enumeration_seconds"]
                                                             for p in probs),
                           net_seconds_median=median(p["net_seconds"] for p in probs),
                           auto_method="enumerate" if b[1] <= 100 else "net"))
    return rows


def exact_marginals(lik, valid, pd, lam):
    """Parametric JPDA marginals in exact rational arithmetic at the given doubles: a
    forward-backward pass over the measurements whose states are the sets of targets
    used (an independent reference for the accuracy rows; slow)."""
    from fractions import Fraction

    m, T = valid.shape
    w = {(j, t): Fraction(float(pd[t])) * Fraction(float(lik[j, t])) / Fraction(float(lam))
         for j in range(m) for t in range(T) if valid[j, t]}
    miss = [1 - Fraction(float(pd[t])) for t in range(T)]
    fwd = [{0: Fraction(1)}]
    for j in range(m):
        nxt = {}
        for mask, v in fwd[j].items():
            nxt[mask] = nxt.get(mask, 0) + v
            for t in range(T):
                if (j, t) in w and not (mask >> t) & 1:
                    nxt[mask | 1 << t] = nxt.get(mask | 1 << t, 0) + v * w[j, t]
        fwd.append(nxt)
    bwd = [None] * (m + 1)
    bwd[m] = {}
    for mask in fwd[m]:
        v = Fraction(1)
        for t in range(T):
            if not (mask >> t) & 1:
                v *= miss[t]
        bwd[m][mask] = v
    for j in range(m - 1, -1, -1):
        bwd[j] = {}
        for mask in fwd[j]:
            v = bwd[j + 1][mask]
            for t in range(T):
                if (j, t) in w and not (mask >> t) & 1:
                    v += w[j, t] * bwd[j + 1][mask | 1 << t]
            bwd[j][mask] = v
    z = bwd[0][0]
    beta = np.zeros((m + 1, T))
    for j in range(m):
        for t in range(T):
            if (j, t) in w:
                acc = sum(v * bwd[j + 1][mask | 1 << t] for mask, v in fwd[j].items()
                          if not (mask >> t) & 1)
                beta[j + 1, t] = float(acc * w[j, t] / z)
    for t in range(T):
        acc = sum(v * bwd[m][mask] for mask, v in fwd[m].items() if not (mask >> t) & 1)
        beta[0, t] = float(acc / z)
    return beta


ACCURACY_CASES = ((6, 8), (8, 10))
ACCURACY_LAMS = (1e-3, 1e-20, 1e-60)


def bench_jpda_accuracy(seed: int = 0) -> list[dict]:
    """Largest relative error of the enumeration and of the net against
    :func:`exact_marginals` on all-valid T x m problems (likelihoods U(1e-3, 1e-2),
    ``P_D = 0.9``) at three clutter densities; whether the net's scaled arithmetic was
    certified or it used log space; and the CPU time of the net's public call."""
    from trackcore.association import feasible_event_count
    from trackcore.association._jpda_net import net_marginals
    from trackcore.association.jpda import _net_inputs

    rng = np.random.default_rng(seed)
    # the reference against brute force, on a small problem
    v = np.ones((3, 3), bool)
    lk = rng.uniform(1e-3, 1e-2, (3, 3))
    be, _ = jpda_marginals(lk, v, 0.9, 1e-3, method="enumerate")
    if not np.allclose(exact_marginals(lk, v, np.full(3, 0.9), 1e-3), be, rtol=1e-13, atol=0):
        raise AssertionError("exact_marginals disagrees with the enumeration")
    rows = []
    for T, m in ACCURACY_CASES:
        valid = np.ones((m, T), bool)
        lik = rng.uniform(1e-3, 1e-2, (m, T))
        for lam in ACCURACY_LAMS:
            ref = exact_marginals(lik, valid, np.full(T, 0.9), lam)
            logw, log_miss = _net_inputs(lik, valid, lik, False, np.full(T, 0.9),
                                         -math.log(lam))
            status = int(net_marginals(logw, valid, log_miss, np.zeros(1))[3])
            cpu, _, (b_net, _) = _time_calls(
                lambda: jpda_marginals(lik, valid, 0.9, lam, method="net"), 0.05)
            with Stopwatch() as sw:
                b_enum, n = jpda_marginals(lik, valid, 0.9, lam, method="enumerate")
            nz = ref > 0
            rows.append(record(
                "jpda_accuracy", "trackcore", f"{T}x{m} lam={lam:g}", cpu, unit="call",
                targets=T, measurements=m, lam=lam, feasible_events=n,
                events_check=int(feasible_event_count(valid)),
                net_max_rel_error=float(np.max(np.abs(b_net[nz] / ref[nz] - 1))),
                enumeration_max_rel_error=float(np.max(np.abs(b_enum[nz] / ref[nz] - 1))),
                net_scaled_certified=status == 0, enumeration_seconds=sw.cpu,
                reference="exact rational arithmetic (fractions) at the same doubles"))
    return rows


def bench_hpda(m_max: int = 500, snr: float = 10.0, tau: float = 2.0, pg: float = 0.99,
               clutter_mean: float = 2.0) -> list[dict]:
    pd = math.exp(-tau / (1.0 + snr))
    ms = range(1, m_max + 1)
    # closed-form check of every m, in log space (mu_F(m - 1) underflows for large m)
    worst = 0.0
    for m in ms:
        lpt, _, _ = hpda_log_rank_probabilities(m, snr, tau, pg, clutter_mean)
        if not np.all(np.isfinite(lpt)):
            raise AssertionError(f"HPDA: non-finite log rank probability at m = {m}")
        ref = math.log(pd * pg) + (m - 1) * math.log(clutter_mean) - clutter_mean - math.lgamma(m)
        worst = max(worst, abs(float(logsumexp(lpt)) - ref))
    if not worst < 1e-9:
        raise AssertionError(f"HPDA: sum over ranks misses the closed form by {worst:g} (log)")
    pairs = m_max * (m_max + 1) // 2
    times, walls = [], []
    for _ in range(7):
        with Stopwatch() as sw:
            for m in ms:
                hpda_log_rank_probabilities(m, snr, tau, pg, clutter_mean)
        times.append(sw.cpu / pairs)
        walls.append(sw.wall / pairs)
    return [record("hpda_rank_probabilities", "trackcore", m_max, median(times), unit="pair",
                   trials=sorted(times), wall=walls, pairs=pairs, max_abs_log_error_closed_form=worst,
                   api="hpda_log_rank_probabilities(m, ...) for m = 1..500",
                   snr=snr, tau=tau, pg=pg, clutter_mean=clutter_mean)]


WORKLOADS = {"jpda": bench_jpda, "hpda": bench_hpda}
