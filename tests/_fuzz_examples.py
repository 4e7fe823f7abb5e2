"""Valid example calls of every public trackcore callable, for the fuzz suite.

``EXAMPLES[name]()`` returns a fresh :class:`_fuzz_engine.Example` (new arrays and a new
seeded generator on every call, so cases never share state).  Keep each example small and
fast: every argument of it is mutated about a dozen ways.  Arguments with defaults are
passed explicitly when they should be fuzzed too.
"""
from __future__ import annotations

import functools
import math

import numpy as np

from _fuzz_engine import _Replace, call

EXAMPLES = {}


def example(*names):
    def deco(fn):
        for n in names or (fn.__name__,):
            EXAMPLES[n] = fn
        return fn
    return deco


def rng(seed=12345):
    return np.random.default_rng(seed)


def cv_F(T=1.0):
    F = np.eye(4)
    F[0, 2] = F[1, 3] = T
    return F


def cv_Q(T=1.0, q=0.5):
    G = np.array([[T * T / 2, 0], [0, T * T / 2], [T, 0], [0, T]])
    return q * G @ G.T


def H2():
    return np.array([[1.0, 0, 0, 0], [0, 1.0, 0, 0]])


def P4():
    return np.diag([4.0, 4.0, 1.0, 1.0])


def x4():
    return np.array([10.0, 20.0, 1.0, -0.5])


def R2():
    return np.array([[2.0, 0.3], [0.3, 1.0]])


def particles(N=40, seed=3):
    r = np.random.default_rng(seed)
    return r.normal([100.0, 50.0, 1.0, 0.5], [5.0, 5.0, 0.5, 0.5], size=(N, 4))


# ------------------------------------------------------------------ core
@example()
def as_array():
    return call(np.array([[1.0, 2.0], [3.0, 4.0]]), "x", ndim=2, shape=(2, 2))


@example()
def as_vector():
    return call(np.array([1.0, 2.0]), "x", 2)


@example()
def as_matrix():
    return call(np.ones((2, 3)), "M", (2, 3))


@example()
def as_square_matrix():
    return call(np.eye(3), "F", 3)


@example()
def as_covariance():
    return call(P4(), "P", 4, strict=True, rtol=1e-9)


@example()
def as_measurements():
    return call(np.array([[1.0, 2.0], [3.0, 4.0]]), "z", 2)


@example()
def as_scalar():
    return call(1.5, "x")


@example()
def as_positive():
    return call(1.5, "sigma")


@example()
def as_nonnegative():
    return call(0.5, "T")


@example()
def as_probability():
    return call(0.3, "pd", open_low=True, open_high=False)


@example()
def as_probabilities():
    return call(np.array([0.1, 0.9]), "p", shape=(2,))


@example()
def as_count():
    return call(3, "n")


@example()
def as_int():
    return call(3, "k", minimum=1)


@example()
def as_rng():
    return call(rng(), "rng")


@example()
def as_bool_matrix():
    return call(np.array([[True, False], [True, True]]), "valid", (2, 2))


@example()
def as_offsets():
    return call(np.array([0, 2, 2, 5]), 5, "offsets", min_scans=1)


@example()
def logsumexp():
    return (call(np.array([[0.0, -1.0, -np.inf], [2.0, 3.0, 1.0]]), axis=1)
            .rejects("inf", np.array([np.inf, 0.0]), match="a must not contain"))


@example()
def normalize_log_weights():
    return call(np.array([-1.0, -2.0, -np.inf, 0.5]))


@example()
def gaussian_logpdf():
    return call(np.array([[1.0, 2.0], [0.0, 0.5]]), np.array([0.5, 1.0]), R2())


@example()
def finite_result():
    return call(np.array([1.0, 2.0]), "the value", "x and y")


@example()
def spawn_seed_sequences():
    return call(7, 3)


@example()
def spawn_generators():
    return call(7, 3)


@example()
def generator_for_run():
    return call(7, 1, 3).rejects("i=2.5", 1, 2.5, 3, match="i must be an integer")


@example()
def make_rng():
    return call(7)


# ------------------------------------------------------------------ models (motion, measurement)
@example()
def kron_axes():
    return call(np.array([[1.0, 1.0], [0.0, 1.0]]), 2)


@example()
def cv_transition():
    return call(1.5, 2)


@example()
def cv_process_noise():
    return call(1.5, 0.2, 2, "cwna")


@example()
def coordinated_turn_transition():
    return call(0.05, 2.0)


@example()
def coordinated_turn_process_noise():
    return call(2.0, 0.3, "dwna")


@example()
def singer_transition():
    return call(1.0, 20.0)


@example()
def singer_process_noise():
    return call(1.0, 20.0, 15.0)


@example()
def van_loan_discretize():
    A = np.array([[0.0, 1.0], [0.0, -0.05]])
    W = np.array([[0.0, 0.0], [0.0, 2.0]])
    return call(A, W, 1.0)


@example()
def position_matrix():
    return call(2, 4)


@example()
def wrap_angle():
    return call(np.array([0.5, 7.0, -4.0]))


@example()
def range_bearing():
    return call(particles(5), np.array([1.0, -2.0]))


@example()
def range_bearing_jacobian():
    return call(particles(5), np.array([1.0, -2.0]))


@example()
def range_bearing_doppler():
    return call(particles(5))


@example()
def range_bearing_doppler_jacobian():
    return call(particles(5))


@example()
def polar_to_cartesian():
    return call(np.array([[100.0, 0.3], [50.0, -1.0]]), np.array([1.0, 2.0]))


@example()
def converted_measurement_covariance():
    return call(1000.0, 0.4, 10.0, 0.01)


# ------------------------------------------------------------------ filters
@example()
def kf_predict():
    return call(x4(), P4(), cv_F(), cv_Q())


@example()
def kf_update():
    return call(x4(), P4(), np.array([11.0, 19.0]), H2(), R2())


@example()
def ekf_update():
    x = x4()
    from trackcore.models import range_bearing as rb, range_bearing_jacobian as rbj
    return call(x, P4(), np.array([22.5, 1.1]), rb(x), rbj(x), np.diag([1.0, 0.01]), 1)


def _zs(K=6, seed=4):
    r = np.random.default_rng(seed)
    t = np.arange(1, K + 1)[:, None]
    return np.hstack([10 + t, 20 - 0.5 * t]) + r.normal(0, 1.0, (K, 2))


@example()
def kalman_filter_run():
    zs = _zs()
    zs[2] = np.nan
    return call(zs, x4(), P4(), cv_F(), cv_Q(), H2(), R2())


@example()
def kalman_filter_batch():
    zs = np.stack([_zs(seed=4), _zs(seed=5)])
    zs[1, 3] = np.nan
    return call(zs, x4(), P4(), cv_F(), cv_Q(), H2(), R2())


def _imm():
    xs = np.stack([x4(), x4() + 0.5])
    Ps = np.stack([P4(), 2 * P4()])
    mu = np.array([0.7, 0.3])
    PI = np.array([[0.95, 0.05], [0.1, 0.9]])
    Fs = np.stack([cv_F(), cv_F()])
    Qs = np.stack([cv_Q(q=0.1), cv_Q(q=2.0)])
    return xs, Ps, mu, PI, Fs, Qs


@example()
def imm_mix():
    xs, Ps, mu, PI, _, _ = _imm()
    return call(mu, PI, xs, Ps)


@example()
def imm_mode_update():
    return call(np.array([0.6, 0.4]), np.array([-3.0, -1.5]))


@example()
def imm_combine():
    xs, Ps, mu, _, _, _ = _imm()
    return call(mu, xs, Ps)


@example()
def imm_step():
    xs, Ps, mu, PI, Fs, Qs = _imm()
    return call(xs, Ps, mu, PI, Fs, Qs, np.array([11.0, 19.0]), H2(), R2())


@example()
def imm_filter_run():
    xs, Ps, mu, PI, Fs, Qs = _imm()
    zs = _zs()
    zs[1] = np.nan
    return call(zs, xs, Ps, mu, PI, Fs, Qs, H2(), R2())


@example()
def noise_factor():
    return call(cv_Q(), "Q", 1e-12)


@example()
def propagate_linear():
    return call(particles(), cv_F(), cv_Q(), rng())


@example()
def effective_sample_size():
    return call(np.array([-1.0, -2.0, 0.0, -np.inf]))


@example()
def weighted_mean_cov():
    X = particles(6)
    return call(X, np.array([-1.0, -2.0, 0.0, -np.inf, -0.5, -3.0]))


def _w():
    return np.array([0.1, 0.0, 0.5, 0.2, 0.2])


@example("systematic_resample", "stratified_resample", "residual_resample",
         "multinomial_resample")
def _resamplers():
    return call(_w(), rng(), 7)


@example()
def resample_particles():
    X = particles(5)
    with np.errstate(divide="ignore"):
        logw = np.log(_w())
    return call(X, logw, rng(), "stratified", 6)


@example()
def loglik_gaussian_position():
    return call(particles(), np.array([101.0, 49.0]), R2(), parallel=False)


@example()
def loglik_range_bearing():
    return call(particles(), np.array([110.0, 0.47]), np.diag([25.0, 1e-3]),
                np.array([1.0, -1.0]), parallel=False)


@example()
def bootstrap_step():
    from trackcore.filters import noise_factor as nf
    N = 40
    far = particles(N)
    far[0, 0] = 1e300
    return (call(particles(N), np.zeros(N), cv_F(), nf(cv_Q()), np.array([110.0, 0.47]),
                 np.diag([25.0, 1e-3]), rng(), "range_bearing", sensor=(1.0, -1.0),
                 ess_threshold=0.5, scratch=np.zeros((N, 4)), parallel=False)
            .accepts("far-particle", far, np.zeros(N), cv_F(), nf(cv_Q()),
                     np.array([110.0, 0.47]), np.diag([25.0, 1e-3]), rng()))


# ------------------------------------------------------------------ association: gating, PDA
@example()
def gate_threshold():
    return call(0.99, 2)


@example()
def gate_probability():
    return call(9.21, 2)


@example()
def unit_ball_volume():
    return call(3)


@example()
def gate_volume():
    return call(9.21, R2())


@example()
def mahalanobis_gate():
    z = np.array([[1.0, 2.0], [5.0, -1.0], [0.5, 0.1]])
    return call(z, np.array([1.0, 1.0]), R2(), 9.21, 1)


@example()
def pda_betas():
    return call(np.array([0.02, 0.001, 0.0]), 0.9, 0.99, 1e-3)


@example()
def pda_log_likelihood():
    return call(None, 0.9, 0.99, None, log_lik=np.array([-3.0, -9.0]), mode="nonparametric",
                volume=50.0)


@example()
def pda_update():
    z = np.array([[11.0, 19.0], [12.5, 18.0]])
    zp = H2() @ x4()
    return call(x4(), P4(), z, zp, H2(), R2(), np.array([0.5, 0.3]), 0.2, 1)


# ------------------------------------------------------------------ metrics
def _est_truth():
    r = np.random.default_rng(8)
    truth = np.cumsum(r.normal(size=(5, 4)), axis=0)
    est = truth[None] + r.normal(size=(3, 5, 4))
    return est, truth


@example()
def rmse():
    est, truth = _est_truth()
    return call(est, truth, 0)


@example()
def position_rmse():
    est, truth = _est_truth()
    return call(est, truth, 2, 0)


@example()
def velocity_rmse():
    est, truth = _est_truth()
    return call(est, truth, 2, 0)


@example()
def nees():
    return call(np.array([[1.0, -0.5], [0.2, 0.3]]), R2())


@example()
def nis():
    return call(np.array([1.0, -0.5]), R2())


@example()
def chi2_bounds():
    return call(2, 50, 0.05)


def _sets():
    X = np.array([[0.0, 0.0], [10.0, 1.0], [50.0, 50.0]])
    Y = np.array([[1.0, 0.5], [9.0, 2.0]])
    return X, Y


@example()
def ospa():
    X, Y = _sets()
    return (call(X, Y, 20.0, 2.0)
            .accepts("p=300", [[0, 0], [1, 1]], [[50, 0], [0, 50]], 100, 300.0))


@example()
def gospa():
    X, Y = _sets()
    return call(X, Y, 20.0, 2.0, 2.0)


@example()
def cardinality_error():
    return call(np.array([[1.0, 2.0, 2.0], [0.0, 3.0, 2.0]]), np.array([1.0, 2.0, 2.0]), 0)


# ------------------------------------------------------------------ montecarlo
def _trial(rng, scale=1.0):
    return {"a": scale * rng.standard_normal(), "b": np.arange(3.0)}


@example()
def run():
    return call(_trial, 5, 11, None, False, (2.0,), None, pass_index=False, chunksize=2)


@example()
def stack_results():
    return call([{"a": 1.0, "b": np.zeros(2)}, {"a": 2.0, "b": np.ones(2)}])


@example()
def default_chunksize():
    return call(100)


@example()
def process_pool():
    return call(1, "spawn")


@example()
def InlineExecutor():
    return call()


# ------------------------------------------------------------------ plotting
def _ax():
    import matplotlib.pyplot as plt
    return plt.subplots()[1]


@example()
def use_book_style():
    return call()


@example()
def plot_rmse_vs_time():
    t = np.arange(5.0)
    return call(_ax(), t, {"KF": np.array([1.0, 2.0, 1.5, 1.0, 0.5])}, [(1.0, 2.0)],
                xlabel="t [s]", ylabel="RMSE [m]", shade_label="turn",
                styles={"KF": {"lw": 2}})


@example()
def plot_tracks_2d():
    tr = np.cumsum(np.ones((6, 4)), axis=0)
    return call(_ax(), tr, {"PF": tr + 0.5}, [np.ones((2, 2)), np.zeros((0, 2))], units="km")


@example()
def plot_count_vs_scan():
    k = np.arange(5.0)
    return call(_ax(), k, {"PHD": np.array([0.0, 1.0, 1.2, 2.0, 2.1])},
                np.array([0.0, 1.0, 1.0, 2.0, 2.0]), ylabel="count")


@example()
def plot_consistency():
    t = np.arange(5.0)
    return call(_ax(), t, np.array([1.0, 2.0, 3.0, 2.0, 1.5]), (1.5, 2.6), "NIS",
                xlabel="t [s]")


@example()
def paper_vs_ours_table():
    return call([["RMSE", 1.5, 1.7], ["Pd", None, 0.9]], ("quantity", "paper", "ours"),
                floatfmt=".2f")


@example()
def results_table():
    return call([["RMSE", 1.5, 1.7]], ("quantity", "paper", "ours"), floatfmt=".2f",
                align="lrr")


@example()
def integer_ticks():
    return call(_ax(), "both")


# ------------------------------------------------------------------ shared scenario data
# Built once per child process (lru_cache) and copied into each case.
@functools.lru_cache(maxsize=None)
def _hpda_data(K=8):
    from trackcore.scenarios import hpda_parameters, hpda_truth, simulate_hpda_scans
    p = hpda_parameters(1)
    truth = hpda_truth(n_scans=K)
    scans = simulate_hpda_scans(truth, p, rng(1))
    return p, truth, scans


def hpda_data(K=8):
    import copy
    return copy.deepcopy(_hpda_data(K))


@functools.lru_cache(maxsize=None)
def _tbd_data(K=6):
    from trackcore.scenarios import TbdRadarParameters, simulate_tbd_radar, tbd_radar_truth
    prm = TbdRadarParameters(n_scans=K)
    truth = tbd_radar_truth(prm)
    scans = simulate_tbd_radar(truth, prm, rng(2))
    return prm, truth, scans


def tbd_data(K=6):
    import copy
    return copy.deepcopy(_tbd_data(K))


@functools.lru_cache(maxsize=None)
def _scene(name="S2a"):
    from trackcore.scenarios import render_scene
    return render_scene(name, rng(3))


def scene(name="S2a"):
    import copy
    return copy.deepcopy(_scene(name))


@functools.lru_cache(maxsize=None)
def _segmented(name="S2a"):
    from trackcore.scenarios import segment_scene
    return segment_scene(_scene(name), "running_average")


def segmented(name="S2a"):
    import copy
    return copy.deepcopy(_segmented(name))


@functools.lru_cache(maxsize=None)
def _sprt_data():
    from trackcore.scenarios import sprt_acm_measurements, sprt_acm_scenario, sprt_acm_truth
    sc = sprt_acm_scenario(1)
    truth = sprt_acm_truth(sc)
    z = sprt_acm_measurements(sc, rng(5), truth)
    return sc, truth, z


def sprt_data():
    import copy
    return copy.deepcopy(_sprt_data())


@functools.lru_cache(maxsize=None)
def _houles_scans():
    from trackcore.scenarios import houles_measurements, houles_truth
    truth = houles_truth(np.arange(8.0))
    return truth, houles_measurements(truth, rng(6), clutter_density=5e-5, window=600.0)


def houles_scans():
    import copy
    return copy.deepcopy(_houles_scans())


def _dets(points):
    from trackcore.detection import ImageDetections, vehicle_sprite
    z = np.array(points, float).reshape(-1, 2)
    van = vehicle_sprite("van")[1]
    return ImageDetections(z, np.zeros((len(z), 4), np.int64), np.zeros(len(z), np.int64),
                           [van] * len(z), [van] * len(z))


# ------------------------------------------------------------------ models: TOM, modified polar
@example()
def chord_heading():
    return call(np.array([100.0, 50.0]), np.array([110.0, 52.0]), 0.3, 1e-6)


@example()
def tom_rotation():
    return call(0.7)


@example()
def tom_transition():
    return call(0.7, 2.0)


@example()
def tom_process_noise():
    return call(0.7, 2.0, 1.0, 3.0, "cwna")


@example()
def tom_printed_process_noise():
    return call(0.7, 2.0, 1.0, 3.0)


@example("tom_from_cartesian", "tom_to_cartesian")
def _tom_frames():
    return call(x4(), P4(), 0.4)


@example()
def modified_polar_from_cartesian():
    return call(np.array([1000.0, 500.0]))


def _mp_state():
    from trackcore.models import modified_polar_from_cartesian as mp
    return mp(np.array([1000.0, 500.0]))


@example("modified_polar_f", "modified_polar_F")
def _mp_f():
    return call(_mp_state(), np.array([1.0, -2.0]))


@example()
def modified_polar_Q():
    return call(_mp_state(), 1.0, 2.0)


# ------------------------------------------------------------------ association: HPDA, JPDA
@example("hpda_rank_probabilities", "hpda_false_rank_probabilities",
         "hpda_measurement_count_probability", "hpda_conditional_rank_probabilities",
         "hpda_log_rank_probabilities", "hpda_rank_probabilities_printed")
def _hpda_ranks():
    return call(3, 10.0, 2.0, 0.99, 1.5)


@example()
def rank_probability_q():
    return call(np.array([1, 2, 3]), 3, 5.0)


@example("pa_bar", "pa_bar_alternating")
def _pa_bar():
    return call(4, 5.0)


@example()
def rank_gamma():
    return call(2, 5.0)


@example()
def hpda_betas():
    return (call(np.array([0.02, 0.01]), np.array([0.6, 0.3]), np.array([0.2, 0.3]), 5.0)
            .rejects("p_target=1.1", np.array([0.02]), np.array([1.1]), np.array([0.2]), 5.0,
                     match="p_target"))


@example()
def hpda_select():
    return call(np.array([0.1, 0.6, 0.3]))


@example()
def hpda_mixture_loglik():
    r = np.random.default_rng(3)
    X = np.column_stack([r.normal(3000, 50, 30), r.normal(4000, 50, 30), np.zeros(30),
                         np.zeros(30)])
    R = np.diag([50.0 ** 2, np.deg2rad(0.1) ** 2])
    z = np.array([5000.0, math.atan2(4000, 3000)])
    return (call(X, z, R, 0.7, 0.3, 6.0, np.array([1.0, 2.0]))
            .rejects("asymmetric-R", X, z, np.array([[2500.0, 40.0], [0.0, 3e-6]]), 0.7, 0.3,
                     6.0, match="R"))


@example()
def existence_predict():
    return call(0.7, 0.98, 0.01)


@example()
def existence_update():
    return call(0.6, -0.5)


@example()
def hpda_existence_delta():
    return call(3, 1, 0.01, 10.0, 2.0, 0.99, 1e-3, 5.0)


@example()
def nn_existence_delta():
    return call(2, 1.0, 0.05, 0.9, 0.99, 2.0)


@example()
def ipda_existence_delta():
    return call(np.array([0.1, 0.05]), 0.9, 0.99, 2.0)


@example()
def simulate_hpda_ranks():
    return call(rng(), 200, 10.0, 2.0, 0.99, 1.5, 4)


@example()
def simulate_existence_posterior():
    return call(rng(), 500, 2, 1, (1.0, 0.5), 0.3, 10.0, 2.0, 9.21, 1.5, 0.5)


def _valid():
    return np.array([[True, True], [True, False], [False, True]])


@example("feasible_event_count")
def feasible_event_count():
    # counted without enumerating (5.3e10 events in a fraction of a second)
    return call(_valid()).accepts("12x12-all-valid", np.ones((12, 12), bool))


@example("feasible_events")
def feasible_events():
    return call(_valid()).rejects("12x12-all-valid", np.ones((12, 12), bool),
                                  match="MAX_LISTED_EVENTS")


@example("jpda_clusters")
def _valid_clusters():
    return call(_valid()).accepts("12x12-all-valid", np.ones((12, 12), bool))


@example()
def feature_validation():
    return call(_valid(), np.array([[1.0, 0.5], [0.8, 0.7], [0.2, 0.9]]), 0.6)


@example()
def jpda_marginals():
    return (call(np.full((3, 2), 0.01), _valid(), 0.9, 1e-3,
                 np.array([[1.0, 0.7], [0.8, 0.7], [0.2, 0.9]]), "parametric", None, 0.6)
            .accepts("10x10-all-valid", np.full((10, 10), 0.01), np.ones((10, 10), bool), 0.9,
                     1e-3)
            # the 10x10 case is the first to run the hypothesis net: it compiles its kernels
            # on a cold numba cache (about 5 s CPU)
            .limit(30))


@example()
def permanent():
    return (call(np.array([[1.0, 2.0, 0.5], [0.3, 1.0, 2.0]]))
            .accepts("2x30-ones", np.ones((2, 30))))


# ------------------------------------------------------------------ detection
@example("amplitude_likelihood_ratio")
def _alr():
    return call(np.array([1.5, 3.0]), 10.0, 1.2)


@example()
def clutter_amplitude_pdf():
    return call(np.array([0.5, 2.0]))


@example()
def target_amplitude_pdf():
    return call(np.array([0.5, 2.0]), 10.0)


@example()
def exponential_amplitude_threshold():
    return call(0.9, 10.0)


@example()
def exponential_detection_probability():
    return call(2.0, 10.0)


@example()
def exponential_false_alarm_probability():
    return call(2.0)


@example()
def sample_clutter_amplitudes():
    return call(rng(), 5, 1.2)


@example()
def sample_target_amplitudes():
    return call(rng(), 5, 10.0, 1.2)


@example("marcum_q1", "marcum_q1_complement", "log_marcum_q1", "log_marcum_q1_complement")
def _marcum():
    return (call(np.array([1.0, 3.0]), np.array([2.0, 2.5]))
            .accepts("a=3e4", 3e4, 1.0).accepts("a=1e300", 1e300, 1.0))


@example("marcum_detection_probability", "marcum_miss_probability",
         "log_marcum_detection_probability", "log_marcum_miss_probability",
         "swerling1_detection_probability", "swerling1_miss_probability",
         "detection_probability")
def _pd_pfa():
    return call(np.array([3.0, 20.0]), 1e-4)


@example()
def square_law_threshold():
    return call(1e-4)


@example()
def rician_log_likelihood_ratio():
    return call(np.array([2.0, 8.0]), 5.0)


@example()
def sprt_thresholds():
    return call(0.05, 0.02)


@example()
def sprt_symmetric_error():
    return call(3.0)


@example()
def SprtState():
    return call(0.5, 2, -1, 0)


@example()
def sprt_step():
    from trackcore.detection import SprtState as S
    return call(S(0.5, 2, -1, 0), 0.7, -2.0, 2.5)


@example()
def sprt_decide():
    return call(np.array([[0.5, 1.0, 3.0], [-0.5, -2.5, -1.0]]), -2.0, 2.5)


@example()
def sprt_test():
    return call(np.array([0.5, 0.6, 1.8, 0.1]), -2.0, 2.5)


@example()
def sprt_summary():
    return call(np.array([[0.5, 1.0, 3.0], [-0.5, -2.5, -1.0], [1.0, 2.0, 2.6]]), -2.0, 2.5, 1)


@example()
def wald_error_probabilities():
    return call(-2.9, 2.9)


@example()
def wald_oc():
    return call(0.5, -2.9, 2.9)


@example()
def wald_asn():
    return call(-0.6, -2.9, 2.9, 0.95)


@example()
def first_crossing_scan():
    return call(np.array([0.5, 1.5, 3.0, 2.0]), 2.0)


@example()
def gaussian_llr_walks():
    return call(1.0, 5, 12, rng())


@example()
def wald_expected_stopping_llr():
    return call(-2.9, 2.9, 0.4)


@example()
def wald_gaussian_oc_asn():
    return call(-0.3, 1.0, -2.9, 2.9)


@example()
def vehicle_sprite():
    return call("van")


@example()
def glare_sprite():
    return call(3.5, 180.0)


@example()
def bar_sprite():
    return call(12, 4, 90.0)


@example()
def foliage_sprite():
    return call(rng(), 5.0, 70.0, 0.3).rejects("radius=nan", rng(), np.nan, match="radius")


@example()
def rotate_sprite():
    from trackcore.detection import vehicle_sprite as vs
    I, M = vs("sedan")
    return call(I, M, 0.35)


@example()
def terrain():
    return call(rng(), (40, 60), 40.0, 8.0, 30.0, (10, 16), (20, 26), None)


def _small_frame():
    from trackcore.detection import terrain as tr
    return tr(rng(4), (40, 60), 40.0, 8.0, 30.0, (10, 16), (20, 26), None)


@example()
def render_frame():
    from trackcore.detection import vehicle_sprite as vs
    I, M = vs("van")
    return (call(_small_frame(), [(I, M, 30.0, 20.0)], rng(), 1.0, 3.0)
            .rejects("gain=nan", _small_frame(), [(I, M, 30.0, 20.0)], rng(), np.nan, 3.0,
                     match="gain"))


@example()
def ViBe():
    return call(_small_frame().astype(np.uint8), rng(), 8, 12.0, 2, 16)


@example()
def RunningAverage():
    return call(_small_frame().astype(np.uint8), 0.05, 12.0)


def _mask():
    m = np.zeros((30, 40), bool)
    m[5:15, 5:25] = True
    return m


@example()
def clean_mask():
    return call(_mask())


@example()
def detect_blobs():
    m = _mask()
    return call(m, np.where(m, 60.0, 30.0), 25, 4, True)


@example()
def mask_iou():
    m = _mask()
    return call(m, np.roll(m, 2, axis=1))


@example("ncc", "ncc_reference")
def _ncc():
    from trackcore.detection import vehicle_sprite as vs
    bad = vs("van")[1].astype(float)
    bad[0, 0] = np.nan
    return (call(vs("van")[1], vs("sedan")[1], 2, "mask")
            .rejects("mask-nan", bad, vs("sedan")[1], 2, "mask", match="A"))


@example()
def ncc_sliding():
    from trackcore.detection import vehicle_sprite as vs
    return call(vs("van")[1], vs("sedan")[1], 2, "mask")


@example()
def ncc_matrix():
    from trackcore.detection import vehicle_sprite as vs
    m = [vs("van")[1], vs("sedan")[1]]
    return call(m, m[::-1], 2, "mask")


# ------------------------------------------------------------------ trackers
@example()
def HpdaPfConfig():
    return (call(0.9, 10.0, 3e-8, n_particles=50, T=10.0, sigma_r=50.0, pi11=0.98,
                 p_confirm=0.9, gate_probability=0.99)
            .rejects("pi11=1.1", 0.9, 10.0, 3e-8, pi11=1.1, match="pi11")
            .rejects("sigma_r=-50", 0.9, 10.0, 3e-8, sigma_r=-50.0, match="sigma_r"))


@example()
def ClusteringConfig():
    return (call(0.9, 3e-8, n_particles=40, T=10.0, sigma_r=50.0, eta=2, eps_w=1.0)
            .rejects("sigma_r=0", 0.9, 3e-8, sigma_r=0.0, match="sigma_r"))


@example()
def SmcPhdConfig():
    return (call(0.9, 3e-8, n_per_target=50, n_birth=30, T=10.0, sigma_r=50.0,
                 birth_mass=0.2, p_survival=0.99)
            .rejects("sigma_r=0", 0.9, 3e-8, sigma_r=0.0, match="sigma_r"))


@example()
def hpda_pf_run():
    from trackcore.trackers import HpdaPfConfig as C
    p, truth, s = hpda_data()
    cfg = C(pd=p.pd, snr=p.snr, clutter_density_xy=p.clutter_density_xy, n_particles=40)
    # a config changed inside the case, so that a validating constructor raises there
    return (call(s.z, s.amplitude, s.offsets, cfg, rng()).limit(10)
            .rejects("snr=-1", s.z, s.amplitude, s.offsets, _Replace(cfg, {"snr": -1.0}), rng(),
                     match="snr")
            .rejects("sigma_r=0", s.z, s.amplitude, s.offsets, _Replace(cfg, {"sigma_r": 0.0}),
                     rng(), match="sigma_r"))


@example()
def clutter_likelihood_ratios():
    return call("ipda", 1.0, 3.0, 0.9, 0.99, 50, rng())


@example()
def clustering_run():
    from trackcore.trackers import ClusteringConfig as C
    p, truth, s = hpda_data()
    cfg = C(pd=p.pd, clutter_density_xy=p.clutter_density_xy, n_particles=40)
    return call(s.z, s.offsets, cfg, rng()).limit(10)


@example()
def smc_phd_run():
    from trackcore.trackers import SmcPhdConfig as C
    p, truth, s = hpda_data()
    cfg = C(pd=p.pd, clutter_density_xy=p.clutter_density_xy, n_per_target=40, n_birth=20)
    return call(s.z, s.offsets, cfg, rng()).limit(10)


@example()
def check_scans():
    p, truth, s = hpda_data()
    return call(s.z, s.amplitude, s.offsets)


def _phd_model():
    from trackcore.models import cv_process_noise as cq, cv_transition as ct
    from trackcore.trackers import smc_phd_model as mk
    return mk(ct(1.0), cq(1.0, 0.5, kind="cwna"), np.diag([100.0, 1e-4]), pd=0.9, ps=0.99,
              clutter_intensity=1e-3, birth_mean=np.array([1800.0, 1800.0, 0.0, 0.0]),
              birth_cov=np.diag([1e6, 1e6, 100.0, 100.0]), n_birth=20, birth_rate=0.05)


def _phd_particles(N=40):
    r = np.random.default_rng(12)
    X = np.array([1500.0, 1000.0, 0.0, 0.0]) + r.standard_normal((N, 4)) * [20, 20, 2, 2]
    return X, np.full(N, 1.0 / N)


def _phd_scan():
    return np.array([[1803.0, 0.588], [2500.0, 1.0], [900.0, 0.3]])


@example()
def smc_phd_model():
    from trackcore.models import cv_process_noise as cq, cv_transition as ct
    return call(ct(1.0), cq(1.0, 0.5, kind="cwna"), np.diag([100.0, 1e-4]), pd=0.9, ps=0.99,
                clutter_intensity=1e-3, birth_mean=np.array([1800.0, 1800.0, 0.0, 0.0]),
                birth_cov=np.diag([1e6, 1e6, 100.0, 100.0]), n_birth=20, birth_rate=0.05,
                sensor=(0.0, 0.0), gate=60.0)


@example()
def smc_phd_update():
    X, w = _phd_particles()
    return call(X, w, _phd_scan(), np.diag([100.0, 1e-4]), 0.9, 1e-3, sensor=(0.0, 0.0),
                gate=60.0)


@example()
def smc_phd_step():
    X, w = _phd_particles()
    return (call(X, w, _phd_scan(), _phd_model(), rng(), n_out=50)
            .rejects("model.pd=1.1", X, w, _phd_scan(), _phd_model()._replace(pd=1.1), rng(),
                     match="pd"))


@example()
def smc_phd_filter():
    X, w = _phd_particles()
    z = np.vstack([_phd_scan(), _phd_scan()[:2]])
    return (call(X, w, z, np.array([0, 3, 5]), _phd_model(), rng(), n_out=50)
            .rejects("model.n_birth=nan", X, w, z, np.array([0, 3, 5]),
                     _phd_model()._replace(n_birth=np.nan), rng(), match="n_birth"))


@example()
def TbdTrackerConfig():
    return call("C", 50, 2500.0, 150.0, 40.0, 15.0, 1e-6, 0.5, 11.345)


@example()
def run_tbd_tracker():
    from trackcore.scenarios import TBD_INITIAL_COVARIANCE
    from trackcore.trackers import TbdTrackerConfig as C
    prm, truth, s = tbd_data()
    return call(s, truth.states[0], TBD_INITIAL_COVARIANCE, rng(), C(method="C", n_particles=50))


@example()
def run_tbd_gated_b():
    from trackcore.scenarios import TBD_INITIAL_COVARIANCE
    from trackcore.trackers import TbdTrackerConfig as C
    _, truth, s = tbd_data()
    return call(s, truth.states[0], TBD_INITIAL_COVARIANCE, rng(), C(method="B", n_particles=50))


@example()
def run_tbd_snr_ekf():
    from trackcore.scenarios import TBD_INITIAL_COVARIANCE
    from trackcore.trackers import TbdTrackerConfig as C
    _, truth, s = tbd_data()
    return call(s, truth.states[0], TBD_INITIAL_COVARIANCE, C(method="A"))


@example()
def run_tbd_imm():
    from trackcore.scenarios import TBD_INITIAL_COVARIANCE
    from trackcore.trackers import TbdTrackerConfig as C
    _, truth, s = tbd_data()
    return call(s, truth.states[0], TBD_INITIAL_COVARIANCE, C(method="A"))


def _tbd_particles():
    r = np.random.default_rng(7)
    return np.array([30e3, 10e3, 5e3, -150.0, 50.0, 0.0]) + r.normal(0, 100, (20, 6))


@example()
def direct_particle_log_weights():
    X = _tbd_particles()
    p = X[:3, :3] + 10.0
    return call(X, p, np.array([-150.0, -140.0, 10.0]), np.array([5.0, 20.0, 3.0]), 150.0, 40.0,
                1e-6, kernel="laplace")


@example()
def weighted_mean_detection():
    X = _tbd_particles()
    return call(X[:3, :3], np.array([-150.0, -140.0, 10.0]), np.array([5.0, 20.0, 3.0]),
                X[0, :3], -150.0, 150.0, 40.0, 1e-6, kernel="laplace")


@example("radial_velocity", "range_azimuth_elevation", "spherical_to_cartesian")
def _tbd_x():
    return call(_tbd_particles()[:4])


@example()
def range_azimuth_elevation_jacobian():
    return call(_tbd_particles()[0], with_doppler=True)


@example()
def tbd_position_errors():
    X = _tbd_particles()
    return call(X[:5], X[5:10])


@example()
def tbd_measurement_errors():
    pos = np.array([[1.0, 0, 0], [3.0, 0, 0], [0.0, 0, 0]])
    return call(pos, np.array([0, 2, 2, 3]), np.zeros((3, 6)), np.array([True, True, False]))


@example("tbd_track_lost", "tbd_loss_onset")
def _tbd_lost():
    e = np.r_[np.zeros(5), np.full(12, 2000.0), np.zeros(3)]
    return call(e, 1000.0, 10)


@example()
def tbd_error_summary():
    E = np.full((4, 12), 100.0)
    E[1, 1:12] = 2000.0
    return call(E, slice(0, 5), 5000.0)


@example()
def IntensityGrid():
    return call(75.0, 0.0087, 0.5, 6, 3)


@example()
def IntensityTbdConfig():
    return call(50, 4.0, 15.0, 0.5, 1.0)


def _grid():
    from trackcore.trackers import IntensityGrid as G
    return G(75.0, 0.0087, 0.5, 6, 3)


def _cell_centre(i, j, k, g):
    r = i * g.range_cell
    az = j * g.angle_cell
    el = k * g.angle_cell
    return np.array([r * math.cos(el) * math.cos(az), r * math.cos(el) * math.sin(az),
                     r * math.sin(el)])


@functools.lru_cache(maxsize=None)
def _maps():
    from trackcore.scenarios import simulate_intensity_maps as sim
    g = _grid()
    p = np.array([_cell_centre(500 + k, 60, 10, g) for k in range(4)])
    return p, sim(p, np.full(4, 8.0), g, rng(8))


@example()
def IntensityMaps():
    import copy
    p, m = _maps()
    m = copy.deepcopy(m)
    return call(m.footprint_centre, m.footprint_power, m.noise_key, m.grid)


@example()
def intensity_psf():
    return call(_cell_centre(500, 60, 10, _grid()), _grid())


@example()
def intensity_log_likelihood_ratio():
    import copy
    p, m = _maps()
    m = copy.deepcopy(m)
    X = np.column_stack([p[0] + np.random.default_rng(9).normal(0, 100, (20, 3)),
                         np.zeros((20, 3))])
    return call(X, m, 0, 8.0)


@example()
def simulate_intensity_maps():
    g = _grid()
    p = np.array([_cell_centre(500 + k, 60, 10, g) for k in range(3)])
    return call(p, np.full(3, 8.0), g, rng())


@example()
def run_intensity_tbd():
    import copy
    from trackcore.trackers import IntensityTbdConfig as C
    p, m = _maps()
    m = copy.deepcopy(m)
    x0 = np.r_[p[0], 75.0, 0.0, 0.0]
    P0 = np.diag([100.0 ** 2] * 3 + [20.0 ** 2] * 3)
    return call(m, x0, P0, rng(), C(n_particles=50))


@example()
def markov_matrix():
    return call(3, 0.9).rejects("r=2.5", 2.5, 0.9, match="r")


def _houles_errors(n_runs=6, n_filters=2, seed=7):
    """Squared position errors (runs, filters, 90) of a Table 1 experiment; run 0 of
    filter 0 loses the target from t = 30 s on."""
    e = rng(seed).gamma(2.0, 200.0, size=(n_runs, n_filters, 90))
    e[0, 0, 29:] = 1e6
    return e


@example()
def window_mse():
    return call(_houles_errors()[:, 0])


@example()
def failure_anatomy():
    return call(_houles_errors()[:, 0], 200.0)


@example()
def rmse_estimate():
    e = _houles_errors()
    return call(e, np.any(e > 200.0**2, axis=-1), 1, window="manoeuvring")


@example()
def rmse_ratio():
    e = _houles_errors()
    return call(e, np.any(e > 200.0**2, axis=-1), 1, 0, window="total")


@example()
def rmse_estimate_mse():
    from trackcore.scenarios import window_mse

    e = _houles_errors()
    return call(window_mse(e), np.any(e > 200.0**2, axis=-1), 1, window="manoeuvring")


@example()
def rmse_ratio_mse():
    from trackcore.scenarios import window_mse

    e = _houles_errors()
    return call(window_mse(e), np.any(e > 200.0**2, axis=-1), 1, 0, window="total")


@example()
def cv_model_set():
    return call(1.0, 2.0)


@example()
def ct_imm_model_set():
    return call((0.0, 0.05, -0.05), (1.0, 2.0, 2.0), 1.0)


@example()
def tom_model_set():
    return call((0.0, 10.0, -10.0), (1.0, 3.0, 3.0), 1.0, 1.0)


@example()
def car_imm_model_set():
    return call(1.0, 0.14, 1.0, 8.0, None, (0.8, 0.1, 0.1))


@example()
def singer_imm_model_set():
    return call(1.0, (20.0, 5.0), (15.0, 60.0), 1.0, 15.0, None, (0.8, 0.1, 0.1))


@example()
def tom_imm_model_set():
    return call(1.0, 70.0, 1.0, 3.0, 20.0, None, (0.8, 0.1, 0.1), "dwna")


@example()
def two_point_init():
    return call(np.array([100.0, 200.0]), np.array([110.0, 195.0]), 400.0 * np.eye(2), 1.0)


@example()
def pack_scans():
    return call([np.zeros((0, 2)), np.array([[1.0, 2.0]]), np.ones((3, 2))], 2)


def _imm_pdaf_inputs():
    from trackcore.trackers import two_point_init as tpi
    truth, s = houles_scans()
    x0, P0 = tpi(s.z[s.target_index[0]], s.z[s.target_index[1]], 400.0 * np.eye(2))
    z, off = s.z[s.offsets[2]:], s.offsets[2:] - s.offsets[2]
    return z, off, x0, P0


@example()
def imm_pdaf_track_packed():
    from trackcore.trackers import car_imm_model_set as car
    z, off, x0, P0 = _imm_pdaf_inputs()
    return (call(car(), z, off, x0, P0, 400.0 * np.eye(2), pd=0.9, pg=0.99,
                 clutter_density=5e-5, prev_position=None)
            .rejects("pd=1.1", car(), z, off, x0, P0, 400.0 * np.eye(2), pd=1.1, pg=0.99,
                     clutter_density=5e-5, prev_position=None, match="pd"))


@example()
def imm_pdaf_track():
    from trackcore.trackers import car_imm_model_set as car
    z, off, x0, P0 = _imm_pdaf_inputs()
    scans = [z[off[k]:off[k + 1]] for k in range(len(off) - 1)]
    return call(car(), scans, x0, P0, 400.0 * np.eye(2), pd=0.9, pg=0.99,
                clutter_density=5e-5, prev_position=None)


@example()
def JPDATrackerConfig():
    return (call("FJPDA", 0.3, 1.0, 0.9, 9.21, 1e-5, 0.6, 5.0, 3.0, 20.0, 5.0, 3, True, "cv",
                 4.0)
            .rejects("pair_margin=-1", pair_margin=-1.0, match="pair_margin")
            .rejects("dup_frames=nan", dup_frames=np.nan, match="dup_frames"))


@example()
def JPDATracker():
    from trackcore.trackers import JPDATrackerConfig as C
    return call(C(variant="JPDA"))


@example()
def run_jpda_tracker():
    from trackcore.trackers import JPDATrackerConfig as C
    dets = [_dets([[50.0 + 2 * k, 100.0 + 0.5 * k]]) for k in range(6)]
    bad = list(dets)
    bad[2] = _dets([[np.nan, 101.0]])
    return (call(dets, C(variant="FJPDA"))
            .rejects("nan-detection", bad, C(variant="FJPDA"), match="detections"))


@example()
def SprtAcmFilterConfig():
    return call(5.0, 0.035, 1.0, 2.0, 1.0, 2.0, 100.0, 30.0)


@example()
def sprt_acm_discriminate():
    from trackcore.trackers import SprtAcmFilterConfig as C
    sc, truth, z = sprt_data()
    return call(z.z_pre, z.z_a, z.z_b, truth.own, sc.T, C())


@example()
def sprt_acm_llr():
    return call(np.array([[-1.0, -2.0, -1.5, -0.5], [-3.0, -1.0, -2.0, -2.0]]))


# ------------------------------------------------------------------ scenarios
@example()
def HpdaParameters():
    return (call(0.9, 10.0, 5.0, 10.0, 20, 1e4, 50.0, 0.0017, 0.0015, 0.01)
            .rejects("sigma_r=nan", 0.9, 10.0, 5.0, sigma_r=np.nan, match="sigma_r"))


@example()
def hpda_parameters():
    return call(2)


@example()
def hpda_truth():
    return call("B", 10.0, 0.01, 12, 20)


@example()
def hpda_true_count():
    p, truth, s = hpda_data()
    return call(truth)


@example()
def simulate_hpda_scans():
    p, truth, s = hpda_data()
    return call(truth, p, rng())


@example()
def hpda_tracker_configs():
    from trackcore.scenarios import hpda_parameters as hp
    return call(hp(1), hpda={"n_particles": 50})


@example()
def track_delays():
    from trackcore.trackers import HpdaPfConfig as C, hpda_pf_run as run
    p, truth, s = hpda_data()
    res = run(s.z, s.amplitude, s.offsets,
              C(pd=p.pd, snr=p.snr, clutter_density_xy=p.clutter_density_xy, n_particles=40),
              rng())
    return call(res, truth, 500.0)


@example()
def run_hpda_trial():
    return call(rng(), 1, ("phd",), False, {"phd": {"n_per_target": 30, "n_birth": 20}},
                {"n_scans": 6}).limit(10)


@example()
def TbdRadarParameters():
    return (call(1.0, 10, 0.01, 1.3e9, 100, 35.0, 35.0, 10.0)
            .rejects("n_pulses=nan", n_pulses=np.nan, match="n_pulses"))


@example()
def tbd_radar_truth():
    from trackcore.scenarios import TbdRadarParameters as P
    return call(P(n_scans=8))


@example()
def simulate_tbd_radar():
    prm, truth, s = tbd_data()
    return call(truth, prm, rng())


@example()
def select_threshold():
    prm, truth, s = tbd_data()
    return call(s, 7.0)


@example()
def sample_clutter():
    c = np.random.default_rng(11).uniform(-1e4, 1e4, (3, 3))
    return call(c, 2000.0, 10 ** 0.5, 2.82, 300.0, rng())


@example()
def radar_equation_snr():
    return (call(np.array([1.0, 2.0]), np.array([10e3, 20e3]), 1e-3)
            .rejects("rcs<0", np.array([-0.01]), np.array([10e3]), 1e-3, match="rcs_m2"))


@example()
def tbd_paired_trial():
    from trackcore.scenarios import TBD_INITIAL_COVARIANCE
    from trackcore.trackers import TbdTrackerConfig as C
    prm, truth, s = tbd_data()
    return call(rng(), {"C": C(n_particles=30)}, prm, truth, TBD_INITIAL_COVARIANCE, False)


@example()
def tbd_intensity_trial():
    from trackcore.scenarios import TBD_INITIAL_COVARIANCE
    from trackcore.trackers import IntensityTbdConfig as C
    prm, truth, s = tbd_data()
    return call(rng(), C(n_particles=30), prm, truth, _grid(), TBD_INITIAL_COVARIANCE, False)


@example()
def houles_truth():
    return call(np.array([0.0, 10.0, 25.5, 60.0]))


@example()
def houles_windows():
    return call()


@example()
def houles_measurements():
    from trackcore.scenarios import houles_truth as ht
    t = np.arange(6.0)
    return call(ht(t), rng(), sigma=20.0, pd=0.9, clutter_density=5e-5, window=600.0, times=t)


@example()
def houles_imm_trial():
    from trackcore.trackers import car_imm_model_set as car
    return call(rng(), [car()], pd=0.9, pg=0.99, clutter_density=2e-6, window=2000.0,
                sigma=20.0, detect_init=True).limit(10)


@example()
def houles_table():
    e = np.random.default_rng(0).exponential(300.0, size=(6, 2, 90))
    failed = np.zeros((6, 2), bool)
    failed[1, 1] = True
    return call(e, failed, rng(), n_boot=50, reference=0, level=0.95)


@example()
def position_failures():
    e = np.random.default_rng(0).exponential(100.0, size=(3, 90))
    return call(e, 200.0)


@example()
def gate_miss_failures():
    g = np.array([[1, 0, 0, 0, 1], [1, 1, 0, 1, 1]], dtype=np.int64)
    return call(g, 3)


@example()
def random_manoeuvre_xy():
    return call(rng(), 50, 1.0, 2.0, 20.0, 200.0)


@example()
def random_manoeuvre_turn():
    return call(rng(), 50, 1.0, 1.3, 0.006, 0.3, (50.0, 400.0), 20.0, 200.0)


@example()
def forward_lateral():
    return call(np.array([[0.0, -3.0], [1.0, 1.0]]), np.array([[10.0, 0.0], [0.0, 5.0]]))


@example()
def cross_correlation_coefficient():
    r = np.random.default_rng(1)
    u = r.normal(size=50)
    return call(u, np.roll(u, 2) + 0.1 * r.normal(size=50), 5)


@example()
def SprtAcmScenario():
    from trackcore.scenarios import sprt_acm_scenario as s
    import dataclasses
    sc = s(1)
    return call(**{f.name: getattr(sc, f.name) for f in dataclasses.fields(sc) if f.init})


@example()
def sprt_acm_scenario():
    return call(2, t_end=80.0).rejects("t_end=nan", 1, t_end=np.nan, match="t_end")


@example()
def sprt_acm_states():
    sc, truth, z = sprt_data()
    return call(sc, np.array([0.0, 60.0, 70.0]))


@example()
def sprt_acm_truth():
    sc, truth, z = sprt_data()
    return call(sc)


@example()
def sprt_acm_measurements():
    sc, truth, z = sprt_data()
    return call(sc, rng(), truth, False)


@example()
def sprt_acm_filter_config():
    sc, truth, z = sprt_data()
    return call(sc, beta_std_factor=1.5)


@example()
def sprt_acm_trial():
    sc, truth, z = sprt_data()
    return call(rng(), sc, None, False)


@example()
def sprt_acm_monte_carlo():
    sc, truth, z = sprt_data()
    return call(sc, 2, 7, None, False)


@example()
def scene_layout():
    return call("S2a")


@example()
def render_scene():
    return call("S1", rng()).limit(10)


@example()
def segment_scene():
    return call(scene(), "running_average", None).limit(10)


@example()
def fig3_patches():
    return call(rng(), "running_average", (1, -2)).limit(10)


@example()
def crossing_detections():
    return call(rng(), 0.35, "van", "sedan", 2.5, 2.5, 3.0, 20, 10, 0.9, 1.0, 1.0, 0.2, 120.0)


def _reports(n=None):
    from trackcore.trackers import JPDATrackerConfig as C, run_jpda_tracker as run
    dets, _ = segmented()
    return run(dets[:n] if n else dets, C(variant="FJPDA"))


@example()
def match_tracks():
    sc = scene()
    reps = _reports()
    return call(sc.xy, sc.present, reps, 10.0)


@example()
def same_frames_error():
    a = np.array([[0.5, np.nan], [3.0, 1.0], [2.0, 1.5]])
    b = np.array([[np.nan, np.nan], [2.5, 0.5], [1.0, 2.5]])
    return call(a, b)


@example()
def scene_metrics():
    return call(scene(), _reports(), 10.0)


@example()
def clear_mot_metrics():
    return call(scene(), _reports(), 10.0)


@example()
def hota_metrics():
    return call(scene(), _reports(), 10.0)


@example()
def vehicle_mask_iou():
    from trackcore.scenarios.feature_scenes import N_WARMUP
    sc = scene()
    return call(sc, sc.labels[N_WARMUP:] > 0, 3).limit(10)


@example()
def scene_trial():
    from trackcore.trackers import JPDATrackerConfig as C
    return call(rng(), "S2a", {"JPDA": C(variant="JPDA")}, "running_average").limit(20)


@example()
def scene_trials():
    from trackcore.trackers import JPDATrackerConfig as C
    return call(rng(), "S2a", {"running_average": {"JPDA": C(variant="JPDA")}}).limit(20)


@example()
def scene_run():
    from trackcore.trackers import JPDATrackerConfig as C
    return call(rng(), "S2a", {"JPDA": C(variant="JPDA")}, "running_average").limit(20)


@example()
def crossing_trial():
    from trackcore.trackers import JPDATrackerConfig as C
    return call(rng(), {"JPDA": C(variant="JPDA")}, n_frames=30, conflict=15).limit(10)


@example()
def closest_approach():
    return call(scene())


@example()
def pair_gaps():
    sc = scene()
    a, b = sc.pair
    return call(sc.labels[-1], a + 1, b + 1)


@example()
def feature_correlation_samples():
    return call(rng(), 10, (20.0, 90.0), 0.2).limit(10)


@example()
def separate_blob_distance():
    return call(0.35, "van", "sedan", 2.5, 2.5, 60.0).limit(10)


@example()
def paired_comparison():
    return call(_runs(1), _runs(2), ("A", "B"), True)


# ------------------------------------------------------------------ stats
def _runs(seed=1, n=40):  # 40 >= trackcore.stats.MIN_RUNS
    return np.random.default_rng(seed).normal(1.0, 0.3, n)


@example()
def Estimate():
    return call(1.0, 0.8, 1.2, 0.95, 20, "bca")


@example()
def mean_ci():
    return call(_runs(), level=0.95, n_boot=200, seed=0)


@example("diff_ci", "paired_diff_ci")
def _diff_ci():
    return call(_runs(1), _runs(2), level=0.95, n_boot=200, seed=0)


@example()
def ratio_ci():
    return call(_runs(1) + 1, _runs(2) + 1, paired=True, level=0.95, n_boot=200, seed=0)


@example()
def paired_rate_diff_ci():
    x = (np.arange(600) % 5 == 0).astype(float)
    y = (np.arange(600) % 7 == 0).astype(float)
    return call(x, y, level=0.95, n_boot=200, seed=0)


@example()
def bootstrap_ci():
    return call(np.median, _runs(1), paired=True, level=0.95, n_boot=200, seed=0)


@example()
def rate_ci():
    return call(7, 20, level=0.95)


@example()
def wilson_interval():
    return call(7, 20, 1.96).rejects("k=nan", np.nan, 10, match="k")


@example()
def mcnemar_exact():
    return call(3, 9)


@example()
def compare():
    return call(_runs(1), _runs(2), ("A", "B"), paired=True, kind="difference",
                lower_is_better=True, level=0.95, n_boot=200, seed=0)


@example()
def band_verdict():
    from trackcore.stats import Estimate as E
    return call(E(1.0, 0.8, 1.2, 0.95, 20, "bca"), 0.5, 1.5)


# ------------------------------------------------------------------ added in wave 2
@example()
def failure_comparison():
    f = np.random.default_rng(4).random((30, 3)) < 0.3
    return call(f, 1, 0)


@example()
def count_error_ci():
    r = np.random.default_rng(5)
    c = r.integers(0, 4, (40, 8)).astype(float)  # MIN_RUNS runs
    return call(c, np.full(8, 2.0), versus=c + r.normal(0, 0.5, c.shape), paired=True,
                kind="e", early=None, seed=0)


@example()
def hpda_run_metrics():
    from trackcore.trackers import SmcPhdConfig as C, smc_phd_run
    p, truth, s = hpda_data()
    run = smc_phd_run(s.z, s.offsets, C(pd=p.pd, clutter_density_xy=p.clutter_density_xy,
                                         n_per_target=30, n_birth=20), rng())
    return call(run, truth, 500.0, 2.0)


@example()
def hpda_stress_clutter_mean():
    return call(1.0, reference_range=5000.0, sigma_r=150.0, sigma_theta=0.05, radius=10000.0,
                gate_probability=0.99)


@example()
def clustering_link_rates():
    from trackcore.trackers import ClusteringConfig as C
    p, truth, s = hpda_data()
    xy = truth.states[..., :2]
    rng_ = np.hypot(xy[..., 0], xy[..., 1])
    return call(s.z, s.offsets, s.origin, rng_,
                C(pd=p.pd, clutter_density_xy=p.clutter_density_xy, n_particles=40),
                np.array([0.0, 5000.0, 20000.0]))


@example()
def detection_snr_cap():
    return call(1e-6)


@example()
def intensity_false_alarm_probability():
    return call(5.0)


@example()
def intensity_tracker_config():
    return call("C", _grid(), 5.0)


@example()
def intensity_detections():
    import copy
    p, m = _maps()
    return call(copy.deepcopy(m), 0, p[0], 500.0, 3.0)


@example()
def run_tbd_tracker_on_map():
    import copy
    from trackcore.trackers import intensity_tracker_config as cfg
    p, m = _maps()
    x0 = np.r_[p[0], 0.0, 0.0, 0.0]
    return call(copy.deepcopy(m), x0, np.diag([100.0, 100, 100, 25, 25, 25]) ** 2, rng(),
                cfg("C", _grid(), 5.0, n_particles=50)).limit(10)


@example()
def pseudo_measurement_errors():
    from trackcore.trackers import TbdTrackerConfig as C
    _, truth, s = tbd_data()
    return call(s, truth.states, C(method="A", n_particles=50))


@example()
def tbd_nees():
    X = _tbd_particles()
    C = np.broadcast_to(np.diag([1e4, 1e4, 1e4, 100, 100, 100]), (5, 6, 6)).copy()
    return call(X[:5], C, X[5:10])


@example()
def tbd_run_outcomes():
    e = np.r_[np.zeros(5), np.full(12, 2000.0), np.zeros(3)]
    return call(np.vstack([e, np.zeros(20), np.full(20, 6000.0)]), 1000.0, 10, 5000.0)


@example()
def matched_config():
    return call("FJPDA", 0.5)


@example()
def steady_state_gate():
    from trackcore.trackers import JPDATrackerConfig as C
    return call(C(variant="FJPDA"))


@example()
def initial_gate():
    from trackcore.trackers import JPDATrackerConfig as C
    return call(C(variant="FJPDA"))


@example()
def failure_grid():
    r = np.random.default_rng(6)
    mx = r.random((40, 3)) * 3e5
    return call(mx, mx * r.random((40, 3)), r.random((40, 3)) < 0.1)
