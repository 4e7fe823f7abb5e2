"""clear_mot_metrics reuses one py-motmetrics metrics host per process: its numbers must
be those of a fresh host per call (the way they were computed before), bit for bit."""
import numpy as np

from trackcore.scenarios.feature_metrics import MOT_METRICS, clear_mot_metrics
from trackcore.scenarios.feature_scenes import crossing_detections
from trackcore.trackers.jpda_tracker import JPDATrackerConfig, run_jpda_tracker


def _fresh_host(scene, reports, match_gate=10.0):
    """The metrics as a fresh ``metrics.create()`` and its one-row DataFrame give them."""
    import motmetrics as mm

    veh = np.nonzero(scene.is_vehicle)[0]
    acc = mm.MOTAccumulator(auto_id=True)
    for k in range(scene.xy.shape[0]):
        objs = [int(o) for o in veh if scene.present[k, o]]
        tr = [s for s in reports[k].tracks if s.status in ("confirmed", "memory")]
        D = np.full((len(objs), len(tr)), np.nan)
        if objs and tr:
            P = np.array([[s.x, s.y] for s in tr])
            X = scene.xy[k, objs]
            D = np.hypot(X[:, None, 0] - P[None, :, 0], X[:, None, 1] - P[None, :, 1])
            D[D > match_gate] = np.nan
        acc.update(objs, [s.tid for s in tr], D)
    out = mm.metrics.create().compute(acc, metrics=list(MOT_METRICS), name="run").iloc[0]
    return {name: float(out[name]) for name in MOT_METRICS}


def test_reused_host_gives_a_fresh_hosts_numbers():
    runs = []
    for seed in (0, 1, 2):
        detections, scene = crossing_detections(np.random.default_rng(seed))
        for cfg in (JPDATrackerConfig(), JPDATrackerConfig(variant="JPDA")):
            runs.append((scene, run_jpda_tracker(detections, cfg)))
    first = [clear_mot_metrics(s, r) for s, r in runs]
    again = [clear_mot_metrics(s, r) for s, r in reversed(runs)][::-1]
    for (s, r), a, b in zip(runs, first, again):
        want = _fresh_host(s, r)
        assert a.keys() == want.keys(), f"measures {sorted(a)} != {sorted(want)}"
        for name in MOT_METRICS:
            same = np.float64(a[name]).tobytes() == np.float64(want[name]).tobytes()
            assert same, f"{name}: {a[name]!r} with the reused host, {want[name]!r} fresh"
            assert np.float64(b[name]).tobytes() == np.float64(a[name]).tobytes(), \
                f"{name}: a second pass over the same runs differs ({b[name]!r})"
