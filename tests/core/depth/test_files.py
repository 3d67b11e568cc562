"""Depth PNG files (depth/files.py): round trips and bad images refused by name."""

import numpy as np
import pytest

from mirrorcore.base.errors import FileFormatError
from mirrorcore.depth.files import read_depth_png, write_depth_png
from mirrorcore.geometry.camera import Intrinsics

CAMERA = Intrinsics.primesense()


def test_depth_png_round_trip_and_bad_images(tmp_path):
    depth = np.random.default_rng(0).uniform(0.5, 4, CAMERA.shape)
    depth[0, 0] = 0
    write_depth_png(tmp_path / "d.png", depth, 0.001)
    back = read_depth_png(tmp_path / "d.png", 0.001, CAMERA.shape)
    assert back.dtype == np.float32 and back[0, 0] == 0
    assert np.abs(back - depth).max() <= 0.0005 + 1e-6
    import cv2
    cv2.imwrite(str(tmp_path / "8bit.png"), np.zeros((480, 640), np.uint8))
    with pytest.raises(FileFormatError,
                       match="8bit.png: a depth image is 16-bit, this one is uint8"):
        read_depth_png(tmp_path / "8bit.png", 0.001)
    with pytest.raises(FileFormatError, match="size 640x480 does not match the camera's 320x240"):
        read_depth_png(tmp_path / "d.png", 0.001, (240, 320))
    (tmp_path / "corrupt.png").write_bytes(b"\x89PNG\r\n\x1a\n garbage")
    with pytest.raises(FileFormatError, match="corrupt.png: not a readable image"):
        read_depth_png(tmp_path / "corrupt.png", 0.001)
