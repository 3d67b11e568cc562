"""The Live panel (mirrorscan.panels.live, panels.planes): the glass, planes sent to the
refinement, the header, the legend."""
from dataclasses import replace
from types import SimpleNamespace

from mirrorscan.context import TabState
from mirrorscan.panels.live import source_title
from mirrorscan.wording.legend import legend_html
from mirrorscan.panels.planes import from_markers, no_glass
from mirrorscan.wording.hints import start_hint

from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.geometry.plane import Plane
from mirrorcore.io.session import Session, SessionMirror


def test_a_glass_measured_as_0_is_not_said_to_be_missing(tmp_path):
    """After a refinement measured 0.0 ± 0.8 mm, the mirror's line said 'measured' and the next step
    'No glass set' (the demo at 1024x600)."""
    plane = Plane.from_abcd([0.5, 0.0, -0.8, 2.4])
    mirrors = (
        SessionMirror("left", ((1.0, 1.0),) * 3, plane=plane, id=1),
        SessionMirror("right", ((1.0, 1.0),) * 3, plane=plane, id=2, marker_offset_std=8e-4),
    )
    jobs = SimpleNamespace(from_object=lambda mirror_id, plane: False)
    assert no_glass(jobs, Session(tmp_path, Intrinsics.kinect_v1(), mirrors)) == ("left",)


def test_planes_fitted_behind_the_glass_typed_in_are_sent_to_the_refinement(tmp_path):
    """The glass typed in, a markers fit applied over a plane from the object: its report asked to
    refine again and the next step read "Ready". The next step names the mirrors whose
    planes a markers fit of this tool set behind a glass typed in; not those from the object, those
    fitted elsewhere, nor a glass measured."""
    plane = Plane.from_abcd([0.5, 0.0, -0.8, 2.4])
    mirrors = (
        SessionMirror("left", ((1.0, 1.0),) * 3, plane=plane, id=1, marker_offset=0.003),
        SessionMirror("right", ((1.0, 1.0),) * 3, plane=plane, id=2, marker_offset=0.003),
        SessionMirror("top", ((1.0, 1.0),) * 3, plane=plane, id=3, marker_offset=0.003),
        SessionMirror(
            "back",
            ((1.0, 1.0),) * 3,
            plane=plane,
            id=4,
            marker_offset=0.003,
            marker_offset_std=5e-4,
        ),
    )
    session = Session(
        tmp_path,
        Intrinsics.kinect_v1(),
        tuple(replace(m, boundary=((0, 0), (9, 0), (9, 9))) for m in mirrors),
    )
    jobs = SimpleNamespace(from_object=lambda mirror_id, plane: mirror_id == 2)
    editor = SimpleNamespace(fitted_on_its_markers=lambda mirror_id: mirror_id != 3)
    assert from_markers(jobs, editor, session) == ("left",)
    assert start_hint(session, TabState(mirror_id=1), True, True, from_markers=("left",)) == (
        "Ready. The planes of left come from markers alone: **Mirrors › Refine from the object** "
        "makes them more "
        "accurate."
    )


def test_the_header_names_the_session_edited_where_another_plays(tmp_path):
    """After Record's replay and Back to
    for edits of the session served, which the header named."""
    gait, recording = tmp_path / "gait", tmp_path / "recording-1"
    assert source_title("session gait", gait, gait) == "**session gait**"
    # the demo: not saved
    assert source_title("session gait", gait, None) == "**session gait**"
    assert source_title("session gait", gait, recording) == (
        "**session gait** · edits saved in session **recording-1**"
    )
    assert (
        source_title("Kinect v1", None, gait) == "**Kinect v1** · edits saved in session **gait**"
    )


def test_the_legend_says_which_mirrors_leave_their_part_out():
    """Before its plane a mirror's part of the frame is left out, and the legend says so."""
    name = {0: "direct", 1: "left", 2: "right"}.get
    assert "no plane yet" not in legend_html({0: 1350, 1: 0}, name, (1, 2))
    one = legend_html({0: 1350, 1: 0}, name, (1, 2), ("left",))
    assert one.endswith(
        "<br>left: no plane yet, so all inside its outline is left out (the object "
        "in front "
        "too)</div>"
    )
    assert (
        "left and right: no plane yet, so all inside their outlines is left out (the object in "
        "front "
        "too)"
    ) in legend_html({0: 1350}, name, (1, 2), ("left", "right"))


def test_the_true_colour_legend_claims_the_tint_undone_only_when_every_mirror_has_its_gain():
    """With no mirror, or while a mirror has no colour gain, the head does not say every tint is
    undone; the mirrors without one follow the counts in the same run of text (no line of their
    own)."""
    name = {0: "direct", 1: "left", 2: "right"}.get
    gained = legend_html({0: 1350, 1: 20, 2: 30}, name, (1, 2), true_colour=True)
    assert "each mirror's tint undone" in gained and "no colour gain" not in gained
    tinted = legend_html({0: 1350, 1: 20, 2: 30}, name, (1, 2), true_colour=True,
                         no_gain=("left", "right"))
    assert "tint undone" not in tinted and "<br>" not in tinted
    assert legend_html({0: 1350}, name, (), true_colour=True).endswith(
        "<b>True colour</b>: <span style=\"white-space:nowrap\">direct <b>1,350</b></span></div>"
    )
    assert tinted.endswith(
        "right <b>30</b></span> · left and right: no colour gain yet (the glass's tint shows)</div>"
    )
