"""The session folder (io/session.py): round trips, clear errors naming the file and the key,
nothing lost on a failed save, files that follow the umask."""
import dataclasses
import json
import os
from dataclasses import replace

import numpy as np
import pytest

from mirrorcore.base.errors import FileFormatError
from mirrorcore.depth.files import write_depth_png
from mirrorcore.depth.selection import Selection
from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.geometry.plane import Plane
from mirrorcore.io.session import Session, SessionMirror
from mirrorcore.io.sessionfile import load_session, save_session

CAMERA = Intrinsics.primesense()


def make_session(root) -> Session:
    write_depth_png(root / "background.png", np.full(CAMERA.shape, 3.0), 0.001)
    (root / "frames").mkdir(parents=True, exist_ok=True)
    write_depth_png(root / "frames/000000.png", np.full(CAMERA.shape, 2.5), 0.001)
    mirrors = (SessionMirror("mirror 1", ((10.0, 20.0), (30.5, 40.0), (50.0, 20.0)),
                             ((0, 0), (100, 0), (100, 100)),
                          Plane.from_abcd([0.3, 0, -1, 2.5])),
               SessionMirror("mirror 2", extra={"note": "kept"}))
    return Session(root, CAMERA, mirrors, "background.png", ("frames/000000.png",),
                   Selection(depth_max=5.0),
                   extra={"note": "kept too"})


def test_session_round_trip(tmp_path):
    session = make_session(tmp_path)
    save_session(session)
    loaded = load_session(tmp_path)
    np.testing.assert_allclose(loaded.mirrors[0].plane.abcd, session.mirrors[0].plane.abcd, rtol=0,
                               atol=1e-15)
    assert loaded.with_mirror(0, session.mirrors[0]) == session
    assert loaded.mirrors[1].extra == {"note": "kept"} and loaded.extra == {"note": "kept too"}
    assert loaded.selection == Selection(depth_max=5.0) and [m.id for m in loaded.mirrors] == [1, 2]
    assert loaded.read_frame(0)[0, 0] == pytest.approx(2.5)
    assert loaded.read_background()[5, 5] == pytest.approx(3.0)
    data = json.loads((tmp_path / "session.json").read_text())
    assert set(data) >= {"version", "camera", "mirrors", "background",
                         "frames"} and data["version"] == 1
    assert data["mirrors"][1]["plane"] is None
    # written only when the markers are off the silver
    assert "marker_offset" not in data["mirrors"][1]


def test_marker_offset_round_trip(tmp_path):
    session = make_session(tmp_path)
    session = session.with_mirror(0, replace(session.mirrors[0], marker_offset=0.0042))
    save_session(session)
    assert json.loads((tmp_path / "session.json").read_text())["mirrors"][0][
        "marker_offset"] == 0.0042
    assert load_session(tmp_path).mirrors[0].marker_offset == 0.0042
    # typed
    assert "marker_offset_std" not in json.loads((tmp_path / "session.json").read_text())[
        "mirrors"][0]
    assert load_session(tmp_path).mirrors[0].glass_typed
    # measured
    save_session(session.with_mirror(0, replace(session.mirrors[0], marker_offset_std=0.0008)))
    assert json.loads((tmp_path / "session.json").read_text())["mirrors"][0][
        "marker_offset_std"] == 0.0008
    loaded = load_session(tmp_path).mirrors[0]
    assert loaded.marker_offset_std == 0.0008 and not loaded.glass_typed


@pytest.mark.parametrize("bad", [-0.001, 0.2, "1", True, float("nan")])
def test_a_glass_uncertainty_that_is_not_metres_is_refused_by_name(tmp_path, bad):
    session = make_session(tmp_path)
    save_session(session)
    data = json.loads((tmp_path / "session.json").read_text())
    data["mirrors"][0]["marker_offset_std"] = bad
    (tmp_path / "session.json").write_text(json.dumps(data))
    with pytest.raises(FileFormatError,
                       match=r"mirrors\[0\].*'marker_offset_std' must be the metres"):
        load_session(tmp_path)


def test_bounces_are_kept_and_written_only_when_set(tmp_path):
    """The session's `bounces` (extension): 3 unless the file says otherwise, written only when it
    differs."""
    session = make_session(tmp_path)
    save_session(session)
    assert "bounces" not in json.loads((tmp_path / "session.json").read_text())
    assert load_session(tmp_path).bounces == 3
    save_session(dataclasses.replace(session, bounces=1))
    assert json.loads((tmp_path / "session.json").read_text())["bounces"] == 1
    assert load_session(tmp_path).bounces == 1


def test_save_keeps_the_previous_version(tmp_path):
    session = make_session(tmp_path)
    save_session(session)
    first = (tmp_path / "session.json").read_text()
    save_session(session.with_mirror(1, SessionMirror("renamed")))
    assert (tmp_path / "session.json.bak").read_text() == first
    assert load_session(tmp_path).mirrors[1].name == "renamed"


def test_failed_save_leaves_the_session_intact(tmp_path, monkeypatch):
    session = make_session(tmp_path)
    save_session(session)
    before = (tmp_path / "session.json").read_bytes()

    def full_disk(*args):
        raise OSError(28, "No space left on device")
    monkeypatch.setattr(os, "fsync", full_disk)
    with pytest.raises(OSError, match="No space left"):
        save_session(session.with_mirror(0, SessionMirror("changed")))
    assert (tmp_path / "session.json").read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["background.png", "frames",
                                                          "session.json"]


def edit(tmp_path, change):
    save_session(make_session(tmp_path))
    data = json.loads((tmp_path / "session.json").read_text())
    change(data)
    (tmp_path / "session.json").write_text(json.dumps(data))


@pytest.mark.parametrize("change, message", [
    (lambda d: d.pop("camera"), "missing key\\(s\\) camera"),
    (lambda d: d.update(version=7), "unknown version 7"),
    (lambda d: d["camera"].pop("fx"), "camera: missing key\\(s\\) fx"),
    (lambda d: d["mirrors"][0].update(markers=[[700, 3]]),
     r"mirrors\[0\] \(mirror 1\): markers\[0\]: pixel \(700, 3\) is outside"),
    (lambda d: d["mirrors"][0].update(markers=[[1, "a"]]),
     r"markers\[0\]: must be a pair of numbers"),
    (lambda d: d["mirrors"][0].update(boundary=[[0, 0], [9, 9], [9, 0], [0, 9]]), "crosses itself"),
    (lambda d: d["mirrors"][0].update(boundary=[[0, 0], [9, 9]]), "at least 3 vertices"),
    (lambda d: d["mirrors"][0].update(plane=[0, 0, 0, 1]), "normal .* is zero"),
    (lambda d: d["mirrors"][0].update(plane=[0, 0, 1, -2]), "camera behind the mirror"),
    (lambda d: d["mirrors"][0].update(name=""), "name: must be a non-empty string"),
    (lambda d: d["mirrors"][0].update(marker_offset=0.3),
     r"mirrors\[0\] \(mirror 1\): 'marker_offset' must be metres"),
    (lambda d: d["mirrors"][0].update(marker_offset="3 mm"),
     "'marker_offset' must be metres .* got '3 mm'"),
    (lambda d: d["mirrors"][0].update(marker_offset=True), "'marker_offset' must be metres"),
    (lambda d: d.update(frames=["../../etc/passwd"]),
     r"frames\[0\]: path '../../etc/passwd' leaves the session folder"),
    (lambda d: d.update(background="/etc/passwd"),
     "background: path '/etc/passwd' leaves the session folder"),
    (lambda d: d.update(bounces=4), "bounces: must be a whole number from 1 to 3, got 4"),
    (lambda d: d.update(bounces=2.0), "bounces: must be a whole number from 1 to 3, got 2.0"),
    (lambda d: d.update(bounces=True), "bounces: must be a whole number from 1 to 3, got True"),
])
def test_bad_session_files_are_refused_by_name_and_left_unchanged(tmp_path, change, message):
    edit(tmp_path, change)
    before = (tmp_path / "session.json").read_bytes()
    with pytest.raises(FileFormatError, match=message):
        load_session(tmp_path)
    assert (tmp_path / "session.json").read_bytes() == before


def test_malformed_and_missing_session(tmp_path):
    with pytest.raises(FileFormatError, match="no such file"):
        load_session(tmp_path)
    (tmp_path / "session.json").write_text('{"version": 1, "camera": ')
    with pytest.raises(FileFormatError, match="invalid JSON at line 1"):
        load_session(tmp_path)


def test_saved_files_follow_the_umask_and_keep_their_mode(tmp_path):
    old = os.umask(0o022)
    try:
        session = make_session(tmp_path)
        save_session(session)
        assert (tmp_path / "session.json").stat().st_mode & 0o777 == 0o644
        (tmp_path / "session.json").chmod(0o600)
        save_session(session)
        assert (tmp_path / "session.json").stat().st_mode & 0o777 == 0o600
    finally:
        os.umask(old)


@pytest.mark.parametrize("key", ["marker_offset", "marker_offset_std"])
def test_glass_values_past_a_float_are_refused_in_one_line(tmp_path, key):
    save_session(make_session(tmp_path))
    text = (tmp_path / "session.json").read_text()
    data = json.loads(text)
    data["mirrors"][0][key] = 0
    # JSON holds integers no float can: 10^400 written out
    text = json.dumps(data).replace(f'"{key}": 0', f'"{key}": 1{"0" * 400}')
    (tmp_path / "session.json").write_text(text)
    with pytest.raises(FileFormatError, match=rf"mirrors\[0\] \(mirror 1\): '{key}' must be"):
        load_session(tmp_path)
