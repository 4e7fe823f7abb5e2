"""Smoke tests for trackcore.plotting with the Agg backend."""
import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from trackcore.metrics import chi2_bounds  # noqa: E402
from trackcore.plotting import (BOOK_COLORS, paper_vs_ours_table, plot_consistency,  # noqa: E402
                                plot_count_vs_scan, plot_rmse_vs_time, plot_tracks_2d,
                                use_book_style)


@pytest.fixture
def ax():
    use_book_style()
    fig, ax = plt.subplots()
    yield ax
    plt.close(fig)


def test_use_book_style_sets_palette():
    use_book_style()
    cycle = matplotlib.rcParams["axes.prop_cycle"].by_key()["color"]
    assert tuple(cycle) == BOOK_COLORS


def test_plot_rmse_vs_time(ax):
    t = np.arange(50.0)
    plot_rmse_vs_time(ax, t, {"KF": np.sqrt(t + 1), "IMM": np.log1p(t)}, shade=[(10, 20), (30, 35)])
    assert len(ax.lines) == 2
    assert len(ax.patches) == 2            # two manoeuvre bands
    labels = [tx.get_text() for tx in ax.get_legend().get_texts()]
    assert labels == ["manoeuvre", "KF", "IMM"]
    assert ax.get_xlabel() == "time [s]" and ax.get_ylabel() == "RMSE [m]"
    with pytest.raises(ValueError, match="curves"):
        plot_rmse_vs_time(ax, t, {"bad": np.ones(3)})
    with pytest.raises(ValueError, match="shade"):
        plot_rmse_vs_time(ax, t, {"KF": t}, shade=[(5, 1)])
    with pytest.raises(TypeError, match="curves"):
        plot_rmse_vs_time(ax, t, [t])
    with pytest.raises(TypeError, match="ax"):
        plot_rmse_vs_time(None, t, {"KF": t})


def test_plot_tracks_2d(ax):
    rng = np.random.default_rng(0)
    truth = [np.cumsum(rng.normal(size=(20, 4)), axis=0) for _ in range(2)]
    est = [tr + rng.normal(scale=0.3, size=tr.shape) for tr in truth]
    scans = [rng.normal(size=(rng.integers(0, 4), 2)) for _ in range(20)] + [np.zeros((0, 2))]
    plot_tracks_2d(ax, truth, {"IMM": est, "KF": est[0]}, measurements=scans)
    # 1 measurement line + 2 x (truth line + start marker) + 3 estimate lines
    assert len(ax.lines) == 1 + 4 + 3
    labels = [tx.get_text() for tx in ax.get_legend().get_texts()]
    assert labels == ["measurements", "truth", "IMM", "KF"]
    with pytest.raises(ValueError, match="measurements"):
        plot_tracks_2d(ax, truth, est, measurements=np.zeros((5, 3)))
    with pytest.raises(ValueError, match="truth"):
        plot_tracks_2d(ax, np.zeros(5), est)


def test_plot_count_vs_scan(ax):
    k = np.arange(1, 31)
    truth = np.where(k < 15, 2, 3)
    plot_count_vs_scan(ax, k, {"PHD": truth + 0.1, "HPDA": truth - 0.2}, truth)
    assert len(ax.lines) == 3
    with pytest.raises(ValueError, match="truth"):
        plot_count_vs_scan(ax, k, {"PHD": truth}, truth[:-1])
    with pytest.raises(ValueError, match="mean_counts"):
        plot_count_vs_scan(ax, k, {"PHD": truth[:3]}, truth)


def test_plot_consistency(ax):
    rng = np.random.default_rng(1)
    lo, hi = chi2_bounds(4, 50)
    vals = rng.chisquare(4 * 50, size=100) / 50
    plot_consistency(ax, np.arange(100.0), vals, (lo, hi), "NEES")
    inside = np.mean((vals >= lo) & (vals <= hi))
    text = ax.get_legend().get_texts()[1].get_text()
    assert text == f"NEES ({100 * inside:.0f} % inside)"
    assert ax.get_ylabel() == "average NEES"
    with pytest.raises(ValueError, match="bounds"):
        plot_consistency(ax, np.arange(3.0), np.ones(3), (2.0, 1.0))
    with pytest.raises(TypeError, match="bounds"):
        plot_consistency(ax, np.arange(3.0), np.ones(3), 5.0)
    with pytest.raises(ValueError, match="values"):
        plot_consistency(ax, np.arange(3.0), np.ones(4), (1.0, 2.0))


def test_paper_vs_ours_table():
    tab = paper_vs_ours_table([("RMSE [m]", 12.0, 11.8312), ("P_D", None, 0.9), ("a|b", 1, 2)])
    lines = tab.splitlines()
    assert lines[0].startswith("| quantity") and lines[1].startswith("| ---")
    assert lines[2] == "| RMSE [m] | 12    | 11.8      |"
    assert "\u2014" in lines[3] and "a\\|b" in lines[4]
    assert len({len(line) for line in lines}) == 1     # aligned columns
    with pytest.raises(ValueError, match="rows\\[0\\]"):
        paper_vs_ours_table([(1, 2)])
    with pytest.raises(TypeError, match="rows"):
        paper_vs_ours_table(5)


def test_plot_inputs_checked_before_drawing(ax):
    """Issue 17: a one-column state array was an IndexError; bad shade/styles clear errors."""
    t = np.arange(5.0)
    with pytest.raises(ValueError, match="truth must be an \\(n_steps, n\\) state array"):
        plot_tracks_2d(ax, np.zeros((5, 1)), np.zeros((5, 4)))
    with pytest.raises(ValueError, match="measurements\\[0\\] must be \\(m, 2\\)"):
        plot_tracks_2d(ax, np.zeros((5, 4)), np.zeros((5, 4)), measurements=[np.zeros((2, 3))])
    with pytest.raises(TypeError, match="shade"):
        plot_rmse_vs_time(ax, t, {"KF": t}, shade=[1.0])
    with pytest.raises(TypeError, match="styles"):
        plot_rmse_vs_time(ax, t, {"KF": t}, styles=[("KF", {})])
