"""What fixes a refined mirror plane: the readings it shares with views already fixed, and how
well the comparisons determine the plane (1 sigma); a mirror its views cannot fix is refused by
name."""
from __future__ import annotations

import numpy as np

from mirrorcore.base.errors import CalibrationError
from mirrorcore.base.words import listed
from mirrorcore.calibration.residuals import Residuals

# Readings of a mirror and of the camera (or of mirrors fixed so) that agree, both ways, over all
# frames (fixed_by); then the plane's offset at the object must be known to MAX_SHIFT_STD (metres,
# 1 sigma) and its tilt to MAX_TILT_STD_DEG, or the mirror is refused: its views overlap too little.
MIN_AGREEMENTS = 200
MAX_SHIFT_STD = 1e-3
MAX_TILT_STD_DEG = 0.2
# Metres at the object, degrees: how far a refinement from the surfaces moves from one pose of the
# object to another, beyond what its frames' own spread shows (the frames of one refinement may all
# show one pose: the last 5 live frames span a sixth of a second). On the walking figure (2 mirrors,
# Kinect noise, seeds 0 to 3), refinements on 5 consecutive frames taken 0.8 to 1.4 s apart spread
# by 0.24 to 0.64 mm along the normal and 0.011 to 0.028 degrees in tilt (each axis), while their
# own 1 sigma read 0.16 to 0.88 mm (median 0.35) and 0.007 to 0.04 degrees. Two refinements differ
# by sqrt(2) times that spread, so a repeat lands within 2 sigma of the first (95 %) when sigma is
# 1.39 times the largest spread (0.9 mm); in tilt, the length of a 2-vector, 1.73 times (0.05
# degrees). tests/core/calibration/test_repeat.py repeats it.
POSE_SHIFT = 0.9e-3
POSE_TILT_DEG = 0.05


def fixed_by(found: Residuals, refined: list[int], names: list[str], frames: int,
             held_only: bool = False) -> dict[int, int]:
    """How many readings of each refined mirror agree with those of the views that fix it.

    The views that fix a mirror are the camera's and the mirrors' not refined, then, in turn,
    those of the mirrors these fixed: at least MIN_AGREEMENTS (both ways, all frames) fix a mirror
    (on an arc of three, the middle mirror faces the camera and sees a person's back, the camera
    the front: the mirrors beside it see the sides it shares). With `held_only`, only the views
    not refined count: a search's guess is scored against those (search.search_plane), since
    mirrors refined together can agree with one another on a wrong plane.

    Parameters
    ----------
    found : Residuals
        The comparisons of the settled planes.
    refined : list of int
        The refined mirrors (1-based).
    names : list of str
        Their names, in the same order.
    frames : int
        How many frames were compared (for the refusal).
    held_only : bool

    Returns
    -------
    dict
        {mirror j: agreeing readings}.

    Raises
    ------
    CalibrationError
        Naming every mirror nothing fixes: its plane would be left free (a box facing the camera:
        the mirrors see only its sides and back).
    """
    held = {0} | (set(np.unique(found.pair)) - set(refined))
    fixing, counts = set(held), {}
    while True:
        more = {j: found.shared(j, fixing) for j in refined if j not in counts}
        more = {j: n for j, n in more.items() if n >= MIN_AGREEMENTS}
        if not more:
            break
        counts.update(more)
        if not held_only:
            fixing |= set(more)
    free = [(j, name) for j, name in zip(refined, names) if j not in counts]
    if free:
        raise CalibrationError(_free_refusal(found, free, held, frames, held_only),
                               tuple(name for _, name in free))
    return counts


def _free_refusal(found: Residuals, free: list[tuple[int, str]], held: set[int], frames: int,
                  held_only: bool) -> str:
    """The refusal of the mirrors nothing fixes (free: (j, name) pairs, in session order), one
    line naming each."""
    one = len(free) == 1
    names = listed([name for _, name in free])
    agree = listed([f"{found.shared(j, held):,}" if one else f"{name}: {found.shared(j, held):,}"
                    for j, name in free])
    what = ("the mirror see too little of the same surface to determine its plane" if one else
            "the mirrors see too little of the same surface to determine their planes")
    if held_only:
        mirrors = ("; a plane found without markers must be fixed by the camera or by mirrors "
                   "calibrated before it")
        them = "it" if one else "them"
        advice = f"click markers on {them} and fit {them}, then refine from the object"
    else:
        shared = [(name, found.shared(j, set(np.unique(found.pair)) - {0, j}))
                  for j, name in free]
        # one mirror sharing that many with the others would be fixed
        mirrors = ""
        if any(n >= MIN_AGREEMENTS for _, n in shared):
            counts = listed([f"{name}: {n:,}" for name, n in shared])
            mirrors = (f"; the readings they share with one another ({counts}) fix nothing, as "
                       "the camera fixes none of them")
        advice = ("refine on an object that both see from the side (a person, a sphere), not a "
                  "flat face, or on more frames of one that moves")
    return (f"{names}: the camera and {what} ({agree} readings agree over {frames} frame(s), "
            f"{MIN_AGREEMENTS} are needed{mirrors}); {advice}")


def determined(final: Residuals, refined: list[int], j: int, name: str,
               scatter: tuple[float, float] | None) -> tuple[float, float]:
    """How well the comparisons that settled the planes determine mirror j's plane.

    Parameters
    ----------
    final : Residuals
        The comparisons at the settled planes.
    refined : list of int
        The refined mirrors (1-based), the order of the jacobian's columns.
    j : int
        The mirror (1-based).
    name : str
        Its name, for the refusal.
    scatter : (float, float) or None
        The frames' own spread (metres, degrees), or None.

    Returns
    -------
    (float, float)
        1 sigma along its normal at the object (metres) and in tilt (degrees): the larger of the
        fit's own and `scatter`, with the pose's part (POSE_SHIFT, POSE_TILT_DEG) added in
        quadrature.

    Raises
    ------
    CalibrationError
        When the fit's own says the views overlap too little (MAX_SHIFT_STD, MAX_TILT_STD_DEG).
    """
    weights = final.weights()
    hessian = final.jacobian.T @ (weights[:, None] * final.jacobian)
    scale = np.sum(weights * final.residual ** 2) / max(len(final.residual) - hessian.shape[0], 1)
    cov = scale * np.linalg.inv(hessian)
    i = 3 * refined.index(j)
    shift_std = float(np.sqrt(cov[i + 2, i + 2]))
    tilt_std = float(np.degrees(np.sqrt(np.linalg.eigvalsh(cov[i:i + 2, i:i + 2]).max())))
    # the overlap's geometry, not the frames' noise
    if shift_std > MAX_SHIFT_STD or tilt_std > MAX_TILT_STD_DEG:
        raise CalibrationError(
            f"{name}: the views overlap too little to determine its plane (known only to "
            f"±{1e3 * shift_std:.1f} mm and ±{tilt_std:.2f}°); use more frames, or move the "
            "object so that both the camera and the mirror see its sides", (name,))
    if scatter is not None:
        shift_std, tilt_std = max(shift_std, scatter[0]), max(tilt_std, scatter[1])
    return float(np.hypot(shift_std, POSE_SHIFT)), float(np.hypot(tilt_std, POSE_TILT_DEG))
