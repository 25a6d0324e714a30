"""Ground truth from one long-exposure photo of a flashing LED (the lab report's Figs. 1 and 2).

An LED on the robot flashes at ``led_hz`` with ON fraction ``duty``; a camera on a tripod keeps
its shutter open while the robot drives. Every ON interval draws a bright dash on the photo:
a piece of the true path of known duration. This module reads it back:

1. :func:`read_floor_points` / :func:`floor_homography`: four or more points clicked on the
   photo (``u,v`` px) with their floor coordinates (``x,y`` m): the homography of the floor plane
   (image -> floor), its residual and the size of a pixel on the floor anywhere.
2. :func:`find_dashes`: bright strokes above the local background, each split from its
   neighbours where the light falls below half its local peak; each dash's centre line (a
   quadratic in the stroke's principal axes) and its two ends, in pixels and on the floor. A spot
   that is not a stroke (a lamp, the robot standing still), a blob much wider than the dashes (a
   reflection, two dashes where the path crosses itself) and a dash cut by the frame's edge are
   set aside with the reason.
3. :func:`order_dashes`: the dashes chained along the path (each next dash where the last one
   points, one gap further), with the number of ON intervals between neighbours (a missing or
   set-aside dash leaves a gap of two periods or more).
4. :func:`time_dashes`: dash ``k`` of the chain is the ON interval ``[t0 + k / f, t0 + (k + duty)
   / f]``. The odometry's distance along its path ``s(t)`` (any frame: distance is frame-free)
   is matched to the photo's distance along the chain, ``s_photo = c s(t0 + tau) + b`` at every
   dash end (``c`` absorbs the odometry's scale error, ``b`` where the photo's path starts):
   ``t0`` by a grid search then least squares, in both directions of the chain (the better fit
   says where the robot started). ``t0``'s standard error (from the fit's Jacobian and
   residuals) is the phase's uncertainty.

:func:`track_photo` does all four; :func:`write_photo_csv` writes ``t,x,y,quality`` (a row at each
dash's start, centre and end); :func:`draw_overlay` draws the odometry over the photo. OpenCV and
SciPy are imported inside the functions. See docs/ground-truth.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from odolab.core.arrays import FloatArray
from odolab.core.trajectory import Trajectory
from odolab.tracking.camera import TrackingError

__all__ = [
    "Dash",
    "DashSearch",
    "FloorHomography",
    "FloorPoints",
    "PhotoError",
    "PhotoTiming",
    "PhotoTrack",
    "draw_overlay",
    "find_dashes",
    "floor_homography",
    "order_dashes",
    "read_floor_points",
    "read_photo",
    "time_dashes",
    "track_photo",
    "write_photo_csv",
]


class PhotoError(TrackingError):
    """A photo, floor-point table or run that ``track-photo`` cannot read as a timed path."""


# ---------------------------------------------------------------------------------------------
# the floor


@dataclass(frozen=True)
class FloorPoints:
    """Points clicked on the photo: ``uv`` (k, 2) px and their floor coordinates ``xy`` (k, 2) m."""

    uv: FloatArray
    xy: FloatArray
    source: str = "floor points"


@dataclass(frozen=True)
class FloorHomography:
    """``matrix`` maps image pixels to floor metres (3x3, homogeneous); ``rms`` the residual of
    the clicked points on the floor (m)."""

    matrix: FloatArray
    rms: float

    def floor_from_pixels(self, uv: FloatArray) -> FloatArray:
        """Pixels (k, 2) -> floor points (k, 2)."""
        p = np.column_stack((uv, np.ones(len(uv)))) @ self.matrix.T
        return np.asarray(p[:, :2] / p[:, 2:3], dtype=np.float64)

    def pixels_from_floor(self, xy: FloatArray) -> FloatArray:
        """Floor points (k, 2) -> pixels (k, 2)."""
        p = np.column_stack((xy, np.ones(len(xy)))) @ np.linalg.inv(self.matrix).T
        return np.asarray(p[:, :2] / p[:, 2:3], dtype=np.float64)

    def pixel_size(self, uv: FloatArray) -> FloatArray:
        """The side (m) of a pixel's footprint on the floor at each of ``uv`` (k, 2): the square
        root of the homography's Jacobian determinant."""
        e = 0.5
        c = self.floor_from_pixels(uv)
        du = self.floor_from_pixels(uv + np.array([e, 0.0])) - c
        dv = self.floor_from_pixels(uv + np.array([0.0, e])) - c
        det = np.abs(du[:, 0] * dv[:, 1] - du[:, 1] * dv[:, 0]) / (e * e)
        return np.asarray(np.sqrt(det), dtype=np.float64)


def read_floor_points(path: str | Path) -> FloorPoints:
    """Read ``u,v,x,y`` (pixels, metres), one clicked point a row.

    Raises:
        PhotoError: the file is missing, lacks the u,v,x,y header, or a line is not four finite
            numbers.
    """
    from odolab.io.limits import check_text_file

    p = Path(path)
    if not p.is_file():
        raise PhotoError(f"{p}: no such file; expected the floor points u,v,x,y")
    check_text_file(p, expected="a floor-point CSV u,v,x,y")
    lines = [ln.strip() for ln in p.read_text(encoding="utf-8-sig").splitlines()]
    header = [c.strip().lower() for c in lines[0].split(",")] if lines else []
    if not all(k in header for k in ("u", "v", "x", "y")):
        raise PhotoError(f"{p}: line 1 is {lines[0] if lines else ''!r}; expected header u,v,x,y")
    cols = [header.index(k) for k in ("u", "v", "x", "y")]
    rows = []
    for number, line in enumerate(lines[1:], start=2):
        if not line:
            continue
        cells = line.split(",")
        try:
            row = [float(cells[i]) for i in cols]
        except (ValueError, IndexError):
            raise PhotoError(
                f"{p}: line {number} is {line!r}; expected four numbers u,v (px) and x,y (m)"
            ) from None
        if not all(math.isfinite(v) for v in row):
            raise PhotoError(f"{p}: line {number} is {line!r}; expected finite numbers")
        rows.append(row)
    arr = np.array(rows, dtype=np.float64).reshape(-1, 4)
    return FloorPoints(arr[:, :2], arr[:, 2:], str(p))


def _collinear(pts: FloatArray) -> bool:
    """True when the points (k, 2) lie on one line (or three of exactly four do)."""
    c = pts - pts.mean(axis=0)
    s = np.linalg.svd(c, compute_uv=False)
    if s[0] == 0 or s[1] / s[0] < 1e-3:
        return True
    if len(pts) == 4:
        span = float(s[0])
        for i in range(4):
            a, b, d = (pts[j] for j in range(4) if j != i)
            area = abs((b[0] - a[0]) * (d[1] - a[1]) - (b[1] - a[1]) * (d[0] - a[0]))
            if area < 1e-3 * span * span:
                return True
    return False


def floor_homography(points: FloorPoints) -> FloorHomography:
    """The image-to-floor homography of the clicked points (least squares over all of them).

    Raises:
        PhotoError: fewer than four points are given, or they lie on one line, or no homography fits
            them.
    """
    import cv2

    k = len(points.uv)
    if k < 4:
        raise PhotoError(
            f"{points.source}: {k} floor point{'s' if k != 1 else ''}; expected four or more "
            "points clicked on the floor (u,v px) with their floor coordinates (x,y m)"
        )
    for name, pts in (("floor coordinates x,y", points.xy), ("pixels u,v", points.uv)):
        if _collinear(pts):
            raise PhotoError(
                f"{points.source}: the points' {name} lie on one line (or three of four do); "
                "expected points spread around the area the robot drives in, no three in a row"
            )
    h, _ = cv2.findHomography(points.uv, points.xy, 0)
    if h is None or not np.all(np.isfinite(h)):
        raise PhotoError(f"{points.source}: no homography fits these points; check u,v and x,y")
    hom = FloorHomography(np.asarray(h, dtype=np.float64), 0.0)
    res = hom.floor_from_pixels(points.uv) - points.xy
    return FloorHomography(hom.matrix, float(np.sqrt(np.mean(np.sum(res**2, axis=1)))))


# ---------------------------------------------------------------------------------------------
# the dashes


@dataclass(frozen=True)
class Dash:
    """One bright stroke: its centre line ``uv`` (m, 2) px and ``xy`` (m, 2) floor, from one end
    to the other (the chain's direction once ordered), and its brightest level."""

    uv: FloatArray
    xy: FloatArray
    peak: float
    area: int

    @property
    def length(self) -> float:
        """Length of the centre line on the floor (m)."""
        return float(np.sum(np.hypot(*np.diff(self.xy, axis=0).T)))

    def reversed(self) -> Dash:
        return Dash(self.uv[::-1].copy(), self.xy[::-1].copy(), self.peak, self.area)

    def point_at(self, fraction: float) -> FloatArray:
        """The floor point a ``fraction`` (0..1) of the way along the centre line."""
        seg = np.hypot(*np.diff(self.xy, axis=0).T)
        s = np.concatenate(([0.0], np.cumsum(seg)))
        target = min(max(fraction, 0.0), 1.0) * s[-1]
        return np.array([np.interp(target, s, self.xy[:, 0]), np.interp(target, s, self.xy[:, 1])])


@dataclass(frozen=True)
class DashSearch:
    """The dashes found and what was set aside: ``(reason, u, v)`` each."""

    dashes: list[Dash]
    set_aside: list[tuple[str, float, float]] = field(default_factory=list)


def read_photo(path: str | Path) -> FloatArray:
    """The photo as brightness (h, w) float: the brightest of its colour channels (an LED of any
    colour), 0..255.

    Raises:
        PhotoError: the file is missing or not an image OpenCV reads.
    """
    import cv2

    p = Path(path)
    if not p.is_file():
        raise PhotoError(f"{p}: no such file; expected the long-exposure photo")
    raw = cv2.imread(str(p), cv2.IMREAD_UNCHANGED)
    if raw is None:
        raise PhotoError(f"{p}: not an image OpenCV can read; expected a PNG or JPEG photo")
    img = np.asarray(raw, dtype=np.float64)
    if raw.dtype == np.uint16:
        img = img / 257.0
    if img.ndim == 3:
        img = img[:, :, :3].max(axis=2)
    return img


def _centre_line(
    us: FloatArray, vs: FloatArray, w: FloatArray, samples: int = 9
) -> tuple[FloatArray, float]:
    """Centre line of a stroke's pixels (weights ``w``): principal axis, then the across offset
    as a quadratic of the along coordinate; returns (samples, 2) px from one end to the other
    and the weighted RMS of the across residual (px)."""
    m = np.array([np.average(us, weights=w), np.average(vs, weights=w)])
    d = np.column_stack((us, vs)) - m
    cov = (d * w[:, None]).T @ d / w.sum()
    _, evecs = np.linalg.eigh(cov)
    axis, normal = evecs[:, 1], evecs[:, 0]
    a = d @ axis
    b = d @ normal
    deg = 2 if len(a) >= 12 else 1
    coef = np.polyfit(a, b, deg, w=np.sqrt(w))
    resid = b - np.polyval(coef, a)
    rms = float(np.sqrt(np.average(resid**2, weights=w)))
    # ends: the extreme along-coordinates of the pixels above half the stroke's peak, moved in
    # by half a pixel (the pixel's centre is half a pixel inside its edge)
    lo, hi = float(a.min()) + 0.5, float(a.max()) - 0.5
    if hi <= lo:
        lo = hi = float(a.mean())
    t = np.linspace(lo, hi, samples)
    line = m + np.outer(t, axis) + np.outer(np.polyval(coef, t), normal)
    return np.asarray(line, dtype=np.float64), rms


#: more bright pieces than this and the photo is not a long exposure of one LED
MAX_PIECES = 1000


def find_dashes(
    image: FloatArray,
    homography: FloorHomography,
    *,
    window: int = 41,
    min_area: int = 6,
) -> DashSearch:
    """The LED's dashes in a long-exposure photo (brightness (h, w), 0..255).

    The background (a wide median of the photo) is taken off; a pixel is in a dash where it is
    above half the brightest light within ``window`` px (so a shallow gap between two dashes
    still splits them) and well above the noise. Connected pieces of ``min_area`` px or more
    are kept as dashes unless they touch the frame's edge, are round spots, or are much wider
    than the dashes' median (set aside with the reason).

    Raises:
        PhotoError: the photo has more bright pieces than dashes can be.
    """
    import cv2

    img = np.asarray(image, dtype=np.float32)
    small = cv2.resize(img, None, fx=0.25, fy=0.25, interpolation=cv2.INTER_AREA)
    bg = cv2.resize(cv2.medianBlur(np.clip(small, 0, 255).astype(np.uint8), 15), img.shape[::-1])
    signal = img - bg.astype(np.float32)
    noise = 1.4826 * float(np.median(np.abs(signal - np.median(signal))))
    peak_local = cv2.dilate(signal, np.ones((window, window), np.uint8))
    # well above the noise, and a fifth of the brightest light (the floor's own texture, tile
    # joints and grain, stays below it; a lamp much brighter than the LED raises it)
    top = float(cv2.GaussianBlur(signal, (0, 0), 1.0).max())
    floor_level = max(8.0 * noise, 12.0, 0.2 * top)
    bright = ((signal > 0.5 * peak_local) & (signal > floor_level)).astype(np.uint8)
    mask = cv2.morphologyEx(bright, cv2.MORPH_OPEN, np.ones((2, 2), np.uint8))
    count, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
    if count - 1 > MAX_PIECES:
        raise PhotoError(
            f"{count - 1} bright pieces in the photo; expected at most {MAX_PIECES} dashes (a "
            "photo taken with the lights on, or a textured bright floor?)"
        )
    h, w = img.shape
    found: list[tuple[Dash, float, tuple[float, float], bool]] = []
    aside: list[tuple[str, float, float]] = []
    for i in range(1, count):
        x0, y0, bw, bh, area = (int(v) for v in stats[i])
        if area < min_area:
            continue
        sub = labels[y0 : y0 + bh, x0 : x0 + bw] == i
        vs, us = np.nonzero(sub)
        us_f = us.astype(np.float64) + x0
        vs_f = vs.astype(np.float64) + y0
        wts = np.maximum(signal[vs + y0, us + x0].astype(np.float64), 1e-6)
        line, rms = _centre_line(us_f, vs_f, wts)
        centre = (float(np.mean(us_f)), float(np.mean(vs_f)))
        length_px = float(np.hypot(*(line[-1] - line[0])))
        width_px = area / max(length_px, 1.0)
        if length_px < 1.5 * width_px:
            spot = "a round spot, not a dash (a lamp, or the robot standing still)"
            aside.append((spot, *centre))
            continue
        edge = x0 <= 1 or y0 <= 1 or x0 + bw >= w - 1 or y0 + bh >= h - 1
        dash = Dash(line, homography.floor_from_pixels(line), float(wts.max()), area)
        found.append((dash, width_px + 2.0 * rms, centre, edge))
    if found:
        typical = float(np.median([f[1] for f in found]))
        kept = []
        for dash, width, centre, edge in found:
            if width > 2.5 * typical:
                wide = "much wider than the dashes (a reflection, or the path crossing itself)"
                aside.append((wide, *centre))
            elif edge:
                aside.append(("cut by the frame's edge", *centre))
            else:
                kept.append(dash)
        return DashSearch(kept, aside)
    return DashSearch([], aside)


# ---------------------------------------------------------------------------------------------
# the order


@dataclass(frozen=True)
class DashChain:
    """The dashes in order along the path, each from its entry end to its exit end, and the ON
    interval of each (``index``: 0 for the first, +1 per period)."""

    dashes: list[Dash]
    index: NDArray[np.int64]
    jumps: list[tuple[int, float]]

    def reversed(self) -> DashChain:
        last = int(self.index[-1])
        n = len(self.dashes)
        return DashChain(
            [d.reversed() for d in self.dashes[::-1]],
            (last - self.index[::-1]).astype(np.int64),
            [(n - 1 - i, d) for i, d in self.jumps],
        )


def _exit_dir(d: Dash) -> FloatArray:
    v = d.xy[-1] - d.xy[-3]
    n = float(np.hypot(*v))
    return np.asarray(v / n if n > 0 else v, dtype=np.float64)


def _greedy(dashes: list[Dash], first: int, flip: bool, duty: float) -> tuple[float, list[Dash]]:
    """Chain from ``dashes[first]`` (reversed when ``flip``): each next dash is the one whose
    nearer end is closest to where the path would be one OFF interval beyond the current exit
    (at the current dash's speed); it is entered at that nearer end."""
    left = set(range(len(dashes)))
    left.discard(first)
    cur = dashes[first].reversed() if flip else dashes[first]
    chain, cost = [cur], 0.0
    while left:
        p = cur.xy[-1]
        want = p + _exit_dir(cur) * cur.length * (1.0 - duty) / duty
        best, best_cost, best_flip = -1, math.inf, False
        for j in left:
            d = dashes[j]
            f = bool(np.hypot(*(d.xy[-1] - p)) < np.hypot(*(d.xy[0] - p)))
            q = d.xy[-1] if f else d.xy[0]
            c = float(np.hypot(*(q - want)))
            if c < best_cost:
                best, best_cost, best_flip = j, c, f
        left.discard(best)
        cur = dashes[best].reversed() if best_flip else dashes[best]
        chain.append(cur)
        cost += best_cost
    return cost, chain


def order_dashes(dashes: list[Dash], duty: float) -> DashChain:
    """The dashes chained along the path (one direction; :func:`time_dashes` picks the
    robot's). A gap longer than the local speed allows for one OFF interval counts the ON
    intervals it skipped (a dash missing, set aside or too faint).

    Raises:
        PhotoError: there are no dashes.
    """
    if not dashes:
        raise PhotoError("no dashes to order")
    best: tuple[float, list[Dash]] | None = None
    for i in range(len(dashes)):
        for flip in (False, True):
            cand = _greedy(dashes, i, flip, duty)
            if best is None or cand[0] < best[0]:
                best = cand
    assert best is not None
    chain = best[1]
    index = [0]
    jumps: list[tuple[int, float]] = []
    for k in range(1, len(chain)):
        a, b = chain[k - 1], chain[k]
        speed_per_period = 0.5 * (a.length + b.length) / duty  # distance per period
        start_to_start = a.length + float(np.hypot(*(b.xy[0] - a.xy[-1])))
        periods = max(1, round(start_to_start / max(speed_per_period, 1e-9)))
        if periods > 1:
            jumps.append((k, float(np.hypot(*(b.xy[0] - a.xy[-1])))))
        index.append(index[-1] + periods)
    return DashChain(chain, np.array(index, dtype=np.int64), jumps)


# ---------------------------------------------------------------------------------------------
# the time


@dataclass(frozen=True)
class PhotoTiming:
    """The chain on the encoder clock: dash ``k`` is ON over ``[t0 + index_k / f, t0 + (index_k +
    duty) / f]``; ``t0_std`` its standard error (s); ``coef`` the photo's distance per metre of
    each wheel's nominal travel and the offset (m); ``rms`` the distance residual (m);
    ``reversed`` when the robot drove the chain from its other end."""

    t0: float
    t0_std: float
    coef: FloatArray
    rms: float
    reversed: bool
    chain: DashChain

    @property
    def scale(self) -> float:
        """The photo's distance per metre of nominal odometry (straight ahead: both wheels)."""
        return float(self.coef[0] + self.coef[1])

    def distance(self, travel: WheelTravel, t: FloatArray) -> FloatArray:
        """The photo's distance along the path at times ``t`` (as fitted)."""
        left = np.interp(t, travel.t, travel.left)
        right = np.interp(t, travel.t, travel.right)
        return np.asarray(self.coef[0] * left + self.coef[1] * right + self.coef[2])


@dataclass(frozen=True)
class WheelTravel:
    """What the encoder log says about the distance driven: at each stamp ``t`` (n,), each
    wheel's cumulative travel (m, nominal radii) counted in the direction the robot moves
    (``left`` + ``right`` over 2 is the distance along the path, whichever way it drives)."""

    t: FloatArray
    left: FloatArray
    right: FloatArray

    @classmethod
    def from_increments(
        cls, t: FloatArray, dticks_left: FloatArray, dticks_right: FloatArray,
        left_m_per_tick: float, right_m_per_tick: float,
    ) -> WheelTravel:  # fmt: skip
        """From per-sample count increments (the first sample's are ignored) and each wheel's
        metres per count."""
        dl = np.asarray(dticks_left, dtype=np.float64) * left_m_per_tick
        dr = np.asarray(dticks_right, dtype=np.float64) * right_m_per_tick
        dl[0] = dr[0] = 0.0
        sign = np.where(dl + dr < 0, -1.0, 1.0)
        return cls(np.asarray(t, dtype=np.float64), np.cumsum(sign * dl), np.cumsum(sign * dr))

    @property
    def distance(self) -> FloatArray:
        """Distance along the path (m, nominal radii)."""
        return np.asarray(0.5 * (self.left + self.right), dtype=np.float64)


def _chain_samples(chain: DashChain, led_hz: float, duty: float) -> tuple[FloatArray, FloatArray]:
    """(tau, s_photo): each dash end's time after dash 0's start (s) and distance along the
    chain (m; straight across each gap)."""
    tau, s = [], []
    pos = 0.0
    for k, d in enumerate(chain.dashes):
        if k > 0:
            pos += float(np.hypot(*(d.xy[0] - chain.dashes[k - 1].xy[-1])))
        i = int(chain.index[k])
        tau += [i / led_hz, (i + duty) / led_hz]
        s += [pos, pos + d.length]
        pos += d.length
    return np.array(tau), np.array(s)


def _fit(
    travel: WheelTravel, tau: FloatArray, s_photo: FloatArray
) -> tuple[float, float, FloatArray, float]:
    """Best ``t0`` (a grid, then least squares) for ``s_photo = cl L(t0 + tau) + cr R(t0 + tau)
    + b``, ``L``, ``R`` each wheel's travel: the photo's distances are true, the wheels' radii are
    only nominal (a scale per wheel, so that arcs one way and the other do not pull the time).
    Returns (t0, t0_std, (cl, cr, b), rms)."""
    from scipy.optimize import least_squares

    t = travel.t

    def design(t0: float) -> FloatArray:
        x = t0 + tau
        return np.column_stack(
            (np.interp(x, t, travel.left), np.interp(x, t, travel.right), np.ones_like(tau))
        )

    def linear(t0: float) -> tuple[FloatArray, FloatArray]:
        a = design(t0)
        coef = np.asarray(np.linalg.lstsq(a, s_photo, rcond=None)[0], dtype=np.float64)
        return coef, np.asarray(s_photo - a @ coef, dtype=np.float64)

    lo, hi = t[0] - 0.5 * tau[-1], t[-1] - 0.5 * tau[-1]
    grid = np.arange(lo, hi, 0.01)
    costs = np.array([float(np.sum(linear(float(g))[1] ** 2)) for g in grid])
    t_best = float(grid[int(np.argmin(costs))])

    def resid(p: FloatArray) -> FloatArray:
        return np.asarray(s_photo - design(float(p[0])) @ p[1:], dtype=np.float64)

    coef, _ = linear(t_best)
    sol = least_squares(resid, np.concatenate(([t_best], coef)), diff_step=1e-5, x_scale=1.0)
    r = sol.fun
    dof = max(len(r) - 4, 1)
    sigma2 = float(r @ r) / dof
    try:
        cov = np.linalg.inv(sol.jac.T @ sol.jac) * sigma2
        std = float(np.sqrt(max(cov[0, 0], 0.0)))
    except np.linalg.LinAlgError:
        std = math.inf
    rms = float(np.sqrt(np.mean(r**2)))
    return float(sol.x[0]), std, np.asarray(sol.x[1:], dtype=np.float64), rms


def time_dashes(
    chain: DashChain, travel: WheelTravel, led_hz: float, duty: float, source: str = "photo"
) -> PhotoTiming:
    """Place the chain on the encoder log's clock (see the module), trying both directions.

    Raises:
        PhotoError: the encoder log shows no motion, or the dashes cannot be matched to its time
            span.
    """
    s_odo = travel.distance
    moving = np.nonzero(s_odo > s_odo[0] + 1e-4)[0]
    if len(moving) == 0:
        raise PhotoError(f"{source}: the encoder log shows no motion; expected the run's log")
    t_first = float(travel.t[max(moving[0] - 1, 0)])
    t_last = float(travel.t[np.nonzero(s_odo < s_odo[-1] - 1e-4)[0][-1] + 1])
    spanned = int(chain.index[-1]) + duty
    moved = t_last - t_first
    if spanned / led_hz > moved + 1.0 / led_hz:
        raise PhotoError(
            f"{source}: {len(chain.dashes)} dashes span {spanned / led_hz:.2f} s at "
            f"{led_hz:g} Hz, but the robot moved for only {moved:.2f} s in the encoder log; "
            f"expected at most {math.floor(moved * led_hz) + 1} dashes (check the LED's "
            "frequency and that the log is this run's)"
        )
    if len(chain.dashes) < 3:
        raise PhotoError(
            f"{source}: {len(chain.dashes)} dash{'es' if len(chain.dashes) != 1 else ''} found; "
            "expected three or more to time the path"
        )
    best: PhotoTiming | None = None
    for rev in (False, True):
        ch = chain.reversed() if rev else chain
        tau, s_photo = _chain_samples(ch, led_hz, duty)
        t0, std, coef, rms = _fit(travel, tau, s_photo)
        cand = PhotoTiming(t0, std, coef, rms, rev, ch)
        if best is None or cand.rms < best.rms:
            best = cand
    assert best is not None
    return best


# ---------------------------------------------------------------------------------------------
# the whole


@dataclass(frozen=True)
class PhotoTrack:
    """The photo read as a timed path: rows ``t, x, y, quality`` (3 per timed dash: start,
    centre, end), the dash each row is from (``dash``, its place in the chain), and what was
    found."""

    t: FloatArray
    x: FloatArray
    y: FloatArray
    quality: FloatArray
    dash: NDArray[np.int64]
    timing: PhotoTiming
    search: DashSearch
    homography: FloorHomography
    untimed: int
    image_shape: tuple[int, int]

    def trajectory(self) -> Trajectory:
        """The rows as a trajectory, heading from the path's tangent (position-only truth)."""
        from odolab.io.trajectory_csv import heading_from_path

        return Trajectory.from_xyh(self.t, self.x, self.y, heading_from_path(self.x, self.y))


def track_photo(
    image: FloatArray,
    points: FloorPoints,
    travel: WheelTravel,
    *,
    led_hz: float,
    duty: float = 0.5,
    source: str = "photo",
) -> PhotoTrack:
    """Read a long-exposure photo of a flashing LED as a timed path on ``odometry``'s clock.

    Raises:
        PhotoError: the LED frequency or duty is out of range, or no dash is found within the log's
            time span.
    """
    if not (math.isfinite(led_hz) and led_hz > 0):
        raise PhotoError(f"LED frequency {led_hz!r} Hz; expected a positive number")
    if not (math.isfinite(duty) and 0.05 <= duty <= 0.95):
        raise PhotoError(f"LED duty {duty!r}; expected the ON fraction, 0.05 to 0.95")
    hom = floor_homography(points)
    search = find_dashes(image, hom)
    if not search.dashes:
        aside = f" ({len(search.set_aside)} bright spots set aside)" if search.set_aside else ""
        raise PhotoError(
            f"{source}: no dashes found{aside}; expected the LED's bright dashes on a darker "
            "floor (a long exposure in a dim room)"
        )
    chain = order_dashes(search.dashes, duty)
    timing = time_dashes(chain, travel, led_hz, duty, source)
    s_fit = timing.distance(travel, travel.t)
    speed = np.gradient(s_fit, travel.t)
    rows: list[tuple[float, float, float, float, int]] = []
    untimed = 0
    ch = timing.chain
    for k, d in enumerate(ch.dashes):
        ts = timing.t0 + int(ch.index[k]) / led_hz
        te = ts + duty / led_hz
        if ts < travel.t[0] or te > travel.t[-1]:
            untimed += 1
            continue
        tm = 0.5 * (ts + te)
        sa, sm, se = np.interp([ts, tm, te], travel.t, s_fit)
        frac = (sm - sa) / (se - sa) if se > sa else 0.5
        pix = float(np.median(hom.pixel_size(d.uv)))
        for t, pt in ((ts, d.xy[0]), (tm, d.point_at(frac)), (te, d.xy[-1])):
            v = float(np.interp(t, travel.t, speed))
            q = math.hypot(0.5 * pix, v * timing.t0_std)
            rows.append((t, float(pt[0]), float(pt[1]), q, k))
    if not rows:
        raise PhotoError(f"{source}: no dash falls within the encoder log's time span")
    arr = np.array(rows)
    return PhotoTrack(
        arr[:, 0], arr[:, 1], arr[:, 2], arr[:, 3], arr[:, 4].astype(np.int64), timing, search,
        hom, untimed, (int(image.shape[0]), int(image.shape[1])),
    )  # fmt: skip


def write_photo_csv(path: str | Path, track: PhotoTrack) -> Path:
    """Write ``t,x,y,quality`` (s, m, m, m): position-only ground truth; a reader derives the
    heading from the path's tangent."""
    from odolab.io.tabular import write_columns

    cols = {"t": track.t, "x": track.x, "y": track.y, "quality": track.quality}
    return write_columns(Path(path), cols, "photo track CSV")


def align_to_floor(
    odometry: Trajectory, track: PhotoTrack, first_dashes: int = 4
) -> tuple[FloatArray, FloatArray]:
    """The odometry's path moved onto the floor: the rigid motion (rotation, translation; no
    scale) that best puts its positions at the times of the rows of the ``first_dashes`` timed
    dashes on those rows (least squares, Umeyama), so that the drift shows as it grows from the
    start. Returns x, y (n,)."""
    keep = track.dash < np.unique(track.dash)[: max(first_dashes, 2)].max() + 1
    px = np.interp(track.t[keep], odometry.t, odometry.x)
    py = np.interp(track.t[keep], odometry.t, odometry.y)
    a = np.column_stack((px, py))
    b = np.column_stack((track.x[keep], track.y[keep]))
    ma, mb = a.mean(axis=0), b.mean(axis=0)
    u, _, vt = np.linalg.svd((b - mb).T @ (a - ma))
    r = u @ vt
    if np.linalg.det(r) < 0:
        u[:, -1] *= -1
        r = u @ vt
    moved = (np.column_stack((odometry.x, odometry.y)) - ma) @ r.T + mb
    return moved[:, 0].copy(), moved[:, 1].copy()


def draw_overlay(
    path: str | Path, image: FloatArray, track: PhotoTrack, odometry: Trajectory
) -> Path:
    """The photo, dimmed, with the dashes read (green centre lines, red start ends, their order
    every fifth), what was set aside (orange circles) and the odometry's path (white; put on the
    first dashes by a rigid motion) drawn over it (the lab report's Fig. 2): PNG.

    Raises:
        PhotoError: the overlay cannot be encoded.
    """
    import cv2

    from odolab.core.writing import write_bytes_file

    base = np.clip(image * 0.6, 0, 255).astype(np.uint8)
    out = cv2.cvtColor(base, cv2.COLOR_GRAY2BGR)
    scale = max(1, round(max(image.shape) / 1000))
    ox, oy = align_to_floor(odometry, track)
    inside = (odometry.t >= track.t[0] - 1.0) & (odometry.t <= track.t[-1] + 1.0)
    uv = track.homography.pixels_from_floor(np.column_stack((ox[inside], oy[inside])))
    cv2.polylines(
        out, [np.round(uv).astype(np.int32).reshape(-1, 1, 2)], False, (255, 255, 255),
        scale, cv2.LINE_AA,
    )  # fmt: skip
    ch = track.timing.chain
    for k, d in enumerate(ch.dashes):
        pts = np.round(d.uv).astype(np.int32).reshape(-1, 1, 2)
        cv2.polylines(out, [pts], False, (0, 200, 0), max(1, scale // 2), cv2.LINE_AA)
        cv2.circle(out, (int(pts[0, 0, 0]), int(pts[0, 0, 1])), 2 * scale, (0, 0, 255), -1)
        if k % 5 == 0:
            cv2.putText(
                out, str(k), (int(pts[0, 0, 0]) + 6 * scale, int(pts[0, 0, 1]) - 6 * scale),
                cv2.FONT_HERSHEY_SIMPLEX, 0.5 * scale, (0, 255, 255), scale, cv2.LINE_AA,
            )  # fmt: skip
    for _, u, v in track.search.set_aside:
        cv2.circle(out, (round(u), round(v)), 12 * scale, (0, 140, 255), scale, cv2.LINE_AA)
    ok, data = cv2.imencode(".png", out)
    if not ok:
        raise PhotoError(f"{path}: OpenCV cannot encode the overlay PNG")
    return write_bytes_file(path, data.tobytes(), what="overlay PNG")
