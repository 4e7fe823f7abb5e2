"""Tests for trackcore.detection.image (renderer, segmentation, blobs, NCC)."""
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from trackcore.detection.image import (
    SPRITES, RunningAverage, ViBe, bar_sprite, clean_mask, detect_blobs, foliage_sprite,
    glare_sprite, mask_iou, ncc, ncc_matrix, ncc_reference, render_frame, rotate_sprite,
    terrain, vehicle_sprite,
)


# ---------------------------------------------------------------- NCC
def test_ncc_equals_direct_loop():
    rng = np.random.default_rng(0)
    for _ in range(25):
        A = rng.normal(50, 20, rng.integers(3, 15, 2))
        B = rng.normal(50, 20, rng.integers(3, 15, 2))
        assert abs(ncc(A, B, kind="grey") - ncc_reference(A, B, kind="grey")) < 1e-12
        Am, Bm = A > 50, B > 50
        assert abs(ncc(Am, Bm) - ncc_reference(Am, Bm)) < 1e-12


@settings(max_examples=30, deadline=None)
@given(h1=st.integers(2, 12), w1=st.integers(2, 12), h2=st.integers(2, 12),
       w2=st.integers(2, 12), s=st.integers(0, 4), seed=st.integers(0, 2**31))
def test_ncc_property_bounds_symmetry_and_reference(h1, w1, h2, w2, s, seed):
    rng = np.random.default_rng(seed)
    A = rng.random((h1, w1)) > 0.4
    B = rng.random((h2, w2)) > 0.4
    r = ncc(A, B, s=s)
    assert -1 - 1e-12 <= r <= 1 + 1e-12
    assert abs(r - ncc_reference(A, B, s=s)) < 1e-12


def test_ncc_identity_shift_and_symmetry():
    I, M = vehicle_sprite("van")
    assert ncc(M, M) == pytest.approx(1.0, abs=1e-12)
    assert ncc(I, I, kind="grey") == pytest.approx(1.0, abs=1e-12)
    # shifting within the search window does not matter
    padded = np.zeros((M.shape[0] + 3, M.shape[1] + 2), bool)
    padded[2:2 + M.shape[0], 1:1 + M.shape[1]] = M
    assert ncc(M, padded) == pytest.approx(1.0, abs=1e-12)
    S = vehicle_sprite("sedan")[1]
    assert ncc(M, S) == pytest.approx(ncc(S, M), abs=1e-12)
    # a constant patch has no variance: rho = 0 by convention
    assert ncc(np.ones((5, 5)), np.ones((4, 4)), s=0, kind="grey") == 0.0


def test_ncc_equals_skimage_match_template():
    """scikit-image (pinned test dependency) is the independent peer: with s = 0 and
    equal-size patches the canvas is the patch itself, so our NCC is the Pearson
    correlation that ``match_template`` returns for the single placement."""
    from skimage.feature import match_template

    rng = np.random.default_rng(3)
    for _ in range(20):
        h, w = rng.integers(3, 15, size=2)
        A = rng.normal(0, 1, (h, w))
        B = 0.6 * A + rng.normal(0, 1, (h, w))
        ref = float(match_template(A, B)[0, 0])
        assert ncc(A, B, s=0, kind="grey") == pytest.approx(ref, abs=1e-12)
    # and on a real sprite against its noisy copy
    S = vehicle_sprite("sedan")[0].astype(float)
    N = S + rng.normal(0, 5, S.shape)
    assert ncc(S, N, s=0, kind="grey") == pytest.approx(float(match_template(S, N)[0, 0]), abs=1e-12)


def test_ncc_bad_input():
    with pytest.raises(ValueError, match="A"):
        ncc(np.zeros((0, 3)), np.ones((2, 2)))
    with pytest.raises(ValueError, match="kind"):
        ncc(np.ones((2, 2)), np.ones((2, 2)), kind="x")
    with pytest.raises(ValueError, match="B"):
        ncc(np.ones((2, 2)), np.ones(3))
    with pytest.raises(ValueError, match="s"):
        ncc(np.ones((2, 2)), np.ones((2, 2)), s=-1)
    with pytest.raises(ValueError, match="B"):
        ncc(np.ones((2, 2)), np.full((2, 2), np.nan))


def test_ncc_rejects_non_binary_masks_and_checks_the_reference():
    """kind="mask" needs 0/1 or boolean patches; ncc_reference checks its inputs too."""
    for f in (ncc, ncc_reference):
        with pytest.raises(ValueError, match="A"):
            f(np.full((3, 3), 2.0), np.ones((3, 3)))
        with pytest.raises(ValueError, match="B"):
            f(np.ones((3, 3)), np.full((3, 3), np.nan))
        with pytest.raises(ValueError, match="kind"):
            f(np.ones((3, 3)), np.ones((3, 3)), kind="rgb")
        with pytest.raises(ValueError, match="s"):
            f(np.ones((3, 3)), np.ones((3, 3)), s=-2)
        with pytest.raises(TypeError, match="A"):
            f("abc", np.ones((3, 3)), kind="grey")
    with pytest.raises(ValueError, match="templates"):
        ncc_matrix(np.ones((3, 3)), [np.ones((3, 3))])


def test_image_tools_reject_bad_masks_and_parameters():
    bad = np.ones((5, 5))
    bad[2, 2] = 2.0
    nan = np.ones((5, 5))
    nan[1, 1] = np.nan
    for m in (bad, nan):
        with pytest.raises(ValueError, match="mask"):
            clean_mask(m)
        with pytest.raises(ValueError, match="mask"):
            detect_blobs(m, np.zeros((5, 5)))
        with pytest.raises(ValueError, match="a"):
            mask_iou(m, np.ones((5, 5), bool))
        with pytest.raises(ValueError, match="mask"):
            rotate_sprite(np.ones((5, 5)), m, 0.3)
    rng = np.random.default_rng(0)
    bg = np.zeros((20, 20))
    with pytest.raises(ValueError, match="gain"):
        render_frame(bg, [], rng, gain=np.nan)
    with pytest.raises(ValueError, match="noise_sd"):
        render_frame(bg, [], rng, noise_sd=-1.0)
    with pytest.raises(ValueError, match="mask"):
        render_frame(bg, [(np.ones((5, 5)), bad, 5.0, 5.0)], rng)
    with pytest.raises(ValueError, match="x"):
        render_frame(bg, [(np.ones((5, 5)), np.ones((5, 5), bool), np.nan, 5.0)], rng)
    with pytest.raises(ValueError, match="radius"):
        foliage_sprite(rng, radius=np.nan)
    with pytest.raises(ValueError, match="intensity"):
        foliage_sprite(rng, intensity=np.nan)
    with pytest.raises(ValueError, match="amplitude"):
        foliage_sprite(rng, amplitude=1.5)
    I, M = vehicle_sprite("van")
    with pytest.raises(ValueError, match="heading"):
        rotate_sprite(I, M, np.nan)
    with pytest.raises(ValueError, match="intensity"):
        bar_sprite(intensity=np.inf)
    with pytest.raises(ValueError, match="radius"):
        glare_sprite(radius=0.0)
    with pytest.raises(ValueError, match="texture_sd"):
        terrain(rng, texture_sd=np.nan)


def test_render_positions_round_half_up():
    """Shifting every position by whole pixels shifts the rendered labels (no
    round-half-to-even flips), so camera jitter keeps the relative geometry."""
    I, M = vehicle_sprite("sedan")            # 12 x 24: centre offsets end in .5
    bg = np.zeros((60, 80))
    rng = np.random.default_rng(0)
    ref = render_frame(bg, [(I, M, 30.0, 20.0)], rng, noise_sd=0.0)[1]
    for dx, dy in ((1, 0), (0, 1), (3, -2)):
        lab = render_frame(bg, [(I, M, 30.0 + dx, 20.0 + dy)], rng, noise_sd=0.0)[1]
        assert np.array_equal(np.roll(ref, (dy, dx), axis=(0, 1)), lab)


def test_glare_sprite():
    I, M = glare_sprite(3.5, 200.0)
    assert M.shape == (7, 7) and M.sum() == 37 and I.max() == 200.0
    assert max(ncc(M, vehicle_sprite(k)[1]) for k in ("sedan", "van", "truck")) < 0.3


def test_silhouettes_separate_vehicle_types():
    masks = [vehicle_sprite(k)[1] for k in ("sedan", "van", "truck", "compact")]
    rho = ncc_matrix(masks, masks)
    assert np.allclose(np.diag(rho), 1.0)
    off = rho[~np.eye(4, dtype=bool)]
    assert off.max() < 0.9
    bar = bar_sprite(6, 22)[1]
    assert max(ncc(bar, m) for m in masks) < 0.6


# ---------------------------------------------------------------- sprites and rendering
def test_vehicle_sprite_lamps_and_corners():
    for kind, (h, w, body) in SPRITES.items():
        I, M = vehicle_sprite(kind)
        assert I.shape == M.shape == (h, w)
        assert not M[0, 0] and not M[-1, -1]
        lamp_rows = np.nonzero((I == 255).any(axis=1))[0]
        assert len(lamp_rows) == 4                      # two 2-row lamps
        assert (I[:, : w - 3] != 255).all()             # lamps only at the front
        assert (I == 255).sum() <= 12
    with pytest.raises(ValueError, match="kind"):
        vehicle_sprite("bus")


def test_rotate_sprite():
    I, M = vehicle_sprite("sedan")
    I90, M90 = rotate_sprite(I, M, np.pi / 2)
    assert M90.shape == (M.shape[1], M.shape[0])
    # heading up: lamps at the top rows
    assert (I90[:3] > 200).any() and not (I90[-3:] > 200).any()
    I20, M20 = rotate_sprite(I, M, np.deg2rad(20))
    assert abs(M20.sum() - M.sum()) / M.sum() < 0.1


def test_foliage_and_bar():
    rng = np.random.default_rng(1)
    I, M = foliage_sprite(rng)
    assert 80 < M.sum() < 400
    I, M = bar_sprite()
    assert M.shape == (22, 6)


def test_render_frame_and_truth():
    rng = np.random.default_rng(2)
    bg = terrain(rng)
    assert bg.shape == (240, 320)
    assert np.all(bg[104:136] == 30) and np.all(bg[:, 144:176] == 30)
    I, M = vehicle_sprite("van")
    frame, labels, boxes = render_frame(bg, [(I, M, 100.0, 120.0)], rng)
    assert frame.dtype == np.uint8 and frame.shape == (240, 320)
    assert labels.sum() == M.sum()
    r, c = np.nonzero(labels == 1)
    assert abs(c.mean() - 100) <= 0.5 and abs(r.mean() - 120) <= 0.5
    assert tuple(boxes[0]) == (r.min(), c.min(), r.max() + 1, c.max() + 1)
    # off-frame object: no pixels, box -1
    _, labels, boxes = render_frame(bg, [(I, M, -100.0, 120.0)], rng)
    assert labels.max() == 0 and boxes[0, 0] == -1
    with pytest.raises(TypeError, match="rng"):
        render_frame(bg, [], None)


def test_render_deterministic_given_rng():
    bg = terrain(np.random.default_rng(4))
    f1 = render_frame(bg, [], np.random.default_rng(5))[0]
    f2 = render_frame(bg, [], np.random.default_rng(5))[0]
    assert np.array_equal(f1, f2)


# ---------------------------------------------------------------- segmentation
def _segment_sequence(seg_cls, seed):
    rng = np.random.default_rng(seed)
    bg = terrain(rng)
    sprites = [vehicle_sprite(k) for k in ("van", "compact")]
    frames = [render_frame(bg, [], rng)[0] for _ in range(10)]
    seg = seg_cls(frames[0], rng) if seg_cls is ViBe else seg_cls(frames[0])
    for f in frames[1:]:
        seg.apply(f)
    ious, dets = [], []
    for k in range(20):
        objs = [(sprites[0][0], sprites[0][1], 30 + 3.0 * k, 114.0),
                (sprites[1][0], sprites[1][1], 250.0 - 2.5 * k, 126.0)]
        frame, labels, _ = render_frame(bg, objs, rng, gain=1 + 0.02 * np.sin(2 * np.pi * k / 200))
        mask = clean_mask(seg.apply(frame))
        for i in (1, 2):
            ious.append(mask_iou(mask & (np.abs(np.arange(320)[None] - objs[i - 1][2]) < 25)
                                 & (np.abs(np.arange(240)[:, None] - objs[i - 1][3]) < 10),
                                 labels == i))
        dets.append(detect_blobs(mask, frame, clean=False))
    return np.array(ious), dets


@pytest.mark.parametrize("seg_cls", [ViBe, RunningAverage])
def test_segmentation_iou_and_detections(seg_cls):
    ious, dets = _segment_sequence(seg_cls, 11)
    assert ious.mean() >= 0.8
    # two vehicles -> two detections per frame, almost always
    counts = np.array([len(d.z) for d in dets])
    assert np.mean(counts == 2) >= 0.9


def test_detect_blobs_geometry_and_empty():
    mask = np.zeros((50, 60), bool)
    mask[10:20, 5:25] = True
    mask[30:32, 40:42] = True        # too small (area 4 < 25)
    frame = np.where(mask, 60.0, 30.0)
    d = detect_blobs(mask, frame, clean=False)
    assert d.z.shape == (1, 2)
    assert np.allclose(d.z[0], [14.5, 14.5])
    assert tuple(d.boxes[0]) == (10, 5, 20, 25) and d.areas[0] == 200
    assert d.masks[0].shape == (18, 28) and d.greys[0].shape == (18, 28)
    e = detect_blobs(np.zeros((50, 60), bool), frame)
    assert e.z.shape == (0, 2) and e.masks == []
    with pytest.raises(ValueError, match="mask"):
        detect_blobs(np.zeros((10, 10), bool), frame)


def test_running_average_bad_input():
    with pytest.raises(ValueError, match="alpha"):
        RunningAverage(np.zeros((4, 4)), alpha=2.0)
    with pytest.raises(ValueError, match="frame"):
        RunningAverage(np.zeros((4, 4))).apply(np.zeros((3, 3)))
    with pytest.raises(TypeError, match="rng"):
        ViBe(np.zeros((4, 4)), rng=1)
    with pytest.raises(ValueError, match="min_matches"):
        ViBe(np.zeros((4, 4)), np.random.default_rng(0), n_samples=2, min_matches=3)


def test_mask_iou():
    a = np.zeros((4, 4), bool)
    assert mask_iou(a, a) == 1.0
    b = a.copy(); b[0, :2] = True
    c = a.copy(); c[0, 1:3] = True
    assert mask_iou(b, c) == pytest.approx(1 / 3)


def test_image_tools_refuse_sizes_that_would_exhaust_memory():
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match="h and w"):
        bar_sprite(10**6, 6)
    with pytest.raises(ValueError, match="radius"):
        glare_sprite(1e300)
    with pytest.raises(ValueError, match="radius"):
        foliage_sprite(rng, radius=1e300)
    with pytest.raises(ValueError, match="shape"):
        terrain(rng, shape=(10**6, 10**6))
    with pytest.raises(ValueError, match="n_samples"):
        ViBe(np.zeros((4, 4)), rng, n_samples=10**9)
    with pytest.raises(ValueError, match="s "):
        ncc(np.ones((3, 3)), np.ones((3, 3)), s=10**6)
    with pytest.raises(ValueError, match="gain"):
        render_frame(np.zeros((5, 5)), [], rng, gain=1e300)
    with pytest.raises(ValueError, match="A"):
        ncc(np.full((3, 3), 1e300), np.ones((3, 3)), kind="grey")


def test_terrain_checks_road_ranges():
    from trackcore.detection.image import terrain
    g = np.random.default_rng(0)
    with pytest.raises(ValueError, match="horizontal_road"):
        terrain(g, horizontal_road=(104,))
    with pytest.raises(TypeError, match="horizontal_road"):
        terrain(g, horizontal_road=np.array([[104, 136]]))
    with pytest.raises(TypeError, match="vertical_road"):
        terrain(g, vertical_road=104)
    with pytest.raises(TypeError, match="vertical_road"):
        terrain(g, vertical_road=(144, 176.5))
    a = terrain(np.random.default_rng(1))
    b = terrain(np.random.default_rng(1), horizontal_road=(104, 136), vertical_road=(144, 176))
    assert np.array_equal(a, b)
