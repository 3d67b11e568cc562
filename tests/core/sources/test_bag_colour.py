"""RealSense .bag recordings with a colour stream, written here with pyrealsense2's software
device: the colour is aligned to the depth grid by rs.align and paired by time."""
import numpy as np
import pytest

from mirrorcore.sources import KINDS, open_source, record
from tests.core.sources.test_devices import write_bag

H, W = 48, 64
# fx = 58 px: a colour camera 5 cm along x sees a wall 1.45 m away 2 px further right
WALL_UNITS, SHIFT_M, SHIFT_PX = 1450, 0.05, 2


def _colours(n: int) -> np.ndarray:
    """n (H, W, 3) uint8 RGB images: red 3 x column, green 4 x row, blue 50 x the image's index."""
    v, u = np.mgrid[:H, :W]
    return np.stack([np.stack([3 * u, 4 * v, np.full_like(u, 50 * k)], axis=-1)
                     for k in range(n)]).astype(np.uint8)


def test_bag_colour_is_aligned_to_the_depth_grid(tmp_path):
    depth = np.full((3, H, W), WALL_UNITS, np.uint16)
    depth[:, :, 10] = 0                                                # a column without a reading
    colour = _colours(3)
    write_bag(tmp_path / "c.bag", depth, 0.001, colour, shift_m=SHIFT_M)
    with open_source(str(tmp_path / "c.bag")) as source:
        assert source.has_colour and source.frame_count == 3
        frames = [source.read(i) for i in (2, 0, 1)]                  # seekable: any order
    for frame, k in zip(frames, (2, 0, 1)):
        assert frame.colour.dtype == np.uint8 and frame.colour.shape == (H, W, 3)
        np.testing.assert_array_equal(frame.units, depth[k])
        inside = frame.colour[:, 12:W - SHIFT_PX - 1]
        u = np.arange(12, W - SHIFT_PX - 1)
        # depth pixel u sees what colour pixel u + 2 sees
        np.testing.assert_array_equal(inside[..., 0], np.broadcast_to(3 * (u + SHIFT_PX),
                                                                      inside.shape[:2]))
        np.testing.assert_array_equal(inside[..., 1], colour[k, :, 12:W - SHIFT_PX - 1, 1])
        assert np.all(inside[..., 2] == 50 * k)
        # no depth, no colour
        assert not frame.colour[:, 10].any()


def test_a_larger_colour_image_is_brought_to_the_depth_grid(tmp_path):
    depth = np.full((1, H, W), WALL_UNITS, np.uint16)
    v, u = np.mgrid[:2 * H, :2 * W]
    # red = the colour image's column, green = its row
    colour = np.stack([u, v, np.zeros_like(u)], axis=-1)[None].astype(np.uint8)
    write_bag(tmp_path / "big.bag", depth, 0.001, colour)
    with open_source(str(tmp_path / "big.bag")) as source:
        frame = source.read(0)
    assert frame.colour.shape == (H, W, 3)
    # depth pixel u's centre is colour column 2u + 0.5
    dv, du = np.mgrid[1:H - 1, 1:W - 1]
    assert np.all(np.isin(frame.colour[1:-1, 1:-1, 0] - 2 * du, (0, 1)))
    assert np.all(np.isin(frame.colour[1:-1, 1:-1, 1] - 2 * dv, (0, 1)))


def test_each_depth_frame_takes_the_colour_frame_nearest_in_time(tmp_path):
    depth = np.full((4, H, W), WALL_UNITS, np.uint16)
    # depth at 0, 33.3, 66.7, 100 ms; colour at 2, 30, 40, 75 ms: 0, 1, 3 and 3 are nearest
    colour = _colours(4)
    write_bag(tmp_path / "t.bag", depth, 0.001, colour, colour_ms=[2.0, 30.0, 40.0, 75.0])
    with open_source(f"bag:{tmp_path / 't.bag'}") as source:
        blues = [int(source.read(i).colour[..., 2].max()) for i in range(4)]
    assert blues == [0, 50, 150, 150]


def test_bgr_colour_streams_are_read_as_rgb(tmp_path):
    depth = np.full((2, H, W), WALL_UNITS, np.uint16)
    colour = _colours(2)
    write_bag(tmp_path / "b.bag", depth, 0.001, colour[..., ::-1].copy(), colour_format="bgr8")
    with open_source(str(tmp_path / "b.bag")) as source:
        np.testing.assert_array_equal(source.read(1).colour, colour[1])


def test_a_bag_without_colour_says_so(tmp_path):
    write_bag(tmp_path / "d.bag", np.full((2, H, W), WALL_UNITS, np.uint16), 0.001)
    with open_source(str(tmp_path / "d.bag")) as source:
        assert not source.has_colour and source.read(1).colour is None


def test_the_sources_table_says_what_bags_do_with_colour():
    bag = next(kind for kind in KINDS if kind.name == "bag")
    assert "aligned to depth" in bag.colour


def test_a_recording_of_a_bag_keeps_its_colour(tmp_path):
    depth = np.full((2, H, W), WALL_UNITS, np.uint16)
    write_bag(tmp_path / "r.bag", depth, 0.001, _colours(2))
    with open_source(str(tmp_path / "r.bag")) as source:
        session = record(source, tmp_path / "rec")
    assert session.colour_frames is not None and len(session.colour_frames) == 2
    with open_source(str(tmp_path / "rec")) as played:
        np.testing.assert_array_equal(played.read(1).colour, _colours(2)[1])


def test_every_frame_of_a_longer_bag_keeps_its_own_colour(tmp_path):
    """Neither playback drops a frame: frame k's colour (blue 8 k) comes with depth frame k."""
    n = 30
    depth = np.full((n, H, W), WALL_UNITS, np.uint16)
    colour = np.zeros((n, H, W, 3), np.uint8)
    colour[..., 2] = 8 * np.arange(n)[:, None, None]
    write_bag(tmp_path / "long.bag", depth, 0.001, colour)
    with open_source(str(tmp_path / "long.bag")) as source:
        assert source.frame_count == n
        blues = [int(source.read(i).colour[..., 2].max()) for i in range(n)]
        # seeking back replays both playbacks
        assert int(source.read(4).colour[..., 2].max()) == 32
    assert blues == [8 * k for k in range(n)]
