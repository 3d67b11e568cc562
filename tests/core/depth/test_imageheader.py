"""Images sized from their real header whatever their name: the format comes from the first bytes
and must be the name's, the size from the header before anything is decoded."""
from __future__ import annotations

import struct
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from mirrorcore.base.budget import MemoryBudgetError, set_memory_budget
from mirrorcore.base.errors import FileFormatError
from mirrorcore.depth.files import decode_depth_png, read_depth_png
from mirrorcore.depth.imageheader import read_header, sniff
from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.depth.files import read_colour

ROOT = Path(__file__).resolve().parents[3]
CAMERA = Intrinsics.primesense()


@pytest.fixture
def budget():
    yield set_memory_budget
    set_memory_budget(None)


def _encoded(suffix: str, image: np.ndarray) -> bytes:
    ok, buf = cv2.imencode(suffix, image)
    assert ok
    return buf.tobytes()


@pytest.mark.parametrize("suffix, image", [
    (".png", np.zeros((48, 64), np.uint16)),
    (".png", np.zeros((48, 64, 4), np.uint8)),
    (".jpg", np.zeros((48, 64, 3), np.uint8)),
    (".bmp", np.zeros((48, 64, 3), np.uint8)),
    (".pgm", np.zeros((48, 64), np.uint16)),
    (".ppm", np.zeros((48, 64, 3), np.uint8)),
    (".tif", np.zeros((48, 64), np.uint16)),
])
def test_the_header_gives_the_size_opencv_decodes(suffix, image):
    data = _encoded(suffix, image)
    header = read_header(data, "x" + suffix, "x" + suffix)
    decoded = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
    assert (header.height, header.width) == decoded.shape[:2] == (48, 64)
    assert header.decoded_bytes >= decoded.nbytes / decoded.shape[0] / decoded.shape[1]


def test_a_jpeg_size_is_found_after_its_other_segments():
    """The frame header of a JPEG follows any number of segments (EXIF, comments)."""
    data = _encoded(".jpg", np.zeros((30, 70, 3), np.uint8))
    comment = b"\xff\xfe" + struct.pack(">H", 60002) + bytes(60000)
    header = read_header(data[:2] + comment + data[2:], "x.jpg")
    assert (header.width, header.height) == (70, 30)


def test_a_jpeg_2000_file_named_png_is_refused_before_it_is_decoded(tmp_path):
    """A 6000 x 6000 JPEG 2000 image written by OpenCV (a few hundred bytes) named .png: refused
    by its bytes, in a process of its own whose peak memory does not grow (by 200 MB when
    decoded)."""
    jp2 = tmp_path / "big.jp2"
    assert cv2.imwrite(str(jp2), np.zeros((6000, 6000), np.uint16))
    named = tmp_path / "frame.png"
    named.write_bytes(jp2.read_bytes())
    assert jp2.stat().st_size < 2000 and sniff(named.read_bytes()) == "JPEG 2000"
    reader = ("import re, sys\nfrom mirrorcore.base.budget import set_memory_budget\n"
              "from mirrorcore.depth.files import read_depth_png\n"
              "peak = lambda: int(re.search(r'VmHWM:\\s+(\\d+)', "
              "open('/proc/self/status').read()).group(1))\n"
              "set_memory_budget('256M')\nbefore = peak()\n"
              "try:\n    read_depth_png(sys.argv[1], 0.001)\n    print('decoded')\n"
              "except Exception as exc:\n    print(exc)\nprint(peak() - before)\n")
    for path, refusal in ((named, "frame.png: named .png but its bytes are a JPEG 2000 image; "
                                  "save it as a PNG image"),
                          (jp2, "big.jp2: a JPEG 2000 image; mirrorscan reads PNG, JPEG")):
        run = subprocess.run([sys.executable, "-c", reader, str(path)], capture_output=True,
                             text=True, timeout=120, cwd=ROOT)
        said, grown_kb = run.stdout.splitlines()
        assert refusal in said, run.stdout + run.stderr
        assert int(grown_kb) < 20_000, f"the peak grew by {int(grown_kb) // 1024} MB"


def test_an_upload_or_a_colour_frame_of_another_format_than_its_name_is_refused(tmp_path):
    depth = _encoded(".png", np.ones(CAMERA.shape, np.uint16))
    jpeg = _encoded(".jpg", np.zeros((*CAMERA.shape, 3), np.uint8))
    with pytest.raises(FileFormatError, match="up.png: named .png but its bytes are a JPEG"):
        decode_depth_png(jpeg, 0.001, CAMERA.shape, "up.png")
    assert decode_depth_png(depth, 0.001, CAMERA.shape, "up.png").shape == CAMERA.shape
    (tmp_path / "rgb.png").write_bytes(jpeg)
    with pytest.raises(FileFormatError, match="rgb.png: named .png but its bytes are a JPEG"):
        read_colour(tmp_path / "rgb.png", CAMERA)
    (tmp_path / "rgb.jpg").write_bytes(jpeg)
    assert read_colour(tmp_path / "rgb.jpg", CAMERA).shape == (*CAMERA.shape, 3)
    (tmp_path / "small.jpg").write_bytes(_encoded(".jpg", np.zeros((24, 32, 3), np.uint8)))
    with pytest.raises(FileFormatError, match="small.jpg: size 32x24 does not match the camera's"):
        read_colour(tmp_path / "small.jpg", CAMERA)


def test_a_header_beyond_the_budget_is_refused_whatever_the_format(tmp_path, budget):
    """A small JPEG whose frame header says 16000 x 16000 (a colour frame, a depth file)."""
    data = bytearray(_encoded(".jpg", np.zeros((8, 8, 3), np.uint8)))
    at = next(i for i in range(2, len(data)) if data[i] == 0xFF and data[i + 1] == 0xC0)
    data[at + 5:at + 9] = struct.pack(">HH", 16000, 16000)
    (tmp_path / "huge.jpg").write_bytes(bytes(data))
    budget("256M")
    with pytest.raises(MemoryBudgetError, match="huge.jpg: decoding a 16000x16000 image: needs"):
        read_depth_png(tmp_path / "huge.jpg", 0.001)
    big = Intrinsics(**{**CAMERA.to_dict(), "width": 16000, "height": 16000})
    with pytest.raises(MemoryBudgetError, match="huge.jpg: decoding a 16000x16000 image: needs"):
        read_colour(tmp_path / "huge.jpg", big)
