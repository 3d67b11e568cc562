"""Mirror planes without markers (`calibrate --method scene`): in rounds, search the planes in one
frame (search.py), then refine the best supported over every frame (refine.py), so that a mirror
the camera hardly shares anything with is found against the mirrors beside it."""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from mirrorcore.base.words import sentences
from mirrorcore.base.errors import CalibrationError
from mirrorcore.base.progress import RATCHET_SECONDS, Progress, Ratchet
from mirrorcore.calibration.refine import MAX_DISAGREEMENT, Leash, refine_session
from mirrorcore.calibration.results import Refinement
from mirrorcore.calibration.search import (MIN_POINTS, Found, direct_far, near_outline,
                                           search_plane)
from mirrorcore.io.session import Session
from mirrorcore.rig.model import Mirror, Rig

# Metres: the refinement after a search starts with this wide agreement (Leash.gate), from the
# found plane moved search.NEARER towards the camera.
SEARCH_GATE = 0.03
# Metres, degrees: how far the refinement may move a searched plane.
SEARCH_CHANGE = (0.2, 15.0)
# A round refines the mirrors whose search scores at least this share of the best's; the others
# are searched again once these are calibrated, against them too (an arc's middle mirror scores
# 0.2 against the camera alone where the mirrors beside it score 0.76 and 0.91, and its plane
# found so is 17 degrees off).
LEAD_SHARE = 0.5
# The refinement after a search.
FROM_SEARCH = Leash(SEARCH_GATE, SEARCH_CHANGE, MAX_DISAGREEMENT, held_only=True)


def calibrate_scene(session: Session, depths: np.ndarray, masks: np.ndarray,
                    rng: np.random.Generator, indices=None, progress: Progress | None = None,
                    cancel=None, with_: str = "auto") -> tuple[Session, Refinement]:
    """Calibrate a session's mirrors without markers, in rounds.

    Each round searches the planes still to find in the first frame (search.search_plane, against
    the camera and the mirrors calibrated so far; a mirror's own plane is ignored), then refines
    those the search supports best (at least LEAD_SHARE of the best's support) over every frame
    (refine.refine_session, comparing `with_`, each fixed by the views calibrated before:
    FROM_SEARCH); a mirror the refinement refuses waits with the others for the next round, which
    searches them against these too (an arc's middle mirror, which the camera sees from the front
    and it from the back, is found through the mirrors beside it).

    Parameters
    ----------
    session : Session
    depths : (F, H, W) or (H, W) float
        Metres, as measured.
    masks : (F, H, W) or (H, W) bool
        The object's pixels.
    rng : numpy.random.Generator
        The search's only source of randomness.
    indices : iterable of int, optional
        The mirrors to calibrate (0-based); default all.
    progress, cancel, with_
        As for refine.refine_planes.

    Returns
    -------
    (Session, Refinement)
        The session with the planes found and one Refinement of them all; a mirror no round could
        calibrate keeps its plane and is named, with why, in the Refinement's `refused`.

    Raises
    ------
    CalibrationError
        Naming the mirrors when none can be calibrated.
    """
    indices = list(range(len(session.mirrors)) if indices is None else indices)
    if not indices:
        raise CalibrationError(f"{session.path}: the session has no mirrors")
    depths, masks = np.asarray(depths), np.asarray(masks, bool)
    if depths.ndim == 2:
        depths, masks = depths[None], masks[None]
    # the refinements' masks
    direct = _without_spill(Rig.from_session(session), depths, masks)
    bar = Ratchet(progress, RATCHET_SECONDS)
    calibrated, todo, rounds, refused = session, list(indices), [], {}
    while todo:
        done = 1.0 - len(todo) / len(indices)
        found, failed = _search_round(calibrated, depths[0], masks[0], todo, rng, cancel,
                                      bar.part(done, done + (1.0 - done) / 3), wide=bool(rounds))
        refused.update(failed)
        todo = [i for i in todo if i in found]
        result = _refine_round(calibrated, found, depths, direct, with_, cancel, bar, done,
                               len(indices), refused)
        if result is None:
            break
        calibrated, round_result = result
        rounds.append(round_result)
        todo = [i for i in todo if i not in round_result.planes]
    if not rounds:
        names = tuple(session.mirrors[i].name for i in sorted(refused))
        raise CalibrationError(sentences(refused[i] for i in sorted(refused)), names)
    # a mirror not found keeps its plane
    for i in refused:
        mirror = replace(calibrated.mirrors[i], plane=session.mirrors[i].plane)
        calibrated = calibrated.with_mirror(i, mirror)
    bar(1.0)
    mirrors = tuple(sorted((m for r in rounds for m in r.mirrors), key=lambda m: m.index))
    return calibrated, replace(rounds[0], mirrors=mirrors,
                               iterations=sum(r.iterations for r in rounds),
                               refused=tuple(sorted(refused.items())))


def _without_spill(rig: Rig, depths: np.ndarray, masks: np.ndarray) -> np.ndarray:
    """The masks without a mirror's image spilling over an outline drawn too narrow.

    In the frames of depths (F, H, W) metres where the search would see one (search's outline
    check: MIN_POINTS of the object's readings beyond what the camera sees directly within
    SPILL_PX outside an outline), every reading outside every outline beyond what the camera sees
    directly is left out of masks (F, H, W) bool (an outline 80 px too narrow leaves its image up
    to 80 px wide), so that it is not taken for the camera's view in the other mirrors'
    refinement; frames without one keep their masks whole.
    """
    outside = rig.inside_bits == 0
    near = near_outline(~outside) & outside
    out = masks.copy()
    for k, (depth, mask) in enumerate(zip(depths, masks)):
        beyond = mask & outside & (depth > direct_far(depth[mask & outside]))
        if np.count_nonzero(beyond & near) >= MIN_POINTS:
            out[k] &= ~beyond
    return out


def _search_round(session: Session, depth: np.ndarray, mask: np.ndarray, todo: list[int],
                  rng: np.random.Generator, cancel, progress: Progress,
                  wide: bool) -> tuple[dict[int, Found], dict[int, str]]:
    """Search the planes of the mirrors at `todo` (0-based) in one frame, against the camera and
    the mirrors with a plane that are not searched (`wide`: search_plane's) -> ({index: Found},
    {index: why it was not found})."""
    rig = Rig.from_session(session)
    blind = Rig(rig.intrinsics, tuple(Mirror(m.name, None if i in todo else m.plane, m.boundary)
                                      for i, m in enumerate(rig.mirrors)))
    found, failed = {}, {}
    for k, i in enumerate(todo):
        try:
            found[i] = search_plane(blind, depth, mask, i, rng, cancel, wide,
                                    lambda f, k=k: progress((k + f) / len(todo)))
        except CalibrationError as exc:
            failed[i] = str(exc)
        progress((k + 1) / len(todo))
    return found, failed


def _refine_round(session: Session, found: dict[int, Found], depths: np.ndarray,
                  masks: np.ndarray, with_: str, cancel, bar: Ratchet, done: float, total: int,
                  refused: dict[int, str]) -> tuple[Session, Refinement] | None:
    """Refine the best-supported of the planes `found` (LEAD_SHARE), held to the views calibrated
    before; a mirror the refinement names is set aside (its refusal in `refused`, until a later
    round calibrates it) and the others refined again, then the next best. -> (the session with
    the planes refined, their Refinement), or None when none of them could be refined."""
    waiting = dict(found)
    while waiting:
        best = max(waiting, key=lambda i: waiting[i].support)
        lead = sorted(i for i, f in waiting.items()
                      if i == best or f.support >= LEAD_SHARE * waiting[best].support)
        trial = session
        for i in lead:
            trial = trial.with_mirror(i, replace(trial.mirrors[i], plane=waiting[i].plane))
        start = done + (1.0 - done) / 3
        part = bar.part(start, max(start, done + len(lead) / total))
        try:
            calibrated, result = refine_session(trial, depths, masks, lead, part, cancel, with_,
                                                FROM_SEARCH)
        except CalibrationError as exc:
            named = [i for i in lead if session.mirrors[i].name in exc.mirrors] or lead
            for i in named:
                refused[i] = str(exc)
                del waiting[i]
            continue
        for i in lead:
            refused.pop(i, None)
        return calibrated, result
    return None
