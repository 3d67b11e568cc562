"""The next-step hint (mirrorscan.wording.hints): it names the next step and is short."""
from dataclasses import replace

from mirrorscan.context import TabState
from mirrorscan.wording import HEADLINE_WORDS, words
from mirrorscan.wording.hints import start_hint

from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.geometry.plane import Plane
from mirrorcore.io.session import Session, SessionMirror


def test_the_hint_names_the_next_step_and_not_a_mode_already_chosen(tmp_path):
    session = Session(tmp_path, Intrinsics.kinect_v1(), mirrors=(SessionMirror("left", id=1),))
    assert "Add a mirror" in start_hint(Session(tmp_path, session.camera), TabState(), True, False)
    hint = start_hint(session, TabState(mirror_id=1, view="depth"), True, False)
    assert (
        hint == "left: choose **Boundary** and click its corners; click the first corner to close."
    )
    hint = start_hint(session, TabState(mirror_id=1, view="depth", mode="boundary"), True, False)
    assert hint == "left: click its corners; click the first corner to close."
    edged = Session(
        tmp_path,
        session.camera,
        mirrors=(SessionMirror("left", id=1, boundary=((0, 0), (9, 0), (0, 9))),),
    )
    assert start_hint(edged, TabState(mirror_id=1), True, False) == (
        "Look at the **Depth frame** (View, below); left: choose **Markers** and click a marker on "
        "the mirror, or "
        "**Find the planes from the object**."
    )
    assert start_hint(edged, TabState(mirror_id=1), True, False, calibrating=0.45) == (
        "A calibration from the object runs (45% done): its progress, **Cancel** and then its "
        "report are under "
        "*Mirrors*."
    )
    assert start_hint(edged, TabState(mirror_id=1, mode="markers", view="depth"), True, False) == (
        "left: click a marker on the mirror, or **Find the planes from the object**."
    )
    assert start_hint(
        edged,
        TabState(mirror_id=1, mode="markers", view="depth"),
        True,
        False,
        refused={1: "scene"},
    ) == (
        "left: not found from the object (why: under Mirrors); or click a marker on the mirror."
    )
    one = Session(tmp_path, session.camera, mirrors=(replace(edged.mirrors[0], markers=((1, 1),)),))
    assert start_hint(one, TabState(mirror_id=1, mode="markers", view="depth"), True, False) == (
        # markers begun: no second way
        "left: click more markers (3 or more, spread out) on the mirror."
    )
    waiting = start_hint(edged, TabState(mirror_id=1, proposal_for=("left",)), True, False)
    assert waiting == "A new plane for left waits: **Mirrors › Apply** it or **Discard** it."
    done = Session(
        tmp_path,
        session.camera,
        mirrors=(
            replace(
                edged.mirrors[0],
                plane=Plane.from_point_normal([0, 0, 2], [0, 0, -1]),
                markers=((1, 1), (5, 1), (1, 5)),
            ),
        ),
    )
    # one mirror fitted: not ready before the rig's other mirrors are added
    assert start_hint(done, TabState(mirror_id=1), True, True) == (
        "left is fitted; the cloud merges its view alone: **Mirrors › Add a mirror** for each "
        "other mirror of the rig."
    )
    done_two = replace(done, mirrors=(*done.mirrors, replace(done.mirrors[0], name="right", id=2)))
    assert start_hint(done_two, TabState(mirror_id=1), True, True).startswith(
        "Ready: the merged cloud is live"
    )
    assert start_hint(done_two, TabState(mirror_id=1), True, True, no_glass=("left",)) == (
        "Ready: the merged cloud is live. No glass set on left: **Mirrors › Refine from the "
        "object** measures it."
    )
    assert start_hint(
        done_two, TabState(mirror_id=1), True, True, no_glass=("left",), refused={1: "refine"}
    ) == (
        "Ready. No glass on left, and this object could not measure it: type it under **Mirrors › "
        "Rename, glass, "
        "remove, clear**."
    )
    assert start_hint(done, TabState(mirror_id=1), True, True, glass_unused=("left",)) == (
        "The glass typed in for left is not in its plane yet: **Mirrors › Fit plane** moves it "
        "behind the glass."
    )
    assert start_hint(done, TabState(mirror_id=1), True, True, "paused").startswith("Paused: ")
    assert start_hint(
        done, TabState(mirror_id=1), True, True, "recording", start="session gait"
    ).endswith(
        "**Back to session gait** (above) when done."
    )
    # 'the live source' while a session played
    marked = replace(done.mirrors[0], plane=None)
    assert start_hint(
        Session(tmp_path, session.camera, mirrors=(marked,)), TabState(mirror_id=1), True, True
    ) == ("left: **Fit plane**.")
    two = Session(tmp_path, session.camera, mirrors=(marked, replace(marked, name="right", id=2)))
    assert (
        start_hint(two, TabState(mirror_id=1), True, True) == "left and right: **Fit all planes**."
    )
    bare = Session(
        tmp_path,
        session.camera,
        mirrors=(done.mirrors[0], replace(marked, name="top", id=2, markers=())),
    )
    assert start_hint(bare, TabState(mirror_id=1), True, True) == (
        "Now top: select it and do the same (no markers: click 3 or more, or **Find the planes "
        "from the object**)."
    )
    assert start_hint(bare, TabState(mirror_id=1), True, True, refused={2: "scene"}) == (
        "Now top: not found from the object (why: under Mirrors); or select it and click 3 or more "
        "markers on it."
    )
    outline = Session(
        tmp_path,
        session.camera,
        mirrors=(done.mirrors[0], replace(marked, name="top", id=2, markers=(), boundary=())),
    )
    assert start_hint(outline, TabState(mirror_id=1), True, True) == (
        "Now top: select it, choose **Boundary** and click its corners."
    )
    drafted = TabState(mirror_id=2, view="depth", drafts={2: ((1.0, 1.0), (9.0, 1.0))})
    assert (
        start_hint(outline, drafted, True, True)
        == "top: 2 corners drawn; choose **Boundary** and click the next."
    )
    drafted = replace(drafted, mode="boundary", drafts={2: ((1.0, 1.0), (9.0, 1.0), (9.0, 9.0))})
    assert (
        start_hint(outline, drafted, True, True)
        == "top: 3 corners drawn; click the next, or the first to close."
    )
    assert start_hint(done, TabState(mirror_id=1), True, True, recording=True).startswith(
        "Recording (see above)"
    )
    # no markers, as for calibrate --method scene
    unmarked = replace(done_two, mirrors=tuple(replace(m, markers=()) for m in done_two.mirrors))
    assert start_hint(unmarked, TabState(mirror_id=1), True, True).startswith("Ready: ")
    # flagged mirrors before "Ready"
    assert start_hint(done, TabState(mirror_id=1), True, True, disagreeing=("left", "right")) == (
        "⚠ left and right: their views disagree with the others (why: under *Mirrors*): "
        "**Mirrors › Refine from the object**, or fit again."
    )
    assert start_hint(done, TabState(mirror_id=1), True, True, disagreeing=("left",)).startswith(
        "⚠ left: its view disagrees with the others"
    )


def test_every_next_step_hint_is_short(tmp_path):
    """The 'Start here' line at every stage of two mirrors is at most HEADLINE_WORDS words."""
    plane = Plane.from_abcd([0.0, 0.0, -1.0, 2.0])
    outline = ((0, 0), (9, 0), (0, 9))
    bare = (SessionMirror("mirror 1", id=1), SessionMirror("mirror 2", id=2))
    drawn = tuple(replace(m, boundary=outline) for m in bare)
    marked = tuple(replace(m, markers=((1, 1), (5, 1))) for m in drawn)
    ready = tuple(replace(m, markers=((1, 1), (5, 1), (1, 5))) for m in drawn)
    done = tuple(replace(m, plane=plane) for m in ready)
    names = ("mirror 1", "mirror 2")
    hints = []
    for mirrors in ((), bare, drawn, marked, ready, done, (done[0], drawn[1]), (done[0], bare[1])):
        session = Session(tmp_path, Intrinsics.kinect_v1(), mirrors)
        for state in (TabState(mirror_id=1), TabState(mirror_id=2, drafts={2: ((1.0, 1.0),) * 3}),
                      TabState(mirror_id=1, proposal_for=names)):
            for refused in ({}, {1: "scene", 2: "scene"}, {1: "refine"}):
                hints += [start_hint(session, state, True, background, playback, None, False, names,
                                     (), refused, "session gait", None, disagreeing, names)
                          for background in (False, True)
                          for playback in ("live", "paused", "recording")
                          for disagreeing in ((), names)]
        hints.append(start_hint(session, TabState(mirror_id=1), True, True, glass_unused=names))
        hints.append(start_hint(session, TabState(mirror_id=1), True, True, calibrating=0.45))
        hints.append(start_hint(session, TabState(mirror_id=1), True, True, batch=0.5))
    for hint in set(hints):
        assert words(hint) <= HEADLINE_WORDS, hint
