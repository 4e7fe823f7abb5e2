"""ncc_sliding against a direct numpy loop over the template's positions (the kernel
takes its window sums from a summed-area table on 0/1 canvases and skips constant
windows; these must not change a score)."""
import numpy as np
import pytest

from trackcore.detection.image import _fill_value, ncc_sliding


def _sliding_reference(A, B, s, kind):
    """Every position of ``A`` over ``B`` centred on a (max h + 2s) x (max w + 2s)
    canvas (filled as ncc_sliding fills it), the NCC over the window, the maximum (0
    for constant windows)."""
    A = np.asarray(A, float)
    B = np.asarray(B, float)
    fb = _fill_value(B, kind)
    if kind == "grey":
        B = B - fb
    H = max(A.shape[0], B.shape[0]) + 2 * s
    W = max(A.shape[1], B.shape[1]) + 2 * s
    cb = np.zeros((H, W))
    rb, qb = (H - B.shape[0]) // 2, (W - B.shape[1]) // 2
    cb[rb:rb + B.shape[0], qb:qb + B.shape[1]] = B
    a = A - A.mean()
    best = 0.0
    for r in range(H - A.shape[0] + 1):
        for c in range(W - A.shape[1] + 1):
            w = cb[r:r + A.shape[0], c:c + A.shape[1]]
            d = w - w.mean()
            den = np.sqrt((a * a).sum() * (d * d).sum())
            if den > 0:
                best = max(best, float((a * d).sum() / den))
    return best


@pytest.mark.parametrize("kind", ["mask", "grey"])
def test_ncc_sliding_matches_direct_loop(kind):
    rng = np.random.default_rng(3)
    for _ in range(150):
        ha, wa, hb, wb = rng.integers(1, 12, 4)
        s = int(rng.integers(0, 5))
        if kind == "mask":
            A, B = rng.random((ha, wa)) < 0.6, rng.random((hb, wb)) < 0.6
        else:
            A, B = rng.normal(size=(ha, wa)), rng.integers(-2, 3, (hb, wb)).astype(float)
        got = ncc_sliding(A, B, s, kind)
        ref = _sliding_reference(A, B, s, kind)
        assert got == pytest.approx(ref, rel=1e-12, abs=1e-12), (
            f"ncc_sliding {got} differs from the direct loop {ref} "
            f"(A {A.shape}, B {B.shape}, s {s}, {kind})")


def test_ncc_sliding_constant_windows_score_zero():
    A = np.zeros((3, 3), bool)
    A[1, 1] = True
    assert ncc_sliding(A, np.zeros((5, 5), bool)) == 0.0, "an empty patch must score 0"
    assert ncc_sliding(A, np.ones((5, 5), bool), 0) == 0.0, (
        "a window that is all ones (or all zeros) must score 0")
