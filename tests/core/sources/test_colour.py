"""Colour registered to depth from the recorded sources: TUM folders by nearest stamp, .npz
stacks, session folders and their recording round trip; sources without colour say so."""
from pathlib import Path

import cv2
import numpy as np
import pytest

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.sources import StackSource, open_source, record

H, W = 48, 64


def _write_png(path: Path, image: np.ndarray) -> None:
    path.parent.mkdir(exist_ok=True)
    assert cv2.imwrite(str(path), image)


def _colours(n: int) -> np.ndarray:
    """n (H, W, 3) uint8 RGB images, each a gradient of its own hue."""
    ramp = np.linspace(0, 200, W, dtype=np.uint8)[None, :, None]
    tint = np.array([[40, 0, 0], [0, 40, 0], [0, 0, 40], [20, 20, 0], [0, 20, 20]], np.uint8)
    return np.stack([np.broadcast_to(ramp, (H, W, 3)) + tint[k] for k in range(n)])


def test_tum_colour_is_the_nearest_rgb_within_the_gap_on_the_depth_grid(tmp_path):
    depth_stamps = [10.00, 10.10, 10.20]
    # frame 0: 10.005 is nearer than 9.985; frame 1: 10.112; frame 2: nearest is 0.045 s off
    rgb_stamps = [9.985, 10.005, 10.112, 10.14, 10.245]
    colours = _colours(len(rgb_stamps))
    for k, t in enumerate(depth_stamps):
        _write_png(tmp_path / "depth" / f"{t:.3f}.png", np.full((H, W), 5000 + k, np.uint16))
    for t, rgb in zip(rgb_stamps, colours):
        _write_png(tmp_path / "rgb" / f"{t:.3f}.png", rgb[..., ::-1])
    (tmp_path / "depth.txt").write_text("".join(f"{t:.3f} depth/{t:.3f}.png\n"
                                                for t in depth_stamps))
    (tmp_path / "rgb.txt").write_text("".join(f"{t:.3f} rgb/{t:.3f}.png\n" for t in rgb_stamps))
    (tmp_path / "cam.json").write_text(
        f'{{"width": {W}, "height": {H}, "fx": 50, "fy": 50, "cx": 31.5, "cy": 23.5}}')
    with open_source(f"tum:{tmp_path}?camera={tmp_path / 'cam.json'}") as source:
        assert source.has_colour
        frames = list(source)
    for frame in frames[:2]:
        assert frame.colour.shape == (H, W, 3) and frame.colour.dtype == np.uint8
    np.testing.assert_array_equal(frames[0].colour, colours[1])
    np.testing.assert_array_equal(frames[1].colour, colours[2])
    assert frames[2].colour is None
    assert frames[2].depth[0, 0] == pytest.approx(5002 / 5000)


def _stack(colour: bool) -> StackSource:
    camera = Intrinsics(W, H, 50.0, 50.0, 31.5, 23.5, 0.001)
    units = np.arange(3)[:, None, None] * 10 + np.full((3, H, W), 1500, np.uint16)
    return StackSource("stack", camera, units.astype(np.uint16), 0.001, np.arange(3) / 30,
                       _colours(3) if colour else None)


def test_npz_png_folder_and_bare_stacks_say_whether_they_have_colour(tmp_path):
    stack = _stack(True)
    K = np.array([[50.0, 0, 31.5], [0, 50.0, 23.5], [0, 0, 1]])
    np.savez(tmp_path / "c.npz", depth=stack.units, K=K, depth_scale=0.001, colour=stack.colour)
    with open_source(str(tmp_path / "c.npz")) as source:
        assert source.has_colour
        np.testing.assert_array_equal(source.read(2).colour, _colours(3)[2])
    assert not _stack(False).has_colour and _stack(False).read(0).colour is None
    _write_png(tmp_path / "pngs" / "0.png", np.full((H, W), 900, np.uint16))
    assert not open_source(f"dir:{tmp_path / 'pngs'}?camera=primesense").has_colour


def test_a_recording_keeps_its_sources_colour_and_plays_it_back(tmp_path):
    session = record(_stack(True), tmp_path / "rec")
    assert session.colour_frames is not None and len(session.colour_frames) == 3
    with open_source(str(tmp_path / "rec")) as played:
        assert played.has_colour
        got = [played.read(i) for i in range(3)]
    for frame, expected, k in zip(got, _colours(3), range(3)):
        np.testing.assert_array_equal(frame.colour, expected)
        np.testing.assert_allclose(frame.depth, 1.5 + 0.01 * k, atol=1e-6)
    record(_stack(False), tmp_path / "bare")
    with open_source(str(tmp_path / "bare")) as played:
        assert not played.has_colour and played.read(0).colour is None


def test_colour_is_an_option_of_the_cameras_only(tmp_path):
    (tmp_path / "depth.txt").write_text("1.0 d.png\n")
    with pytest.raises(MirrorscanError, match="colour=registered is not read here"):
        open_source(f"tum:{tmp_path}?colour=registered")
    with pytest.raises(MirrorscanError, match="colour=rgb is not read here"):
        open_source("freenect:0?colour=rgb")
