"""What the live loop streams to a tab (mirrorscan.stream): float16 offsets within 0.3 mm of every
point, one node per source, each point's colour in true colour, views through several mirrors
named and drawn."""

import numpy as np
import pytest
from mirrorscan.editor import SESSION_SCOPE
from mirrorscan.stream import FLOAT16_EXTENT, MAX_POINTS, Anchors, downsample, stream_parts

from mirrorcore.base.palette import source_colour
from mirrorcore.rig.cloud import Cloud
from tests.app.support import simulated_app


def test_float16_offsets_keep_every_point_within_a_third_of_a_millimetre():
    rng = np.random.default_rng(0)
    points = (rng.uniform(-0.95, 0.95, (20_000, 3)) + [0.3, -0.2, 3.0]).astype(np.float32)
    sources = rng.integers(0, 3, len(points)).astype(np.uint8)
    parts = stream_parts(Cloud(points, sources, np.arange(len(points)), 640), range(3))
    assert [p.key for p in parts] == [(0, 0), (0, 1), (1, 0), (1, 1), (2, 0), (2, 1)]
    second = stream_parts(
        Cloud(points, sources, np.arange(len(points)), 640), range(3), halves=(1,)
    )
    # a live frame's half alone
    assert [p.key for p in second] == [(0, 1), (1, 1), (2, 1)]
    for part, whole in zip(second, parts[1::2]):
        np.testing.assert_array_equal(part.offsets, whole.offsets)
        np.testing.assert_array_equal(part.centre, whole.centre)
    for part in parts:
        assert part.offsets.dtype == np.float16 and part.offsets.flags.c_contiguous
        mine = points[sources == part.source][part.half :: 2]
        np.testing.assert_array_equal(
            part.offsets, (mine - part.centre.astype(np.float32)).astype(np.float16)
        )
        back = part.offsets.astype(np.float64) + part.centre
        np.testing.assert_array_less(np.abs(back - mine), 0.3e-3)
    wide = (
        points * [1, 1, 1] + np.where(np.arange(len(points)) % 2, 0, 2.5 * FLOAT16_EXTENT)[:, None]
    )
    parts = stream_parts(
        Cloud(wide.astype(np.float32), sources, np.arange(len(points)), 640), range(4)
    )
    # too wide for float16: float32
    assert {p.offsets.dtype for p in parts[:6]} == {np.dtype(np.float32)}
    # an absent source is cleared
    assert len(parts[6].offsets) == len(parts[7].offsets) == 0


def test_a_source_keeps_its_centre_while_its_points_stay_within_reach():
    """The walking person moves: the node keeps its centre (no pose update) until a point would
    leave float16's reach of it, and every point stays within 0.3 mm meanwhile."""
    rng = np.random.default_rng(1)
    body = rng.uniform(-0.3, 0.3, (4_000, 3)).astype(np.float32) + np.float32([0, 0, 3])
    sources = np.zeros(len(body), np.uint8)
    anchors, centres = Anchors(), []
    # 1.2 m to the side, 0.1 m a frame
    for step in np.arange(0, 1.2, 0.1, dtype=np.float32):
        points = body + np.float32([step, 0, 0])
        part = stream_parts(
            Cloud(points, sources, np.arange(len(points)), 640), [0], halves=(0,), anchors=anchors
        )[0]
        assert part.offsets.dtype == np.float16
        np.testing.assert_array_less(
            np.abs(part.offsets.astype(np.float64) + part.centre - points[0::2]), 0.3e-3
        )
        centres.append(part.centre[0])
    # the frames whose centre is new
    moved = np.flatnonzero(np.diff(centres)) + 1
    # the middle of the first frame's box, kept
    assert centres[0] == pytest.approx(0, abs=0.01)
    # until its far side (0.3 m + step) reaches 1 m
    assert len(moved) == 1 and moved[0] in (7, 8), centres
    # then the middle of the box again
    assert centres[moved[0]] == pytest.approx(0.1 * moved[0], abs=0.01)


def test_parts_in_true_colour_carry_each_points_colour():
    """Each part's colours are its points' `rgb` (a strided view, as Algorithm 1 gives it), in the
    order of its offsets, downsampled with them; without true colour a part has none."""
    rng = np.random.default_rng(2)
    n = 9_001
    points = (rng.uniform(-0.5, 0.5, (n, 3)) + [0.0, 0.0, 2.0]).astype(np.float32)
    sources = rng.integers(0, 3, n).astype(np.uint8)
    rgba = rng.integers(0, 256, (n, 4), dtype=np.uint8)
    cloud = Cloud(points, sources, np.arange(n), 640, rgba[:, :3])
    for max_points in (MAX_POINTS, 4_000):
        parts = stream_parts(cloud, range(3), max_points=max_points, true_colour=True)
        thinned = downsample(cloud, max_points)
        assert sum(len(p.colours) for p in parts) == len(thinned)
        for part in parts:
            mine = thinned.sources == part.source
            assert part.colours.dtype == np.uint8 and part.colours.flags.c_contiguous
            np.testing.assert_array_equal(part.colours, thinned.rgb[mine][part.half :: 2])
            np.testing.assert_array_equal(
                part.offsets,
                (thinned.points[mine][part.half :: 2] - part.centre.astype(np.float32)).astype(
                    np.float16
                ),
            )
    assert all(p.colours is None for p in stream_parts(cloud, range(3)))


def test_a_source_with_no_points_is_cleared_in_true_colour_too():
    """A source that left the view (a mirror added, with no plane yet) or a half with none of its
    points is an empty part with no colours, not an error that stops the frame."""
    points = np.array([[0.0, 0.0, 2.0], [0.1, 0.0, 2.0], [0.2, 0.0, 2.0]], np.float32)
    rgb = np.array([[10, 20, 30], [40, 50, 60], [70, 80, 90]], np.uint8)
    cloud = Cloud(points, np.array([0, 0, 1], np.uint8), np.arange(3), 640, rgb)
    parts = {(p.source, p.half): p for p in stream_parts(cloud, range(3), true_colour=True)}
    assert len(parts) == 6
    for empty in ((1, 1), (2, 0), (2, 1)):
        assert parts[empty].colours.shape == (0, 3) and len(parts[empty].offsets) == 0
    np.testing.assert_array_equal(parts[1, 0].colours, [[70, 80, 90]])
    np.testing.assert_array_equal(parts[0, 1].colours, [[40, 50, 60]])


def test_a_tab_in_true_colour_is_sent_each_points_colour(demo):
    """Two frames in a row: every node's colours are its points' `rgb`; in the sources' colours a
    node has its source's one colour (the live frame's parts of each colouring made once)."""
    app, headless = demo
    tab = headless.tab
    assert tab.true_colour
    frames = [app.loop.run_once(), app.loop.run_once()]
    for (j, half), handle in tab.scene._clouds.items():
        cloud = next(f for f in frames if f.index % 2 == half).cloud
        assert handle.colors.shape == (len(handle.points), 3)
        np.testing.assert_array_equal(handle.colors, cloud.rgb[cloud.sources == j][half::2])
    assert frames[1].parts(1, True) is frames[1].parts(1, True)
    tab.colour_by(False)
    try:
        for (j, _), handle in tab.scene._clouds.items():
            np.testing.assert_array_equal(handle.colors, source_colour(j, frames[1].mirror_ids))
        app.loop.run_once()
        assert all(h.colors.shape == (3,) for h in tab.scene._clouds.values())
    finally:
        tab.colour_by(True)
    assert all(h.colors.shape == (len(h.points), 3) for h in tab.scene._clouds.values())


def test_live_frames_reach_the_tab_every_point_within_a_third_of_a_millimetre(demo):
    """Two frames in a row: each refreshes one half of every source, so the tab shows every point of
    the two."""
    app, headless = demo
    tab = headless.tab
    frames = [app.loop.run_once(), app.loop.run_once()]
    counts = frames[1].cloud.counts(2)
    assert min(counts.values()) > 1000, counts
    nodes = tab.scene._clouds
    assert sorted(nodes) == [(j, h) for j in range(3) for h in range(2)]
    # each node holds its own source's half of its frame
    for (j, half), handle in nodes.items():
        frame = next(f for f in frames if f.index % 2 == half)
        assert handle.precision == "float16"
        got = handle.points.astype(np.float64) + handle.position
        expected = frame.cloud.points[frame.cloud.sources == j][half::2]
        np.testing.assert_array_less(np.abs(got - expected), 0.3e-3)
    shown = sum(len(h.points) for h in nodes.values())
    assert abs(shown - len(frames[1].cloud)) < 0.02 * len(frames[1].cloud)  # every point shown
    assert "mirror 2" in tab.header.legend.content
    tab._send_screen(force=True)
    assert tab.screen.handle.image.shape == (480, 640, 3)


def test_views_through_several_mirrors_are_streamed_named_and_drawn(notes):
    """On a 72-degree kaleidoscope with its true planes: the views through two mirrors in turn reach
    the tab as sources of their own, the legend names them with the mirrors' names, their virtual
    cameras are drawn, and the number of mirrors followed is a session setting that can be undone.
    """
    from mirrorscan.bench.tabs import HeadlessTab

    from mirrorcore.base.palette import FIRST_MULTI_LABEL
    from mirrorcore.sim.layouts import kaleidoscope_scene

    app = simulated_app(kaleidoscope_scene(72.0))
    try:
        with HeadlessTab(app) as headless:
            tab = headless.tab
            frame = app.loop.run_once()
            multi = [label for label in frame.counts if label >= FIRST_MULTI_LABEL]
            assert multi and all(frame.counts[label] > 100 for label in multi)
            # streamed as their own nodes
            assert {label for label, _ in tab.scene._clouds} >= set(multi)
            assert "mirror 1 then mirror 2" in tab.header.legend.content
            # first and second order
            assert len(tab.scene._virtual) >= 2 + len(multi)
            named = {label.text for label in tab.scene._virtual_labels}
            assert {"camera in mirror 1", "camera in mirror 1 then mirror 2"} <= named
            app.editor.set_bounces(1)
            frame = app.loop.run_once()
            assert max(frame.counts) <= 2 and app.snapshot.session.bounces == 1
            # the tab's own cameras too
            assert len(tab.scene._virtual) == 2
            assert len(tab.scene._virtual_labels) == 2
            assert app.editor.undo(SESSION_SCOPE) == "mirrors followed in turn"
            assert app.snapshot.session.bounces == 3
            assert len(tab.scene._virtual) >= 2 + len(multi)
    finally:
        app.stop()
