"""Several tabs editing one session through one editor: an edit made on a state another tab
changed since is refused in one line and changes nothing, while edits of other mirrors (or of the
session's own scope) made meanwhile are not; the check and the save are one step, from any number
of threads; one mirror per Add a mirror click; undo and redo that remove a mirror are known
before they are made."""
import json
import threading

import pytest
from mirrorscan.editor import SESSION_SCOPE, SessionEditor, StaleEdit, made_on

from mirrorcore.depth.selection import Selection
from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.io.session import Session

SQUARE = [(10, 10), (100, 10), (100, 100), (10, 100)]


@pytest.fixture
def editor(tmp_path):
    editor = SessionEditor(Session(tmp_path, Intrinsics.kinect_v1()))
    editor.add_mirror()
    editor.add_mirror()
    return editor


def saved(tmp_path) -> dict:
    return json.loads((tmp_path / "session.json").read_text())


def test_an_outline_closed_on_a_stale_mirror_is_refused_and_changes_nothing(editor, tmp_path):
    """Tab B closes mirror 1's outline; tab C, which drew mirror 1 without one, closes its own
    draft: refused, naming the mirror, and B's outline stays."""
    drawn_b = drawn_c = editor.session
    with made_on(drawn_b):
        editor.set_boundary(1, SQUARE)
    before = (tmp_path / "session.json").read_bytes()
    with made_on(drawn_c), pytest.raises(StaleEdit, match=r"^mirror 1 changed in another tab; "
                                                          r"this tab now shows it as it is"):
        editor.set_boundary(1, [(200, 200), (300, 200), (300, 300)])
    assert editor.mirror(1).boundary == tuple((float(u), float(v)) for u, v in SQUARE)
    assert (tmp_path / "session.json").read_bytes() == before
    # redrawn, the same change goes through
    with made_on(editor.session):
        editor.set_boundary(1, [(200, 200), (300, 200), (300, 300)])


def test_edits_of_other_mirrors_or_of_the_session_made_meanwhile_refuse_nothing(editor):
    drawn_b = drawn_c = editor.session
    with made_on(drawn_b):
        editor.add_marker(1, (50, 50))
        editor.set_selection(Selection(depth_max=3.0))
        editor.rename_mirror(1, "left")
    with made_on(drawn_c):
        editor.add_marker(2, (60, 60))
        editor.set_boundary(2, SQUARE)
    assert editor.mirror(1).markers == ((50.0, 50.0),) and editor.mirror(2).markers == ((60, 60),)
    # the session's own scope, changed by B since C drew it
    with made_on(drawn_c), pytest.raises(StaleEdit, match="^the session's mirrors or settings "
                                                          "changed since this tab drew them"):
        editor.set_bounces(1)


def test_a_removed_or_changed_mirror_is_neither_edited_nor_removed_on_a_stale_drawing(editor):
    drawn_b = drawn_c = editor.session
    with made_on(drawn_b):
        editor.add_marker(2, (50, 50))
    # C's Remove was asked on mirror 2 without B's marker: what it would lose changed
    with made_on(drawn_c), pytest.raises(StaleEdit, match="^mirror 2 changed in another tab"):
        editor.remove_mirror(2)
    assert [m.id for m in editor.session.mirrors] == [1, 2]
    with made_on(editor.session):
        editor.remove_mirror(2)
    with made_on(drawn_c), pytest.raises(StaleEdit, match="^mirror 2 is no longer in the session"):
        editor.add_marker(2, (70, 70))


def test_a_double_click_on_add_adds_one_mirror_and_undo_leaves_none_behind(editor):
    drawn = editor.session
    with made_on(drawn):
        assert editor.add_mirror() == 3
    with made_on(drawn), pytest.raises(StaleEdit):
        editor.add_mirror()
    assert [m.id for m in editor.session.mirrors] == [1, 2, 3]
    editor.undo(editor.travel_scope(3))
    assert [m.id for m in editor.session.mirrors] == [1, 2]
    assert editor.undo_label(SESSION_SCOPE) == "add mirror 2"


def test_an_actions_edits_in_turn_are_each_made_on_the_one_before(editor):
    with made_on(editor.session):
        mirror_id = editor.add_mirror()
        editor.set_boundary(mirror_id, SQUARE)
        editor.add_marker(mirror_id, (50, 50))
    assert editor.mirror(mirror_id).markers == ((50.0, 50.0),)


def test_undo_and_redo_on_a_stale_drawing_are_refused_and_their_removals_known(editor):
    """Tab B removes mirror 2 and tab C brings it back; B's Redo would remove it again: the editor
    names it before (the panel asks), and a redo on B's drawing before C's Undo is refused."""
    with made_on(editor.session):
        editor.add_marker(2, (50, 50))
        editor.remove_mirror(2)
    drawn_b = editor.session
    assert editor.removal(SESSION_SCOPE) is None
    with made_on(editor.session):
        editor.undo(SESSION_SCOPE)  # C: Bring back mirror 2
    assert editor.removal(SESSION_SCOPE, redo=True).markers == ((50.0, 50.0),)
    with made_on(drawn_b), pytest.raises(StaleEdit):
        editor.redo(SESSION_SCOPE)
    assert [m.id for m in editor.session.mirrors] == [1, 2]
    # the undo of an add removes the added mirror
    with made_on(editor.session):
        added = editor.add_mirror()
    assert editor.removal(SESSION_SCOPE).id == added
    assert editor.removal(1) is None


def test_two_tabs_released_together_on_one_drawing_make_one_edit(editor, tmp_path):
    """Each round, two threads edit mirror 1 on the same drawing at once: exactly one is made,
    the other refused, and the file holds what the editor holds."""
    for round_ in range(30):
        drawn, barrier = editor.session, threading.Barrier(2)
        outcomes: list[str] = []

        def edit(uv) -> None:
            barrier.wait()
            try:
                with made_on(drawn):
                    editor.add_marker(1, uv)
                outcomes.append("made")
            except StaleEdit:
                outcomes.append("refused")
        threads = [threading.Thread(target=edit, args=((10 + round_, 10 + k),)) for k in (0, 1)]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join()
        assert sorted(outcomes) == ["made", "refused"]
    assert len(editor.mirror(1).markers) == 30
    assert len(saved(tmp_path)["mirrors"][0]["markers"]) == 30


def test_a_hundred_edits_from_several_threads_lose_none(editor, tmp_path):
    """Four threads, each adding 25 markers to its own mirror, each edit made on the session as
    that thread last read it: none refused (the others' mirrors are not its own), none lost."""
    editor.add_mirror()
    editor.add_mirror()
    barrier, refused = threading.Barrier(4), []

    def work(mirror_id: int) -> None:
        barrier.wait()
        for k in range(25):
            try:
                with made_on(editor.session):
                    editor.add_marker(mirror_id, (10 + 4 * k, 10 * mirror_id))
            except StaleEdit as exc:
                refused.append(str(exc))
    threads = [threading.Thread(target=work, args=(i,)) for i in (1, 2, 3, 4)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert not refused
    assert [len(m.markers) for m in editor.session.mirrors] == [25] * 4
    assert [len(m["markers"]) for m in saved(tmp_path)["mirrors"]] == [25] * 4
