"""Synthetic IR-like scenes replacing the EO/IR video of Kim, Jung, Kang & Yoon
(2016).

Frames are 240 x 320 grey uint8, one frame per time step.  A horizontal road
(rows 104-136) and a vertical road (columns 144-176) at intensity 30 cross a
textured terrain (mean 40); vehicles are top-down sprites with saturated lamps;
clutter is a flickering hot bar, a foliage blob redrawn every frame, or a glare
blob travelling with a vehicle.  Each sequence starts with ``N_WARMUP``
vehicle-free frames from which the background models are initialised.

**Camera jitter.**  ``render_scene(name, rng, jitter=sigma)`` shakes the camera:
every frame (warm-up included) the whole image -- background, vehicles and
clutter -- is shifted by an independent offset drawn from N(0, sigma^2) per axis
and rounded to whole pixels (clipped at 4 sigma).  The truth stays in scene
coordinates, so the jitter is measurement noise common to every object of a
frame; the relative geometry of the objects, and hence which blobs merge, does
not change.  :func:`trackcore.trackers.jpda_tracker.matched_config` gives the
tracker matched to a jitter.

Scenes (``SCENES``; ``DEFAULT_JITTER`` gives each one's sigma):

* ``"S1"``  clutter near a track (paper Fig 6): a van along the horizontal road
  passes a hot bar 16 px beside its lane and a foliage blob.
* ``"S2a"`` 90-degree crossing (Fig 7): an SUV up the vertical road and a
  hatchback along the horizontal road, whose silhouettes correlate above c_I
  (0.68); closest approach at frame 43.
* ``"S2b"`` shallow crossing (Fig 7 as described): a sedan on a 20-degree road
  passes the van; closest approach at frame 43.
* ``"S3"``  following (Fig 8): a compact with a sedan 40 px behind and a hot bar
  beside the compact's path.
* ``"jitter"`` the S1 layout under camera jitter (default 3 px).
* ``"glare"`` a flickering glare blob (radius 3.5 px) travels 14 px beside a
  van, inside its gate under 5 px camera jitter.
* ``"side_by_side"`` a van and a compact drive side by side, 16 px apart
  (centroids), for the whole sequence, under 5 px camera jitter; their
  silhouettes correlate at 0.52, below c_I.
* ``"occlusion"`` a 90-degree crossing whose two blobs merge for several
  frames.

Every vehicle mask stays at least ``MIN_VEHICLE_GAP`` px from every other
object (so that their blobs never merge), except the pair of the occlusion
scene; the generator asserts it, and records the frames where that pair's masks
come closer (``FeatureScene.merged``).
"""
from __future__ import annotations

import copy
import math
from typing import NamedTuple

import numpy as np
from scipy import ndimage

from ..core.validation import (as_int, as_nonnegative, as_positive, as_probability, as_rng,
                                as_scalar)
from ..detection.image import (FRAME_SHAPE, ImageDetections, RunningAverage, ViBe, bar_sprite,
                               clean_mask, detect_blobs, foliage_sprite, glare_sprite,
                               render_frame, rotate_sprite, terrain, vehicle_sprite)

__all__ = [
    "SCENES",
    "PAPER_SCENES",
    "AMBIGUITY_SCENES",
    "DEFAULT_JITTER",
    "N_WARMUP",
    "MIN_VEHICLE_GAP",
    "FeatureScene",
    "render_scene",
    "segment_scene",
    "scene_layout",
    "pair_gaps",
    "closest_approach",
    "fig3_patches",
    "crossing_detections",
    "separate_blob_distance",
    "feature_correlation_samples",
]

N_WARMUP = 10
MIN_VEHICLE_GAP = 3
PAPER_SCENES = ("S1", "S2a", "S2b", "S3")
AMBIGUITY_SCENES = ("jitter", "glare", "side_by_side", "occlusion")
SCENES = PAPER_SCENES + AMBIGUITY_SCENES
DEFAULT_JITTER = {"S1": 0.0, "S2a": 0.0, "S2b": 0.0, "S3": 0.0, "jitter": 3.0,
                  "glare": 5.0, "side_by_side": 5.0, "occlusion": 3.0}
_FRAMES = {"S1": 70, "S2a": 80, "S2b": 80, "S3": 80, "jitter": 70, "glare": 65,
           "side_by_side": 60, "occlusion": 55}

# lanes: right-moving traffic on the upper half of the horizontal road, etc.
_LANE_RIGHT = 111.0     # y of right-moving vehicles
_LANE_LEFT = 130.0      # y of left-moving vehicles
_LANE_UP = 166.0        # x of up-moving vehicles
_CONFLICT = 43          # the paper's time index of its Fig 7 crossing

# crossing geometry (closest approach at frame _CONFLICT; see _crossing)
_S2A_C = 7.5            # 90-degree crossing, separate blobs: smallest offset keeping 3 px
_OCCL_C = 6.0           # 90-degree crossing whose blobs merge for 5 frames
_S2B_ANGLE = math.radians(20.0)
_S2B_C = 30.0           # 20-degree crossing, separate blobs: smallest keeping 3 px


class FeatureScene(NamedTuple):
    """A rendered sequence (warm-up frames first).

    ``frames`` (N_WARMUP + K, H, W) uint8; ``labels`` (N_WARMUP + K, H, W)
    int8 (object i + 1, 0 = background; in image coordinates); per scene frame
    k = 0..K-1, in scene coordinates: ``xy`` (K, n, 2) centroid [x, y] of each
    object's full mask (NaN when absent), ``present`` (K, n) any pixel visible,
    ``visible`` (K, n) every pixel visible (in the frame and not occluded);
    ``names`` and ``is_vehicle`` (n,); ``conflict_frame`` the scored crossing
    frame (-1 if none); ``pair`` the two vehicle indices of the crossing,
    side-by-side or following pair; ``score_window`` (k0, k1) the frames whose
    track IDs the crossing outcome compares ((-1, -1) if none); ``jitter`` the
    camera jitter sigma (px) and ``offsets`` (N_WARMUP + K, 2) the per-frame
    image shift [dx, dy]; ``merged`` (K,) the frames where the pair's masks come
    closer than ``MIN_VEHICLE_GAP`` px (their blobs merge).

    Examples
    --------
    A scene without frames, as :func:`crossing_detections` returns it (truth only):

    >>> detections, scene = crossing_detections(np.random.default_rng(0))
    >>> scene.name, scene.xy.shape, scene.names
    ('crossing', (60, 2, 2), ('A', 'B'))
    >>> scene.pair, scene.conflict_frame, scene.score_window
    ((0, 1), 30, (20, 40))
    """
    name: str
    frames: np.ndarray
    labels: np.ndarray
    xy: np.ndarray
    present: np.ndarray
    visible: np.ndarray
    names: tuple
    is_vehicle: np.ndarray
    conflict_frame: int
    pair: tuple
    score_window: tuple = (-1, -1)
    jitter: float = 0.0
    offsets: np.ndarray | None = None
    merged: np.ndarray | None = None


def check_scene(scene, name="scene"):
    """``scene`` itself if it is a :class:`FeatureScene`, else a ``TypeError`` naming it."""
    if not isinstance(scene, FeatureScene):
        raise TypeError(f"{name} must be a FeatureScene (from render_scene), got "
                        f"{type(scene).__name__}")
    return scene


def _vehicle(kind, heading):
    I, M = vehicle_sprite(kind)
    return rotate_sprite(I, M, heading)


def _crossing(c, conflict=_CONFLICT):
    """Positions of a vehicle going up the vertical road at 2 px/frame and one going
    right along the horizontal road at 3 px/frame whose centroids are closest at
    frame ``conflict``: there the right-mover is (2 c, -3 c) px from the up-mover,
    a vector normal to their relative velocity (3, 2) px/frame, so that the
    distance sqrt(13) c is the minimum."""

    def up(k):
        return _LANE_UP, _LANE_RIGHT + 3.0 * c + 2.0 * (conflict - k)

    def right(k):
        return _LANE_UP + 2.0 * c + 3.0 * (k - conflict), _LANE_RIGHT

    return up, right


def scene_layout(name, crossing_offset=None):
    """The objects of scene ``name``: a list of dicts with ``name``, ``role``
    (``"vehicle"``/``"bar"``/``"foliage"``/``"glare"``) and ``pos(k) -> (x, y)
    or None`` (None = absent at scene frame k), plus the sprite or clutter
    parameters.  Returns ``(objects, n_frames, conflict_frame, pair,
    score_window, allow_merge)``.  ``crossing_offset`` (occlusion scene only; default
    6) is the offset c of its crossing: the centroids come within sqrt(13) c px,
    so a smaller c merges the pair's blobs for more frames.

    Examples
    --------
    >>> objects, n_frames, conflict, pair, window, allow_merge = scene_layout("S2a")
    >>> [(o["name"], o["role"]) for o in objects], n_frames, conflict, pair, window
    ([('SUV', 'vehicle'), ('hatchback', 'vehicle')], 80, 43, (0, 1), (33, 53))
    >>> objects[0]["pos"](0)  # the SUV at scene frame 0
    (166.0, 219.5)
    """
    if name not in SCENES:
        raise ValueError(f"name must be one of {SCENES}, got {name!r}")
    occl_c = _check_offset(name, crossing_offset)
    K = _FRAMES[name]
    objs = []

    def veh(label, kind, heading, pos):
        I, M = _vehicle(kind, heading)
        objs.append(dict(name=label, role="vehicle", sprite=(I, M), pos=pos))

    def bar(label, x, y, k0, k1, horizontal=False):
        objs.append(dict(name=label, role="bar", horizontal=horizontal, p=0.7,
                         pos=lambda k: (x, y) if k0 <= k <= k1 else None))

    def foliage(label, x, y, k0, k1):
        objs.append(dict(name=label, role="foliage", p=0.5,
                         pos=lambda k: (x, y) if k0 <= k <= k1 else None))

    conflict, pair, window, allow_merge = -1, (), (-1, -1), False
    if name in ("S1", "jitter"):
        veh("van", "van", 0.0, lambda k: (65.0 + 2.5 * k, _LANE_RIGHT))
        # 16 px beside the lane, columns 142-164, lying along the road (6 x 22): 6 px clear
        # of the van (upright, 22 x 6, it would overlap the van by 2 rows)
        bar("bar", 153.0, _LANE_RIGHT + 16.0, 20, 50, horizontal=True)
        # foliage radius <= 7 (1 + 0.35) px: centred 21 px above the lane, >= 3 px clear
        foliage("foliage", 200.0, _LANE_RIGHT - 21.0, 30, 60)
    elif name == "S2a":
        conflict, pair = _CONFLICT, (0, 1)
        window = (conflict - 10, conflict + 10)
        up, right = _crossing(_S2A_C)
        veh("SUV", "suv", math.pi / 2, up)
        veh("hatchback", "hatchback", 0.0, right)
    elif name == "occlusion":
        conflict, pair, allow_merge = 35, (0, 1), True
        window = (conflict - 10, conflict + 10)
        up, right = _crossing(occl_c, conflict)
        veh("sedan", "sedan", math.pi / 2, up)
        veh("van", "van", 0.0, right)
    elif name == "S2b":
        conflict, pair = _CONFLICT, (0, 1)
        window = (conflict - 10, conflict + 10)
        vs = 2.0 * np.array([math.cos(_S2B_ANGLE), -math.sin(_S2B_ANGLE)])
        vv = np.array([3.0, 0.0])
        rel = vs - vv
        n = np.array([-rel[1], rel[0]]) / np.hypot(*rel)   # normal to the relative velocity
        if n[1] > 0:
            n = -n                                         # the sedan passes above the van
        van0 = np.array([_LANE_UP + 20.0, _LANE_RIGHT])
        sed0 = van0 + _S2B_C * n
        veh("sedan", "sedan", _S2B_ANGLE,
            lambda k: tuple(sed0 + vs * (k - _CONFLICT)))
        veh("van", "van", 0.0, lambda k: tuple(van0 + vv * (k - _CONFLICT)))
    elif name == "S3":
        pair = (0, 1)
        veh("compact", "compact", 0.0, lambda k: (-9.0 + 2.5 * k, _LANE_LEFT))
        veh("sedan", "sedan", 0.0, lambda k: (-49.0 + 2.5 * k, _LANE_LEFT))
        bar("bar", 60.0, _LANE_LEFT + 16.0, 10, 30, horizontal=True)
    elif name == "glare":
        veh("van", "van", 0.0, lambda k: (40.0 + 2.5 * k, _LANE_RIGHT))
        # a glint 14 px beside the van's centroid: 3.5 px clear of its mask
        objs.append(dict(name="glare", role="glare", p=0.7,
                         pos=lambda k: (40.0 + 2.5 * k, _LANE_RIGHT + 14.0)
                         if 10 <= k <= 60 else None))
    elif name == "side_by_side":
        pair = (0, 1)
        window = (15, K - 5)
        # centroids 16 px apart, masks 4 px apart; silhouettes correlate at 0.52 < c_I
        veh("van", "van", 0.0, lambda k: (40.0 + 2.5 * k, _LANE_RIGHT + 1.0))
        veh("compact", "compact", 0.0, lambda k: (40.0 + 2.5 * k, _LANE_RIGHT + 17.0))
    return objs, K, conflict, pair, window, allow_merge


def pair_gaps(labels, a, b):
    """Gap in pixels between the masks of labels ``a`` and ``b`` in one label image
    (chessboard distance minus one: 0 when they touch, ``inf`` when one is absent).

    Examples
    --------
    Two label blobs two pixels apart (chessboard distance 3 between their nearest pixels):

    >>> labels = np.zeros((5, 8), dtype=np.int8)
    >>> labels[1:4, 0:2] = 1
    >>> labels[1:4, 4:6] = 2
    >>> pair_gaps(labels, 1, 2), pair_gaps(labels, 1, 3)
    (2.0, inf)
    """
    labels = np.asarray(labels)
    if labels.ndim != 2 or not np.issubdtype(labels.dtype, np.integer):
        raise ValueError(f"labels must be a 2-D integer label image, got a {labels.ndim}-D "
                         f"{labels.dtype} array")
    a, b = as_int(a, "a"), as_int(b, "b")
    ma, mb = labels == a, labels == b
    if not ma.any() or not mb.any():
        return math.inf
    ra, ca = np.nonzero(ma)
    rb, cb = np.nonzero(mb)
    g = MIN_VEHICLE_GAP + 1
    r0 = max(min(ra.min(), rb.min()) - g, 0)
    c0 = max(min(ca.min(), cb.min()) - g, 0)
    r1 = max(ra.max(), rb.max()) + g + 1
    c1 = max(ca.max(), cb.max()) + g + 1
    crop = labels[r0:r1, c0:c1]
    dist = ndimage.distance_transform_cdt(crop != a, metric="chessboard")
    return float(dist[crop == b].min() - 1)


def _full_centroid(M, x, y):
    """Centroid (scene px) of sprite mask ``M`` pasted with its centre at (x, y) the
    way :func:`trackcore.detection.image.render_frame` pastes it."""
    h, w = M.shape
    r0 = math.floor(y - (h - 1) / 2.0 + 0.5)
    c0 = math.floor(x - (w - 1) / 2.0 + 0.5)
    rr, cc = np.nonzero(M)
    return c0 + cc.mean(), r0 + rr.mean()


def _check_offset(name, crossing_offset):
    if crossing_offset is None:
        return _OCCL_C
    if name != "occlusion":
        raise ValueError(f"crossing_offset applies to the occlusion scene only, not {name!r}")
    c = as_nonnegative(crossing_offset, "crossing_offset")
    if c > 30.0:
        raise ValueError(f"crossing_offset must be at most 30 px, got {c}")
    return c


def render_scene(name, rng, jitter=None, crossing_offset=None):
    """Render scene ``name`` with generator ``rng`` (texture, noise, flicker,
    camera jitter).  ``jitter`` is the camera jitter sigma in px (default:
    ``DEFAULT_JITTER[name]``); ``crossing_offset`` as in :func:`scene_layout`.

    Examples
    --------
    Scene S2b: a sedan and a van cross at scene frame 43, after 10 warm-up frames:

    >>> scene = render_scene("S2b", np.random.default_rng(0))
    >>> scene.frames.shape, scene.frames.dtype, scene.names, scene.conflict_frame
    ((90, 240, 320), dtype('uint8'), ('sedan', 'van'), 43)
    >>> int(scene.present.sum(axis=0)[0]), int(scene.merged.sum())  # sedan present; blobs merged
    (80, 0)
    """
    rng = as_rng(rng)
    objs, K, conflict, pair, window, allow_merge = scene_layout(name, crossing_offset)
    sigma = DEFAULT_JITTER[name] if jitter is None else as_nonnegative(jitter, "jitter")
    if sigma > 20.0:
        raise ValueError(f"jitter must be at most 20 px, got {sigma}")
    margin = int(math.ceil(4.0 * sigma))
    H, W = FRAME_SHAPE
    m = margin
    diag = None
    if name == "S2b":
        # the 20-degree road through the sedan's path
        x0, y0 = objs[0]["pos"](_CONFLICT)
        diag = (x0 + m, y0 + m, _S2B_ANGLE, 24.0)
    bg_big = terrain(rng, shape=(H + 2 * m, W + 2 * m), horizontal_road=(104 + m, 136 + m),
                     vertical_road=(144 + m, 176 + m), diagonal_road=diag)
    n = len(objs)
    total = N_WARMUP + K
    frames = np.empty((total, H, W), np.uint8)
    labels = np.zeros((total, H, W), np.int8)
    offsets = np.zeros((total, 2), np.int64)
    xy = np.full((K, n, 2), np.nan)
    present = np.zeros((K, n), bool)
    visible = np.zeros((K, n), bool)
    merged = np.zeros(K, bool)
    is_vehicle = np.array([o["role"] == "vehicle" for o in objs])
    veh_idx = np.nonzero(is_vehicle)[0]
    # clutter first, vehicles on top (later vehicles occlude earlier ones)
    order = [i for i in range(n) if not is_vehicle[i]] + list(veh_idx)
    for f in range(total):
        k = f - N_WARMUP
        if sigma > 0:
            offsets[f] = np.clip(np.rint(rng.normal(0.0, sigma, 2)), -m, m)
        dx, dy = int(offsets[f, 0]), int(offsets[f, 1])
        bg = bg_big[m - dy:m - dy + H, m - dx:m - dx + W]
        gain = 1.0 + 0.02 * math.sin(2 * math.pi * f / 200.0)
        placed, idx, full_area = [], [], []
        if k >= 0:
            for i in order:
                o = objs[i]
                p = o["pos"](k)
                if p is None:
                    continue
                if o["role"] == "vehicle":
                    I, M = o["sprite"]
                else:
                    if rng.random() >= o["p"]:
                        continue
                    if o["role"] == "bar":
                        shape = (6, 22) if o["horizontal"] else (22, 6)
                        I, M = bar_sprite(*shape, rng.uniform(80, 120))
                    elif o["role"] == "glare":
                        I, M = glare_sprite(3.5, rng.uniform(150, 220))
                    else:
                        I, M = foliage_sprite(rng, intensity=rng.uniform(60, 90))
                placed.append((I, M, p[0] + dx, p[1] + dy))
                idx.append(i)
                full_area.append(int(M.sum()))
                xy[k, i] = _full_centroid(M, p[0], p[1])
        frame, lab, boxes = render_frame(bg, placed, rng, gain=gain)
        frames[f] = frame
        if not idx:
            continue
        lut = np.zeros(len(idx) + 1, np.int8)
        lut[1:] = np.array(idx) + 1
        out = lut[lab]
        labels[f] = out
        if k < 0:
            continue
        counts = np.bincount(lab.ravel(), minlength=len(idx) + 1)
        box = {}
        for slot, i in enumerate(idx):
            present[k, i] = counts[slot + 1] > 0
            visible[k, i] = counts[slot + 1] == full_area[slot]
            box[i] = boxes[slot]
        xy[k, ~present[k]] = np.nan
        # a vehicle never comes within MIN_VEHICLE_GAP px of another object (so that every
        # object is a separate blob), except the occlusion scene's pair, which may merge
        vs = [i for i in idx if is_vehicle[i] and present[k, i]]
        for a in vs:
            for b in idx:
                if b == a or not present[k, b] or (is_vehicle[b] and b < a):
                    continue
                if not _boxes_near(box[a], box[b]):
                    continue
                gap = pair_gaps(out, a + 1, b + 1)
                if gap < MIN_VEHICLE_GAP:
                    if allow_merge and {a, b} == set(pair):
                        merged[k] = True
                    else:
                        raise AssertionError(f"{name}: {objs[a]['name']} and {objs[b]['name']}"
                                             f" touch at frame {k}")
    if len(pair) == 2 and conflict >= 0:
        d = np.hypot(*(xy[:, pair[0]] - xy[:, pair[1]]).T)
        k_min = int(np.nanargmin(d))
        if abs(k_min - conflict) > 2 or not window[0] <= k_min <= window[1]:
            raise AssertionError(f"{name}: closest approach at frame {k_min}, not within "
                                 f"2 frames of the scored frame {conflict}")
    return FeatureScene(name, frames, labels, xy, present, visible,
                        tuple(o["name"] for o in objs), is_vehicle, conflict, pair,
                        window, float(sigma), offsets, merged)


def _boxes_near(ba, bb):
    """Whether two boxes [r0, c0, r1, c1] (exclusive ends) come within
    ``MIN_VEHICLE_GAP`` px (a cheap test before the exact gap)."""
    g = MIN_VEHICLE_GAP
    return not (ba[0] - g >= bb[2] or bb[0] - g >= ba[2]
                or ba[1] - g >= bb[3] or bb[1] - g >= ba[3])


def closest_approach(scene):
    """``(frame, distance)`` of the closest approach of the scene's pair (centroids).

    Examples
    --------
    The measurement-level crossing brings its pair to ``min_sep`` = 3 px at frame 30:

    >>> detections, scene = crossing_detections(np.random.default_rng(0))
    >>> frame, distance = closest_approach(scene)
    >>> frame, round(distance, 3)
    (30, 3.0)
    """
    check_scene(scene)
    a, b = scene.pair
    d = np.hypot(*(scene.xy[:, a] - scene.xy[:, b]).T)
    k = int(np.nanargmin(d))
    return k, float(d[k])


def segment_scene(scene, method="vibe", rng=None):
    """Background-subtract every scene frame (after the warm-up) and return
    ``(detections, masks)``: a list of :class:`ImageDetections` per scene
    frame and the (K, H, W) cleaned foreground masks.  ``method`` is
    ``"vibe"`` (needs ``rng``) or ``"running_average"``.  Detections are in
    image coordinates (they carry the camera jitter).

    Examples
    --------
    >>> scene = render_scene("S1", np.random.default_rng(0))
    >>> detections, masks = segment_scene(scene, "running_average")
    >>> len(detections), masks.shape, [len(d.z) for d in detections[:8]]
    (70, (70, 240, 320), [1, 1, 1, 1, 1, 1, 1, 1])
    >>> segment_scene(scene, "vibe")  # ViBe draws random numbers: it needs rng
    Traceback (most recent call last):
        ...
    TypeError: rng must be a numpy.random.Generator (e.g. numpy.random.default_rng(seed)), got NoneType
    """
    check_scene(scene)
    if method == "vibe":
        seg = ViBe(scene.frames[0].astype(float), as_rng(rng))
    elif method == "running_average":
        seg = RunningAverage(scene.frames[0].astype(float))
    else:
        raise ValueError(f"method must be 'vibe' or 'running_average', got {method!r}")
    for f in range(1, N_WARMUP):
        seg.apply(scene.frames[f].astype(float))
    dets, masks = [], []
    for f in range(N_WARMUP, scene.frames.shape[0]):
        frame = scene.frames[f].astype(float)
        mask = clean_mask(seg.apply(frame))
        masks.append(mask)
        dets.append(detect_blobs(mask, frame, clean=False))
    return dets, np.array(masks)


def fig3_patches(rng, method="vibe", shift=(1, -2)):
    """Fig 3 data: four vehicles (sedan, van, truck, compact) on a night-like
    road, a template from frame a and a detection from frame b (moved by
    ``shift`` = (dx, dy) px, independent noise), each segmented by a
    background model trained on ``N_WARMUP`` empty frames.

    Returns a dict with ``frame_a``, ``frame_b``, ``kinds``, and lists
    ``grey_a``, ``mask_a``, ``grey_b``, ``mask_b`` (detections matched to the
    vehicles by nearest centroid, in ``kinds`` order).

    Examples
    --------
    >>> d = fig3_patches(np.random.default_rng(0), method="running_average")
    >>> d["kinds"], [m.shape for m in d["mask_a"]]
    (('sedan', 'van', 'truck', 'compact'), [(20, 32), (22, 38), (24, 48), (18, 26)])
    """
    rng = as_rng(rng)
    if len(shift) != 2:
        raise ValueError(f"shift must be (dx, dy), got {shift!r}")
    shift = tuple(as_scalar(v, "shift") for v in shift)
    if max(abs(v) for v in shift) > 20:
        raise ValueError(f"shift must be at most 20 px per axis, got {shift!r}")
    bg = terrain(rng, horizontal_road=(90, 150), vertical_road=None)
    kinds = ("sedan", "van", "truck", "compact")
    xs = (50.0, 120.0, 200.0, 270.0)
    sprites = [vehicle_sprite(k) for k in kinds]
    empty = [render_frame(bg, [], rng)[0].astype(float) for _ in range(N_WARMUP)]
    if method == "vibe":
        seg = ViBe(empty[0], rng)
    elif method == "running_average":
        seg = RunningAverage(empty[0])
    else:
        raise ValueError(f"method must be 'vibe' or 'running_average', got {method!r}")
    for f in empty[1:]:
        seg.apply(f)
    out = {"kinds": kinds}
    for tag, (dx, dy) in (("a", (0, 0)), ("b", shift)):
        objs = [(I, M, x + dx, 120.0 + dy) for (I, M), x in zip(sprites, xs)]
        frame = render_frame(bg, objs, rng)[0].astype(float)
        model = copy.deepcopy(seg)          # both frames see the same trained model
        mask = clean_mask(model.apply(frame))
        det = detect_blobs(mask, frame, clean=False)
        order = [int(np.argmin(np.abs(det.z[:, 0] - (x + dx)))) for x in xs]
        out[f"frame_{tag}"] = frame
        out[f"grey_{tag}"] = [det.greys[j] for j in order]
        out[f"mask_{tag}"] = [det.masks[j] for j in order]
    return out


def _cross_neighbours(M):
    """(any, all) of the 4-neighbourhood plus centre of every pixel (outside = 0):
    binary dilation and erosion by the cross, as ``scipy.ndimage`` does by default."""
    P = np.pad(M, 1)
    stack = (P[1:-1, 1:-1], P[:-2, 1:-1], P[2:, 1:-1], P[1:-1, :-2], P[1:-1, 2:])
    return np.logical_or.reduce(stack), np.logical_and.reduce(stack)


def _jitter_mask(M, rng, p_flip):
    """Flip boundary pixels of a mask with probability ``p_flip`` (segmentation
    noise); the result is one pixel larger on every side."""
    outer, inner = _cross_neighbours(M)
    flip = outer & ~inner & (rng.random(M.shape) < p_flip)
    out = np.pad(M, 1)
    dil, ero = _cross_neighbours(out)
    return np.where(dil & ~ero & np.pad(flip, 1), ~out, out)


def _crossing_geometry(heading_b, speed_a, speed_b, min_sep, n_frames, conflict):
    c0 = np.array([160.0, 120.0])
    va = np.array([speed_a, 0.0])
    vb = speed_b * np.array([math.cos(heading_b), -math.sin(heading_b)])   # image y points down
    vrel = vb - va
    nrel = np.hypot(*vrel)
    if nrel == 0:
        raise ValueError("the two vehicles must not move with the same velocity")
    perp = np.array([-vrel[1], vrel[0]]) / nrel
    k = np.arange(n_frames)[:, None] - conflict
    xy = np.empty((n_frames, 2, 2))
    xy[:, 0] = c0 + va * k
    xy[:, 1] = c0 + min_sep * perp + vb * k
    return xy, c0


def crossing_detections(rng, heading_b=math.radians(20.0), kind_a="van", kind_b="sedan",
                        speed_a=2.5, speed_b=2.5, min_sep=3.0, n_frames=60, conflict=30,
                        pd=0.9, clutter_rate=1.0, noise_sd=1.0, p_flip=0.2, window=120.0):
    """Measurement-level crossing without rendering (an extension): vehicle A
    moves along +x, vehicle B along ``heading_b``; their distance is smallest,
    ``min_sep`` px, at frame ``conflict`` (B is offset from A perpendicular to
    the relative velocity).  Each vehicle is detected with probability ``pd``
    at its position plus N(0, noise_sd^2) noise, as a separate measurement
    whatever the distance (a renderer would merge the two blobs below
    :func:`separate_blob_distance`), with its sprite mask whose boundary pixels
    flip with probability ``p_flip``; Poisson(``clutter_rate``) foliage blobs
    per frame fall uniformly in a ``window`` x ``window`` square around the
    conflict point.

    Returns ``(detections, scene)``: a list of :class:`ImageDetections` and a
    :class:`FeatureScene` (no frames) holding the truth for
    :func:`trackcore.scenarios.scene_metrics`.

    Examples
    --------
    A van along +x and a sedan at 20 degrees pass 3 px apart at frame 30; each frame has
    the detected vehicles and Poisson(1) foliage blobs:

    >>> detections, scene = crossing_detections(np.random.default_rng(0))
    >>> len(detections), [len(d.z) for d in detections[28:33]]
    (60, [5, 2, 2, 3, 4])
    >>> np.round(scene.xy[30], 2)  # the two vehicles' positions at the conflict
    array([[160.  , 120.  ],
           [162.95, 119.48]])
    """
    rng = as_rng(rng)
    heading_b = as_scalar(heading_b, "heading_b")
    speed_a = as_positive(speed_a, "speed_a")
    speed_b = as_positive(speed_b, "speed_b")
    min_sep = as_nonnegative(min_sep, "min_sep")
    n_frames = as_int(n_frames, "n_frames", minimum=3)
    if n_frames > 10_000:
        raise ValueError(f"n_frames must be at most 10000, got {n_frames}")
    conflict = as_int(conflict, "conflict", minimum=0)
    if conflict >= n_frames:
        raise ValueError(f"conflict must be < n_frames = {n_frames}, got {conflict}")
    pd = as_probability(pd, "pd")
    clutter_rate = as_nonnegative(clutter_rate, "clutter_rate")
    if clutter_rate > 100:
        raise ValueError(f"clutter_rate must be at most 100 per frame, got {clutter_rate}")
    noise_sd = as_nonnegative(noise_sd, "noise_sd")
    p_flip = as_probability(p_flip, "p_flip")
    window = as_positive(window, "window")
    Ma = vehicle_sprite(kind_a)[1]
    Mb = rotate_sprite(*vehicle_sprite(kind_b), heading_b)[1]
    xy, c0 = _crossing_geometry(heading_b, speed_a, speed_b, min_sep, n_frames, conflict)
    dets = []
    for k in range(n_frames):
        zs, masks = [], []
        for i, M in ((0, Ma), (1, Mb)):
            if rng.random() < pd:
                zs.append(xy[k, i] + rng.normal(0.0, noise_sd, 2))
                masks.append(_jitter_mask(M, rng, p_flip))
        for _ in range(rng.poisson(clutter_rate)):
            zs.append(c0 + rng.uniform(-window / 2, window / 2, 2))
            masks.append(foliage_sprite(rng)[1])
        z = np.array(zs, float).reshape(-1, 2)
        dets.append(ImageDetections(z, np.zeros((len(z), 4), np.int64),
                                    np.zeros(len(z), np.int64), masks, masks))
    present = np.ones((n_frames, 2), bool)
    scene = FeatureScene("crossing", np.zeros((0, 1, 1), np.uint8), np.zeros((0, 1, 1), np.int8),
                         xy, present, present, ("A", "B"), np.array([True, True]), conflict,
                         (0, 1), (conflict - 10, conflict + 10))
    return dets, scene


def separate_blob_distance(heading_b=math.radians(20.0), kind_a="van", kind_b="sedan",
                           speed_a=2.5, speed_b=2.5, max_sep=60.0):
    """The smallest closest-approach distance (px, centroids, to 0.5 px) at which the
    two silhouettes of :func:`crossing_detections` stay separate blobs after
    segmentation's 3 x 3 opening and closing at every frame of the crossing; below
    it a renderer would give one merged blob.

    Examples
    --------
    Below about 31.5 px of closest approach the two silhouettes of the default crossing
    would merge into one blob:

    >>> separate_blob_distance()
    31.5
    """
    max_sep = as_positive(max_sep, "max_sep")
    if max_sep > 200:
        raise ValueError(f"max_sep must be at most 200 px, got {max_sep}")
    heading_b = as_scalar(heading_b, "heading_b")
    speed_a = as_positive(speed_a, "speed_a")
    speed_b = as_positive(speed_b, "speed_b")
    Ia, Ma = vehicle_sprite(kind_a)
    Ib, Mb = rotate_sprite(*vehicle_sprite(kind_b), heading_b)

    def separate(sep):
        xy, _ = _crossing_geometry(heading_b, speed_a, speed_b, sep, 31, 15)
        for k in range(31):
            off = xy[k, 1] - xy[k, 0] + 60.0
            canvas = np.zeros((120, 120), bool)
            for M, (x, y) in ((Ma, (60.0, 60.0)), (Mb, off)):
                h, w = M.shape
                r0 = math.floor(y - (h - 1) / 2.0 + 0.5)
                c0 = math.floor(x - (w - 1) / 2.0 + 0.5)
                if r0 < 0 or c0 < 0 or r0 + h > 120 or c0 + w > 120:
                    break           # far apart: this frame cannot merge them
                canvas[r0:r0 + h, c0:c0 + w] |= M
            else:
                lab, n = ndimage.label(clean_mask(canvas), structure=np.ones((3, 3), bool))
                if n < 2:
                    return False
        return True

    sep = 0.0
    while sep <= max_sep:
        if separate(sep):
            return sep
        sep += 0.5
    raise ValueError(f"the blobs merge at every separation up to max_sep = {max_sep}")


def feature_correlation_samples(rng, n_draws=200, headings_deg=(20.0, 90.0), p_flip=0.2):
    """Labelled silhouette correlations for fitting a feature likelihood: for every
    draw and every crossing heading, a van template and a sedan template (the sedan
    rotated to the heading) are each correlated with a noisy silhouette of the same
    vehicle (a *true* pair) and with a noisy silhouette of the other vehicle and a
    foliage blob (*wrong* pairs), with the noise of :func:`crossing_detections`.
    Returns ``(true_rho, wrong_rho)`` as arrays.

    Examples
    --------
    True pairs correlate far better than wrong ones:

    >>> true_rho, wrong_rho = feature_correlation_samples(np.random.default_rng(0), n_draws=20)
    >>> true_rho.shape, wrong_rho.shape
    ((80,), (160,))
    >>> round(float(true_rho.mean()), 3), round(float(wrong_rho.mean()), 3)
    (0.959, 0.501)
    """
    from ..detection.image import ncc
    rng = as_rng(rng)
    n_draws = as_int(n_draws, "n_draws", minimum=1)
    if n_draws > 10_000:
        raise ValueError(f"n_draws must be at most 10000, got {n_draws}")
    p_flip = as_probability(p_flip, "p_flip")
    van = vehicle_sprite("van")[1]
    sedans = [rotate_sprite(*vehicle_sprite("sedan"), math.radians(h))[1]
              for h in headings_deg]
    true_r, wrong_r = [], []
    for _ in range(n_draws):
        for sedan in sedans:
            for tmpl, own, other in ((van, van, sedan), (sedan, sedan, van)):
                true_r.append(ncc(tmpl, _jitter_mask(own, rng, p_flip)))
                wrong_r.append(ncc(tmpl, _jitter_mask(other, rng, p_flip)))
                wrong_r.append(ncc(tmpl, foliage_sprite(rng)[1]))
    return np.array(true_r), np.array(wrong_r)
