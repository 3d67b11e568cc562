"""Recorded depth sources: real frames through the PNG-folder and TUM readers, .npz stacks, spec
strings."""
import json
import os
import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest

from mirrorcore.base.errors import FileFormatError, MirrorscanError
from mirrorcore.geometry.fitting import fit_sphere
from mirrorcore.geometry.camera import Intrinsics, reproject_depth
from mirrorcore.sources import Frame, StackSource, open_source, parse_spec

REAL = Path(__file__).resolve().parents[4] / "shared" / "data" / "real"
needs_real = pytest.mark.skipif(not REAL.is_dir(),
                                reason=f"no real frames at {REAL} (shared/ beside the clone)")


@needs_real
def test_png_folder_reads_the_kinect_room_in_millimetres(tmp_path):
    for k in (1, 2, 3):
        shutil.copy(REAL / f"kinect_room_depth_{k}.png", tmp_path / f"{k:06d}.png")
    (tmp_path / "camera.json").write_text(json.dumps(
        {"width": 640, "height": 480, "fx": 518.0, "fy": 519.0, "cx": 325.5, "cy": 253.5,
         "depth_scale": 0.001}))
    with open_source(f"dir:{tmp_path}") as source:
        assert source.frame_count == 3 and not source.live and source.intrinsics.fx == 518.0
        frames = list(source)
    units = cv2.imread(str(REAL / "kinect_room_depth_2.png"), cv2.IMREAD_UNCHANGED)
    np.testing.assert_array_equal(frames[1].depth, units.astype(np.float32) * np.float32(0.001))
    assert [f.timestamp for f in frames] == pytest.approx([0, 1 / 30, 2 / 30])
    assert 1.0 < np.median(frames[0].depth[frames[0].depth > 0]) < 4.0        # a room, in metres
    # a bare path, options override
    again = open_source(f"{tmp_path}?camera=primesense&scale=0.002&fps=10")
    # read(4) loops to 1
    assert again.intrinsics.fx == 525.0 and again.read(4).timestamp == pytest.approx(0.1)
    np.testing.assert_array_equal(again.read(4).depth, 2 * frames[1].depth)


@needs_real
def test_tum_folder_finds_the_globe_at_2_2_m_with_its_colour(tmp_path):
    (tmp_path / "depth").mkdir()
    (tmp_path / "rgb").mkdir()
    shutil.copy(REAL / "tum_globe_depth.png", tmp_path / "depth" / "1305031102.160407.png")
    shutil.copy(REAL / "tum_globe_color.png", tmp_path / "rgb" / "1305031102.175304.png")
    (tmp_path / "depth.txt").write_text(
        "# depth maps\n1305031102.160407 depth/1305031102.160407.png\n")
    (tmp_path / "rgb.txt").write_text("# colour\n1305031102.175304 rgb/1305031102.175304.png\n"
                                      "1305031109.0 rgb/missing.png\n")
    source = open_source(f"tum:{tmp_path}")
    assert source.frame_count == 1 and source.intrinsics.depth_scale == pytest.approx(1 / 5000)
    frame = source.read(0)
    assert frame.timestamp == 1305031102.160407
    bgr = cv2.imread(str(REAL / "tum_globe_color.png"))
    np.testing.assert_array_equal(frame.colour, bgr[..., ::-1])
    box = np.zeros(source.intrinsics.shape, bool)
    box[20:200, 60:260] = True                          # where the README says the globe stands
    # in front of the cabinet behind it (2.3 m+)
    near = box & (frame.depth > 1.8) & (frame.depth < 2.25)
    points, _ = reproject_depth(source.intrinsics, frame.depth, near)
    globe = fit_sphere(points, np.random.default_rng(0)).shape
    assert 0.20 < globe.radius < 0.24                  # an inflatable globe, about 21-23 cm
    # its front at about 2.1 m, its centre one radius behind
    assert 2.2 < globe.centre[2] < 2.45


def test_npz_stack_integer_and_float_with_no_readings(tmp_path):
    depth = np.array([[[1000, 0], [2000, 65535]], [[1500, 1], [2, 3]]], np.uint16)
    K = np.array([[500.0, 0, 0.5], [0, 500.0, 0.5], [0, 0, 1]])
    np.savez(tmp_path / "u.npz", depth=depth, K=K, depth_scale=0.001,
             timestamps=np.array([5.0, 5.5]))
    source = open_source(str(tmp_path / "u.npz"))
    assert isinstance(source, StackSource) and source.intrinsics == Intrinsics(
        2, 2, 500, 500, 0.5, 0.5, 0.001)
    frame = source.read(0)
    assert isinstance(frame, Frame) and frame.timestamp == 5.0 and frame.colour is None
    np.testing.assert_array_equal(frame.units, depth[0])
    np.testing.assert_allclose(frame.depth, [[1.0, 0.0], [2.0, 65.535]], rtol=1e-6)
    floats = np.array([[np.nan, np.inf], [-1.0, 2.5]], np.float32)
    np.savez(tmp_path / "f.npz", depth=floats, K=K)
    frame = open_source(f"npz:{tmp_path / 'f.npz'}").read(0)
    np.testing.assert_array_equal(frame.depth, [[0, 0], [0, 2.5]])
    assert frame.units is None and frame.depth.dtype == np.float32


def test_npz_errors_name_the_file_and_never_unpickle(tmp_path):
    K = np.eye(3)
    np.savez(tmp_path / "pickled.npz", depth=np.array([{"x": 1}], dtype=object), K=K)
    np.savez(tmp_path / "nok.npz", depth=np.zeros((1, 2, 2), np.uint16), depth_scale=0.001)
    np.savez(tmp_path / "noscale.npz", depth=np.zeros((1, 2, 2), np.uint16), K=K)
    np.savez(tmp_path / "badk.npz", depth=np.zeros((1, 2, 2), np.float32), K=np.eye(2))
    np.savez(tmp_path / "complex.npz", depth=np.zeros((1, 2, 2), np.uint8), K=K,
             depth_scale=np.complex64(1j))
    (tmp_path / "junk.npz").write_bytes(b"not a zip")
    cases = {"pickled": "holds pickled \\(object\\) arrays, which mirrorscan never loads",
             "nok": "missing array 'K'",
             "noscale": "an integer depth stack needs 'depth_scale'",
             "badk": "'K' must be integer or floating of shape \\(3, 3\\)",
             "junk": "not a .npz archive",
             # a TypeError,
             "complex": "'depth_scale' must be integer or floating of shape \\(\\), got complex64"}
    # found by the fuzzing (tests/core/io/test_fuzz_loaders.py)
    for name, message in cases.items():
        with pytest.raises(FileFormatError, match=rf"{name}.npz: {message}"):
            open_source(f"npz:{tmp_path / name}.npz")


def test_png_folder_and_tum_errors(tmp_path):
    cv2.imwrite(str(tmp_path / "a.png"), np.zeros((4, 4), np.uint16))
    with pytest.raises(FileFormatError,
                       match="no camera.json or intrinsic.json; give the camera as"):
        open_source(f"dir:{tmp_path}")
    with pytest.raises(FileFormatError,
                       match=r"a.png: size 4x4 does not match the camera's 640x480"):
        open_source(f"dir:{tmp_path}?camera=kinect_v1").read(0)
    (tmp_path / "depth.txt").write_text("1.0\n")
    with pytest.raises(FileFormatError, match=r"depth.txt: line 1 is not 'timestamp path'"):
        open_source(f"tum:{tmp_path}")



@pytest.mark.parametrize("stamps, message", [
    (("-1e308", "1e308"), r"depth.txt: line 2: timestamp -1e308 is not seconds of a recording"),
    (("0", "1e9"), r"depth.txt: 2 frames over 1e\+09 s is not a camera's rate"),
    (("5", "5", "5"), r"depth.txt: 3 frames over 0 s is not a camera's rate"),
])
def test_a_tum_folder_with_absurd_timestamps_is_refused_in_one_line(tmp_path, stamps, message):
    cv2.imwrite(str(tmp_path / "d.png"), np.zeros((480, 640), np.uint16))
    lines = "".join(f"{t} d.png\n" for t in stamps)
    (tmp_path / "depth.txt").write_text(f"# depth maps\n{lines}")
    with pytest.raises(FileFormatError, match=message):
        open_source(f"tum:{tmp_path}")
    (tmp_path / "depth.txt").write_text("1305031102.16 d.png\n1305031102.19 d.png\n")
    assert open_source(f"tum:{tmp_path}").fps == pytest.approx(1 / 0.03)

def test_spec_strings_split_into_kind_target_and_options():
    assert parse_spec("freenect:0") == ("freenect", "0", {})
    assert parse_spec("dir:/data/x?scale=0.0002&camera=cam.yaml") == ("dir", "/data/x", {
        "scale": "0.0002", "camera": "cam.yaml"})
    assert parse_spec("session") == ("session", "", {})
    with pytest.raises(MirrorscanError, match="unknown option\\(s\\) speed"):
        parse_spec("sim?speed=2")
    with pytest.raises(MirrorscanError, match="unknown source 'kinect'.*mirrorscan sources"):
        open_source("kinect")
    with pytest.raises(MirrorscanError, match="fps must be a positive number, got '-1'"):
        open_source("sim?fps=-1")
    with pytest.raises(MirrorscanError, match="freenect needs a device index"):
        open_source("freenect:first")


def test_a_tum_folder_named_in_no_utf8_plays_and_is_named_with_replacement_characters(tmp_path):
    folder = os.fsencode(tmp_path) + b"/caf\xe9"
    os.mkdir(folder)
    # written by Python: OpenCV cannot open such a path
    for name, image in ((b"d.png", np.zeros((480, 640), np.uint16)),
                        (b"c.png", np.full((480, 640, 3), 200, np.uint8))):
        with open(folder + b"/" + name, "wb") as f:
            f.write(cv2.imencode(".png", image)[1].tobytes())
    for name, image in ((b"depth.txt", "d.png"), (b"rgb.txt", "c.png")):
        with open(folder + b"/" + name, "w") as f:
            f.write(f"1305031102.16 {image}\n")
    source = open_source(f"tum:{os.fsdecode(folder)}")
    assert source.name == "TUM caf\ufffd" and source.name.encode("utf-8")
    frame = source.read(0)
    assert frame.depth.shape == (480, 640) and frame.colour[0, 0].tolist() == [200, 200, 200]
