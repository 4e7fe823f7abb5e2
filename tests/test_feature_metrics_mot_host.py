"""clear_mot_metrics reuses one py-motmetrics metrics host per process: its numbers must
be those of a fresh host per call (the way they were computed before), bit for bit."""
import numpy as np

from trackcore.scenarios import feature_metrics
from trackcore.scenarios.feature_metrics import MOT_METRICS, clear_mot_metrics
from trackcore.scenarios.feature_scenes import crossing_detections
from trackcore.trackers.jpda_tracker import JPDATrackerConfig, run_jpda_tracker


def _fresh_host(scene, reports):
    """The metrics with a metrics host built for this call alone (the cache emptied
    before and after, so the reused host of the other calls is not touched)."""
    saved = list(feature_metrics._MOT_HOST)
    feature_metrics._MOT_HOST.clear()
    try:
        out = clear_mot_metrics(scene, reports)
        fresh = feature_metrics._MOT_HOST[0]
    finally:
        feature_metrics._MOT_HOST[:] = saved
    assert not saved or fresh is not saved[0], "the oracle must use its own host"
    return out


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
