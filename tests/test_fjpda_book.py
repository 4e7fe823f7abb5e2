"""Unit tests of the feature-JPDA chapter's private presentation helpers."""

from types import SimpleNamespace

import matplotlib
import pytest

matplotlib.use("Agg")

import matplotlib.pyplot as plt
import numpy as np

from trackcore.scenarios import _fjpda_book as fb


def _track(tid, status, x=50.0, y=40.0):
    return SimpleNamespace(tid=tid, status=status, x=x, y=y, gate_x=5.0, gate_y=4.0)


def _report(*tracks):
    return SimpleNamespace(tracks=list(tracks))


def test_overall_rule():
    better, worse = "FJPDA better", "JPDA better"
    assert fb.overall({"a": better, "b": "tie"}) == ("reproduced", ["a"], []), (
        "better somewhere, worse nowhere holds"
    )
    assert fb.overall({"a": better, "b": worse})[0] == "not reproduced", (
        "worse in one scene fails"
    )
    assert fb.overall({"a": "tie", "b": "no interval"})[0] == "not reproduced", (
        "ties alone do not hold"
    )
    with pytest.raises(TypeError, match="verdicts"):
        fb.overall([better])


def test_paired_row():
    c = SimpleNamespace(
        mean_a=0.12345, mean_b=2.0, diff=-1.87655, a_better=3, b_better=1,
        verdict="A better",
    )  # fmt: skip
    assert fb.paired_row(c) == ("0.123", "2", "-1.88", "3 / 1", "A better"), (
        "means and difference to 3 significant digits"
    )
    assert fb.paired_row(c, ".2f")[2] == "-1.88", "the difference's format is an option"


def test_first_differing():
    a, b = [1, 2, 3, 4], [1, 2, 5, 4]
    assert fb.first_differing(a, b, lambda m: m, 4) == 2, "index of the first change"
    assert fb.first_differing(a, a, lambda m: m, 4) is None, "None when all agree"
    assert fb.first_differing(a, b, lambda m: m, 2) is None, "only the first n count"
    with pytest.raises(ValueError, match="n"):
        fb.first_differing(a, b, lambda m: m, 0)


def test_first_frame_apart_and_describe():
    ra = [_report(_track(1, "confirmed")), _report(_track(1, "confirmed"))]
    rb = [_report(_track(1, "confirmed")), _report(_track(2, "memory"))]
    assert fb.first_frame_apart(ra, rb) == 1, "frame 1 reports other IDs"
    assert fb.first_frame_apart(ra, ra) == 1, "the last frame when none differs"
    tentative = [_report(_track(1, "confirmed"), _track(7, "tentative"))] * 2
    assert fb.first_frame_apart(ra, tentative) == 1, "tentative tracks are not reported"
    with pytest.raises(ValueError, match="same length"):
        fb.first_frame_apart(ra, rb[:1])
    assert fb.describe("X", rb, 1) == "X: 1 reported track(s) at frame 1, IDs [2]", (
        "the reported tracks of the frame"
    )


def test_track_panel_draws():
    frame = np.zeros((240, 320))
    reps = [_report(_track(1, "confirmed", 50 + k, 40), _track(3, "tentative"))
            for k in range(3)]  # fmt: skip
    fig, ax = plt.subplots()
    fb.track_panel(ax, frame, reps, 2, "t", (-10, 500))
    assert len(ax.lines) == 1, "one trail: the reported track's"
    assert len(ax.patches) == 2, "a gate per track, reported or not"
    assert [t.get_text() for t in ax.texts] == ["1"], "only reported tracks labelled"
    assert ax.get_xlim() == (0, 200) and ax.get_ylim() == (240, 140), (
        "the 200 x 100 px window is clipped to the image"
    )
    plt.close(fig)


def test_interval_ends():
    from trackcore.stats import Estimate

    e = Estimate(0.1, -0.2, 0.3, 0.95, 40, "BCa bootstrap")
    assert fb.interval_ends(e) == (0.1, -0.2, 0.3), "an estimate's ends"
    assert fb.interval_ends(0.25) == (0.25, 0.25, 0.25), "no interval: the value"
    with pytest.raises(ValueError, match="d must"):
        fb.interval_ends(float("nan"))


def test_tsi_scan():
    sprite, bar = np.ones((3, 4), bool), np.ones((2, 6), bool)
    d = fb.tsi_scan([(1, 2), (3, 4)], sprite)
    assert d.z.shape == (2, 2) and d.z[1].tolist() == [3.0, 4.0], "centroids as given"
    assert all(m is sprite for m in d.masks), "the sprite for every point by default"
    assert fb.tsi_scan([(1, 2)], sprite, [bar]).masks[0] is bar, "given masks are used"
    with pytest.raises(ValueError, match="masks must"):
        fb.tsi_scan([(1, 2), (3, 4)], sprite, [bar])


def test_tsi_panel_and_log_row():
    track = _track(4, "tentative", 30.0, 20.0)
    tracker_track = SimpleNamespace(tid=4, x=np.array([30.0, 20.0, 2.0, 1.0]))
    fig, ax = plt.subplots()
    fb.tsi_panel(ax, [(10, 10), (60, 60)], [(30, 20)], _report(track), [tracker_track])
    assert len(ax.patches) == 2, "a gate circle per stored measurement"
    assert [ln.get_label() for ln in ax.lines] == ["stored", "measurements"], "markers"
    assert [t.get_text() for t in ax.texts] == ["", "4: tentative"], "arrow and label"
    assert ax.get_xlim() == (0, 95) and ax.get_ylim() == (95, 0), "y down, 95 px"
    plt.close(fig)
    assert fb.tsi_log_row(2, _report(track), 3) == (2, "4 tentative", 3), "the row"
    assert fb.tsi_log_row(0, _report(), 3)[1] == "none", "no tracks: none"
    with pytest.raises(ValueError):
        fb.tsi_log_row(-1, _report(), 0)


def test_state_diagram():
    nodes = {"a": (0.1, 0.5), "b": (0.9, 0.5), "deleted": (0.5, 0.1)}
    fig, ax = plt.subplots()
    fb.state_diagram(ax, nodes, [("a", "b", "hit", 0.0, 0.0)], "note")
    texts = [t.get_text() for t in ax.texts]
    assert texts == ["a", "b", "deleted", "", "hit", "note"], "states, arrow, note"
    colours = [t.get_bbox_patch().get_facecolor() for t in ax.texts[:3]]
    assert colours[0] == colours[1] != colours[2], "the alert state shaded apart"
    plt.close(fig)
    with pytest.raises(ValueError, match="not nodes"):
        fb.state_diagram(ax, nodes, [("a", "c", "hit", 0.0, 0.0)], "note")
