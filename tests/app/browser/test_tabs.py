"""Three tabs of one session in headless Chromium: a double click on Add a mirror adds one mirror
and Undo leaves none behind; an outline closed in one tab is not replaced by another tab's draft,
whose picture and panel then both show it closed; a Redo that would remove a mirror another tab
brought back asks first, and every tab is told of the removal."""

from __future__ import annotations

import time

import numpy as np
import pytest

from mirrorcore.base.palette import source_colour
from mirrorcore.sim.export import session_mirrors
from tests.browser import button, click_pixel, look_at_the_depth_frame, open_tab, text
from tests.conftest import sphere_app
from tests.waiting import wait_for

LIVE_FPS = 5.0  # software WebGL for three pages on 2 cores: keep the stream light

pytestmark = pytest.mark.steps("tabs")

# The smallest L1 distance (summed over RGB) of a pixel of the 21x21 patch around (u, v) of the
# last depth frame the page received to `colour`.
NEAREST_COLOUR = """([u, v, colour]) => {
  const last = window.__depth.at(-1);
  if (!last) return 1e9;
  const patch = window.__patch(last[2], u, v);
  let best = 1e9;
  for (let i = 0; i < patch.length; i += 4)
    best = Math.min(best, Math.abs(patch[i] - colour[0]) + Math.abs(patch[i + 1] - colour[1])
                          + Math.abs(patch[i + 2] - colour[2]));
  return best;
}"""
SHOWN = 60  # a JPEG's corner dot in the mirror's colour is within this of it


@pytest.fixture(scope="module")
def app(tmp_path_factory):
    app = sphere_app(tmp_path_factory.mktemp("tabs") / "session", fps=LIVE_FPS)
    app.start()
    yield app
    app.stop()


@pytest.fixture(scope="module")
def tabs(app, browser):
    """Three pages on the app, A, B and C, each with the app's Tab for it."""
    opened = [open_tab(browser, app, 1000, 700) for _ in range(3)]
    yield opened
    for page, _ in opened:
        page.close()


def shows(page, uv, colour) -> bool:
    """Whether the last depth frame the page received has `colour` near pixel uv."""
    found = page.evaluate(NEAREST_COLOUR, [float(uv[0]), float(uv[1]), [int(c) for c in colour]])
    return found < SHOWN


def test_a_double_click_on_add_adds_one_mirror_and_undo_leaves_none(app, tabs):
    (page, tab), _, _ = tabs
    page.get_by_role("button", name="Add a mirror", exact=True).dblclick()
    # the page answered a question sent after it was sent the new mirror: a second click it sent
    # came before that answer
    # a page busy drawing on a loaded machine answers late: generous
    wait_for(lambda: tab.seen.mirrors, 60, "the page's answer")
    time.sleep(1.0)  # deliberate: a second add, had one come, runs on a worker thread by now
    assert [m.id for m in app.editor.session.mirrors] == [1]
    assert [m.id for m in tab.seen.mirrors] == [1]
    wait_for(lambda: tab.state.mode == "boundary", 30, "boundary mode on the new mirror")
    button(page, "Undo: add mirror 1")
    wait_for(lambda: not app.editor.session.mirrors, 30, "the mirror taken back")
    wait_for(lambda: page.get_by_role("button", name="Undo", exact=True).is_disabled(), 30,
             "nothing left to undo")


def test_a_draft_never_replaces_an_outline_closed_in_another_tab(app, tabs):
    """C draws two corners of mirror 1's outline; B draws and closes it. C's draft is dropped and
    C told; C's picture and panel both show B's outline, and C's next click does not replace it."""
    _, (page_b, tab_b), (page_c, tab_c) = tabs
    rig = app.source.rig
    truth = session_mirrors(rig, rig.background().truth)[0]
    corners = np.clip(np.array(truth.boundary), 1,
                      [rig.intrinsics.width - 2, rig.intrinsics.height - 2])
    centre = corners.mean(axis=0)
    button(page_b, "Add a mirror")  # selects it, boundary mode, the depth frame
    wait_for(lambda: len(app.editor.session.mirrors) == 1 and tab_b.state.mode == "boundary", 30,
             "mirror 1 in boundary mode")
    wait_for(lambda: tab_c.state.mirror_id == 1, 30, "mirror 1 selected in C")
    button(page_c, "Boundary")
    look_at_the_depth_frame(page_c, tab_c, press=False)
    draft = [centre + (-20, -20), centre + (20, -20)]
    for k, uv in enumerate(draft, start=1):
        click_pixel(page_c, tab_c, uv, lambda: len(tab_c.state.drafts.get(1, ())) >= k)
    colour = source_colour(1, (1,))
    wait_for(lambda: shows(page_c, draft[1], colour), 30, "C's draft in C's page")
    look_at_the_depth_frame(page_b, tab_b, press=False)
    for k, uv in enumerate(corners, start=1):
        click_pixel(page_b, tab_b, uv, lambda: len(tab_b.state.drafts.get(1, ())) >= k)
    click_pixel(page_b, tab_b, corners[0], lambda: app.editor.mirror(1).boundary)
    outline = app.editor.mirror(1).boundary
    np.testing.assert_allclose(np.array(outline), corners, atol=1.0)
    # C: told, its draft gone, its panel and its picture on B's outline
    wait_for(lambda: "Outline of mirror 1 drawn in another tab" in text(page_c), 30, "C told")
    assert not tab_c.state.drafts
    wait_for(lambda: "Delete the picked corner" in text(page_c), 30, "C's panel: closed")
    assert "Close boundary" not in text(page_c)
    wait_for(lambda: shows(page_c, corners[2], colour) and not shows(page_c, draft[1], colour), 30,
             "C's picture: B's outline, not C's draft")
    # C's click on its draft's first corner does not start or close an outline over B's
    click_pixel(page_c, tab_c, draft[0])
    wait_for(lambda: "has a boundary" in text(page_c), 30, "the refusal")
    assert app.editor.mirror(1).boundary == outline


def test_a_redo_that_removes_a_mirror_asks_and_every_tab_is_told(app, tabs):
    """A removes mirror 1, every tab is told; C brings it back; A's Redo would remove it again:
    it asks first (Keep it keeps it), then removes it on Remove, and every tab is told again."""
    (page_a, tab_a), (page_b, _), (page_c, tab_c) = tabs
    outline = app.editor.mirror(1).boundary
    wait_for(lambda: tab_a.state.mirror_id == 1, 30, "mirror 1 selected in A")
    page_a.get_by_text("Rename, glass, remove, clear").click()
    button(page_a, "Remove this mirror…")
    button(page_a, "Remove mirror 1")
    wait_for(lambda: not app.editor.session.mirrors, 30, "mirror 1 removed")
    for page in (page_a, page_b, page_c):
        wait_for(lambda: "mirror 1 removed" in text(page), 30, "every tab told")
    wait_for(lambda: page_c.get_by_role("button", name="Undo: remove mirror 1").is_enabled(), 30,
             "C's Undo offers it")
    button(page_c, "Undo: remove mirror 1")
    wait_for(lambda: app.editor.session.mirrors, 30, "mirror 1 back")
    wait_for(lambda: page_a.get_by_role("button", name="Redo: remove mirror 1").is_enabled(), 30,
             "A's Redo offers the removal again")
    button(page_a, "Redo: remove mirror 1")
    wait_for(lambda: "Redo: remove mirror 1?" in text(page_a), 30, "the question")
    assert app.editor.mirror(1).boundary == outline  # not removed yet
    button(page_a, "Keep it")
    assert app.editor.mirror(1).boundary == outline
    button(page_a, "Redo: remove mirror 1")
    wait_for(lambda: "Redo: remove mirror 1?" in text(page_a), 30, "the question again")
    button(page_a, "Remove mirror 1")
    wait_for(lambda: not app.editor.session.mirrors, 30, "mirror 1 removed by the redo")
    wait_for(lambda: tab_c.state.mirror_id is None, 30, "C's selection cleared")
    for page in (page_b, page_c):
        wait_for(lambda: text(page).count("mirror 1 removed") >= 1, 30, "every tab told")
