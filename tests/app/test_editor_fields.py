"""What the browser's editor saves, the session reader opens: property-based tests over every field
a tab can set (selection, bounces, background, glass, markers, boundaries, planes, names). An edit
the editor accepts is saved and loads again as the same session; an edit the editor refuses is
refused in one line, with nothing changed in memory or on disk; a value the reader refuses (or
reads as another) is refused, and the session's own settings are accepted exactly when the reader
reads them back as they were set."""
from __future__ import annotations

import json
import tempfile
from dataclasses import replace
from pathlib import Path

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from mirrorscan.editor import SessionEditor

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.depth.selection import Selection
from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.geometry.plane import Plane
from mirrorcore.io.session import Session, SessionMirror
from mirrorcore.io.sessionfile import load_session, save_session, session_from_json

CAMERA = Intrinsics(64, 48, 60.0, 60.0, 31.5, 23.5)
SQUARE = ((10.0, 10.0), (30.0, 10.0), (30.0, 30.0), (10.0, 30.0))
EDITS = settings(max_examples=40, deadline=None,
                 suppress_health_check=[HealthCheck.too_slow])

# what a crafted websocket message or a fit can hand the editor (the glass comes as a float: mm
# typed in / 1000)
EXTREMES = st.sampled_from([-1e308, 1e308, -0.0, 0.0, 5e-324, 1e-30, 0.05, 0.050001, 2**53 + 1,
                            2**64, float("nan"), float("inf"), -float("inf")])
NUMBERS = st.one_of(EXTREMES, st.floats(), st.integers(-10**6, 10**6), st.booleans())
PIXELS = st.tuples(st.one_of(NUMBERS, st.floats(-1, 70)), st.one_of(NUMBERS, st.floats(-1, 50)))
TEXTS = st.one_of(st.text(max_size=110),
                  st.sampled_from(["", "   ", "\ud800", "a\tb", "x" * 101, "mirror 2", "<b>x</b>",
                                   "../up.png", "/etc/passwd", "C:x.png", "a\0b", "ok.png"]))


def _editor(folder: Path) -> SessionEditor:
    """An autosaved editor of a saved session of two mirrors, the first outlined and marked."""
    mirrors = (SessionMirror("mirror 1", markers=((20.0, 20.0),), boundary=SQUARE, id=1),
               SessionMirror("mirror 2", id=2))
    session = Session(folder, CAMERA, mirrors, frames=("frames/0.png",), timestamps=(0.5,))
    save_session(session)
    return SessionEditor(load_session(folder))


def _edit(edit) -> bool:
    """Make one edit on a fresh editor; return whether it was accepted.

    Accepted, the file on disk loads as the editor's session; refused, in one line, nothing in
    memory or on disk changed.
    """
    with tempfile.TemporaryDirectory() as tmp:
        editor = _editor(Path(tmp))
        before, saved = editor.session, editor.session.path.read_bytes()
        try:
            edit(editor)
        except MirrorscanError as exc:
            assert "\n" not in str(exc)
            assert editor.session is before and editor.session.path.read_bytes() == saved
            return False
        assert load_session(tmp) == editor.session
        return True


def _reader_reads(change) -> Session | None:
    """The session the reader makes of the saved file of `_editor` changed by `change(data)`, or
    None when it refuses it."""
    with tempfile.TemporaryDirectory() as tmp:
        data = json.loads(_editor(Path(tmp)).session.path.read_text())
        change(data)
        try:
            return session_from_json(json.loads(json.dumps(data)), Path(tmp))
        except MirrorscanError:
            return None


def _reads_as(change, key: str, value) -> bool:
    """Whether the reader accepts the changed file and reads `key` of the session as `value`."""
    back = _reader_reads(change)
    return back is not None and getattr(back, key) == value


# --------------------------------------------------------------------- the session's own fields
@EDITS
@given(low=NUMBERS, high=NUMBERS)
@example(low=-1e308, high=1e308)
def test_a_depth_range_is_saved_only_when_the_reader_opens_it(low, high):
    wanted = replace(Selection(), depth_min=low, depth_max=high)
    accepted = _edit(lambda e: e.set_selection(wanted))
    assert accepted == _reads_as(lambda d: d.update(selection=wanted.to_json()), "selection",
                                 wanted)


@EDITS
@given(key=st.sampled_from(["background_sigmas", "min_gap", "flying_sigmas", "flying_gap",
                            "min_blob", "smooth"]),
       value=st.one_of(NUMBERS, TEXTS, st.none()))
def test_every_selection_setting_is_saved_only_when_the_reader_opens_it(key, value):
    wanted = replace(Selection(), **{key: value})
    accepted = _edit(lambda e: e.set_selection(wanted))
    assert accepted == _reads_as(lambda d: d.update(selection={key: value}), "selection", wanted)


@EDITS
@given(roi=st.one_of(st.none(), st.lists(PIXELS, min_size=0, max_size=6)))
def test_a_region_of_interest_is_saved_only_when_the_reader_opens_it(roi):
    wanted = replace(Selection(), roi=None if roi is None else tuple(roi))
    accepted = _edit(lambda e: e.set_selection(wanted))
    assert accepted == _reads_as(lambda d: d.update(selection={"roi": roi}), "selection", wanted)


@EDITS
@given(bounces=st.one_of(NUMBERS, st.integers(-5, 10)))
def test_bounces_are_saved_only_when_the_reader_opens_them(bounces):
    accepted = _edit(lambda e: e.set_bounces(bounces))
    assert accepted == _reads_as(lambda d: d.update(bounces=bounces), "bounces", bounces)


@EDITS
@given(path=st.one_of(st.none(), TEXTS))
def test_a_background_path_is_saved_only_when_the_reader_opens_it(path):
    accepted = _edit(lambda e: e.set_background(path))
    assert accepted == _reads_as(lambda d: d.update(background=path), "background", path)


# --------------------------------------------------------------------- a mirror's fields
@EDITS
@given(metres=NUMBERS.map(float))
def test_the_glass_is_saved_only_when_the_reader_opens_it(metres):
    _edit(lambda e: e.set_marker_offset(1, metres))


@EDITS
@given(uv=PIXELS, mirror=st.sampled_from([1, 2]))
def test_a_marker_is_saved_only_when_the_reader_opens_it(uv, mirror):
    _edit(lambda e: e.add_marker(mirror, uv))
    _edit(lambda e: e.move_marker(1, 0, uv))


@EDITS
@given(vertices=st.lists(PIXELS, min_size=0, max_size=6))
def test_a_boundary_is_saved_only_when_the_reader_opens_it(vertices):
    _edit(lambda e: e.set_boundary(2, vertices))
    _edit(lambda e: e.move_vertex(1, 0, vertices[0] if vertices else (-1.0, -1.0)))


@EDITS
@given(abcd=st.tuples(NUMBERS, NUMBERS, NUMBERS, NUMBERS), offset=NUMBERS,
       std=st.one_of(st.none(), NUMBERS))
def test_a_plane_and_its_glass_are_saved_only_when_the_reader_opens_them(abcd, offset, std):
    plane = Plane(tuple(abcd[:3]), abcd[3])

    def set_plane(editor: SessionEditor) -> None:
        mirror = editor.mirror(1)
        editor.set_planes({1: (plane, mirror)}, {1: (offset, std)})

    def set_both(editor: SessionEditor) -> None:
        """A good plane for mirror 1 and this one for mirror 2: both or neither (`_edit`)."""
        good = Plane((0.0, 0.0, -1.0), 2.0)
        editor.set_planes({1: (good, editor.mirror(1)), 2: (plane, editor.mirror(2))},
                          {2: (offset, std)})

    _edit(set_plane)
    _edit(set_both)


@EDITS
@given(name=TEXTS)
def test_a_name_is_saved_only_when_the_reader_opens_it(name):
    _edit(lambda e: e.rename_mirror(2, name))
    _edit(lambda e: e.add_mirror(name))


def test_a_depth_range_the_reader_refuses_is_refused_at_the_edit_naming_it(tmp_path):
    editor = _editor(tmp_path)
    before = editor.session
    with pytest.raises(MirrorscanError, match=r"^session\.json: selection: depth_min: must be a "
                                              r"finite number from 0, got -1e\+308$"):
        editor.set_selection(replace(before.selection, depth_min=-1e308, depth_max=1e308))
    assert editor.session is before and load_session(tmp_path) == before
    editor.set_selection(replace(before.selection, depth_min=0.0, depth_max=1e308))
    assert load_session(tmp_path).selection.depth_max == 1e308


def test_a_value_that_would_read_back_otherwise_is_refused_naming_it(tmp_path):
    editor = _editor(tmp_path)
    skewed = Plane((2.0, 0.0, 0.0), 1.0)
    with pytest.raises(MirrorscanError, match=r"mirrors\[0\] \(mirror 1\): plane: .* would read "
                                              r"back as"):
        editor.set_planes({1: (skewed, editor.mirror(1))})
    assert editor.session.mirrors[0].plane is None
