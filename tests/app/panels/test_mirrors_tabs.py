"""The Mirrors panel with several tabs on the demo, without a browser: a double click on Add a
mirror adds one mirror, an edit made on a stale drawing is refused and its tab redrawn, a draft
gives way to an outline closed in another tab, and a Redo that removes a mirror asks first while
every tab is told of each removal."""
import asyncio

import mirrorscan.panels.mirrors.panel as panel_module
import numpy as np
from mirrorscan.bench.tabs import HeadlessTab
from mirrorscan.editor import SESSION_SCOPE
from mirrorscan.panels.mirrors import MirrorsPanel

from tests.app.panels.support import panel
from tests.waiting import wait_for


def test_a_double_click_on_add_adds_one_mirror(demo, notes, monkeypatch):
    app, headless = demo
    said, mirrors = notes(app), panel(headless.tab, MirrorsPanel)
    ids = [m.id for m in app.editor.session.mirrors]

    async def double_click() -> None:
        await mirrors._add_clicked(None)
        await mirrors._add_clicked(None)
    asyncio.run(double_click())
    assert len(app.editor.session.mirrors) == len(ids) + 1
    assert said == ["the session's mirrors or settings changed since this tab drew them; this tab "
                    "now shows it as it is: make the change again if it still applies"]
    # a click after the double-click time, once the page has the new mirror, is one of its own
    monkeypatch.setattr(panel_module, "DOUBLE_CLICK_S", 0.0)
    wait_for(lambda: headless.tab.seen is app.editor.session, 10, "the page's answer")
    asyncio.run(mirrors._add_clicked(None))
    assert len(app.editor.session.mirrors) == len(ids) + 2
    for _ in range(2):
        mirrors._travel(app.editor.undo)  # an empty mirror: taken back without a question
    assert [m.id for m in app.editor.session.mirrors] == ids
    mirrors._set_mode("inspect")


def test_an_edit_on_a_stale_drawing_is_refused_and_its_tab_redrawn(demo, notes):
    app, headless = demo
    said = notes(app)
    with HeadlessTab(app) as other:
        drawn = other.tab.drawn
        headless.tab.act(lambda: app.editor.add_marker(1, app.editor.mirror(1).markers[0]))
        markers = app.editor.mirror(1).markers
        other.tab.act(lambda: app.editor.delete_marker(1, 0), drawn)
        assert said == ["mirror 1 changed in another tab; this tab now shows it as it is: make the "
                        "change again if it still applies"]
        assert app.editor.mirror(1).markers == markers
        assert other.tab.drawn is app.editor.session
        # another mirror's edit, made on the same drawing, goes through
        other.tab.act(lambda: app.editor.rename_mirror(2, "right"), drawn)
        assert app.editor.mirror(2).name == "right" and len(said) == 1
        # the other tab shows it at once
        assert "right" in panel(headless.tab, MirrorsPanel).mirror.options
    app.editor.undo(2)
    app.editor.undo(1)


def test_a_draft_gives_way_to_an_outline_closed_in_another_tab(demo, notes):
    app, headless = demo
    said, outline = notes(app), app.editor.mirror(1).boundary
    app.editor.clear_boundary(1)
    with HeadlessTab(app) as other:
        other.tab.state.mirror_id, other.tab.state.mode = 1, "boundary"
        other.tab.state.drafts[1] = ((100.0, 100.0), (150.0, 100.0))
        other.tab.changed()
        headless.tab.act(lambda: app.editor.set_boundary(1, outline))
        assert not other.tab.state.drafts
        np.testing.assert_allclose(app.editor.mirror(1).boundary, outline, atol=0.01)
        assert said == ["mirror 1 now has the outline drawn in another tab; this tab's unfinished "
                        "outline of it is dropped."]
        # its panel says closed: no Close boundary, Delete the picked corner instead
        mirrors = panel(other.tab, MirrorsPanel)
        assert not mirrors.close.visible and mirrors.delete_corner.visible
    app.editor.undo(1)
    app.editor.undo(1)
    assert app.editor.mirror(1).boundary == outline


def test_a_redo_that_removes_a_mirror_asks_and_every_tab_is_told(demo, notes, monkeypatch):
    app, headless = demo
    said, tab, asked = notes(app), headless.tab, []
    mirrors = panel(tab, MirrorsPanel)
    monkeypatch.setattr(tab, "ask", lambda title, text, yes, on_yes, no: asked.append((title,
                                                                                        on_yes)))
    tab.state.mirror_id = 2
    mirrors._confirm_remove()
    asked.pop()[1]()
    assert [m.id for m in app.editor.session.mirrors] == [1]
    assert said == ["mirror 2 left the session; Undo in the Mirrors step brings it back."]
    app.editor.undo(SESSION_SCOPE)  # brought back in another tab
    mirrors._travel(app.editor.redo)
    title, remove = asked.pop()
    assert title == "Redo: remove mirror 2?" and len(app.editor.session.mirrors) == 2
    remove()
    assert [m.id for m in app.editor.session.mirrors] == [1] and len(said) == 2
    app.editor.undo(SESSION_SCOPE)
