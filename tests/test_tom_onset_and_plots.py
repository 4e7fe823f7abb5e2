"""001-03/05: the onset windows of Singer's onset experiments, and 05's two figures."""
from collections import namedtuple

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from trackcore.experiments.tom_pg1 import _onset_columns, _onset_masks  # noqa: E402
from trackcore.scenarios._tom_book import (  # noqa: E402
    plot_one_at_a_time,
    plot_tuning_grid,
)

Est = namedtuple("Est", "value lo hi")


def test_onset_masks_split_the_manoeuvring_window():
    onset, rest = _onset_masks()
    t = np.arange(1, 91)
    assert list(t[onset]) == [21, 22, 23, 24, 25, 56, 57, 58, 59, 60], "onset samples"
    assert rest.sum() == 30 and not np.any(onset & rest), "rest: 30 other samples"
    man = ((t >= 21) & (t <= 40)) | ((t >= 56) & (t <= 75))
    assert np.array_equal(onset | rest, man), "together the manoeuvring window"


def test_onset_columns_means():
    e = np.ones((2, 3, 90))
    e[..., 20] = 11.0  # t = 21, an onset sample
    cols = _onset_columns(e)
    assert cols["onset_mse"].shape == (2, 3), "one per gate and filter"
    assert np.allclose(cols["onset_mse"], 2.0), "(11 + 9) / 10"
    assert np.allclose(cols["rest_mse"], 1.0), "the rest untouched"
    assert np.allclose(cols["max_err2"], 11.0), "largest squared error"


def _sweep():
    params = [("a", "u", [1.0, 2.0]), ("b", "p", [0.5, 0.9])]
    rows = [
        (lab, v, [Est(0.9, 0.8, 1.0)] * 3, Est(0.02, 0.01, 0.03))
        for lab, _, vals in params
        for v in vals
    ]
    return params, rows


def test_plot_one_at_a_time_draws_a_row_per_parameter():
    params, rows = _sweep()
    fig = plot_one_at_a_time(rows, params, ["t", "m", "n"], Est(0.05, 0.04, 0.06), 6.0)
    assert len(fig.axes) == 4, "two panels per parameter"
    assert len(fig.axes[0].containers) == 3, "one error bar per window"
    plt.close(fig)


def test_plot_one_at_a_time_bad_input():
    params, rows = _sweep()
    with pytest.raises(ValueError, match="windows"):
        plot_one_at_a_time(rows, params, ["t"], Est(0.05, 0.04, 0.06), 6.0)
    with pytest.raises(ValueError, match="params"):
        plot_one_at_a_time(rows[:2], params, ["t", "m", "n"], Est(0.1, 0, 1), 6.0)


def test_plot_tuning_grid_marks_the_points():
    m_c = {(1,): (0.9, 0.8, 1.1, 0.02), (2,): (0.88, 0.8, 1.0, 0.05)}
    m_v = {(3,): (0.85, 0.8, 0.9, 0.03)}
    scores = {"chord": m_c, "velocity": m_v}
    fig = plot_tuning_grid(
        scores, {"chord": [(1,)], "velocity": [(3,)]},
        ((1,), [("chord", (2,)), ("velocity", (3,))]), 0.04, 6.0,
    )
    ax = fig.axes[0]
    assert len(ax.collections) == 5, "grid, past the edges, grid, default, stars"
    assert np.allclose(ax.collections[-1].get_offsets(), [[5, 88], [3, 85]]), "stars"
    plt.close(fig)
    with pytest.raises(ValueError, match="scored"):
        plot_tuning_grid(scores, {"chord": [], "velocity": []},
                         ((9,), []), 0.04, 6.0)
    with pytest.raises(ValueError, match="headings"):
        plot_tuning_grid(scores, {"chord": []}, ((1,), []), 0.04, 6.0)
