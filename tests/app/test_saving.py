"""Saving in the browser tool (mirrorscan.editing, .sessionfile, .notices): a failed save told on
every tab and in the header until a save works, the edits kept in memory and saved elsewhere on
request; one editor per session folder, also within one process; a session open read-only refusing
every edit. The same in real processes: tests/cli/test_serve_saving.py."""
import errno
import re
import threading
from pathlib import Path

import pytest
from mirrorscan.bench.tabs import HeadlessTab
from mirrorscan.demo import demo_source
from mirrorscan.editor import SessionEditor
from mirrorscan.panels.session import SessionPanel
from mirrorscan.server import MirrorscanApp
from mirrorscan.wording import HEADLINE_WORDS, words
from mirrorscan.wording.saving import read_only, unsaved

import mirrorcore.io.sessionfile as sessionfile
from mirrorcore.base.errors import MirrorscanError
from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.io.session import Session
from mirrorcore.io.sessionfile import load_session, save_session
from mirrorcore.io.sessionlock import LOCK_FILE, SessionLock, SessionLocked
from tests.app.panels.support import panel
from tests.conftest import sphere_app

EDITS = 100


def full_disk(path, *args, **kwargs):
    raise OSError(errno.ENOSPC, "No space left on device", str(path))


@pytest.fixture
def app(tmp_path):
    app = sphere_app(tmp_path / "scan")
    yield app
    app.stop()


def test_a_failed_save_stays_on_every_tab_and_in_the_header_until_a_save_works(app, tmp_path,
                                                                               monkeypatch):
    root = tmp_path / "scan"
    with HeadlessTab(app) as one, HeadlessTab(app) as two:
        mirror = app.editor.add_mirror("left")
        monkeypatch.setattr(sessionfile, "write_atomic", full_disk)
        app.editor.rename_mirror(mirror, "right")
        assert app.editor.last_save_error == f"{root / 'session.json'}: No space left on device"
        assert app.unsaved.shown[0] == "Session not saved"
        assert app.unsaved.tabs == {one.tab.client.client_id, two.tab.client.client_id}
        with HeadlessTab(app) as three:
            # a tab opened meanwhile is told too
            assert three.tab.client.client_id in app.unsaved.tabs
            for headless in (one, two, three):
                header = headless.tab.header.title.content
                assert "⚠ **not saved**: edits kept in memory" in header, header
                session = panel(headless.tab, SessionPanel)
                assert "Not saved (No space left on device)" in session.where.content
                assert session.save_elsewhere.visible
        # a later edit and the retry fail too: the edit stays in memory, the file as it was
        app.editor.add_mirror("middle")
        assert not app.editor.retry_save()
        assert [m.name for m in load_session(root).mirrors] == ["left"]
        assert [m.name for m in app.editor.session.mirrors] == ["right", "middle"]
        monkeypatch.undo()
        assert app.editor.retry_save()
        assert [m.name for m in load_session(root).mirrors] == ["right", "middle"]
        assert app.unsaved.shown is None and app.unsaved.tabs == set()
        assert "not saved" not in one.tab.header.title.content
        assert not panel(one.tab, SessionPanel).save_elsewhere.visible


def test_save_elsewhere_refuses_in_one_line_a_folder_it_cannot_write_and_edits_the_copy(
        app, tmp_path, monkeypatch):
    root = tmp_path / "scan"
    with HeadlessTab(app) as headless:
        app.editor.add_mirror("left")
        write = sessionfile.write_atomic

        def full_there(path, *args, **kwargs):
            if root in Path(path).parents:
                full_disk(path)
            write(path, *args, **kwargs)
        monkeypatch.setattr(sessionfile, "write_atomic", full_there)
        app.editor.rename_mirror(1, "right")
        session = panel(headless.tab, SessionPanel)
        (tmp_path / "taken").mkdir()
        (tmp_path / "taken" / "something").write_text("")
        for typed, refused in (
                ("", "type a folder to save in first (a new or empty one)"),
                (str(tmp_path / "taken"),
                 f"{tmp_path / 'taken'}: already exists and is not an empty folder"),
                # a file where a folder should be
                (str(tmp_path / "taken" / "something" / "scan"),
                 f"{tmp_path / 'taken' / 'something' / 'scan'}: cannot save there (")):
            session.elsewhere.value = typed
            with pytest.raises(MirrorscanError, match=re.escape(refused)) as error:
                session._save_elsewhere()
            assert "\n" not in str(error.value)
        session.elsewhere.value = str(tmp_path / "other" / "scan")
        session._save_elsewhere()
    assert app.editor.session.root == tmp_path / "other" / "scan"
    assert [m.name for m in load_session(tmp_path / "other" / "scan").mirrors] == ["right"]
    assert app.editor.last_save_error is None and app.unsaved.shown is None
    # the copy is the session under edit now: locked, its old folder let go
    with pytest.raises(SessionLocked):
        SessionLock(tmp_path / "other" / "scan", "test")
    SessionLock(root, "test").release()


def test_two_editors_of_one_session_in_one_process_the_second_is_refused_and_no_edit_is_lost(
        tmp_path):
    """Two editors released together lost 50 of 100 edits: now the second is refused, and 100
    edits from threads of the first all land."""
    save_session(Session(tmp_path, Intrinsics.kinect_v1()))
    first = SessionEditor(load_session(tmp_path))
    with pytest.raises(SessionLocked, match=r"is being edited by mirrorscan serve \(pid \d+"):
        SessionEditor(load_session(tmp_path))
    mirror = first.add_mirror()
    start = threading.Barrier(4)

    def edit(k: int) -> None:
        start.wait()
        for i in range(EDITS // 4):
            first.add_marker(mirror, (10 + 5 * i, 10 + 20 * k))
    threads = [threading.Thread(target=edit, args=(k,)) for k in range(4)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert len(load_session(tmp_path).mirrors[0].markers) == EDITS
    first.close()
    assert not (tmp_path / LOCK_FILE).exists()
    SessionEditor(load_session(tmp_path)).close()


def test_a_session_open_read_only_refuses_every_edit_and_says_so(tmp_path):
    root = tmp_path / "scan"
    save_session(Session(root, Intrinsics.kinect_v1()))
    with SessionLock(root, "mirrorscan calibrate") as held:
        why = str(SessionLocked(root, held.holder))
        app = MirrorscanApp(load_session(root), demo_source(), port=0, read_only=why)
        try:
            with HeadlessTab(app) as headless:
                with pytest.raises(MirrorscanError) as refused:
                    app.editor.add_mirror()
                assert str(refused.value) == f"not changed: the session is open read-only ({why})"
                assert app.unsaved.shown[0] == "Session open read-only"
                assert "⚠ **read-only**" in headless.tab.header.title.content
                assert panel(headless.tab, SessionPanel).save_elsewhere.visible
        finally:
            app.stop()
        assert load_session(root).mirrors == ()


def test_opening_a_session_another_program_edits_is_refused_and_nothing_changes(app, tmp_path):
    other = tmp_path / "other"
    save_session(Session(other, Intrinsics.kinect_v1()))
    with SessionLock(other, "mirrorscan calibrate"):
        with pytest.raises(SessionLocked, match="is being edited by mirrorscan calibrate"):
            app.open_session(load_session(other))
    assert app.editor.session.root == tmp_path / "scan"
    app.open_session(load_session(other))
    assert app.editor.session.root == other
    SessionLock(tmp_path / "scan", "test").release()


def test_what_is_said_of_saving_leads_with_a_short_headline(tmp_path):
    for reason in ("No space left on device", "Read-only file system", "Disk quota exceeded"):
        message = unsaved(tmp_path, f"{tmp_path}/session.json: {reason}")
        assert message.headline.startswith(f"Not saved ({reason}): edits are kept in memory")
        assert words(message.headline) <= HEADLINE_WORDS, message.headline
    with SessionLock(tmp_path, "mirrorscan calibrate") as held:
        why = str(SessionLocked(tmp_path, held.holder))
    assert words(read_only(why).headline) <= HEADLINE_WORDS
    assert why in read_only(why).details[0]
