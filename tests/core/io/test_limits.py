"""What a session may hold (io/limits.py): counts and strings beyond the limits are refused by
name and quickly, where the session is read and where it is edited; a session at the limits is
saved and opens again."""
from __future__ import annotations

import json
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mirrorcore.base.errors import FileFormatError, MirrorscanError
from mirrorcore.io.limits import MAX_MARKERS, check_name
from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.io.session import Session, SessionMirror
from mirrorcore.io.sessionfile import MAX_MIRRORS, check_session, load_session, save_session
from mirrorcore.rig.model import Rig

DEMO = "sessions/demo"


# --------------------------------------------------------------------- session limits
def _demo() -> dict:
    with open(f"{DEMO}/session.json") as f:
        return json.load(f)


def _write(tmp_path, data: dict | str):
    (tmp_path / "session.json").write_text(data if isinstance(data, str) else json.dumps(data))
    return tmp_path


BIG = 10 ** 400     # a JSON number no float can hold


@pytest.mark.parametrize("edit, message", [
    (lambda d: d.update(mirrors=[dict(d["mirrors"][0], id=i + 1, name=f"m{i}") for i in range(42)]),
     "mirrors: 42 mirrors, more than the 32 a session may hold"),
    (lambda d: d["mirrors"][0].update(markers=[[1, 1]] * 200_000),
     "markers: 200,000 points, more than the 500"),
    (lambda d: d["mirrors"][0].update(boundary=[[1, 1]] * 30_000),
     "boundary: 30,000 points, more than the 1,000"),
    (lambda d: d.update(selection={"roi": [[1, 1]] * 30_000}),
     "roi: 30,000 vertices, more than the 1,000"),
    (lambda d: d["mirrors"][0].update(name="x" * 101), "name: 101 characters, more than the 100"),
    (lambda d: d["mirrors"][0].update(name="bad\ud800"), "cannot be shown or saved"),
    (lambda d: d["mirrors"][0].update(name="tab\tbell\x07"), "cannot be shown or saved"),
    (lambda d: d.update(frames=["a\ud800.png"] * len(d["frames"])), r"frames\[0\]: must be a path"),
    (lambda d: d["camera"].update(fx=BIG), "camera: camera values must be numbers"),
    (lambda d: d["mirrors"][0].update(plane=[BIG, 0, 0, 1]),
     "plane: a plane needs 4 finite numbers"),
    (lambda d: d["mirrors"][0]["markers"].append([BIG, 1]), "must be a pair of numbers"),
    (lambda d: d.update(selection={"min_blob": BIG}), "selection: min_blob: must be a whole"),
    (lambda d: d.update(selection={"roi": [[BIG, 1], [2, 3], [4, 5]]}), "roi: vertices must be"),
    (lambda d: d.update(timestamps=[BIG] * len(d["frames"])), "must be a number of seconds"),
])
def test_sessions_beyond_the_limits_are_refused_by_name_and_quickly(tmp_path, edit, message):
    data = _demo()
    edit(data)
    _write(tmp_path, data)
    t0 = time.perf_counter()
    with pytest.raises(FileFormatError, match=message):
        load_session(tmp_path)
    # generous for a loaded machine: refused before the work, not after minutes
    assert time.perf_counter() - t0 < 10.0


@pytest.mark.parametrize("text, message", [
    ('{"version": 1, "x": ' + "[" * 100_000 + "]" * 100_000 + "}", "nested too deeply"),
    ('{"version": ' + "9" * 5000 + "}", "unreadable number"),
])
def test_session_files_that_json_cannot_hold_are_one_line(tmp_path, text, message):
    with pytest.raises(FileFormatError, match=message):
        load_session(_write(tmp_path, text))


def test_a_session_file_too_large_is_refused_before_reading(tmp_path):
    with open(tmp_path / "session.json", "wb") as f:
        f.truncate(100 << 20)
    with pytest.raises(FileFormatError, match="104,857,600 bytes, more than the 67,108,864"):
        load_session(tmp_path)


def test_the_editor_check_refuses_what_the_reader_would_refuse():
    session = load_session(DEMO)
    assert check_session(session) is session
    mirrors = tuple(SessionMirror(f"mirror {i}", id=i) for i in range(1, MAX_MIRRORS + 1))
    check_session(replace(session, mirrors=mirrors))                            # 32: fine
    with pytest.raises(MirrorscanError, match="33 mirrors, more than the 32"):
        check_session(replace(session, mirrors=mirrors + (SessionMirror("one more", id=99),)))
    m = session.mirrors[0]
    with pytest.raises(MirrorscanError,
                       match=r"mirrors\[0\] \(mirror 1\): markers: 501 points, more than the 500"):
        check_session(session.with_mirror(0, replace(m, markers=((1.0, 1.0),) * (MAX_MARKERS + 1))))
    with pytest.raises(MirrorscanError, match="boundary: 1,001 points"):
        check_session(session.with_mirror(0, replace(m, boundary=((1.0, 1.0),) * 1001)))
    for bad in ("", "   ", "x" * 101, "a\nb", "\ud800"):
        with pytest.raises(MirrorscanError):
            check_name(bad)
    assert check_name("Mirror à gauche ✓") == "Mirror à gauche ✓"


def test_a_session_at_the_limits_is_saved_and_opens_again(tmp_path):
    session = replace(load_session(DEMO), root=tmp_path)
    m = session.mirrors[0]
    full = tuple(replace(m, id=i, name=f"mirror {i}", plane=None)
                 for i in range(1, MAX_MIRRORS + 1))
    save_session(check_session(replace(session, mirrors=full, frames=(), timestamps=None)))
    again = load_session(tmp_path)
    assert len(again.mirrors) == MAX_MIRRORS and Rig.from_session(again).mirrors


CAMERA_NUMBERS = st.one_of(st.floats(), st.integers(-10**6, 10**6), st.booleans(),
                           st.sampled_from([1e308, -1e308, 5e-324, 2**53 + 1, 2**64]))


@settings(max_examples=80, deadline=None)
@given(size=st.tuples(st.integers(1, 5000), st.integers(1, 5000)),
       values=st.tuples(*[CAMERA_NUMBERS] * 5))
def test_a_camera_the_check_accepts_is_saved_and_opens_again(size, values):
    try:
        camera = Intrinsics(*size, *values)
    except (MirrorscanError, TypeError, ValueError, OverflowError):
        return
    with tempfile.TemporaryDirectory() as tmp:
        session = Session(Path(tmp), camera, (SessionMirror("m"),))
        try:
            check_session(session)
        except MirrorscanError as exc:
            assert str(exc).startswith("session.json: camera")
            return
        save_session(session)
        assert load_session(tmp) == session
