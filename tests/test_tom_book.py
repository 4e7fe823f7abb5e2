"""Unit tests of the TOM-IMM chapter's private presentation helpers."""

import math

import pytest

from trackcore.scenarios._tom_book import below_or_sci, tom_discretization_errors


def test_discretization_errors_small():
    for phi, T, sf, ss in [(0.3, 1.0, 1.0, 3.0), (math.pi / 2, 2.0, 1.0, 1.0)]:
        e_phi, e_d, e_c = tom_discretization_errors(phi, T, sf, ss)
        assert e_phi <= 1e-12, f"transition differs from expm by {e_phi}"
        assert e_d <= 1e-9, f"DWNA noise differs by {e_d}"
        assert e_c <= 1e-9, f"CWNA noise differs by {e_c}"


def test_discretization_errors_bad_input():
    with pytest.raises(ValueError, match="T"):
        tom_discretization_errors(0.3, 0.0, 1.0, 1.0)
    with pytest.raises(ValueError, match="sf"):
        tom_discretization_errors(0.3, 1.0, -1.0, 1.0)


def test_below_or_sci():
    assert below_or_sci(1e-13, "1e-12") == "< 1e-12", "below the floor"
    assert below_or_sci(2.5e-8, "1e-9") == "2.5e-08", "above the floor"


def test_max_rel_diff():
    import numpy as np

    from trackcore.scenarios._tom_book import max_rel_diff

    got = max_rel_diff(np.array([1.5, 200.0]), np.array([1.0, 100.0]))
    assert got == 1.0, f"expected 1.0 (relative 100 %), got {got}"
    assert max_rel_diff([0.5], [0.0]) == 0.5, "absolute below |b| = 1"
    with pytest.raises(ValueError, match="shape"):
        max_rel_diff([1.0, 2.0], [1.0])


def test_filterpy_imm_run_matches_trackcore():
    import numpy as np

    from trackcore.core.rng import spawn_generators
    from trackcore.scenarios import houles_measurements, houles_truth
    from trackcore.scenarios._tom_book import filterpy_imm_run, max_rel_diff
    from trackcore.trackers import car_imm_model_set, imm_pdaf_track, two_point_init

    R = 400.0 * np.eye(2)
    models = car_imm_model_set(sigma_cv=5.0)
    rng = spawn_generators(7, 1)[0]
    s = houles_measurements(houles_truth(np.arange(30.0)), rng, clutter_density=0.0)
    x0, P0 = two_point_init(s.z[0], s.z[1], R)
    zs = s.z[2:]
    ours = imm_pdaf_track(
        models, list(zs[:, None, :]), x0, P0, R, pd=1.0, pg=1.0, clutter_density=0.0
    )
    xs, Ps, mus = filterpy_imm_run(models, zs, x0, P0, R)
    i = models.out_index
    assert max_rel_diff(ours.x, xs[:, i]) < 1e-9, "state differs from filterpy"
    assert max_rel_diff(ours.P, Ps[:, i][:, :, i]) < 1e-9, "covariance differs"
    assert max_rel_diff(ours.mu, mus) < 1e-9, "model probabilities differ"
    with pytest.raises(ValueError, match="zs"):
        filterpy_imm_run(models, zs[:, :1], x0, P0, R)


def test_ks_distance():
    import numpy as np

    from trackcore.scenarios._tom_book import ks_distance

    rng = np.random.default_rng(1)
    d_norm = ks_distance(rng.normal(size=4000))
    d_exp = ks_distance(rng.exponential(size=4000))
    assert d_norm < 0.03 < d_exp, f"KS normal {d_norm}, exponential {d_exp}"
    with pytest.raises(ValueError, match="a must"):
        ks_distance(np.ones((2, 2)))


def test_acceleration_seed_stats():
    import numpy as np

    from trackcore.scenarios._tom_book import acceleration_seed_stats

    s = acceleration_seed_stats(np.random.default_rng(3), np.random.default_rng(4))
    assert len(s) == 19, f"expected 19 statistics, got {sorted(s)}"
    assert all(np.isfinite(v) for v in s.values()), f"non-finite statistic in {s}"
    assert 0 <= s["rho_white"] <= 1, f"|ρ| of white noise {s['rho_white']}"
