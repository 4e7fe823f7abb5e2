"""Issue 31, items 2 and 3: the reliability review's F1 (a covariance that is PSD only to
rounding at its own scale) and F2 (``pg = 1``, no gate).

F1.  The one PSD rule (``trackcore.core.validation.as_covariance``): eigenvalues down to
``-1e-9 max|eig|`` are rounding.  It is applied to every covariance argument and to every
covariance a filter call returns (``kf_predict``, ``kf_update``, ``ekf_update``, ``imm_mix``,
``imm_combine``, ``imm_step``, ``pda_update``; every scan's for ``kalman_filter_run``,
``kalman_filter_batch`` and ``imm_filter_run``).  An argument whose negative eigenvalue is
rounding at its own scale but not at the result's gives a ``ValueError`` that names it,
instead of a covariance with a negative variance; a result that fails through the
computation's own rounding (no argument has a negative eigenvalue) is projected onto the PSD
cone.  Results that pass the rule are the kernels' outputs, bit for bit.

F2.  ``pg = 1`` is "no gate": ``gamma = inf``, every measurement validated, ``P_G = 1``, no
finite gate volume (``gate_volume(inf, S)`` and a nonparametric PDA with ``volume = inf``
raise ``ValueError``); the clutter density is then the parametric ``lambda``.
"""
import math

import numpy as np
import pytest

from trackcore.association import (gate_probability, gate_threshold, gate_volume,
                                   mahalanobis_gate, pda_betas, pda_log_likelihood, pda_update)
from trackcore.core.validation import as_covariance
from trackcore.filters import (ekf_update, imm_combine, imm_filter_run, imm_mix, imm_step,
                               kalman_filter_batch, kalman_filter_run, kf_predict, kf_update)
from trackcore.filters.kalman import kf_update_kernel
from trackcore.models import cv_process_noise, cv_transition, position_matrix
from trackcore.trackers import ClusteringConfig, HpdaPfConfig, cv_model_set, imm_pdaf_track

X = np.array([0.0, 1.0, 0.0, 1.0])
H = position_matrix()
NAMES_R = r"\bR \(smallest eigenvalue"


def _passes_rule(P):
    """The PSD rule of as_covariance (it raises otherwise)."""
    as_covariance(P, "P")
    return True


# --------------------------------------------------------------------------- F1 reproducers
def test_f1_reproducer_tiny_P_raises_naming_R():
    with pytest.raises(ValueError, match=NAMES_R) as e:
        kf_update(X, np.eye(4) * 1e-8, np.zeros(2), H, np.diag([1.0, -1e-9]))
    assert "positive semi-definite" in str(e.value), f"unclear message: {e.value}"


def test_f1_reproducer_large_R_raises_naming_R():
    with pytest.raises(ValueError, match=NAMES_R):
        kf_update(X, np.eye(4), np.zeros(2), H, np.diag([1e3, -1e-7]))


def test_f1_reproducer_with_R_clipped_gives_psd_posterior():
    """The same inputs with R's negative eigenvalue set to 0 (the repair the message
    suggests) give a posterior that passes the rule and can be predicted from."""
    for P, R in ((np.eye(4) * 1e-8, np.diag([1.0, 0.0])), (np.eye(4), np.diag([1e3, 0.0]))):
        r = kf_update(X, P, np.zeros(2), H, R)
        assert np.all(np.diag(r.P) >= 0), f"negative variance {np.diag(r.P)}"
        assert _passes_rule(r.P), "posterior fails the PSD rule"
        kf_predict(r.x, r.P, cv_transition(1.0), cv_process_noise(1.0, 1.0))


def test_f1_every_single_step_api_names_R():
    P, R = np.eye(4) * 1e-8, np.diag([1.0, -1e-9])
    with pytest.raises(ValueError, match=NAMES_R):
        ekf_update(X, P, np.zeros(2), H @ X, H, R)
    with pytest.raises(ValueError, match=NAMES_R):
        pda_update(X, P, np.zeros((1, 2)), H @ X, H, R, np.array([1.0]), 0.0)
    F, Q = cv_transition(1.0), np.zeros((4, 4))
    with pytest.raises(ValueError, match=NAMES_R):
        imm_step(np.stack([X, X]), np.stack([P, P]), np.array([0.5, 0.5]),
                 np.array([[0.9, 0.1], [0.1, 0.9]]), np.stack([F, F]), np.stack([Q, Q]),
                 np.zeros(2), H, R)


def test_f1_blames_P_when_P_is_the_cause():
    """P = diag(1, -1e-10) passes the rule at its own scale; measured precisely in its
    first component the posterior's scale is 1e-6, where -1e-10 is not rounding."""
    P = np.diag([1.0, -1e-10])
    with pytest.raises(ValueError, match=r"\bP \(smallest eigenvalue") as e:
        kf_update(np.zeros(2), P, np.zeros(2), np.eye(2), np.diag([1e-6, 1.0]))
    assert "R (smallest" not in str(e.value), f"R is PSD and was blamed: {e.value}"
    # and in a prediction that stretches the negative direction
    with pytest.raises(ValueError, match=r"\bP \(smallest eigenvalue"):
        kf_predict(np.zeros(2), P, np.diag([1e-5, 1.0]), np.zeros((2, 2)))


def test_f1_rounding_of_the_update_itself_is_projected():
    """An exactly singular R (rank 1, a perfectly correlated pair) far larger than P: the
    Joseph form's rounding alone leaves the posterior outside the rule (relative -5e-7),
    although no argument has a negative eigenvalue.  The posterior is then returned with
    its negative eigenvalue set to 0: within that eigenvalue of the kernel's output."""
    P, R = 0.01 * np.eye(2), 1e8 * np.array([[1.0, 3.0], [3.0, 9.0]])
    xo, Po, nu, S, K = (np.empty(2), np.empty((2, 2)), np.empty(2), np.empty((2, 2)),
                        np.empty((2, 2)))
    assert kf_update_kernel(np.zeros(2), P, np.zeros(2), np.eye(2), R, xo, Po, nu, S, K)[2]
    lam = np.linalg.eigvalsh(Po)
    assert lam[0] < -1e-9 * lam[-1], f"the case no longer fails the rule: {lam}"
    u = kf_update(np.zeros(2), P, np.zeros(2), np.eye(2), R)
    assert _passes_rule(u.P), "projected posterior fails the PSD rule"
    assert np.linalg.eigvalsh(u.P)[0] >= -1e-12 * lam[-1], "projection left a negative value"
    np.testing.assert_allclose(u.P, Po, rtol=0, atol=2 * abs(lam[0]),
                               err_msg="projection moved the posterior more than needed")
    assert u.x.tobytes() == xo.tobytes(), "the mean must not change"
    kf_predict(u.x, u.P, np.eye(2), np.zeros((2, 2)))  # the next call accepts it


def _run_case(q):
    zs = np.zeros((50, 2))
    return (zs, np.zeros(4), np.eye(4) * q, cv_transition(1.0), cv_process_noise(1.0, q), H,
            np.diag([1.0, -1e-9]))


@pytest.mark.parametrize("q", [1e-4, 1e-2])
def test_f1_whole_run_functions_name_R(q):
    """With process noise q the posterior's scale is about q, so R's -1e-9 breaks the rule
    in every scan's covariance (relative -3e-6 at q = 1e-4) without making S indefinite:
    the whole-run functions used to return those covariances silently."""
    zs, x0, P0, F, Q, Hm, R = _run_case(q)
    with pytest.raises(ValueError, match=r"Ps\[\d+\].*\bR \(smallest eigenvalue"):
        kalman_filter_run(zs, x0, P0, F, Q, Hm, R)
    with pytest.raises(ValueError, match=r"Ps\[0\]\[\d+\].*\bR \(smallest eigenvalue"):
        kalman_filter_batch(np.stack([zs, zs]), x0, P0, F, Q, Hm, R)
    zm = np.stack([zs, zs])
    zm[1, 3] = np.nan  # a run with a missed scan is checked on its own
    with pytest.raises(ValueError, match=r"\bR \(smallest eigenvalue"):
        kalman_filter_batch(zm, x0, P0, F, Q, Hm, R)
    with pytest.raises(ValueError, match=r"\bR \(smallest eigenvalue"):
        imm_filter_run(zs, np.stack([x0, x0]), np.stack([P0, P0]), np.array([0.5, 0.5]),
                       np.array([[0.9, 0.1], [0.1, 0.9]]), np.stack([F, F]), np.stack([Q, Q]),
                       Hm, R)
    R0 = np.diag([1.0, 0.0])  # the same with R PSD: every scan follows the rule
    run = kalman_filter_run(zs, x0, P0, F, Q, Hm, R0)
    assert all(_passes_rule(P) for P in run.Ps), "a scan's covariance fails the PSD rule"
    batch = kalman_filter_batch(zm, x0, P0, F, Q, Hm, R0)
    assert batch.Ps[0].tobytes() == run.Ps.tobytes(), "batch run 0 differs from the run"


def test_f1_whole_run_rounding_is_projected():
    """The exactly singular R of the projection test in a run: every scan's covariance
    used to break the rule (down to -2e-6 relative); now each follows it, the means are
    untouched (the recursion is the kernel's) and the batch agrees with the run."""
    R = 1e8 * np.array([[1.0, 3.0], [3.0, 9.0]])
    args = (np.zeros(2), 0.01 * np.eye(2), np.eye(2), 1e-4 * np.eye(2), np.eye(2), R)
    zs = np.random.default_rng(5).normal(size=(10, 2))
    run = kalman_filter_run(zs, *args)
    assert all(_passes_rule(P) for P in run.Ps), "a scan's covariance fails the PSD rule"
    batch = kalman_filter_batch(np.stack([zs, zs]), *args)
    for k in range(2):
        assert batch.Ps[k].tobytes() == run.Ps.tobytes(), f"batch run {k} differs"
        assert batch.xs[k].tobytes() == run.xs.tobytes(), f"batch means of run {k} differ"


def test_f1_imm_mix_and_combine_results_follow_the_rule():
    xs = np.array([[0.0, 0.0], [1.0, 0.0]])
    Ps = np.stack([np.eye(2), np.diag([2.0, 1.0])])
    x0s, P0s, _ = imm_mix(np.array([0.3, 0.7]), np.array([[0.9, 0.1], [0.2, 0.8]]), xs, Ps)
    assert all(_passes_rule(P) for P in P0s), "mixed covariance fails the PSD rule"
    assert _passes_rule(imm_combine(np.array([0.3, 0.7]), xs, Ps).P), "combined fails"


def _random_psd(rng, n, scale, rel_neg):
    """A random covariance of the given scale whose smallest eigenvalue is
    ``-rel_neg`` times the largest (0: singular PSD), inside the rule for rel_neg well
    below 1e-9 (the rebuilt matrix's eigenvalues carry rounding)."""
    Qm, _ = np.linalg.qr(rng.normal(size=(n, n)))
    lam = scale * rng.uniform(0.1, 1.0, n)
    lam[0] = -rel_neg * lam.max()
    A = (Qm * lam) @ Qm.T
    return 0.5 * (A + A.T)


@pytest.mark.parametrize("seed", range(4))
def test_f1_posterior_never_leaves_psd(seed):
    """Random P and R at scales 1e-8 .. 1e8 apart, each with a negative eigenvalue inside
    the rule (or none, or singular): every kf_update either returns a posterior that
    passes the rule (and a following kf_predict accepts it) or raises a ValueError naming
    R or P."""
    rng = np.random.default_rng(seed)
    F, Q = cv_transition(1.0), cv_process_noise(1.0, 1e-3)
    n_ok = n_err = 0
    for _ in range(150):
        rel_R, rel_P = rng.choice([0.0, 1e-16, 1e-12, 5e-10], size=2)
        P = _random_psd(rng, 4, 10.0 ** rng.uniform(-8, 8), rel_P)
        R = _random_psd(rng, 2, 10.0 ** rng.uniform(-8, 8), rel_R)
        Hm = rng.normal(size=(2, 4))
        try:
            u = kf_update(X, P, rng.normal(size=2), Hm, R)
        except ValueError as exc:
            msg = str(exc)
            assert any(k in msg for k in ("R (smallest", "P (smallest", "not positive definite",
                                          "R must be", "P must be")), \
                f"error names neither R nor P: {msg}"
            n_err += 1
            continue
        assert _passes_rule(u.P), "kf_update returned a covariance outside the PSD rule"
        p = kf_predict(u.x, u.P, F, Q)
        assert _passes_rule(p.P), "kf_predict returned a covariance outside the PSD rule"
        n_ok += 1
    assert n_ok > 50, f"too few accepted cases to test anything ({n_ok} ok, {n_err} errors)"


@pytest.mark.parametrize("seed", range(3))
def test_f1_accepted_results_are_the_kernels_bit_for_bit(seed):
    """The check adds no arithmetic: a result that passes is the kernel's output."""
    rng = np.random.default_rng(100 + seed)
    for _ in range(50):
        P = _random_psd(rng, 4, 10.0 ** rng.uniform(-3, 3), 0.0) + 1e-3 * np.eye(4)
        R = _random_psd(rng, 2, 10.0 ** rng.uniform(-3, 3), 0.0) + 1e-3 * np.eye(2)
        P, R = 0.5 * (P + P.T), 0.5 * (R + R.T)
        z = rng.normal(size=2)
        u = kf_update(X, P, z, H, R)
        xo, Po, nu, S, K = (np.empty(4), np.empty((4, 4)), np.empty(2), np.empty((2, 2)),
                            np.empty((4, 2)))
        nis, ll, ok = kf_update_kernel(X, P, z, H, R, xo, Po, nu, S, K)
        assert ok, "kernel failed on a PD problem"
        for a, b in ((u.x, xo), (u.P, Po), (u.S, S), (u.K, K)):
            assert a.tobytes() == b.tobytes(), "public result differs from the kernel's"
        assert (u.nis, u.loglik) == (nis, ll), "NIS or log-likelihood differs"


# --------------------------------------------------------------------------- F2: pg = 1
@pytest.mark.parametrize("d", [1, 2, 3, 4])
def test_f2_no_gate_threshold_and_probability(d):
    assert gate_threshold(1.0, d) == math.inf, "pg = 1 must be the infinite (no) gate"
    assert gate_probability(math.inf, d) == 1.0, "the infinite gate has P_G = 1"


def test_f2_no_gate_validates_every_measurement():
    z = np.array([[0.0, 0.0], [30.0, -40.0], [1e6, 1e6]])
    mask, d2 = mahalanobis_gate(z, np.zeros(2), np.eye(2), gate_threshold(1.0, 2))
    assert mask.all(), f"the no-gate must validate every measurement, got {mask}"
    mask99, _ = mahalanobis_gate(z, np.zeros(2), np.eye(2), gate_threshold(0.99, 2))
    assert mask99.tolist() == [True, False, False], "the 0.99 gate changed"


@pytest.mark.parametrize("gamma", [math.inf, np.float64(np.inf), np.array(np.inf)])
def test_f2_no_gate_has_no_volume(gamma):
    with pytest.raises(ValueError, match="no finite gate volume"):
        gate_volume(gamma, np.eye(2))


def test_f2_pda_no_gate_is_parametric():
    """P_G = 1 in 1 - P_D P_G, lambda the given parametric density."""
    lik, pd, lam = np.array([0.02, 0.001]), 0.9, 1e-3
    b0, b = pda_betas(lik, pd=pd, pg=1.0, clutter_density=lam)
    w = np.concatenate([[lam * (1 - pd)], pd * lik])
    np.testing.assert_allclose(np.concatenate([[b0], b]), w / w.sum(), rtol=1e-14, atol=0,
                               err_msg="parametric PDA with P_G = 1")
    assert pda_log_likelihood(lik, pd=pd, pg=1.0, clutter_density=lam) == pytest.approx(
        math.log(w.sum()), rel=1e-14), "parametric PDA log-likelihood with P_G = 1"


@pytest.mark.parametrize("func", [pda_betas, pda_log_likelihood])
@pytest.mark.parametrize("volume", [math.inf, np.float64(np.inf)])
def test_f2_nonparametric_pda_needs_a_finite_volume(func, volume):
    with pytest.raises(ValueError, match=r"volume must be finite.*parametric"):
        func(np.array([0.02]), pd=0.9, pg=1.0, mode="nonparametric", volume=volume)
    with pytest.raises(ValueError, match="no finite gate volume"):
        func(np.array([0.02]), pd=0.9, pg=1.0, mode="nonparametric",
             volume=gate_volume(gate_threshold(1.0, 2), np.eye(2)))


def test_f2_nonparametric_pda_with_a_finite_region_volume():
    """pg = 1 with a finite volume: V is the region the m measurements came from."""
    b0, b = pda_betas(np.array([0.02, 0.001]), pd=0.9, pg=1.0, mode="nonparametric",
                      volume=1000.0)
    w = np.array([2 / 1000.0 * 0.1, 0.9 * 0.02, 0.9 * 0.001])
    np.testing.assert_allclose(np.concatenate([[b0], b]), w / w.sum(), rtol=1e-14,
                               err_msg="nonparametric PDA with a region volume")


def test_f2_imm_pdaf_no_gate_validates_everything():
    """IMM-PDAF with pg = 1: every measurement of every scan is validated and the clutter
    density is the parametric one; with pg = 0.99 a far clutter return is not."""
    rng = np.random.default_rng(7)
    T, K = 1.0, 12
    truth = np.array([[10.0 * k, 5.0 * k] for k in range(K)])
    scans = [np.vstack([truth[k] + rng.normal(0, 1.0, 2), [5e4, -5e4]]) for k in range(K)]
    x0, P0, R = np.array([0.0, 0.0, 10.0, 5.0]), np.eye(4) * 4.0, np.eye(2)
    res1 = imm_pdaf_track(cv_model_set(T=T), scans, x0, P0, R, pg=1.0, clutter_density=1e-6)
    assert res1.gated.all(), "pg = 1 must validate every measurement"
    res99 = imm_pdaf_track(cv_model_set(T=T), scans, x0, P0, R, pg=0.99,
                           clutter_density=1e-6)
    assert not res99.gated[1::2].any(), "the 0.99 gate validated the far clutter return"
    assert np.all(np.isfinite(res1.x)), "no-gate run produced non-finite estimates"


@pytest.mark.parametrize("config, kwargs", [
    (HpdaPfConfig, {"pd": 0.9, "snr": 10.0, "clutter_density_xy": 3e-8}),
    (ClusteringConfig, {"pd": 0.9, "clutter_density_xy": 3e-8}),
])
def test_f2_trackers_that_need_a_gate_say_why(config, kwargs):
    with pytest.raises(ValueError, match=r"gate_probability must be < 1.*no gate"):
        config(**kwargs, gate_probability=1.0)
    config(**kwargs, gate_probability=0.999)  # still accepted below 1
