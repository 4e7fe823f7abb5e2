"""The feature-JPDA tracker's position-and-velocity measurement (``model="pv"``, issue 29,
session 13): zero error on a noiseless constant-velocity target, the config, the 4-dof
gate, the 4-D clutter density and the rule for a detection without a previous-frame
neighbour."""
import numpy as np
import pytest
from scipy.stats import chi2

from trackcore.detection.image import ImageDetections, vehicle_sprite
from trackcore.trackers.jpda_tracker import (
    JPDATracker,
    JPDATrackerConfig,
    matched_config,
    run_jpda_tracker,
    steady_state_gate,
)

VAN = vehicle_sprite("van")[1]


def dets(points):
    z = np.array(points, float).reshape(-1, 2)
    return ImageDetections(z, np.zeros((len(z), 4), np.int64), np.zeros(len(z), np.int64),
                           [VAN] * len(z), [VAN] * len(z))


def line(k, x0=50.0, y0=100.0, vx=2.0, vy=0.5):
    return [x0 + vx * k, y0 + vy * k]


@pytest.mark.parametrize("variant", ["GNN", "JPDA", "FJPDA"])
def test_noiseless_constant_velocity_target_is_tracked_without_error(variant):
    reps = run_jpda_tracker([dets([line(k)]) for k in range(25)],
                            JPDATrackerConfig(variant=variant, model="pv"))
    (t,) = reps[-1].tracks
    assert t.status == "confirmed", t
    assert (t.x, t.y) == pytest.approx(line(24), abs=1e-9), (t.x, t.y)
    trk = JPDATracker(JPDATrackerConfig(variant=variant, model="pv"))
    for k in range(25):
        trk.step(dets([line(k)]))
    assert trk.tracks[0].x[2:] == pytest.approx([2.0, 0.5], abs=1e-9), "velocity"


def test_config_validation_and_derived_values():
    with pytest.raises(ValueError, match="model must be one of"):
        JPDATrackerConfig(model="vel")
    pv = matched_config("JPDA", jitter=5.0, model="pv")
    r = pv.v_max + pv.pair_margin
    assert pv.clutter_density == pytest.approx(pv.lam / (2 * r) ** 2), "lam / (2r)^2"
    assert chi2.cdf(pv.gate_gamma, 4) == pytest.approx(chi2.cdf(pv.gamma, 2)), "same P_G"
    assert round(pv.gate_gamma, 2) == 13.28
    cv = JPDATrackerConfig()
    assert (cv.gate_gamma, cv.clutter_density) == (cv.gamma, cv.lam), "cv unchanged"
    trk = JPDATracker(pv)
    R = pv.r_std ** 2 * np.eye(2)
    assert np.array_equal(trk.H, np.eye(4)), trk.H
    assert np.allclose(trk.R, np.block([[R, R], [R, 2 * R]])), trk.R
    # the gate-size rule reads the position block with gamma on 2 dof, as the CV model
    assert steady_state_gate(pv) < steady_state_gate(matched_config("JPDA", jitter=5.0))


def test_gate_uses_four_dof():
    cfg = JPDATrackerConfig(variant="JPDA", model="pv")
    trk = JPDATracker(cfg)
    for k in range(6):
        trk.step(dets([line(k)]))
    (t,) = trk.tracks
    x, P = trk.F @ t.x, trk.F @ t.P @ trk.F.T + trk.Q
    S = trk.H @ P @ trk.H.T + trk.R
    # a detection at d^2 between the 2-dof (9.21) and the 4-dof (13.28) thresholds along the
    # velocity difference alone: it reports the track's predicted position from a previous
    # detection further back, so only its velocity component is off
    u = np.array([0.0, 0.0, 1.0, 0.0])
    d2_unit = u @ np.linalg.solve(S, u)
    dv = np.sqrt(11.0 / d2_unit)
    zk = x[:2]
    trk.prev_all = np.array([[zk[0] - x[2] - dv, zk[1] - x[3]]])
    rep = trk.step(dets([zk]))
    assert rep.n_valid_kin == 1, "d^2 = 11 lies inside the 4-dof gate"
    assert chi2.ppf(0.99, 2) < 11.0 < chi2.ppf(0.99, 4)


def test_detection_without_previous_neighbour_reports_no_velocity():
    cfg = JPDATrackerConfig(variant="JPDA", model="pv")
    trk = JPDATracker(cfg)
    for k in range(6):
        trk.step(dets([line(k)]))
    # frame 6 missed: the detection of frame 7 has no neighbour in frame 6 and is
    # validated by no track, though it lies on the track's prediction
    rep6 = trk.step(dets([]))
    rep7 = trk.step(dets([line(7)]))
    assert rep6.n_valid_kin == 0 and rep7.n_valid_kin == 0, (rep6, rep7)
    assert [s.status for s in rep7.tracks] == ["memory"], rep7.tracks
    # it is the previous detection of frame 8's pair: validated again from frame 8
    rep8 = trk.step(dets([line(8)]))
    assert rep8.n_valid_kin == 1 and rep8.tracks[0].status == "confirmed", rep8.tracks
    # a lone detection without a neighbour seeds no track this frame, one the next
    fresh = JPDATracker(cfg)
    assert fresh.step(dets([[10.0, 10.0]])).tracks == ()
    assert len(fresh.step(dets([[12.0, 10.0]])).tracks) == 1


def test_velocity_is_the_difference_to_the_nearest_previous_detection_within_r():
    trk = JPDATracker(matched_config("JPDA", jitter=0.0, model="pv"))  # r = 8 px
    trk.prev_all = np.array([[0.0, 0.0], [10.0, 0.0], [100.0, 0.0]])
    zz, has_v = trk._measurements(np.array([[3.0, 0.0], [7.0, 1.0], [60.0, 0.0]]))
    assert has_v.tolist() == [True, True, False], has_v
    assert zz[:2, 2:].tolist() == [[3.0, 0.0], [-3.0, 1.0]], zz
