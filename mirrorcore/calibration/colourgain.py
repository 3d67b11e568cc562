"""The mirrors' colour gains (SessionMirror.colour_gain): the fraction of each colour channel a
mirror reflects, measured where two views see the same surface.

The views' points are paired as the refinement compares them (agreement.TargetView.compare: a
mirror's points, reflected into the real space and mapped into another view's space, each paired
with the reading of that view whose surface it lies on). A pair's two pixels show the same surface,
so their levels differ by the ratio of the two views' gains (a level seen through a mirror = the
level seen directly x its gain). Per pair of views and channel, the pairs' ratios are trimmed about
their median (a pair across an edge of the object's texture compares two colours), and the ratio
of the kept levels' sums is the pair of views' gain ratio. The gains are then the least squares of
the log-ratios over every pair of views, the direct view fixed at 1: a mirror that overlaps only
another mirror's view gets its gain through that mirror.
"""
from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass, replace

import numpy as np

from mirrorcore.base.errors import Cancelled
from mirrorcore.base.progress import Progress, cancel_requested
from mirrorcore.calibration.agreement import frame_views, in_view
from mirrorcore.io.session import MAX_COLOUR_GAIN, Session
from mirrorcore.rig.model import Rig

# Levels: a pair whose level in a channel is below DARK or above BRIGHT (saturated) in either view
# says little of the ratio (rounding, clipping) and is left out.
DARK = 8
BRIGHT = 250
# A pair whose log-ratio in any channel is further from its views' median than TRIM, or than
# TRIM_SIGMAS robust standard deviations of the log-ratios (the colour camera's noise), compares two
# colours (across an edge of the texture): the simulator's checker colours differ by 16 % and more
# in one channel, by 50 % and more in another.
TRIM = 0.06
TRIM_SIGMAS = 3.0
# The fewest kept pairs that measure a mirror's gain.
MIN_PAIRS = 50
# A saved gain's decimals (a pair's level is known to 1 in 250 at best).
GAIN_DECIMALS = 4
# Why a mirror has no gain (MirrorGain.reason).
NO_PLANE = "no plane"
TOO_FEW_PAIRS = "too few pairs"
# (a gain above MAX_COLOUR_GAIN: the views' exposures differ, or the pairs are not the same surface)
OUT_OF_RANGE = "out of range"


@dataclass(frozen=True)
class MirrorGain:
    """One mirror's measured colour gain.

    Attributes
    ----------
    index : int
        The mirror, 0-based (session order).
    name : str
    gain : (float, float, float) or None
        Red, green, blue; None when not measured (`reason` says why).
    pairs : int
        The kept pairs of its points and another view's it rests on (with the camera's and other
        mirrors').
    with_camera : int
        Of those, the pairs with the camera's own readings.
    trimmed : int
        Its pairs left out as comparing two colours (TRIM).
    spread : (float, float, float)
        Per channel, the standard deviation of its kept pairs' log-ratios about their views'
        ratio (about the relative scatter of one pair); NaN without pairs.
    reason : str or None
        NO_PLANE, TOO_FEW_PAIRS or OUT_OF_RANGE when `gain` is None.
    """

    index: int
    name: str
    gain: tuple[float, float, float] | None
    pairs: int
    with_camera: int
    trimmed: int
    spread: tuple[float, float, float]
    reason: str | None = None


@dataclass(frozen=True)
class ColourGains:
    """The colour gains of a rig's mirrors, measured over frames.

    Attributes
    ----------
    mirrors : tuple of MirrorGain
        Session order, every mirror.
    frames : int
        The frames they were measured on.
    """

    mirrors: tuple[MirrorGain, ...]
    frames: int

    @property
    def gains(self) -> tuple[tuple[float, float, float] | None, ...]:
        """Each mirror's gain, session order (None where not measured)."""
        return tuple(m.gain for m in self.mirrors)


@dataclass
class _Pairs:
    """The pairs of one source view's points with one target view's readings, over the frames:
    (k, 3) float64 levels of each."""

    source: list
    target: list

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        return np.concatenate(self.source), np.concatenate(self.target)


def pair_levels(rig: Rig, depths: np.ndarray, masks: np.ndarray, colours: np.ndarray,
                cancel=None, progress: Progress | None = None
                ) -> dict[tuple[int, int], tuple[np.ndarray, np.ndarray]]:
    """Pair every mirror view's points with the readings of the other views that see them.

    Parameters
    ----------
    rig : Rig
        Its planes say where each view's points are.
    depths : (F, H, W) float array
        Metres, as measured.
    masks : (F, H, W) bool array
        Each frame's object (rig.pipeline.prepare_frame's).
    colours : (F, H, W, 3) uint8 array
        RGB registered to the depths.
    cancel : optional
        Checked between frames (base.progress.cancel_requested).
    progress : callable, optional
        progress(share of the frames done) after each.

    Returns
    -------
    dict of (int, int) to ((k, 3), (k, 3)) float64 arrays
        {(a, b): (levels of view a's points, levels of view b's readings they lie on)}, a a mirror
        (1-based), b the camera (0) or another mirror; only pairs with both levels within DARK to
        BRIGHT in every channel.

    Raises
    ------
    Cancelled
        When `cancel` asks.
    """
    found: dict[tuple[int, int], _Pairs] = defaultdict(lambda: _Pairs([], []))
    planes = {j: m.plane for j, m in enumerate(rig.mirrors, start=1) if m.plane is not None}
    for k, (depth, mask, colour) in enumerate(zip(depths, masks, colours)):
        if cancel_requested(cancel):
            raise Cancelled("colour gains cancelled")
        views = frame_views(rig, depth, mask)
        levels = np.asarray(colour).reshape(-1, 3)
        real = {j: in_view(views.points(j), planes.get(j)) for j in views.targets}
        for a in views.targets:
            if a == 0:
                continue
            for b, target in views.targets.items():
                if b == a:
                    continue
                compared = target.compare(in_view(real[a], planes.get(b)))
                source = levels[views.points(a).pixels[compared.index]].astype(np.float64)
                seen = levels[target.view.pixels[compared.reading]].astype(np.float64)
                usable = np.all((np.minimum(source, seen) >= DARK)
                                & (np.maximum(source, seen) <= BRIGHT), axis=1)
                found[a, b].source.append(source[usable])
                found[a, b].target.append(seen[usable])
        if progress is not None:
            progress((k + 1) / len(depths))
    return {key: pairs.arrays() for key, pairs in found.items()}


def estimate_gains(rig: Rig, depths: np.ndarray, masks: np.ndarray, colours: np.ndarray,
                   cancel=None, progress: Progress | None = None) -> ColourGains:
    """Measure each mirror's colour gain from frames with colour (see the module docstring).

    Parameters
    ----------
    rig : Rig
    depths : (F, H, W) or (H, W) float array
        Metres, as measured.
    masks : (F, H, W) or (H, W) bool array
        Each frame's object.
    colours : (F, H, W, 3) or (H, W, 3) uint8 array
        RGB registered to the depths, as the camera gives them (no gain undone).
    cancel, progress
        As for pair_levels.

    Returns
    -------
    ColourGains

    Raises
    ------
    Cancelled
        When `cancel` asks.
    """
    depths, masks, colours = np.asarray(depths), np.asarray(masks, bool), np.asarray(colours)
    if depths.ndim == 2:
        depths, masks, colours = depths[None], masks[None], colours[None]
    ratios, kept, trimmed, scatter = {}, {}, {}, {}
    for key, (source, target) in pair_levels(rig, depths, masks, colours, cancel,
                                             progress).items():
        logs = np.log(source) - np.log(target)
        inlier = _inliers(logs)
        kept[key], trimmed[key] = int(inlier.sum()), int((~inlier).sum())
        if kept[key]:
            ratios[key] = np.log(source[inlier].sum(axis=0) / target[inlier].sum(axis=0))
            scatter[key] = logs[inlier] - ratios[key]
    gains = log_gains({k: r for k, r in ratios.items() if kept[k] >= MIN_PAIRS}, kept)
    out = []
    for j, mirror in enumerate(rig.mirrors, start=1):
        mine = [key for key in kept if j in key]
        pairs = sum(kept[key] for key in mine)
        residuals = [scatter[key] for key in mine if key in scatter]
        spread = (tuple(float(s) for s in np.concatenate(residuals).std(axis=0)) if residuals
                  else (float("nan"),) * 3)
        reason = None
        if mirror.plane is None:
            reason = NO_PLANE
        elif j not in gains:
            reason = TOO_FEW_PAIRS
        elif np.any(np.exp(gains[j]) > MAX_COLOUR_GAIN):
            reason = OUT_OF_RANGE
        gain = None if reason else tuple(float(g) for g in np.exp(gains[j]))
        out.append(MirrorGain(j - 1, mirror.name, gain, pairs,
                              sum(kept[key] for key in mine if 0 in key),
                              sum(trimmed[key] for key in mine), spread, reason))
    return ColourGains(tuple(out), len(depths))


def _inliers(logs: np.ndarray) -> np.ndarray:
    """(k, 3) log-ratios of a pair of views -> (k,) bool: within the TRIM band of their median in
    every channel."""
    if not len(logs):
        return np.zeros(0, bool)
    deviation = np.abs(logs - np.median(logs, axis=0))
    band = np.maximum(TRIM, TRIM_SIGMAS * 1.4826 * np.median(deviation, axis=0))
    return np.all(deviation <= band, axis=1)


def log_gains(ratios: dict[tuple[int, int], np.ndarray],
              kept: dict[tuple[int, int], int]) -> dict[int, np.ndarray]:
    """Solve the views' log-gains from their ratios, the camera's fixed at 0.

    Parameters
    ----------
    ratios : dict of (int, int) to (3,) array
        {(a, b): log gain of view a - log gain of view b} (0 the camera, j mirror j).
    kept : dict of (int, int) to int
        The pairs behind each ratio (its least-squares weight is their square root).

    Returns
    -------
    dict of int to (3,) array
        {j: log gain} of the mirrors joined to the camera through the ratios (directly or
        through other mirrors); least squares where they say more than one thing.
    """
    joined, grew = {0}, True
    while grew:
        grew = False
        for a, b in ratios:
            if (a in joined) != (b in joined):
                joined |= {a, b}
                grew = True
    unknown = sorted(joined - {0})
    if not unknown:
        return {}
    column = {j: i for i, j in enumerate(unknown)}
    rows, rhs, weights = [], [], []
    for (a, b), ratio in ratios.items():
        if a not in column and b not in column:
            continue
        row = np.zeros(len(unknown))
        for j, sign in ((a, 1.0), (b, -1.0)):
            if j in column:
                row[column[j]] += sign
        rows.append(row)
        rhs.append(ratio)
        weights.append(np.sqrt(kept[a, b]))
    w = np.asarray(weights)[:, None]
    solution = np.linalg.lstsq(np.asarray(rows) * w, np.asarray(rhs) * w, rcond=None)[0]
    return {j: solution[column[j]] for j in unknown}


def read_colour_frames(session: Session, picks) -> np.ndarray | None:
    """Read a session's colour frames.

    Parameters
    ----------
    session : Session
    picks : (k,) integer array_like
        Frame indices.

    Returns
    -------
    (k, H, W, 3) uint8 array or None
        RGB; None when the session has no colour frames.

    Raises
    ------
    FileFormatError
        Naming a colour frame that is missing or unreadable (Session.read_colour).
    """
    if not session.colour_frames:
        return None
    return np.stack([session.read_colour(int(i)) for i in picks])


def with_gains(session: Session, measured: ColourGains) -> Session:
    """Return the session with each measured mirror's colour_gain set.

    A mirror not measured keeps the gain it had (a gain is the glass's, not the plane's). Gains are
    rounded to GAIN_DECIMALS.

    Parameters
    ----------
    session : Session
    measured : ColourGains
        Of the session's rig.

    Returns
    -------
    Session
    """
    for m in measured.mirrors:
        if m.gain is not None:
            gain = tuple(round(g, GAIN_DECIMALS) for g in m.gain)
            session = session.with_mirror(m.index, replace(session.mirrors[m.index],
                                                           colour_gain=gain))
    return session
