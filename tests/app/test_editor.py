"""Session editing behind the browser tool, without a browser: mirrors named by their stable id,
markers guarded by the image and the mirror's boundary, boundaries, undo and redo per mirror with
named steps, removal that can be undone, fits computed on a state that changed meanwhile refused,
autosave and round trip."""
import json
import os
from dataclasses import replace

import pytest
from mirrorscan.editor import SESSION_SCOPE, SessionEditor

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.depth.selection import Selection
from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.geometry.plane import Plane
from mirrorcore.io.session import Session
from mirrorcore.io.sessionfile import load_session, save_session

SQUARE = [(10, 10), (100, 10), (100, 100), (10, 100)]
PLANE = Plane.from_abcd([0.5, 0, -0.8, 2.4])


@pytest.fixture
def editor(tmp_path):
    editor = SessionEditor(Session(tmp_path, Intrinsics.kinect_v1()))
    assert editor.add_mirror() == 1
    return editor


def saved(tmp_path) -> dict:
    return json.loads((tmp_path / "session.json").read_text())


def test_markers_are_kept_where_clicked_and_saved(editor, tmp_path):
    assert editor.add_marker(1, (120.4, 33.0)) == 0
    assert editor.add_marker(1, (200, 300)) == 1
    assert editor.mirror(1).markers == ((120.4, 33.0), (200.0, 300.0))
    # autosaved, (u, v)
    assert saved(tmp_path)["mirrors"][0]["markers"] == [[120.4, 33.0], [200.0, 300.0]]
    assert saved(tmp_path)["mirrors"][0]["id"] == 1
    editor.move_marker(1, 0, (121, 34))
    editor.delete_marker(1, 1)
    assert editor.mirror(1).markers == ((121.0, 34.0),)
    with pytest.raises(MirrorscanError, match="pixel \\(640, 5\\) is outside the 640x480 image"):
        editor.add_marker(1, (640, 5))
    with pytest.raises(MirrorscanError, match="no marker 1.2"):
        editor.delete_marker(1, 1)
    editor.clear_markers(1)
    with pytest.raises(MirrorscanError, match="no markers to clear"):
        editor.clear_markers(1)


def test_a_marker_off_its_mirror_is_refused_and_changes_nothing(editor, tmp_path):
    editor.set_boundary(1, SQUARE)
    # on the edge (within 1.5 px) counts
    editor.add_marker(1, (100.5, 50))
    before = (tmp_path / "session.json").read_bytes()
    # a stray click under the panel
    with pytest.raises(MirrorscanError, match="mirror 1: \\(300, 400\\) is outside its boundary"):
        editor.add_marker(1, (300, 400))
    with pytest.raises(MirrorscanError, match="outside its boundary"):
        editor.move_marker(1, 0, (103, 50))
    assert (tmp_path / "session.json").read_bytes() == before
    assert editor.mirror(1).markers == ((100.5, 50.0),)


def test_a_marker_clicked_on_another_mirror_names_it(editor):
    """A click for mirror 2 on mirror 1's glass is refused, naming mirror 1 and how to select it; a
    click on neither says a marker must be on the mirror."""
    editor.set_boundary(1, SQUARE)
    editor.set_boundary(editor.add_mirror(), [(x + 200, y) for x, y in SQUARE])
    with pytest.raises(MirrorscanError, match=r"^mirror 2: \(50, 50\) is outside its boundary; "
                                              r"on mirror 1: select mirror 1 \(Mirror, above\) "
                                              r"to mark it$"):
        editor.add_marker(2, (50, 50))
    with pytest.raises(MirrorscanError, match=r"is outside its boundary; a marker must be on it$"):
        editor.add_marker(2, (150, 50))
    assert not editor.mirror(2).markers and not editor.mirror(1).markers


def test_boundaries_are_validated_and_nothing_changes_on_refusal(editor, tmp_path):
    with pytest.raises(MirrorscanError, match="at least 3 vertices"):
        editor.set_boundary(1, SQUARE[:2])
    with pytest.raises(MirrorscanError, match="crosses itself"):
        editor.set_boundary(1, [(10, 10), (100, 100), (100, 10), (10, 100)])
    assert editor.mirror(1).boundary == ()
    editor.set_boundary(1, SQUARE)
    before = (tmp_path / "session.json").read_bytes()
    # across the opposite edge
    with pytest.raises(MirrorscanError, match="crosses itself"):
        editor.move_vertex(1, 1, (10, 120))
    assert (tmp_path / "session.json").read_bytes() == before
    editor.move_vertex(1, 2, (120, 110))
    assert editor.mirror(1).boundary[2] == (120.0, 110.0)
    # a triangle is still a boundary
    editor.delete_vertex(1, 0)
    with pytest.raises(MirrorscanError, match="at least 3 vertices"):
        editor.delete_vertex(1, 0)
    assert len(editor.mirror(1).boundary) == 3
    editor.clear_boundary(1)
    assert editor.mirror(1).boundary == ()


def test_undo_and_redo_are_per_mirror_and_named(editor):
    editor.add_mirror()
    editor.add_marker(1, (1, 2))
    editor.add_marker(2, (5, 6))
    editor.add_marker(1, (3, 4))
    assert editor.undo_label(1) == "marker 1.2" and editor.undo_label(2) == "marker 2.1"
    # mirror 2's own step, mirror 1 untouched
    assert editor.undo(2) == "marker 2.1"
    assert editor.mirror(2).markers == () and len(editor.mirror(1).markers) == 2
    assert editor.undo(1) == "marker 1.2" and editor.mirror(1).markers == ((1.0, 2.0),)
    assert editor.redo_label(1) == "marker 1.2"
    editor.redo(1)
    assert editor.mirror(1).markers == ((1.0, 2.0), (3.0, 4.0))
    # a new step clears that mirror's redo
    editor.add_marker(1, (7, 8))
    assert editor.redo_label(1) is None and editor.redo_label(2) == "marker 2.1"
    with pytest.raises(MirrorscanError, match="nothing to redo"):
        editor.redo(1)


def test_removal_keeps_ids_and_colours_and_can_be_undone(editor, tmp_path):
    editor.add_mirror()
    editor.add_marker(1, (1, 1))
    editor.rename_mirror(2, "left")
    with pytest.raises(MirrorscanError, match="already a mirror named 'left'"):
        editor.rename_mirror(1, "left")
    editor.remove_mirror(1)
    # mirror 2 stays mirror 2
    assert [(m.id, m.name) for m in editor.session.mirrors] == [(2, "left")]
    # ids are never reused while in the session
    assert editor.add_mirror() == 3
    assert editor.undo_label(SESSION_SCOPE) == "add mirror 3"
    editor.undo(SESSION_SCOPE)
    assert editor.undo(SESSION_SCOPE) == "remove mirror 1"
    assert [m.id for m in editor.session.mirrors] == [1, 2]
    assert editor.mirror(1).markers == ((1.0, 1.0),)
    # its own history came back with it
    assert editor.undo(1) == "marker 1.1"
    assert [m["id"] for m in saved(tmp_path)["mirrors"]] == [1, 2]


def test_an_edit_for_a_removed_mirror_is_refused(editor):
    editor.add_mirror()
    editor.remove_mirror(1)
    with pytest.raises(MirrorscanError, match="mirror 1 is no longer in the session"):
        editor.add_marker(1, (5, 5))
    assert editor.mirror(2).markers == ()


def test_a_fit_computed_on_another_state_is_never_applied(editor):
    """The race of two tabs: a plane fitted for mirror 1 while another tab removes mirror 1, or
    moves its markers, must not land anywhere."""
    editor.add_mirror()
    editor.add_marker(1, (5, 5))
    fitted_on = editor.mirror(1)
    changed = "mirror 1 changed while its plane was computed; fit it again"
    # the markers changed meanwhile
    editor.add_marker(1, (6, 6))
    with pytest.raises(MirrorscanError, match=changed):
        editor.set_planes({1: (PLANE, fitted_on)})
    fitted_on = editor.mirror(1)
    # the glass set meanwhile: the fit used none
    editor.set_marker_offset(1, 0.004)
    with pytest.raises(MirrorscanError, match=changed):
        editor.set_planes({1: (PLANE, fitted_on)})
    fitted_on = editor.mirror(1)
    # the mirror is gone meanwhile
    editor.remove_mirror(1)
    with pytest.raises(MirrorscanError, match="mirror 1 is no longer in the session"):
        editor.set_planes({1: (PLANE, fitted_on)})
    # mirror 2 did not receive it
    assert all(m.plane is None for m in editor.session.mirrors)


def test_planes_of_several_mirrors_are_set_together_and_undone_together(editor, monkeypatch):
    """A fit or refinement of several mirrors is one action: undone and redone from any of its
    mirrors, for every mirror whose last change it still is; saved once, with all of them, so that
    no file with only some of them becomes the backup."""
    import mirrorscan.sessionfile as editor_module
    editor.add_mirror()
    other = Plane.from_abcd([-0.5, 0, -0.8, 2.4])
    written = []
    monkeypatch.setattr(editor_module, "save_session", lambda session: written.append(
        [m.plane for m in session.mirrors]) or save_session(session))
    editor.set_planes({1: (PLANE, editor.mirror(1)), 2: (other, editor.mirror(2))},
                      what="refined plane")
    assert written == [[PLANE, other]]
    assert editor.mirror(1).plane == PLANE and editor.mirror(2).plane == other
    assert editor.undo_label(1) == editor.undo_label(2) == "refined planes of mirror 1 and mirror 2"
    assert editor.undo(2) == "refined planes of mirror 1 and mirror 2"
    assert editor.mirror(2).plane is None and editor.mirror(1).plane is None
    assert editor.redo(1) == "refined planes of mirror 1 and mirror 2"
    assert editor.mirror(1).plane == PLANE and editor.mirror(2).plane == other
    # mirror 2 edited since: its plane stays, and the label says so
    editor.add_marker(2, (7, 7))
    label = "refined plane of mirror 1 only: mirror 2 changed since"
    assert editor.undo_label(1) == label and editor.undo(1) == label
    assert editor.mirror(1).plane is None and editor.mirror(2).plane == other
    assert editor.redo_label(1) == "refined plane of mirror 1"
    assert editor.undo(2) == "marker 2.1" and editor.undo(2) == "refined plane of mirror 2"
    assert editor.mirror(2).plane is None
    editor.set_planes({1: (PLANE, editor.mirror(1)), 2: (other, editor.mirror(2))})
    # a mirror of the group gone: the other's undone
    editor.remove_mirror(2)
    assert editor.undo(1) == "plane of mirror 1" and editor.mirror(1).plane is None
    editor.set_planes({1: (PLANE, editor.mirror(1))})
    # one mirror: named alone
    assert editor.undo_label(1) == "plane of mirror 1"
    editor.set_marker_offset(1, 0.003)
    # the same plane and glass again (a fit of the same frames): no undo step that changes nothing
    assert not editor.set_planes({1: (PLANE, editor.mirror(1))})
    assert editor.undo(1) == "glass of mirror 1"
    # the glass alone: a step
    assert editor.set_planes({1: (PLANE, editor.mirror(1))}, {1: (0.004, 0.0005)})
    assert editor.undo_label(1) == "plane of mirror 1" and editor.mirror(1).marker_offset == 0.004
    # measured
    assert editor.mirror(1).marker_offset_std == 0.0005 and not editor.mirror(1).glass_typed
    editor.set_marker_offset(1, 0.003)
    # typed in
    assert editor.mirror(1).marker_offset_std is None and editor.mirror(1).glass_typed


def test_a_glass_typed_in_after_the_fit_is_known_not_to_be_in_the_plane_yet(editor):
    """The glass typed in moves no plane (the next fit uses it): the editor tells from its undo
    steps that the plane does not include it yet."""
    assert not editor.glass_unused(1)
    # no plane yet: nothing to say
    editor.set_marker_offset(1, 0.004)
    assert not editor.glass_unused(1)
    editor.set_planes({1: (PLANE, editor.mirror(1))})
    assert not editor.glass_unused(1)
    editor.set_marker_offset(1, 0.003)
    # a later marker does not hide it
    editor.add_marker(1, (5, 5))
    assert editor.glass_unused(1)
    # fitted again
    editor.set_planes({1: (replace(PLANE, d=PLANE.d + 0.003), editor.mirror(1))})
    assert not editor.glass_unused(1)
    editor.undo(1)
    assert editor.glass_unused(1)


def test_undo_takes_back_the_newest_step_of_the_mirror_or_the_session(editor):
    """A removal newer than the selected mirror's last step is undone first, and redone first when
    it was undone last; a mirror added is not (its undo would take its work with it)."""
    editor.set_planes({1: (PLANE, editor.mirror(1))}, what="refined plane")
    second = editor.add_mirror()
    # the add: not over 1
    assert editor.travel_scope(1) == 1 and editor.travel_scope(second) == SESSION_SCOPE
    editor.remove_mirror(second)
    assert editor.travel_scope(1) == SESSION_SCOPE
    assert editor.undo_label(SESSION_SCOPE) == f"remove mirror {second}"
    # the removal taken back first
    editor.undo(editor.travel_scope(1))
    assert [m.id for m in editor.session.mirrors] == [1, second]
    assert editor.travel_scope(1, redo=True) == SESSION_SCOPE
    # a newer step of the mirror's own
    editor.add_marker(1, (20, 20))
    assert editor.travel_scope(1) == 1 and editor.undo_label(1) == "marker 1.1"
    editor.undo(editor.travel_scope(1))
    # then its plane (the mirror added: not over it)
    assert editor.travel_scope(1) == 1
    # the marker was undone last
    assert editor.travel_scope(1, redo=True) == 1
    # redone: the newest again
    editor.redo(1)
    assert editor.travel_scope(1) == 1
    assert editor.travel_scope(None) == SESSION_SCOPE
    assert editor.travel_scope(second) == SESSION_SCOPE


def test_a_plane_fitted_on_the_markers_a_mirror_has_is_known_as_such(editor):
    """A markers fit of the same markers again only refits them on other frames: the editor tells
    from its undo steps whether the plane was fitted on the markers, boundary and glass the mirror
    has now."""
    # no plane yet
    assert not editor.fitted_on_its_markers(1)
    for uv in SQUARE[:3]:
        editor.add_marker(1, uv)
    editor.set_planes({1: (PLANE, editor.mirror(1))})
    assert editor.fitted_on_its_markers(1)
    # a marker since: its plane is not theirs
    editor.add_marker(1, SQUARE[3])
    assert not editor.fitted_on_its_markers(1)
    editor.undo(1)
    assert editor.fitted_on_its_markers(1)
    # the glass too is an input of the fit
    editor.set_marker_offset(1, 0.003)
    assert not editor.fitted_on_its_markers(1)
    editor.set_planes({1: (replace(PLANE, d=PLANE.d + 0.003), editor.mirror(1))},
                      what="refined plane")
    # from the object, not from the markers
    assert not editor.fitted_on_its_markers(1)


def test_session_round_trip_through_the_editor(editor, tmp_path):
    editor.add_marker(1, (10, 20))
    editor.set_boundary(1, [(0, 0), (200, 0), (200, 200), (0, 200)])
    editor.set_planes({1: (PLANE, editor.mirror(1))})
    editor.set_selection(Selection(depth_max=3.5))
    loaded = load_session(tmp_path)
    assert loaded.mirrors[0].markers == ((10.0, 20.0),) and loaded.mirrors[0].id == 1
    assert loaded.mirrors[0].boundary == editor.mirror(1).boundary
    assert loaded.selection.depth_max == 3.5
    assert loaded.mirrors[0].plane.angle_to(PLANE) < 1e-9
    editor.undo(SESSION_SCOPE)
    assert load_session(tmp_path).selection == Selection()


def test_a_failed_autosave_keeps_the_last_good_file(editor, tmp_path, monkeypatch):
    editor.add_marker(1, (10, 20))
    good = (tmp_path / "session.json").read_bytes()

    def full_disk(*args):
        raise OSError(28, "No space left on device")
    monkeypatch.setattr(os, "fsync", full_disk)
    editor.add_marker(1, (30, 40))
    assert "No space left on device" in editor.last_save_error
    assert (tmp_path / "session.json").read_bytes() == good
    # the edit itself is kept in memory
    assert len(editor.mirror(1).markers) == 2


def test_listeners_hear_every_change_and_refusals_are_silent(editor):
    heard = []
    editor.listeners.append(lambda s: heard.append(len(s.mirrors[0].markers)))
    editor.add_marker(1, (1, 1))
    with pytest.raises(MirrorscanError):
        editor.add_marker(1, (9999, 1))
    editor.undo(1)
    assert heard == [1, 0]


def written_elsewhere(tmp_path, **changes) -> None:
    """session.json changed by another program (as `mirrorscan calibrate SESSION` in a terminal
    writes it): the first mirror's fields replaced."""
    other = load_session(tmp_path)
    first = replace(other.mirrors[0], **changes)
    save_session(replace(other, mirrors=(first,) + other.mirrors[1:]))


def test_a_change_written_by_another_program_is_reloaded_never_saved_over(editor, tmp_path):
    editor.add_marker(1, (10, 20))
    heard = []
    editor.listeners.append(lambda s: heard.append(s.mirrors[0].plane is not None))
    written_elsewhere(tmp_path, plane=PLANE)
    with pytest.raises(MirrorscanError, match=r"session.json was changed by another program "
                                              r".*reloaded, undo history cleared; this change was "
                                              r"not made: make it again"):
        editor.rename_mirror(1, "left")
    # not saved over
    assert saved(tmp_path)["mirrors"][0]["plane"] == pytest.approx(list(PLANE.abcd))
    assert saved(tmp_path)["mirrors"][0]["name"] == "mirror 1"
    # the tabs are told
    assert editor.mirror(1).plane.abcd == pytest.approx(PLANE.abcd) and heard == [True]
    # the undo history described the file before the other program's change
    assert editor.undo_label(1) is None
    # made again, on the file as it now is
    editor.rename_mirror(1, "left")
    assert saved(tmp_path)["mirrors"][0]["name"] == "left" and editor.mirror(1).plane is not None
    # its own writes are not another program's
    assert editor.reload_if_changed() == ""


def test_the_server_s_poll_reloads_a_changed_file_and_keeps_its_own_over_an_unreadable_one(
        editor, tmp_path):
    editor.add_marker(1, (10, 20))
    written_elsewhere(tmp_path, name="left")
    assert editor.reload_if_changed().endswith("was changed by another program (mirrorscan "
                                               "calibrate?): reloaded, undo history cleared")
    assert editor.mirror(1).name == "left" and editor.reload_if_changed() == ""
    (tmp_path / "session.json").write_text("{ half a file")
    assert "cannot be read" in editor.reload_if_changed()
    # its own session kept
    assert editor.mirror(1).name == "left"
    # not refused: there was nothing to reload
    editor.add_marker(1, (30, 40))
    assert len(saved(tmp_path)["mirrors"][0]["markers"]) == 2
    # what was there is kept
    assert (tmp_path / "session.json.bak").read_text() == "{ half a file"
    (tmp_path / "session.json").unlink()
    assert "was removed by another program" in editor.reload_if_changed()
    editor.add_marker(1, (50, 60))
    assert len(saved(tmp_path)["mirrors"][0]["markers"]) == 3


def test_a_session_that_is_not_saved_is_never_reloaded(tmp_path):
    editor = SessionEditor(Session(tmp_path, Intrinsics.kinect_v1()), autosave=False)
    editor.add_mirror()
    # a file written there belongs to another session
    save_session(Session(tmp_path, Intrinsics.kinect_v1()))
    assert editor.reload_if_changed() == "" and len(editor.session.mirrors) == 1
    editor.add_mirror()
