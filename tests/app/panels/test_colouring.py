"""The header's colour control (mirrorscan.panels.colouring) on the demo: true colour, the sources'
colours and the heat map, one choice; true colour greyed out, with why, for a source without
colour; the legend following the choice; the colour image on the depth frame's screen."""

import numpy as np
from mirrorscan.bench.tabs import HeadlessTab
from mirrorscan.panels.colouring import BY_SOURCE, COLOURS, HEAT_MAP, TRUE_COLOUR
from mirrorscan.panels.live import COLOUR_IMAGE

from mirrorcore.sources import StackSource
from tests.waiting import wait_for


def per_point(tab) -> bool:
    """Whether every cloud node of the tab carries its points' colours."""
    nodes = tab.scene._clouds.values()
    return bool(nodes) and all(h.colors.shape == (len(h.points), 3) for h in nodes)


def without_colour(source, frames: int = 3) -> StackSource:
    """The first frames of a source, without their colour."""
    depth = np.stack([source.read(i).depth for i in range(frames)])
    return StackSource("depth only", source.intrinsics, depth, 1.0, np.arange(frames) / 30.0)


def test_one_control_switches_true_colour_source_and_heat_map(demo):
    """Each choice is one pick of the control: the cloud's nodes, the legend and the heat map
    follow it, from the 3D scene and from the depth frame (the heat map turns the view to the 3D
    scene, where it is drawn)."""
    app, headless = demo
    tab, header = headless.tab, headless.tab.header
    colours = header.colours
    app.loop.run_once()
    assert colours.choice.options == COLOURS and colours.choice.value == TRUE_COLOUR
    assert per_point(tab) and not colours.greyed.visible
    header.show(app.loop.run_once())
    legend = header.legend.content
    # true colour: no swatch of the sources' colours; the demo's mirrors have their gains
    assert "True colour" in legend and "background:rgb(" not in legend and "direct <b>" in legend
    assert "each mirror's tint undone" in legend and "no colour gain yet" not in legend
    colours.choose(BY_SOURCE, ticked=True)
    assert not tab.true_colour and colours.choice.value == BY_SOURCE
    assert all(h.colors.shape == (3,) for h in tab.scene._clouds.values())
    header.show(app.loop.run_once())
    assert "True colour" not in header.legend.content
    assert "background:rgb(" in header.legend.content
    tab.look("depth")
    colours.choose(HEAT_MAP, ticked=True)
    assert tab.heat and tab.state.view == "3d" and colours.choice.value == HEAT_MAP
    assert not any(h.visible for h in tab.scene._clouds.values())
    header.show(app.loop.run_once())
    assert "on the direct surface" in header.legend.content
    assert colours.heat_of.visible
    colours.choose(TRUE_COLOUR, ticked=True)
    assert not tab.heat and tab.true_colour and colours.choice.value == TRUE_COLOUR
    assert not colours.heat_of.visible and per_point(tab)
    assert all(h.visible for h in tab.scene._clouds.values())


def test_a_source_without_colour_greys_true_colour_and_shows_the_sources_colours(demo):
    """While a source without colour plays, true colour is not offered and the small print says
    why; the cloud and the legend show the sources' colours, and the colour image is not a view.
    The choice of true colour stays for the source that has colour."""
    app, headless = demo
    tab, header = headless.tab, headless.tab.header
    colours = header.colours
    assert tab.true_colour and COLOUR_IMAGE in header.view.options
    app.use_source(without_colour(app.source))
    try:
        assert colours.choice.options == (BY_SOURCE, HEAT_MAP)
        assert colours.choice.value == BY_SOURCE
        assert colours.greyed.visible
        assert "Greyed out: <b>true colour</b>: depth only has no colour image" in (
            colours.greyed.content
        )
        assert COLOUR_IMAGE not in header.view.options
        # each frame refreshes one half of the nodes
        frame = app.loop.run_once() and app.loop.run_once()
        assert frame.cloud.rgb is None and frame.colour is None
        assert all(h.colors.shape == (3,) for h in tab.scene._clouds.values())

        def legend_by_source() -> bool:
            # a frame of the coloured source the bus delivers late is followed by the next one
            header.show(app.loop.run_once() or frame)
            legend = header.legend.content
            return "background:rgb(" in legend and "True colour" not in legend

        wait_for(legend_by_source, 10, "the legend in the sources' colours")
        assert tab.true_colour
    finally:
        app.back_to_start_source()
        app.pause(True)
    assert colours.choice.options == COLOURS and colours.choice.value == TRUE_COLOUR
    assert not colours.greyed.visible and COLOUR_IMAGE in header.view.options
    app.loop.run_once()
    app.loop.run_once()
    assert per_point(tab)


def test_the_depth_frames_screen_shows_the_colour_image_under_the_outlines(demo):
    """View > Colour image: the colour image with the outlines, markers and handles drawn over it
    as over the depth frame; Depth frame goes back to the depth."""
    app, headless = demo
    tab, header = headless.tab, headless.tab.header
    frame = app.loop.run_once()
    header._look(COLOUR_IMAGE)
    try:
        assert tab.state.view == "depth" and tab.state.colour_image
        tab._send_screen(force=True)
        shown = tab.screen.handle.image
        drawn = tab.overlay.image[..., 3] > 0
        assert drawn.sum() > 500
        np.testing.assert_array_equal(shown[~drawn], frame.colour[~drawn])
        np.testing.assert_array_equal(shown[drawn], tab.overlay.image[..., :3][drawn])
        header._look("Depth frame")
        assert tab.state.view == "depth" and not tab.state.colour_image
        tab._send_screen(force=True)
        np.testing.assert_array_equal(tab.screen.handle.image[~drawn], frame.depth_rgb[~drawn])
    finally:
        header._look("3D scene")
    assert tab.state.view == "3d"


def test_a_reloaded_page_keeps_its_colouring(demo):
    """A page reloaded takes up its tab's colouring: the sources' colours chosen stay chosen."""
    app, _ = demo
    with HeadlessTab(app, page="colours") as before:
        tab = wait_for(lambda: before.tab.page == "colours" and before.tab, 10, "the page's name")
        tab.header.colours.choose(BY_SOURCE, ticked=True)
    with HeadlessTab(app, page="colours") as after:
        wait_for(
            lambda: not after.tab.true_colour
            and after.tab.header.colours.choice.value == BY_SOURCE,
            10,
            "the colouring taken up",
        )
