"""The memory budget (base/budget.py): it comes from the option, the environment or the default,
and work that needs more (voxel grids, image headers, frame files, .npz shapes, camera and cloud
files) is refused before it allocates."""
from __future__ import annotations

import io
import subprocess
import sys
import time
import tracemalloc
import zipfile
from pathlib import Path

import cv2
import numpy as np
import pytest

from mirrorcore.base.budget import (
    MemoryBudgetError,
    check_memory,
    memory_budget,
    parse_size,
    set_memory_budget,
)
from mirrorcore.base.errors import FileFormatError, MirrorscanError
from mirrorcore.dense import DenseOptions, dense_volume
from mirrorcore.dense.volume import Volume
from mirrorcore.depth.files import read_depth_png
from mirrorcore.io.sessionfile import load_session
from mirrorcore.rig.model import Rig
from mirrorcore.sources import open_source
from mirrorcore.sources.npz import load_npz

DEMO = "sessions/demo"


@pytest.fixture
def budget():
    """Set the memory budget for one test (bytes or '64M'); restored after."""
    yield set_memory_budget
    set_memory_budget(None)


# --------------------------------------------------------------------- the budget
def test_the_budget_comes_from_the_option_the_environment_or_the_default(monkeypatch, budget):
    monkeypatch.delenv("MIRRORSCAN_MEMORY", raising=False)
    # 4 GiB, or half the machine when less
    assert 1 << 30 <= memory_budget() <= 4 << 30
    monkeypatch.setenv("MIRRORSCAN_MEMORY", "1.5GiB")
    assert memory_budget() == 3 << 29
    budget("512M")
    # the command line's --memory wins
    assert memory_budget() == 512 << 20
    for bad in ("lots", "12 parsecs", "1K", "-5G"):
        with pytest.raises(MirrorscanError, match="--memory"):
            parse_size(bad, "--memory")
    with pytest.raises(MemoryBudgetError,
                       match=r"thing: needs 1.0 GiB, more than the memory budget of 512.0 MiB"):
        check_memory(1 << 30, "thing")


def test_a_volume_that_does_not_fit_in_the_budget_is_refused_before_any_grid(budget):
    rig = Rig.from_session(load_session(DEMO))
    box = ((-0.2, -0.3, 1.7), (0.2, 0.3, 2.3))                    # a person-sized box
    t0 = time.perf_counter()
    # The volume holds only its grid of 4^3-voxel blocks (24 bytes each; the fusion allocates the
    # blocks near the surface, carving its two grids, each checked before allocating): 0.3 mm
    # (1334x2000x2000) now fits in 4 GiB.
    with pytest.raises(MemoryBudgetError,
                       match=r"volume: 4000x6000x6000 voxels of 0.1 mm .* memory budget"):
        dense_volume(rig, np.zeros(rig.intrinsics.shape), np.zeros(rig.intrinsics.shape, bool),
                     # a browser client asking for 0.1 mm
                     DenseOptions(voxel=0.0001, bounds=box))
    # generous for a loaded machine: refused before any grid is allocated
    assert time.perf_counter() - t0 < 5.0
    assert Volume.from_bounds(*box, 0.004).size == 100 * 150 * 150  # 4 mm: fine
    budget(4 << 20)
    with pytest.raises(MemoryBudgetError):
        # 352 k blocks x 24 bytes > 4 MiB
        Volume.from_bounds(*box, 0.002)


# --------------------------------------------------------------------- images, frames, .npz
def _png_head(width: int, height: int) -> bytes:
    ok, buf = cv2.imencode(".png", np.zeros((2, 2), np.uint16))
    head = bytearray(buf.tobytes())
    head[16:24] = width.to_bytes(4, "big") + height.to_bytes(4, "big")
    return bytes(head)


def test_a_huge_frame_file_is_refused_by_its_size_before_it_is_read(tmp_path):
    path = tmp_path / "000000.png"
    with open(path, "wb") as f:                                     # 2 GiB, sparse: costs no disk
        f.write(_png_head(640, 480))
        f.truncate(2 << 30)
    with pytest.raises(FileFormatError,
                       match=r"000000.png: 2,147,483,648 bytes is more than a depth image of "
                                              r"307,200 pixels can hold"):
        read_depth_png(path, 0.001, (480, 640))
    # in a process of its own (this one's other threads allocate too): the refusal never holds the
    # file
    reader = ("import re, sys\nfrom mirrorcore.depth.files import read_depth_png\n"
              "try:\n    read_depth_png(sys.argv[1], 0.001, (480, 640))\nexcept Exception:\n    "
              "pass\n"
              "print(re.search(r'VmHWM:\\s+(\\d+)', open('/proc/self/status').read()).group(1))")
    run = subprocess.run([sys.executable, "-c", reader, str(path)], capture_output=True, text=True,
                         timeout=120,
                         cwd=Path(__file__).resolve().parents[3])
    # kB (VmHWM, not inherited like
    assert int(run.stdout.split()[-1]) < 400_000, run.stdout + run.stderr
    # ru_maxrss): the interpreter, numpy and OpenCV, not the file


def test_an_image_header_beyond_the_budget_is_refused_before_decoding(tmp_path, budget):
    path = tmp_path / "big.png"
    path.write_bytes(_png_head(12000, 12000))
    budget(256 << 20)
    with pytest.raises(MemoryBudgetError,
                       match=r"big.png: decoding a 12000x12000 image: needs 824.0 MiB"):
        read_depth_png(path, 0.001)


def _forged_npz(path, shape) -> None:
    """An .npz whose depth.npy header declares `shape` (uint16) but holds 10 bytes."""
    header = io.BytesIO()
    np.lib.format.write_array_header_1_0(header,
                                         {"descr": "<u2", "fortran_order": False, "shape": shape})
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as archive:
        archive.writestr("depth.npy", header.getvalue() + bytes(10))
        archive.writestr("K.npy", _npy(np.eye(3)))


def _npy(array: np.ndarray) -> bytes:
    buf = io.BytesIO()
    np.save(buf, array)
    return buf.getvalue()


def test_an_npz_declaring_hundreds_of_gigabytes_is_refused_from_its_headers(tmp_path):
    path = tmp_path / "tiny.npz"
    _forged_npz(path, (100_000, 1000, 3000))
    assert path.stat().st_size < 1000
    tracemalloc.start()
    with pytest.raises(MemoryBudgetError, match=r"tiny.npz: its arrays: needs 558.8 GiB"):
        load_npz(path)
    with pytest.raises(MemoryBudgetError):
        open_source(f"npz:{path}")
    assert tracemalloc.get_traced_memory()[1] < 10 << 20
    tracemalloc.stop()


def test_the_command_line_takes_the_budget_and_refuses_by_it(tmp_path, capsys, budget):
    from mirrorscan.cli import main
    out = tmp_path / "mesh.ply"
    assert main(["--memory", "64M", "reconstruct", DEMO, "-o", str(out), "--method", "tsdf",
                 "--voxel", "0.001"]) == 2
    err = capsys.readouterr().err
    assert "memory budget of 64.0 MiB" in err and "--memory" in err and not out.exists()
    assert main(["--memory", "lots", "sources"]) == 2
    assert "--memory: 'lots' is not a size" in capsys.readouterr().err


def test_a_camera_or_a_cloud_file_beyond_the_budget_is_refused_before_its_tables(tmp_path, budget):
    from mirrorcore.geometry.camera import Intrinsics
    from mirrorcore.io.ply import read_ply, write_ply
    huge = Intrinsics(16384, 16384, 1e4, 1e4, 8191.5, 8191.5)
    with pytest.raises(MemoryBudgetError,
                       match="rig: the per-pixel tables of a 16384x16384 camera: needs 16.0 GiB"):
        # 16 GiB of tables: refused before any
        Rig(huge, ())
    write_ply(tmp_path / "cloud.ply", np.zeros((300_000, 3), np.float32),
              np.zeros(300_000, np.uint8))
    budget(4 << 20)
    with pytest.raises(MemoryBudgetError, match="cloud.ply: reading the PLY"):
        read_ply(tmp_path / "cloud.ply")
