"""Sizes and counts that a user or a file chooses: the memory budget is checked before the work
(voxel grids, image headers, frame files, .npz shapes), the boundary crossing test stays small,
and a session holds only what the tool can hold: refused by name, quickly, where it is read and
where it is edited."""
from __future__ import annotations

import io
import json
import subprocess
import sys
import time
import tracemalloc
import zipfile
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np
import pytest

from mirrorcore.base.budget import (MemoryBudgetError, check_memory, memory_budget, parse_size,
                                    set_memory_budget)
from mirrorcore.dense import DenseOptions, dense_volume
from mirrorcore.dense.volume import Volume
from mirrorcore.depth.files import read_depth_png
from mirrorcore.base.errors import FileFormatError, MirrorscanError
from mirrorcore.geometry.polygon import MAX_VERTICES, first_crossing, validate_polygon
from mirrorcore.rig.model import Rig
from mirrorcore.io.limits import MAX_MARKERS, check_limits, check_name
from mirrorcore.io.session import MAX_MIRRORS, SessionMirror, load_session
from mirrorcore.sources import open_source
from mirrorcore.sources.files import load_npz

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
    assert time.perf_counter() - t0 < 1.0
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
              "try:\n    read_depth_png(sys.argv[1], 0.001, (480, 640))\nexcept Exception:\n    pass\n"
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


# --------------------------------------------------------------------- polygons
def test_the_crossing_test_of_a_large_polygon_stays_small_in_memory():
    angles = np.linspace(0, 2 * np.pi, 8000, endpoint=False)
    circle = np.c_[320 + 200 * np.cos(angles), 240 + 200 * np.sin(angles)]
    tracemalloc.start()
    assert first_crossing(circle) is None                           # 32 M edge pairs: 4.3 GB before
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 50 << 20
    bowtie = circle.copy()
    # two vertices swapped: it crosses itself
    bowtie[[10, 4000]] = bowtie[[4000, 10]]
    assert first_crossing(bowtie) is not None
    with pytest.raises(MirrorscanError,
                       match=f"boundary: 8,000 vertices, more than the {MAX_VERTICES:,}"):
        validate_polygon(circle, (480, 640), "boundary")


def test_the_first_crossing_is_the_same_pair_as_the_exhaustive_test():
    rng = np.random.default_rng(3)

    def exhaustive(poly):
        n = len(poly)
        for i in range(n):
            for j in range(i + 2, n):
                if i == 0 and j == n - 1:
                    continue
                if _meet(poly[i], poly[(i + 1) % n], poly[j], poly[(j + 1) % n]):
                    return i, j
        return None

    for _ in range(300):
        poly = rng.integers(0, 6, (int(rng.integers(4, 12)), 2)).astype(float)
        assert first_crossing(poly) == exhaustive(poly)


def _meet(p1, q1, p2, q2) -> bool:
    """Segment p1-q1 meets p2-q2, touching included (a plain scalar test to compare with)."""
    def orient(p, q, r):
        return np.sign((q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0]))

    def on(p, q, r):
        return min(p[0], q[0]) <= r[0] <= max(p[0], q[0]) and min(p[1], q[1]) <= r[1] <= max(p[
            1], q[1])

    o1, o2, o3, o4 = orient(p1, q1, p2), orient(p1, q1, q2), orient(p2, q2, p1), orient(p2, q2, q1)
    if o1 * o2 < 0 and o3 * o4 < 0:
        return True
    return any(o == 0 and on(a, b, c) for o, a, b, c in
               ((o1, p1, q1, p2), (o2, p1, q1, q2), (o3, p2, q2, p1), (o4, p2, q2, q1)))


# --------------------------------------------------------------------- session limits
def _demo() -> dict:
    with open(f"{DEMO}/session.json") as f:
        return json.load(f)


def _write(tmp_path, data: dict | str):
    (tmp_path / "session.json").write_text(data if isinstance(data, str) else json.dumps(data))
    return tmp_path


BIG = 10 ** 400     # a JSON number no float can hold


@pytest.mark.parametrize("edit, message", [
    (lambda d: d.update(mirrors=[dict(d["mirrors"][0], id=i + 1, name=f"m{i}") for i in range(42)]),
     "mirrors: 42 mirrors, more than the 32 a session may hold"),
    (lambda d: d["mirrors"][0].update(markers=[[1, 1]] * 200_000),
     "markers: 200,000 points, more than the 500"),
    (lambda d: d["mirrors"][0].update(boundary=[[1, 1]] * 30_000),
     "boundary: 30,000 points, more than the 1,000"),
    (lambda d: d.update(selection={"roi": [[1, 1]] * 30_000}),
     "roi: 30,000 vertices, more than the 1,000"),
    (lambda d: d["mirrors"][0].update(name="x" * 101), "name: 101 characters, more than the 100"),
    (lambda d: d["mirrors"][0].update(name="bad\ud800"), "cannot be shown or saved"),
    (lambda d: d["mirrors"][0].update(name="tab\tbell\x07"), "cannot be shown or saved"),
    (lambda d: d.update(frames=["a\ud800.png"] * len(d["frames"])), r"frames\[0\]: must be a path"),
    (lambda d: d["camera"].update(fx=BIG), "camera: camera values must be numbers"),
    (lambda d: d["mirrors"][0].update(plane=[BIG, 0, 0, 1]),
     "plane: a plane needs 4 finite numbers"),
    (lambda d: d["mirrors"][0]["markers"].append([BIG, 1]), "must be a pair of numbers"),
    (lambda d: d.update(selection={"min_blob": BIG}), "selection: int too large"),
    (lambda d: d.update(selection={"roi": [[BIG, 1], [2, 3], [4, 5]]}), "roi: vertices must be"),
    (lambda d: d.update(timestamps=[BIG] * len(d["frames"])), "must be a number of seconds"),
])
def test_sessions_beyond_the_limits_are_refused_by_name_and_quickly(tmp_path, edit, message):
    data = _demo()
    edit(data)
    _write(tmp_path, data)
    t0 = time.perf_counter()
    with pytest.raises(FileFormatError, match=message):
        load_session(tmp_path)
    assert time.perf_counter() - t0 < 2.0


@pytest.mark.parametrize("text, message", [
    ('{"version": 1, "x": ' + "[" * 100_000 + "]" * 100_000 + "}", "nested too deeply"),
    ('{"version": ' + "9" * 5000 + "}", "unreadable number"),
])
def test_session_files_that_json_cannot_hold_are_one_line(tmp_path, text, message):
    with pytest.raises(FileFormatError, match=message):
        load_session(_write(tmp_path, text))


def test_a_session_file_too_large_is_refused_before_reading(tmp_path):
    with open(tmp_path / "session.json", "wb") as f:
        f.truncate(100 << 20)
    with pytest.raises(FileFormatError, match="104,857,600 bytes, more than the 67,108,864"):
        load_session(tmp_path)


def test_the_editor_check_refuses_what_the_reader_would_refuse():
    session = load_session(DEMO)
    assert check_limits(session) is session
    mirrors = tuple(SessionMirror(f"mirror {i}", id=i) for i in range(1, MAX_MIRRORS + 1))
    check_limits(replace(session, mirrors=mirrors))                            # 32: fine
    with pytest.raises(MirrorscanError, match="33 mirrors, more than the 32"):
        check_limits(replace(session, mirrors=mirrors + (SessionMirror("one more", id=99),)))
    m = session.mirrors[0]
    with pytest.raises(MirrorscanError,
                       match=r"mirrors\[0\] \(mirror 1\): 501 markers, more than the 500"):
        check_limits(session.with_mirror(0, replace(m, markers=((1.0, 1.0),) * (MAX_MARKERS + 1))))
    with pytest.raises(MirrorscanError, match="boundary: 1,001 vertices"):
        check_limits(session.with_mirror(0, replace(m, boundary=((1.0, 1.0),) * 1001)))
    for bad in ("", "   ", "x" * 101, "a\nb", "\ud800"):
        with pytest.raises(MirrorscanError):
            check_name(bad)
    assert check_name("Mirror à gauche ✓") == "Mirror à gauche ✓"


def test_a_session_at_the_limits_is_saved_and_opens_again(tmp_path):
    from mirrorcore.io.session import save_session
    session = replace(load_session(DEMO), root=tmp_path)
    m = session.mirrors[0]
    full = tuple(replace(m, id=i, name=f"mirror {i}", plane=None)
                 for i in range(1, MAX_MIRRORS + 1))
    save_session(check_limits(replace(session, mirrors=full, frames=(), timestamps=None)))
    again = load_session(tmp_path)
    assert len(again.mirrors) == MAX_MIRRORS and Rig.from_session(again).mirrors



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
