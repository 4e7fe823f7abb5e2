"""Image tools for the feature-aided JPDA chapter (Kim, Jung, Kang & Yoon 2016).

* A renderer for IR-like grey frames: textured terrain, roads, vehicle sprites
  (top-down, two saturated lamps at the front), clutter blobs, sensor noise and
  a global gain drift.
* Background subtraction to binary masks: ViBe (Barnich & Van Droogenbroeck
  2011) and the selective running average the paper's text describes.
* Post-processing (3x3 opening then closing) and 8-connected components to
  detections: centroid, bounding box, mask crop and grey crop.
* Zero-mean normalised cross-correlation (Lewis) of two patches on a common
  canvas, maximised over a +-s pixel search; a numba kernel, equal to a direct
  numpy loop (:func:`ncc_reference`).

Image coordinates: row r (down), column c (right); a measurement is
``[x, y] = [c, r]`` in pixels (centroid), matching the ``[x, y, vx, vy]`` state.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numba as nb
import numpy as np
from scipy import ndimage

from ..core.validation import (as_array, as_bool_matrix, as_int, as_nonnegative, as_positive,
                                as_rng, as_scalar)

__all__ = [
    "SPRITES",
    "vehicle_sprite",
    "bar_sprite",
    "glare_sprite",
    "foliage_sprite",
    "rotate_sprite",
    "terrain",
    "render_frame",
    "ViBe",
    "RunningAverage",
    "clean_mask",
    "ImageDetections",
    "detect_blobs",
    "ncc",
    "ncc_reference",
    "ncc_matrix",
    "ncc_sliding",
    "mask_iou",
]

FRAME_SHAPE = (240, 320)
MAX_FRAME = 4096        # largest frame or patch side accepted (px)
MAX_SPRITE = 400        # largest sprite side accepted (px)

#: sprite name -> (h, w, body intensity)
SPRITES = {
    "sedan": (12, 24, 55.0),
    "van": (14, 30, 62.0),
    "truck": (16, 40, 70.0),
    "compact": (10, 18, 50.0),
    "suv": (16, 20, 60.0),
    "hatchback": (14, 18, 57.0),
}


def _as_mask(mask, name):
    """A 2-D boolean mask; entries must be 0/1 or booleans (NaN, 2, ... are errors)."""
    return as_bool_matrix(mask, name)


# ---------------------------------------------------------------- sprites
def vehicle_sprite(kind):
    """Top-down vehicle sprite heading along +w (columns).

    Returns ``(intensity, mask)``: float64 (h, w) and bool (h, w).  Corners are
    rounded by one pixel; two 2x3 saturated (255) lamps sit at the front
    (last three columns), 8 px apart centre to centre.  The truck has a cargo
    box (intensity 82) over its rear 70 %.

    Examples
    --------
    >>> intensity, mask = vehicle_sprite("sedan")
    >>> intensity.shape, int(mask.sum()), float(intensity.max())  # (rows, columns), area, lamps
    ((12, 24), 284, 255.0)
    >>> vehicle_sprite("truck")[0].shape
    (16, 40)
    >>> vehicle_sprite("car")
    Traceback (most recent call last):
        ...
    ValueError: kind must be one of ['compact', 'hatchback', 'sedan', 'suv', 'truck', 'van'], got 'car'
    """
    if kind not in SPRITES:
        raise ValueError(f"kind must be one of {sorted(SPRITES)}, got {kind!r}")
    h, w, body = SPRITES[kind]
    inten = np.full((h, w), body)
    mask = np.ones((h, w), bool)
    for r, c in [(0, 0), (0, w - 1), (h - 1, 0), (h - 1, w - 1)]:
        mask[r, c] = False
    if kind == "truck":
        inten[1:h - 1, 1:int(0.7 * w)] = 82.0
    mid = (h - 1) / 2.0
    for centre in (mid - 4.0, mid + 4.0):
        r0 = int(round(centre - 0.5))
        inten[r0:r0 + 2, w - 3:w] = 255.0
    inten[~mask] = 0.0
    return inten, mask


def bar_sprite(h=22, w=6, intensity=100.0):
    """The flickering hot bar (clutter c1): an h x w rectangle.

    Examples
    --------
    >>> intensity, mask = bar_sprite()
    >>> intensity.shape, int(mask.sum()), float(intensity.max())
    ((22, 6), 132, 100.0)
    """
    h = as_int(h, "h", minimum=1)
    w = as_int(w, "w", minimum=1)
    if max(h, w) > MAX_SPRITE:
        raise ValueError(f"h and w must be at most {MAX_SPRITE} px, got {h} x {w}")
    intensity = as_scalar(intensity, "intensity")
    return np.full((h, w), intensity), np.ones((h, w), bool)


def glare_sprite(radius=3.5, intensity=180.0):
    """A bright round blob (a glint or hot spot travelling with a vehicle): the disc of
    pixels within ``radius`` px of the centre pixel.

    Examples
    --------
    >>> intensity, mask = glare_sprite(radius=3.5)
    >>> mask.shape, int(mask.sum())
    ((7, 7), 37)
    """
    radius = as_positive(radius, "radius")
    if radius > MAX_SPRITE / 2:
        raise ValueError(f"radius must be at most {MAX_SPRITE / 2} px, got {radius}")
    intensity = as_scalar(intensity, "intensity")
    R = int(math.floor(radius))
    yy, xx = np.mgrid[-R:R + 1, -R:R + 1]
    mask = np.hypot(xx, yy) <= radius
    return np.where(mask, intensity, 0.0), mask


def foliage_sprite(rng, radius=7.0, intensity=75.0, amplitude=0.35):
    """A roundish irregular blob (clutter c2): boundary radius
    r(phi) = radius (1 + sum_k a_k cos(k phi + phase_k)), k = 2, 3, 5, with
    the sum of the ``|a_k|`` is the amplitude (random split and phases).

    Examples
    --------
    >>> intensity, mask = foliage_sprite(np.random.default_rng(0), radius=7.0)
    >>> mask.shape, int(mask.sum())
    ((14, 17), 159)
    """
    rng = as_rng(rng)
    radius = as_positive(radius, "radius")
    if radius > MAX_SPRITE / 4:
        raise ValueError(f"radius must be at most {MAX_SPRITE / 4} px, got {radius}")
    intensity = as_scalar(intensity, "intensity")
    amplitude = as_nonnegative(amplitude, "amplitude")
    if amplitude >= 1.0:
        raise ValueError(f"amplitude must be < 1 (a positive radius everywhere), got {amplitude}")
    a = rng.dirichlet(np.ones(3)) * amplitude
    ph = rng.uniform(0, 2 * np.pi, 3)
    R = int(math.ceil(radius * (1 + amplitude))) + 1
    yy, xx = np.mgrid[-R:R + 1, -R:R + 1].astype(float)
    phi = np.arctan2(yy, xx)
    rr = radius * (1 + a[0] * np.cos(2 * phi + ph[0]) + a[1] * np.cos(3 * phi + ph[1])
                   + a[2] * np.cos(5 * phi + ph[2]))
    mask = np.hypot(xx, yy) <= rr
    rows, cols = np.nonzero(mask)
    mask = mask[rows.min():rows.max() + 1, cols.min():cols.max() + 1]
    return np.where(mask, float(intensity), 0.0), mask


def rotate_sprite(intensity, mask, heading):
    """Rotate a sprite heading along +columns to ``heading`` (radians,
    counter-clockwise in the x-right / y-up sense, i.e. 0 = moving right,
    pi/2 = moving up the image).  The mask is nearest neighbour on a 4 x 4
    sub-pixel grid (a pixel is in if half its area is), which keeps the area;
    the intensity is bilinear; both are cropped to the mask.

    Examples
    --------
    A quarter turn stands the sedan upright and keeps its area:

    >>> intensity, mask = vehicle_sprite("sedan")
    >>> up, up_mask = rotate_sprite(intensity, mask, np.pi / 2)
    >>> up_mask.shape, int(up_mask.sum()), int(mask.sum())
    ((24, 12), 284, 284)
    """
    intensity = as_array(intensity, "intensity", ndim=2)
    mask = _as_mask(mask, "mask")
    if mask.shape != intensity.shape:
        raise ValueError(f"mask must have the shape of intensity {intensity.shape}, "
                         f"got {mask.shape}")
    if not mask.any():
        raise ValueError("mask must have at least one pixel set")
    th = as_scalar(heading, "heading")
    if abs(th) < 1e-12:
        return intensity.copy(), mask.copy()
    h, w = mask.shape
    cth, sth = math.cos(th), math.sin(th)
    # extent of the rotated rectangle (x right, y up; rows run down)
    W2 = abs(w * cth) + abs(h * sth)
    H2 = abs(w * sth) + abs(h * cth)
    Ho, Wo = int(math.ceil(H2 - 1e-9)) + 2, int(math.ceil(W2 - 1e-9)) + 2

    def source(rr, cc):
        xo = cc - (Wo - 1) / 2.0           # output coords, x right
        yo = -(rr - (Ho - 1) / 2.0)        # y up
        xi = cth * xo + sth * yo           # inverse rotation by -heading
        yi = -sth * xo + cth * yo
        return -yi + (h - 1) / 2.0, xi + (w - 1) / 2.0

    rr, cc = np.mgrid[0:Ho, 0:Wo].astype(float)
    # mask: area coverage by 4 x 4 supersampling (nearest neighbour per sub-sample)
    cover = np.zeros((Ho, Wo))
    padded = np.pad(mask.astype(float), 1)      # scipy treats points beyond n-1 as outside
    for a in (-0.375, -0.125, 0.125, 0.375):
        for b in (-0.375, -0.125, 0.125, 0.375):
            ri, ci = source(rr + a, cc + b)
            cover += ndimage.map_coordinates(padded, [ri + 1.0, ci + 1.0], order=0,
                                             mode="constant")
    m = cover >= 8.0
    ri, ci = source(rr, cc)
    I = ndimage.map_coordinates(intensity, [ri, ci], order=1, mode="nearest")
    rows, cols = np.nonzero(m)
    sl = (slice(rows.min(), rows.max() + 1), slice(cols.min(), cols.max() + 1))
    m = m[sl]
    I = np.where(m, I[sl], 0.0)
    return np.ascontiguousarray(I), np.ascontiguousarray(m)


# ---------------------------------------------------------------- rendering
def _road(road, name):
    """``None`` or a ``(start, end)`` pair of integer pixel indices."""
    if road is None:
        return None
    if isinstance(road, (str, bytes)) or np.ndim(road) != 1:
        raise TypeError(f"{name} must be None or a (start, end) pair of integers, "
                        f"got {type(road).__name__} of {np.ndim(road)} dimensions")
    if len(road) != 2:
        raise ValueError(f"{name} must be None or a (start, end) pair of integers, "
                         f"got {len(road)} values")
    return tuple(as_int(v, name) for v in road)


def terrain(rng, shape=FRAME_SHAPE, mean=40.0, texture_sd=8.0, road_level=30.0,
            horizontal_road=(104, 136), vertical_road=(144, 176), diagonal_road=None):
    """The frozen textured background of a sequence.

    White noise N(0, texture_sd^2) smoothed by a 5x5 box around ``mean``; a
    horizontal road on rows ``horizontal_road`` and a vertical road on columns
    ``vertical_road`` (inclusive start, exclusive end) at ``road_level``
    (each may be ``None``).  ``diagonal_road = (x0, y0, angle, width)`` adds a
    straight road through pixel (x0, y0) at ``angle`` radians (x right, y up).

    Examples
    --------
    >>> bg = terrain(np.random.default_rng(0))
    >>> bg.shape, round(float(bg[:50, :50].mean()), 1), float(bg[120, 10])  # field, road
    ((240, 320), 39.9, 30.0)
    """
    rng = as_rng(rng)
    if len(shape) != 2:
        raise ValueError(f"shape must be (rows, columns), got {shape!r}")
    H, W = (as_int(n, "shape", minimum=1) for n in shape)
    if max(H, W) > MAX_FRAME:
        raise ValueError(f"shape must be at most {MAX_FRAME} px on a side, got {shape!r}")
    mean = as_scalar(mean, "mean")
    texture_sd = as_nonnegative(texture_sd, "texture_sd")
    road_level = as_scalar(road_level, "road_level")
    horizontal_road = _road(horizontal_road, "horizontal_road")
    vertical_road = _road(vertical_road, "vertical_road")
    bg = mean + ndimage.uniform_filter(rng.normal(0.0, texture_sd, (H, W)), size=5,
                                       mode="reflect")
    if horizontal_road is not None:
        bg[horizontal_road[0]:horizontal_road[1], :] = road_level
    if vertical_road is not None:
        bg[:, vertical_road[0]:vertical_road[1]] = road_level
    if diagonal_road is not None:
        x0, y0, ang, width = diagonal_road
        rr, cc = np.mgrid[0:H, 0:W].astype(float)
        # signed distance from the line through (x0, y0) with direction (cos, sin) in x-up
        dx, dy = cc - x0, -(rr - y0)
        dist = np.abs(-math.sin(ang) * dx + math.cos(ang) * dy)
        bg[dist <= width / 2.0] = road_level
    return bg


def render_frame(background, objects, rng, gain=1.0, noise_sd=3.0):
    """Render one uint8 frame.

    ``objects`` is a sequence of ``(intensity, mask, x, y)``: a sprite and the
    image position (column x, row y) of its centre; its top-left pixel is
    ``floor(y - (h - 1) / 2 + 1/2)``, ``floor(x - (w - 1) / 2 + 1/2)`` (rounding half
    up, so that shifting every position by whole pixels shifts the image).  Objects
    are pasted in order over ``background``, then i.i.d. noise N(0, noise_sd^2) is
    added, the frame is multiplied by ``gain``, rounded to whole grey levels and
    clipped to [0, 255] (in single precision).

    Returns ``(frame, labels, boxes)``: ``labels`` (H, W) int array with
    object i's visible pixels set to i + 1 (0 = background), and ``boxes``
    (n, 4) int array [r0, c0, r1, c1] (exclusive ends; -1 if off-frame).

    Examples
    --------
    A sedan centred at column 60, row 120 (its 12 x 24 sprite has no centre pixel, so its
    box spans rows 115-126 and columns 49-72):

    >>> bg = terrain(np.random.default_rng(0))
    >>> intensity, mask = vehicle_sprite("sedan")
    >>> frame, labels, boxes = render_frame(bg, [(intensity, mask, 60.0, 120.0)],
    ...                                     np.random.default_rng(1))
    >>> frame.dtype, frame.shape, boxes, int((labels == 1).sum())
    (dtype('uint8'), (240, 320), array([[115,  49, 127,  73]]), 284)
    """
    rng = as_rng(rng)
    bg = as_array(background, "background", ndim=2)
    gain = as_positive(gain, "gain")
    noise_sd = as_nonnegative(noise_sd, "noise_sd")
    if gain > 1e3 or noise_sd > 1e3:
        raise ValueError(f"gain and noise_sd must be at most 1000, got {gain} and {noise_sd}")
    H, W = bg.shape
    img = bg.copy()
    labels = np.zeros((H, W), np.int32)
    boxes = np.full((len(objects), 4), -1, np.int64)
    for i, obj in enumerate(objects):
        if len(obj) != 4:
            raise ValueError(f"objects[{i}] must be (intensity, mask, x, y)")
        inten, mask, x, y = obj
        inten = as_array(inten, f"objects[{i}] intensity", ndim=2)
        mask = _as_mask(mask, f"objects[{i}] mask")
        if mask.shape != inten.shape:
            raise ValueError(f"objects[{i}]: mask and intensity must have the same shape")
        x = as_scalar(x, f"objects[{i}] x")
        y = as_scalar(y, f"objects[{i}] y")
        h, w = mask.shape
        r0 = math.floor(y - (h - 1) / 2.0 + 0.5)
        c0 = math.floor(x - (w - 1) / 2.0 + 0.5)
        rr0, cc0 = max(r0, 0), max(c0, 0)
        rr1, cc1 = min(r0 + h, H), min(c0 + w, W)
        if rr1 <= rr0 or cc1 <= cc0:
            continue
        sub_m = mask[rr0 - r0:rr1 - r0, cc0 - c0:cc1 - c0]
        sub_i = inten[rr0 - r0:rr1 - r0, cc0 - c0:cc1 - c0]
        region = img[rr0:rr1, cc0:cc1]
        region[sub_m] = sub_i[sub_m]
        labels[rr0:rr1, cc0:cc1][sub_m] = i + 1
        boxes[i] = (rr0, cc0, rr1, cc1)
    out = rng.standard_normal((H, W), dtype=np.float32)
    out *= noise_sd
    out += img
    out *= gain
    np.rint(out, out=out)
    np.clip(out, 0, 255, out=out)
    return out.astype(np.uint8), labels, boxes


# ---------------------------------------------------------------- background subtraction
@nb.njit(cache=True)
def _vibe_init_kernel(samples, frame, offsets):
    """Each sample of a pixel is a random 8-neighbour (or itself) of the first
    frame; ``offsets`` (H, W, N, 2) holds the drawn offsets in {-1, 0, 1}."""
    H, W, N = samples.shape
    for i in range(H):
        for j in range(W):
            for s in range(N):
                ii = min(max(i + offsets[i, j, s, 0], 0), H - 1)
                jj = min(max(j + offsets[i, j, s, 1], 0), W - 1)
                samples[i, j, s] = frame[ii, jj]


@nb.njit(cache=True)
def _vibe_kernel(samples, frame, radius, min_matches, subsample, u, rng, out):
    """One ViBe step; ``u`` (H, W, 2) uniforms decide the two updates (drawn
    vectorised outside), the rare update draws use ``rng``."""
    H, W, N = samples.shape
    p = 1.0 / subsample
    for i in range(H):
        for j in range(W):
            v = frame[i, j]
            count = 0
            for s in range(N):
                if abs(samples[i, j, s] - v) < radius:
                    count += 1
                    if count >= min_matches:
                        break
            if count >= min_matches:
                out[i, j] = False
                if u[i, j, 0] < p:
                    samples[i, j, int(rng.random() * N)] = v
                if u[i, j, 1] < p:
                    ii = min(max(i + int(rng.random() * 3.0) - 1, 0), H - 1)
                    jj = min(max(j + int(rng.random() * 3.0) - 1, 0), W - 1)
                    samples[ii, jj, int(rng.random() * N)] = v
            else:
                out[i, j] = True


class ViBe:
    """ViBe background subtraction (Barnich & Van Droogenbroeck 2011).

    Per pixel ``n_samples`` stored values; a pixel is background if at least
    ``min_matches`` samples lie within ``radius`` grey levels.  Background
    pixels replace one of their samples with probability 1/``subsample`` and
    one sample of a random 8-neighbour with the same probability
    (conservative update with spatial propagation).

    Examples
    --------
    Initialised on an empty frame, ViBe flags the pixels of a vehicle that appears
    (281 of its 284 pixels, and one more):

    >>> bg = terrain(np.random.default_rng(0))
    >>> empty = render_frame(bg, [], np.random.default_rng(2))[0]
    >>> vibe = ViBe(empty, np.random.default_rng(3))
    >>> intensity, mask = vehicle_sprite("sedan")
    >>> frame = render_frame(bg, [(intensity, mask, 60.0, 120.0)], np.random.default_rng(1))[0]
    >>> fg = vibe.apply(frame)
    >>> fg.dtype, int(fg.sum()), int(fg[115:127, 49:73].sum())
    (dtype('bool'), 282, 281)
    """

    def __init__(self, first_frame, rng, n_samples=20, radius=12.0, min_matches=2,
                 subsample=16):
        self.rng = as_rng(rng)
        first = as_array(first_frame, "first_frame", ndim=2)
        self.n_samples = as_int(n_samples, "n_samples", minimum=1)
        if self.n_samples > 1000:
            raise ValueError(f"n_samples must be at most 1000, got {self.n_samples}")
        self.radius = as_positive(radius, "radius")
        self.min_matches = as_int(min_matches, "min_matches", minimum=1)
        if self.min_matches > self.n_samples:
            raise ValueError("min_matches must not exceed n_samples")
        self.subsample = as_int(subsample, "subsample", minimum=1)
        # float32 samples halve the memory traffic of the per-pixel loop; grey levels of
        # 8-bit frames are stored exactly
        self.samples = np.empty(first.shape + (self.n_samples,), np.float32)
        offsets = self.rng.integers(-1, 2, first.shape + (self.n_samples, 2), dtype=np.int8)
        _vibe_init_kernel(self.samples, first, offsets)

    def apply(self, frame):
        """Foreground mask of ``frame`` (bool, same shape); updates the model."""
        frame = as_array(frame, "frame", ndim=2)
        if frame.shape != self.samples.shape[:2]:
            raise ValueError(f"frame must have shape {self.samples.shape[:2]}, got {frame.shape}")
        out = np.empty(frame.shape, np.bool_)
        u = self.rng.random(frame.shape + (2,), dtype=np.float32)
        _vibe_kernel(self.samples, frame, self.radius, self.min_matches, self.subsample, u,
                     self.rng, out)
        return out


class RunningAverage:
    """Selective running average: foreground if ``|I - B| > threshold``;
    B <- (1 - alpha) B + alpha I on background pixels only.

    Examples
    --------
    A fixed threshold of 12 grey levels also flags sensor noise (sd 3 per frame) away
    from the vehicle:

    >>> bg = terrain(np.random.default_rng(0))
    >>> ra = RunningAverage(render_frame(bg, [], np.random.default_rng(2))[0], threshold=12.0)
    >>> intensity, mask = vehicle_sprite("sedan")
    >>> frame = render_frame(bg, [(intensity, mask, 60.0, 120.0)], np.random.default_rng(1))[0]
    >>> fg = ra.apply(frame)
    >>> int(fg.sum()), int(fg[115:127, 49:73].sum())
    (531, 283)
    >>> detect_blobs(fg, frame).z  # the cleaning removes the scattered noise pixels
    array([[ 60.5, 120.5]])
    """

    def __init__(self, first_frame, alpha=0.05, threshold=12.0):
        self.B = as_array(first_frame, "first_frame", ndim=2).copy()
        self.alpha = as_nonnegative(alpha, "alpha")
        if self.alpha > 1:
            raise ValueError(f"alpha must lie in [0, 1], got {self.alpha}")
        self.threshold = as_positive(threshold, "threshold")

    def apply(self, frame):
        frame = as_array(frame, "frame", ndim=2)
        if frame.shape != self.B.shape:
            raise ValueError(f"frame must have shape {self.B.shape}, got {frame.shape}")
        fg = np.abs(frame - self.B) > self.threshold
        bgpx = ~fg
        self.B[bgpx] = (1 - self.alpha) * self.B[bgpx] + self.alpha * frame[bgpx]
        return fg


_SQUARE = np.ones((3, 3), bool)


@nb.njit(cache=True)
def _morph3_kernel(mask, out, dilate):
    """3x3 binary erosion (``dilate=False``) or dilation, outside pixels = 0
    (scipy.ndimage's default ``border_value=0``); separable row/column passes."""
    H, W = mask.shape
    tmp = np.empty((H, W), np.bool_)
    for i in range(H):
        for j in range(W):
            a = mask[i, j - 1] if j > 0 else False
            b = mask[i, j]
            c = mask[i, j + 1] if j < W - 1 else False
            tmp[i, j] = (a or b or c) if dilate else (a and b and c)
    for i in range(H):
        for j in range(W):
            a = tmp[i - 1, j] if i > 0 else False
            b = tmp[i, j]
            c = tmp[i + 1, j] if i < H - 1 else False
            out[i, j] = (a or b or c) if dilate else (a and b and c)


def clean_mask(mask):
    """3x3 binary opening, then 3x3 closing (same result as
    ``ndimage.binary_closing(ndimage.binary_opening(mask, s), s)`` with a 3x3
    square ``s``; a numba kernel).

    Examples
    --------
    The opening removes an isolated pixel and keeps a 4 x 4 block:

    >>> m = np.zeros((8, 8), dtype=bool)
    >>> m[2:6, 2:6] = True
    >>> m[0, 7] = True
    >>> int(m.sum()), int(clean_mask(m).sum())
    (17, 16)
    """
    a = _as_mask(mask, "mask")
    b = np.empty_like(a)
    _morph3_kernel(a, b, False)      # opening: erode ...
    c = np.empty_like(a)
    _morph3_kernel(b, c, True)       # ... then dilate
    _morph3_kernel(c, b, True)       # closing: dilate ...
    _morph3_kernel(b, c, False)      # ... then erode
    return c


class ImageDetections(NamedTuple):
    """Detections of one frame: ``z`` (m, 2) centroids [x, y] (px), ``boxes``
    (m, 4) [r0, c0, r1, c1], ``areas`` (m,), and per detection the binary
    mask crop and grey crop (bounding box plus ``margin`` px).

    Examples
    --------
    What :func:`detect_blobs` returns:

    >>> m = np.zeros((20, 20), dtype=bool)
    >>> m[5:10, 4:9] = True
    >>> det = detect_blobs(m, np.zeros((20, 20), np.uint8), min_area=4)
    >>> type(det).__name__, det.z, det.areas
    ('ImageDetections', array([[6., 7.]]), array([25]))
    """
    z: np.ndarray
    boxes: np.ndarray
    areas: np.ndarray
    masks: list
    greys: list


def detect_blobs(mask, frame, min_area=25, margin=4, clean=True):
    """Connected components (8-connected, area >= ``min_area``) of a
    foreground mask (cleaned by :func:`clean_mask` unless ``clean=False``).

    Examples
    --------
    Two blobs; the one under ``min_area`` pixels is dropped.  Centroids are ``[x, y]``
    (column, row):

    >>> m = np.zeros((20, 20), dtype=bool)
    >>> m[5:10, 4:9] = True    # 25 px
    >>> m[14:16, 14:16] = True  # 4 px
    >>> det = detect_blobs(m, np.zeros((20, 20), np.uint8), min_area=9, clean=False)
    >>> det.z, det.boxes, det.areas
    (array([[6., 7.]]), array([[ 5,  4, 10,  9]]), array([25]))
    """
    mask = _as_mask(mask, "mask")
    frame = as_array(frame, "frame", ndim=2)
    if mask.shape != frame.shape:
        raise ValueError(f"mask must have the shape of frame {frame.shape}, got {mask.shape}")
    min_area = as_int(min_area, "min_area", minimum=1)
    margin = as_int(margin, "margin", minimum=0)
    if clean:
        mask = clean_mask(mask)
    lab, n = ndimage.label(mask, structure=_SQUARE)
    H, W = mask.shape
    zs, boxes, areas, masks, greys = [], [], [], [], []
    if n:
        objs = ndimage.find_objects(lab)
        counts = np.bincount(lab.ravel(), minlength=n + 1)
        for k, sl in enumerate(objs, start=1):
            if counts[k] < min_area:
                continue
            r0, r1 = sl[0].start, sl[0].stop
            c0, c1 = sl[1].start, sl[1].stop
            rows, cols = np.nonzero(lab[sl] == k)
            zs.append((cols.mean() + c0, rows.mean() + r0))
            boxes.append((r0, c0, r1, c1))
            areas.append(counts[k])
            R0, R1 = max(r0 - margin, 0), min(r1 + margin, H)
            C0, C1 = max(c0 - margin, 0), min(c1 + margin, W)
            masks.append(np.ascontiguousarray(lab[R0:R1, C0:C1] == k))
            greys.append(np.ascontiguousarray(frame[R0:R1, C0:C1]))
    z = np.array(zs, float).reshape(-1, 2)
    return ImageDetections(z, np.array(boxes, np.int64).reshape(-1, 4),
                           np.array(areas, np.int64), masks, greys)


def mask_iou(a, b):
    """Intersection over union of two boolean masks (1.0 if both empty).

    Examples
    --------
    >>> a = np.zeros((4, 4), dtype=bool); a[:2] = True
    >>> b = np.zeros((4, 4), dtype=bool); b[1:3] = True
    >>> round(mask_iou(a, b), 4)  # 4 shared of 12 pixels
    0.3333
    >>> mask_iou(np.zeros((2, 2), bool), np.zeros((2, 2), bool))
    1.0
    """
    a = _as_mask(a, "a")
    b = _as_mask(b, "b")
    if a.shape != b.shape:
        raise ValueError(f"masks must have equal shapes, got {a.shape} and {b.shape}")
    u = np.logical_or(a, b).sum()
    return 1.0 if u == 0 else float(np.logical_and(a, b).sum() / u)


# ---------------------------------------------------------------- correlation
def _fill_value(patch, kind):
    if kind == "mask":
        return 0.0
    return float(np.median(np.concatenate([patch[0], patch[-1]])))


def _canvas(A, B, s, fa, fb):
    H = max(A.shape[0], B.shape[0]) + 2 * s
    W = max(A.shape[1], B.shape[1]) + 2 * s
    ca = np.full((H, W), fa)
    ra, qa = (H - A.shape[0]) // 2, (W - A.shape[1]) // 2
    ca[ra:ra + A.shape[0], qa:qa + A.shape[1]] = A
    rb, qb = (H - B.shape[0]) // 2, (W - B.shape[1]) // 2
    return ca, rb, qb


@nb.njit(cache=True)
def _ncc_patches_kernel(A, B, fa, fb, s):
    """:func:`ncc` of two float64 patches (fills ``fa``, ``fb``): builds the common
    canvas of :func:`_canvas` and calls :func:`_ncc_kernel`."""
    ha, wa = A.shape
    hb, wb = B.shape
    H = max(ha, hb) + 2 * s
    W = max(wa, wb) + 2 * s
    ca = np.full((H, W), fa)
    ra, qa = (H - ha) // 2, (W - wa) // 2
    for i in range(ha):
        for j in range(wa):
            ca[ra + i, qa + j] = A[i, j]
    return _ncc_kernel(ca, B, fb, (H - hb) // 2, (W - wb) // 2, s)


@nb.njit(cache=True)
def _ncc_kernel(ca, B, fb, rb, qb, s):
    """max over shifts |u|, |v| <= s of the zero-mean NCC of canvas ``ca`` and the
    canvas holding ``B`` at (rb + u, qb + v) on fill ``fb``.  B's canvas has the
    same mean and variance at every shift, and sum(ca * b) = sum over B's
    footprint of ca * B + fb * (sum(ca) - sum of ca over the footprint), so each
    shift costs one pass over B's footprint only."""
    H, W = ca.shape
    h, w = B.shape
    n = H * W
    sa = 0.0
    for i in range(H):
        for j in range(W):
            sa += ca[i, j]
    ma = sa / n
    saa = 0.0
    for i in range(H):
        for j in range(W):
            saa += (ca[i, j] - ma) ** 2
    sb = 0.0
    sb2 = 0.0
    for i in range(h):
        for j in range(w):
            sb += B[i, j]
            sb2 += B[i, j] * B[i, j]
    rest = n - h * w
    mb = (sb + fb * rest) / n
    # sum of (b - mb)^2 over the canvas, shift-independent, without cancellation
    sbb = 0.0
    for i in range(h):
        for j in range(w):
            sbb += (B[i, j] - mb) ** 2
    sbb += rest * (fb - mb) ** 2
    den = math.sqrt(saa * sbb)
    best = -np.inf
    for u in range(-s, s + 1):
        for v in range(-s, s + 1):
            r0 = rb + u
            c0 = qb + v
            # sum over the canvas of (a - ma)(b - mb) = sum over B's footprint of
            # (a - ma)(B - fb) + (fb - mb) * sum(a - ma), and sum(a - ma) = 0
            sab = 0.0
            for i in range(h):
                for j in range(w):
                    sab += (ca[r0 + i, c0 + j] - ma) * (B[i, j] - fb)
            r = sab / den if den > 0 else 0.0
            if r > best:
                best = r
    return best


def _check_patch(P, name, kind):
    if kind == "mask":
        P = _as_mask(P, name)
    P = as_array(P, name, ndim=2)
    if P.size == 0:
        raise ValueError(f"{name} must not be empty")
    if np.abs(P).max() > 1e100:
        raise ValueError(f"{name} must hold values of magnitude at most 1e100 "
                         "(the correlation's sums would overflow)")
    return P


def _ncc_inputs(A, B, s, kind):
    """Validate the arguments shared by :func:`ncc` and :func:`ncc_reference`."""
    if kind not in ("mask", "grey"):
        raise ValueError(f"kind must be 'mask' or 'grey', got {kind!r}")
    A = _check_patch(A, "A", kind)
    B = _check_patch(B, "B", kind)
    s = as_int(s, "s", minimum=0)
    if s > 64:
        raise ValueError(f"s (the search half-width) must be at most 64 px, got {s}")
    for name, P in (("A", A), ("B", B)):
        if max(P.shape) > MAX_FRAME:
            raise ValueError(f"{name} must be at most {MAX_FRAME} px on a side, "
                             f"got {P.shape}")
    return A, B, s


def ncc(A, B, s=4, kind="mask"):
    """Zero-mean normalised cross-correlation of two patches (Lewis), the
    symmetric definition used by the chapter: both placed centred on a common canvas of
    size (max h + 2s) x (max w + 2s), filled with 0 (``kind="mask"``) or with
    the median of each patch's border rows (``kind="grey"``); B shifted by
    every integer (u, v) with ``|u|, |v| <= s``; the maximum NCC over the canvas.
    A constant canvas has NCC 0.  With ``kind="mask"`` the patches must be binary
    (0/1 or booleans).

    Examples
    --------
    A sedan's mask against itself, a truck's, and two sedans merged into one blob:

    >>> car = vehicle_sprite("sedan")[1]
    >>> truck = vehicle_sprite("truck")[1]
    >>> two = np.zeros((12, 52), dtype=bool); two[:, :24] = car; two[:, 28:] = car
    >>> round(ncc(car, car), 4), round(ncc(car, truck), 4), round(ncc(car, two), 4)
    (1.0, 0.5152, 0.3832)
    >>> ncc(car, car, kind="x")
    Traceback (most recent call last):
        ...
    ValueError: kind must be 'mask' or 'grey', got 'x'
    """
    A, B, s = _ncc_inputs(A, B, s, kind)
    fa, fb = _fill_value(A, kind), _fill_value(B, kind)
    return float(_ncc_patches_kernel(A, B, fa, fb, s))


def _mask_ncc(A, B, s=4):
    """:func:`ncc` of two boolean masks already checked by the caller (the tracker
    checks every mask once per frame)."""
    return float(_ncc_patches_kernel(A.astype(np.float64), B.astype(np.float64), 0.0, 0.0, s))


@nb.njit(cache=True)
def _sliding_kernel(A, B, s):
    """:func:`ncc_sliding` of two float64 patches (zero fill)."""
    ha, wa = A.shape
    hb, wb = B.shape
    H = max(ha, hb) + 2 * s
    W = max(wa, wb) + 2 * s
    cb = np.zeros((H, W))
    rb, qb = (H - hb) // 2, (W - wb) // 2
    for i in range(hb):
        for j in range(wb):
            cb[rb + i, qb + j] = B[i, j]
    n = ha * wa
    sa = 0.0
    for i in range(ha):
        for j in range(wa):
            sa += A[i, j]
    ma = sa / n
    saa = 0.0
    for i in range(ha):
        for j in range(wa):
            saa += (A[i, j] - ma) ** 2
    # the template zero-meaned once (the same numbers as A[i, j] - ma in the loop)
    ac = np.empty((ha, wa))
    for i in range(ha):
        for j in range(wa):
            ac[i, j] = A[i, j] - ma
    # a canvas of zeros and ones (a mask) has exact window sums in any order: take them
    # from a summed-area table; a constant window (sum 0 or n) scores 0 and is skipped
    whole = True
    for i in range(H):
        for j in range(W):
            if cb[i, j] != 0.0 and cb[i, j] != 1.0:
                whole = False
    sat = np.zeros((H + 1, W + 1))
    if whole:
        for i in range(H):
            for j in range(W):
                sat[i + 1, j + 1] = cb[i, j] + sat[i, j + 1] + sat[i + 1, j] - sat[i, j]
    best = 0.0
    for r0 in range(H - ha + 1):
        for c0 in range(W - wa + 1):
            if whole:
                sw = (sat[r0 + ha, c0 + wa] - sat[r0, c0 + wa] - sat[r0 + ha, c0]
                      + sat[r0, c0])
                if sw == 0.0 or sw == n:
                    continue
            else:
                sw = 0.0
                for i in range(ha):
                    for j in range(wa):
                        sw += cb[r0 + i, c0 + j]
            mw = sw / n
            sww = 0.0
            sab = 0.0
            for i in range(ha):
                for j in range(wa):
                    d = cb[r0 + i, c0 + j] - mw
                    sww += d * d
                    sab += ac[i, j] * d
            den = math.sqrt(saa * sww)
            if den > 0:
                r = sab / den
                if r > best:
                    best = r
    return best


def ncc_sliding(A, B, s=4, kind="mask"):
    """Template matching by normalised cross-correlation with local normalisation
    (Lewis; OpenCV's ``TM_CCOEFF_NORMED``): the template ``A`` slides over every
    position of the search image, ``B`` centred on a canvas of size
    (max h + 2s) x (max w + 2s) filled with 0 (``kind="mask"``) or with the median of
    its border rows (``kind="grey"``); at each position the NCC is taken over the
    template's window only, each side zero-meaned over that window; the maximum
    over the positions (a window of constant values scores 0).  Unlike :func:`ncc`,
    a measurement larger than the template (two merged blobs) is searched
    wholly, and pixels outside the best window do not lower the score.

    Examples
    --------
    The template is found whole inside two merged sedans (compare :func:`ncc`, 0.38):

    >>> car = vehicle_sprite("sedan")[1]
    >>> two = np.zeros((12, 52), dtype=bool); two[:, :24] = car; two[:, 28:] = car
    >>> round(ncc_sliding(car, two), 4)
    1.0
    """
    A, B, s = _ncc_inputs(A, B, s, kind)
    fb = _fill_value(B, kind)
    if kind == "grey":
        B = B - fb
    return float(_sliding_kernel(A, B, s))


def _mask_ncc_sliding(A, B, s=4):
    """:func:`ncc_sliding` of two boolean masks already checked by the caller."""
    return float(_sliding_kernel(A.astype(np.float64), B.astype(np.float64), s))


def ncc_reference(A, B, s=4, kind="mask"):
    """Direct numpy loop over shifts (the test reference for :func:`ncc`); the same
    arguments and checks.

    Examples
    --------
    The same number as :func:`ncc`, by a plain loop:

    >>> car = vehicle_sprite("sedan")[1]
    >>> truck = vehicle_sprite("truck")[1]
    >>> round(ncc_reference(car, truck), 4), round(ncc(car, truck), 4)
    (0.5152, 0.5152)
    """
    A, B, s = _ncc_inputs(A, B, s, kind)
    fa, fb = _fill_value(A, kind), _fill_value(B, kind)
    ca, rb, qb = _canvas(A, B, s, fa, fb)
    best = -np.inf
    for u in range(-s, s + 1):
        for v in range(-s, s + 1):
            cb = np.full(ca.shape, fb)
            cb[rb + u:rb + u + B.shape[0], qb + v:qb + v + B.shape[1]] = B
            a = ca - ca.mean()
            b = cb - cb.mean()
            den = np.sqrt((a * a).sum() * (b * b).sum())
            best = max(best, float((a * b).sum() / den) if den > 0 else 0.0)
    return best


def ncc_matrix(templates, patches, s=4, kind="mask"):
    """rho[i, j] = ncc(templates[i], patches[j]).

    Examples
    --------
    >>> car, truck = vehicle_sprite("sedan")[1], vehicle_sprite("truck")[1]
    >>> np.round(ncc_matrix([car, truck], [car, truck]), 3)
    array([[1.   , 0.515],
           [0.515, 1.   ]])
    """
    if isinstance(templates, np.ndarray) and templates.ndim == 2:
        raise ValueError("templates must be a sequence of 2-D patches, got one 2-D array")
    if isinstance(patches, np.ndarray) and patches.ndim == 2:
        raise ValueError("patches must be a sequence of 2-D patches, got one 2-D array")
    out = np.empty((len(templates), len(patches)))
    for i, A in enumerate(templates):
        for j, B in enumerate(patches):
            out[i, j] = ncc(A, B, s=s, kind=kind)
    return out
