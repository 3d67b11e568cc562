"""Session editing behind the browser tool, without a browser: markers, boundaries, undo, autosave, round trip."""
import json
import os

import pytest

from app.editor import SessionEditor
from mirrorcore.errors import MirrorscanError
from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.geometry.plane import Plane
from mirrorcore.selection import Selection
from mirrorcore.session import Session, load_session

SQUARE = [(10, 10), (100, 10), (100, 100), (10, 100)]


@pytest.fixture
def editor(tmp_path):
    editor = SessionEditor(Session(tmp_path, Intrinsics.kinect_v1()))
    editor.add_mirror()
    return editor


def saved(tmp_path) -> dict:
    return json.loads((tmp_path / "session.json").read_text())


def test_markers_are_kept_where_clicked_and_saved(editor, tmp_path):
    editor.add_marker(0, (120.4, 33.0))
    editor.add_marker(0, (200, 300))
    assert editor.session.mirrors[0].markers == ((120.4, 33.0), (200.0, 300.0))
    assert saved(tmp_path)["mirrors"][0]["markers"] == [[120.4, 33.0], [200.0, 300.0]]   # autosaved, (u, v)
    editor.remove_last_marker(0)
    assert editor.session.mirrors[0].markers == ((120.4, 33.0),)
    editor.clear_markers(0)
    assert editor.session.mirrors[0].markers == ()
    with pytest.raises(MirrorscanError, match="pixel \\(640, 5\\) is outside the 640x480 image"):
        editor.add_marker(0, (640, 5))
    with pytest.raises(MirrorscanError, match="no marker to remove"):
        editor.remove_last_marker(0)


def test_boundary_is_drawn_then_closed(editor, tmp_path):
    for uv in SQUARE[:2]:
        editor.add_vertex(0, uv)
    assert editor.session.mirrors[0].boundary == ()               # still a draft: not in the session
    with pytest.raises(MirrorscanError, match="at least 3 vertices"):
        editor.close_boundary(0)
    for uv in SQUARE[2:]:
        editor.add_vertex(0, uv)
    editor.close_boundary(0)
    assert editor.session.mirrors[0].boundary == tuple((float(u), float(v)) for u, v in SQUARE)
    assert 0 not in editor.drafts
    assert len(saved(tmp_path)["mirrors"][0]["boundary"]) == 4


def test_crossing_boundaries_are_refused_and_nothing_changes(editor, tmp_path):
    for uv in [(10, 10), (100, 100), (100, 10), (10, 100)]:
        editor.add_vertex(0, uv)
    with pytest.raises(MirrorscanError, match="crosses itself"):
        editor.close_boundary(0)
    assert editor.session.mirrors[0].boundary == ()
    editor.clear_boundary(0)
    for uv in SQUARE:
        editor.add_vertex(0, uv)
    editor.close_boundary(0)
    before = (tmp_path / "session.json").read_bytes()
    with pytest.raises(MirrorscanError, match="crosses itself"):
        editor.move_vertex(0, 1, (10, 120))                       # would cross the opposite edge
    assert (tmp_path / "session.json").read_bytes() == before
    editor.delete_vertex(0, 0)                                    # a triangle is still a boundary
    assert len(editor.session.mirrors[0].boundary) == 3
    with pytest.raises(MirrorscanError, match="at least 3 vertices"):
        editor.delete_vertex(0, 0)
    assert len(editor.session.mirrors[0].boundary) == 3


def test_move_and_pick_vertices(editor):
    for uv in SQUARE:
        editor.add_vertex(0, uv)
    editor.close_boundary(0)
    assert editor.nearest_vertex(0, (103, 96)) == 2
    assert editor.nearest_vertex(0, (50, 50)) is None
    editor.move_vertex(0, 2, (120, 110))
    assert editor.session.mirrors[0].boundary[2] == (120.0, 110.0)


def test_undo_restores_sessions_and_draft_vertices(editor):
    editor.add_marker(0, (1, 2))
    editor.add_marker(0, (3, 4))
    editor.add_vertex(0, (5, 5))
    editor.undo()                                                  # the open draft loses its vertex first
    assert 0 not in editor.drafts and len(editor.session.mirrors[0].markers) == 2
    editor.undo()
    assert editor.session.mirrors[0].markers == ((1.0, 2.0),)
    editor.undo()
    editor.undo()                                                  # the mirror itself
    assert editor.session.mirrors == ()
    with pytest.raises(MirrorscanError, match="nothing to undo"):
        editor.undo()


def test_mirrors_add_rename_remove(editor):
    assert editor.add_mirror() == 1 and editor.session.mirrors[1].name == "mirror 2"
    editor.rename_mirror(1, "left")
    with pytest.raises(MirrorscanError, match="already a mirror named 'left'"):
        editor.rename_mirror(0, "left")
    editor.add_vertex(1, (1, 1))
    editor.remove_mirror(0)
    assert [m.name for m in editor.session.mirrors] == ["left"] and editor.drafts == {0: ((1.0, 1.0),)}


def test_session_round_trip_through_the_editor(editor, tmp_path):
    editor.add_marker(0, (10, 20))
    for uv in SQUARE:
        editor.add_vertex(0, uv)
    editor.close_boundary(0)
    editor.set_planes({0: Plane.from_abcd([0.5, 0, -0.8, 2.4])})
    editor.set_selection(Selection(depth_max=3.5))
    loaded = load_session(tmp_path)
    assert loaded.mirrors[0].markers == ((10.0, 20.0),)
    assert loaded.mirrors[0].boundary == editor.session.mirrors[0].boundary
    assert loaded.selection.depth_max == 3.5
    assert loaded.mirrors[0].plane.angle_to(editor.session.mirrors[0].plane) < 1e-9


def test_a_failed_autosave_keeps_the_last_good_file(editor, tmp_path, monkeypatch):
    editor.add_marker(0, (10, 20))
    good = (tmp_path / "session.json").read_bytes()

    def full_disk(*args):
        raise OSError(28, "No space left on device")
    monkeypatch.setattr(os, "fsync", full_disk)
    editor.add_marker(0, (30, 40))
    assert "No space left on device" in editor.last_save_error
    assert (tmp_path / "session.json").read_bytes() == good
    assert len(editor.session.mirrors[0].markers) == 2            # the edit itself is kept in memory


def test_listeners_hear_every_change(editor):
    heard = []
    editor.listeners.append(lambda s: heard.append(len(s.mirrors[0].markers)))
    editor.add_marker(0, (1, 1))
    editor.add_vertex(0, (2, 2))
    assert heard == [1, 1]


def test_planes_of_several_mirrors_are_one_undo_step(editor):
    editor.add_mirror()
    editor.set_planes({0: Plane.from_abcd([0.5, 0, -0.8, 2.4]), 1: Plane.from_abcd([-0.5, 0, -0.8, 2.4])})
    assert all(m.plane is not None for m in editor.session.mirrors)
    editor.undo()
    assert all(m.plane is None for m in editor.session.mirrors) and len(editor.session.mirrors) == 2
