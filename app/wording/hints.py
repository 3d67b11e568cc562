"""The status header's 'Start here' line: what to do next, from where the session and tab stand."""

from __future__ import annotations

from mirrorcore.base.words import listed
from mirrorcore.io.session import Session

from ..context import TabState


def start_hint(
    session: Session,
    state: TabState,
    has_frame: bool,
    has_background: bool,
    playback: str = "live",
    calibrating: float | None = None,
    recording: bool = False,
    no_glass: tuple[str, ...] = (),
    glass_unused: tuple[str, ...] = (),
    refused: dict[int, str] | None = None,
    start: str = "the live source",
    batch: float | None = None,
    disagreeing: tuple[str, ...] = (),
    from_markers: tuple[str, ...] = (),
) -> str:
    """What to do next, in one line (Markdown) of at most HEADLINE_WORDS words.

    Parameters
    ----------
    session, state : the session and this tab's state.
    has_frame, has_background : a frame came; a background is in use.
    playback : 'live' (the source served from the start plays), 'recording' (another plays) or
        'paused'.
    calibrating : how far a calibration from the object that runs is (0 to 1), or None.
    recording : the live frames are being recorded.
    no_glass : the mirrors whose planes come from markers with no glass set.
    glass_unused : those whose glass was typed in after their plane was fitted.
    refused : {mirror id: "refine" or "scene"}, what was refused on it lately (Jobs.refusals).
    start : the name of the source served from the start.
    batch : how far a batch that runs is (0 to 1), or None.
    disagreeing : the mirrors whose views the last agreement check flags.
    from_markers : the mirrors whose planes a markers fit set behind the glass typed in.
    """
    refused = refused or {}
    if not has_frame:
        return "Waiting for the first frame from the source…"
    if recording:
        return (
            "Recording (see above): **Record › Stop recording** saves it, with the calibration as "
            "it then "
            "stands."
        )
    if not session.mirrors:
        return "Start here: **Mirrors › Add a mirror**, then look at the depth frame."
    if calibrating is not None:
        return (
            f"A calibration from the object runs ({calibrating:.0%} done): its progress, "
            "**Cancel** and then its "
            "report are under *Mirrors*."
        )
    if batch is not None:
        return (
            f"A batch reconstructs every frame ({batch:.0%} done): its progress and **Cancel** are "
            "under "
            "*Record › Reconstruct every frame (batch)*."
        )
    if state.proposal_for:
        return (
            f"A new plane for {listed(state.proposal_for)} waits: **Mirrors › Apply** it or "
            "**Discard** "
            "it."
        )
    look = "" if state.view == "depth" else "Look at the **Depth frame** (View, below); "
    mirror = next((m for m in session.mirrors if m.id == state.mirror_id), session.mirrors[-1])
    if not mirror.boundary:
        choose = "" if state.mode == "boundary" else "choose **Boundary** and "
        # kept while another mirror was selected
        if drawn := len(state.drafts.get(mirror.id, ())):
            more = "the next" if drawn < 3 else "the next, or the first to close"
            corners = f"{drawn} corner{'s' if drawn > 1 else ''}"
            return f"{look}{mirror.name}: {corners} drawn; {choose}click {more}."
        return f"{look}{mirror.name}: {choose}click its corners; click the first corner to close."
    # a plane from the object or a region needs none
    if len(mirror.markers) < 3 and mirror.plane is None:
        what = "a marker" if not mirror.markers else "more markers (3 or more, spread out)"
        choose = "" if state.mode == "markers" else "choose **Markers** and "
        if refused.get(mirror.id) == "scene":
            return (
                f"{mirror.name}: not found from the object (why: under Mirrors); or "
                f"{choose}click {what} on the mirror."
            )
        scene = "" if mirror.markers else ", or **Find the planes from the object**"
        return f"{look}{mirror.name}: {choose}click {what} on the mirror{scene}."
    if mirror.plane is None:
        ready = [
            m.name
            for m in session.mirrors
            if m.plane is None and m.boundary and len(m.markers) >= 3
        ]
        if len(ready) > 1:
            return f"{listed(ready)}: **Fit all planes**."
        return f"{mirror.name}: **Fit plane**."
    todo = [m for m in session.mirrors if m.plane is None or not m.boundary]
    if todo:
        if refused.get(todo[0].id) == "scene":
            return (
                f"Now {todo[0].name}: not found from the object (why: under Mirrors); or select it "
                "and click "
                "3 or more markers on it."
            )
        if not todo[0].boundary:  # its Find is not offered before it has an outline
            return f"Now {todo[0].name}: select it, choose **Boundary** and click its corners."
        how = (
            " (no markers: click 3 or more, or **Find the planes from the object**)"
            if not todo[0].markers
            else ""
        )
        return f"Now {todo[0].name}: select it and do the same{how}."
    if glass_unused:
        one = len(glass_unused) == 1
        return (
            f"The glass typed in for {listed(glass_unused)} is not in "
            f"{'its plane' if one else 'their planes'} "
            f"yet: **Mirrors › {'Fit plane' if one else 'Fit all planes'}** moves it behind the "
            "glass."
        )
    if not has_background:
        return "Mirrors done. **Object**: capture the background with the object out of view."
    if playback == "paused":
        return (
            "Paused: the cloud is one frame's (**Step**, or the **Frame** slider of a recording, "
            "under *Playback "
            "and view*); untick **Pause** to play on."
        )
    if playback == "recording":
        return (
            "A recording plays with this calibration: **Refine from the object** works on it; "
            "**Back to "
            f"{start}** (above) when done."
        )
    if disagreeing:
        views = "its view disagrees" if len(disagreeing) == 1 else "their views disagree"
        return (
            f"⚠ {listed(disagreeing)}: {views} with the others (why: under *Mirrors*): "
            "**Mirrors › Refine from the object**, or fit again."
        )
    # "Ready" only once the rig has its mirrors: the tool needs two or more
    if len(session.mirrors) == 1:
        return (
            f"{session.mirrors[0].name} is fitted; the cloud merges its view alone: "
            "**Mirrors › Add a mirror** for each other mirror of the rig."
        )
    if no_glass and "refine" in refused.values():
        return (
            f"Ready. No glass on {listed(no_glass)}, and this object could not measure it: type it "
            "under "
            "**Mirrors › Rename, glass, remove, clear**."
        )
    if no_glass:
        return (
            f"Ready: the merged cloud is live. No glass set on {listed(no_glass)}: **Mirrors › "
            "Refine from "
            "the object** measures it."
        )
    if from_markers:
        return (
            f"Ready. The planes of {listed(from_markers)} come from markers alone: **Mirrors › "
            "Refine from "
            "the object** makes them more accurate."
        )
    return (
        "Ready: the merged cloud is live. **Measure** fits a shape, **Record** records, "
        "**Session** exports."
    )
