"""Device sources without hardware: Kinect v1 through libfreenect's replay driver (fakenect) fed
with the simulator's raw disparity, a RealSense .bag written here with pyrealsense2's software
device, OpenNI2's messages."""
import glob
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from mirrorcore.base.errors import FileFormatError, MirrorscanError
from mirrorcore.depth.kinect import BURRUS_A, depth_to_disparity
from mirrorcore.sim.layouts import paper_scene
from mirrorcore.sim.simulator import Simulator
from mirrorcore.sources import open_source
from mirrorcore.sources.base import require

FAKENECT = sorted(glob.glob("/usr/lib/*/fakenect/libfreenect.so*"))
SHIM = """typedef struct _freenect_device freenect_device;
void freenect_camera_to_world(freenect_device *dev, int cx, int cy, int wz, double *wx, double *wy)
{ *wx = (cx - 320.0) * wz / 575.8157; *wy = (cy - 240.0) * wz / 575.8157; }
"""
READER = """import sys, numpy as np
from mirrorcore.sources import open_source
with open_source("freenect:0") as source:
    frames = [source.read(i) for i in range(int(sys.argv[2]))]
np.savez(sys.argv[1], depth=np.stack([f.depth for f in frames]),
         raw=np.stack([f.units for f in frames]), t=np.array([f.timestamp for f in frames]))
"""


def write_fakenect(folder: Path, raws: list[np.ndarray], period: float, padding: int) -> None:
    """A fakenect recording: raw 11-bit frames as d-TIME-STAMP.pgm (a one-line header, then
    little-endian uint16), `period` seconds apart, then `padding` repeats of the last one 1/30 s
    apart, so that the replay does not run out (libfreenect 0.5's fake driver crashes at the end of
    its index) before the reader closes."""
    folder.mkdir()
    names = []
    for n, raw in enumerate(raws + [raws[-1]] * padding):
        t = n * period if n < len(raws) else (len(raws) - 1) * period + (n - len(raws) + 1) / 30
        names.append(f"d-{1000 + t:.6f}-{n}.pgm")
        (folder / names[-1]).write_bytes(b"P5 640 480 65535\n" + raw.astype("<u2").tobytes())
    (folder / "INDEX.txt").write_text("\n".join(names) + "\n")


@pytest.mark.skipif(not FAKENECT or not shutil.which("gcc"),
                    reason="needs libfreenect's fakenect (Debian "
                    "libfreenect-dev) and gcc for the freenect_camera_to_world shim")
def test_kinect_v1_through_fakenect_gives_the_simulators_depth(tmp_path):
    pytest.importorskip("freenect",
                        reason="needs PyPI freenect (pip install 'mirrorscan[devices]')")
    rig = Simulator(paper_scene(object="sphere", distance=2.0), seed=3)
    truth = np.stack([rig.frame(i).depth for i in range(4)])
    raws = [depth_to_disparity(d) for d in truth]
    write_fakenect(tmp_path / "rec", raws, period=0.2, padding=60)
    (tmp_path / "shim.c").write_text(SHIM)
    subprocess.run(["gcc", "-shared", "-fPIC", "-o", str(tmp_path / "shim.so"),
                    str(tmp_path / "shim.c")], check=True)
    env = {**os.environ, "FAKENECT_PATH": str(tmp_path / "rec"),
           "LD_PRELOAD": str(tmp_path / "shim.so"),
           "LD_LIBRARY_PATH": str(Path(FAKENECT[0]).parent),
           "PYTHONPATH": str(Path(__file__).resolve().parents[3])}
    out = tmp_path / "out.npz"
    run = subprocess.run([sys.executable, "-c", READER, str(out), "4"], env=env,
                         capture_output=True, text=True,
                         timeout=60)
    assert run.returncode == 0, run.stderr[-2000:]
    got = np.load(out, allow_pickle=False)
    # the driver's frames, byte for byte
    np.testing.assert_array_equal(got["raw"], np.stack(raws))
    # one new frame per read, none skipped
    assert np.all(np.diff(got["t"]) > 0.1)
    valid = truth > 0
    np.testing.assert_array_equal(got["depth"] > 0, valid)
    # |dz/draw| = |A| z^2, raw rounded to 1
    half_step = 0.5 * -BURRUS_A * np.maximum(truth, got["depth"]) ** 2
    assert np.all(np.abs(got["depth"] - truth)[valid] <= 1.0001 * half_step[valid])
    # the quantisation is really there
    assert 0.002 < np.abs(got["depth"] - truth)[valid].max()


def write_bag(path: Path, frames: np.ndarray, units: float, colour: np.ndarray | None = None,
              colour_ms: list[float] | None = None, shift_m: float = 0.0,
              colour_format: str = "rgb8") -> None:
    """A RealSense ROS1 .bag of z16 depth frames (N, H, W) uint16, written without a camera.

    With `colour` ((M, H', W', 3) uint8 in `colour_format` order), a colour sensor too: frame k at
    colour_ms[k] (default the depth frames' times), the colour camera's intrinsics those of the
    depth camera scaled to W', shift_m metres along x from it.
    """
    rs = pytest.importorskip("pyrealsense2")
    if not hasattr(rs, "software_device") or not hasattr(rs, "recorder"):
        pytest.skip("this pyrealsense2 has no software device or recorder")
    device = rs.software_device()

    def add(sensor, kind, fmt, bpp, uid, h, w):
        k = rs.intrinsics()
        k.width, k.height, k.fx, k.fy, k.ppx, k.ppy = w, h, 580.0 * w / 640, 581.0 * w / 640, \
            (w - 1) / 2, (h - 1) / 2
        k.model, k.coeffs = rs.distortion.none, [0.0] * 5
        stream = rs.video_stream()
        stream.type, stream.index, stream.uid, stream.width, stream.height = kind, 0, uid, w, h
        stream.fps, stream.bpp, stream.fmt, stream.intrinsics = 30, bpp, fmt, k
        return sensor.add_video_stream(stream)
    depth_sensor = device.add_sensor("Depth")
    streams = [(depth_sensor, add(depth_sensor, rs.stream.depth, rs.format.z16, 2, 0,
                                  *frames.shape[1:]), frames,
                [n * 1000 / 30 for n in range(len(frames))])]
    depth_sensor.add_read_only_option(rs.option.depth_units, units)
    if colour is not None:
        colour_sensor = device.add_sensor("Color")
        profile = add(colour_sensor, rs.stream.color, getattr(rs.format, colour_format), 3, 1,
                      *colour.shape[1:3])
        extrinsics = rs.extrinsics()
        extrinsics.rotation, extrinsics.translation = [1, 0, 0, 0, 1, 0, 0, 0, 1], [shift_m, 0, 0]
        streams[0][1].register_extrinsics_to(profile, extrinsics)
        streams.append((colour_sensor, profile, colour, colour_ms or streams[0][3]))
    device.register_info(rs.camera_info.name, "mirrorscan test")
    device.register_info(rs.camera_info.serial_number, "0001")
    recorder = rs.recorder(str(path), device)
    queue = rs.frame_queue(4)
    for sensor, profile, _, _ in streams:
        sensor.open(profile)
        sensor.start(queue)
    # every frame in the order of its time, as a camera delivers them
    order = sorted((ms, s, n) for s, (_, _, _, times) in enumerate(streams)
                   for n, ms in enumerate(times))
    for ms, s, n in order:
        sensor, profile, images, _ = streams[s]
        frame = rs.software_video_frame()
        bpp = images.itemsize * (3 if images.ndim == 4 else 1)
        frame.pixels, frame.stride, frame.bpp = images[n], bpp * images.shape[2], bpp
        frame.timestamp, frame.frame_number = ms, n
        frame.domain = rs.timestamp_domain.hardware_clock
        frame.profile = profile.as_video_stream_profile()
        sensor.on_video_frame(frame)
        queue.wait_for_frame()
    for sensor, _, _, _ in streams:
        sensor.stop()
        sensor.close()
    del recorder                                                       # closes the bag


def test_realsense_bag_written_here_reads_back_exactly(tmp_path):
    rng = np.random.default_rng(0)
    frames = rng.integers(0, 6000, (3, 480, 640), dtype=np.uint16)
    write_bag(tmp_path / "scan.bag", frames, 0.001)
    with open_source(str(tmp_path / "scan.bag")) as source:
        assert source.frame_count == 3 and (source.intrinsics.fx, source.intrinsics.fy) == (580.0,
                                                                                            581.0)
        got = [source.read(i) for i in (2, 0, 1)]                       # seekable: any order
    for frame, expected in zip(got, frames[[2, 0, 1]]):
        np.testing.assert_array_equal(frame.units, expected)
        scale = np.float32(source.intrinsics.depth_scale)
        np.testing.assert_array_equal(frame.depth, expected.astype(np.float32) * scale)
    assert source.intrinsics.depth_scale == pytest.approx(0.001)
    assert [f.timestamp for f in got] == pytest.approx([2 / 30, 0, 1 / 30])


def test_a_missing_library_is_named_with_what_to_install():
    with pytest.raises(MirrorscanError,
                       match="cannot import no_such_camera_lib .*; install Debian's libfoo"):
        require("no_such_camera_lib", "foo:0", "Debian's libfoo")


def test_realsense_recordings_that_are_missing_or_broken_are_named(tmp_path):
    pytest.importorskip("pyrealsense2",
                        reason="needs PyPI pyrealsense2 (pip install 'mirrorscan[devices]')")
    with pytest.raises(FileFormatError, match="nope.bag: no such .bag recording"):
        open_source(f"bag:{tmp_path / 'nope.bag'}")
    (tmp_path / "junk.bag").write_bytes(b"junk")
    with pytest.raises(FileFormatError, match="junk.bag: not a readable RealSense recording"):
        open_source(str(tmp_path / "junk.bag"))


def test_a_missing_oni_recording_is_named(tmp_path):
    pytest.importorskip("openni", reason="needs PyPI openni (pip install 'mirrorscan[devices]')")
    with pytest.raises(FileFormatError, match="nope.oni: no such .oni recording"):
        open_source(f"openni2:{tmp_path / 'nope.oni'}")


def test_a_bag_is_read_one_frame_at_a_time(tmp_path):
    """A .bag is streamed, not loaded: reading 40 frames of 640x480 holds a few frames at most (a
    whole bag in memory takes 1.2 MB a frame: about 22 GB for 10 minutes)."""
    import tracemalloc
    frames = np.random.default_rng(1).integers(0, 6000, (40, 480, 640), dtype=np.uint16)
    write_bag(tmp_path / "long.bag", frames, 0.001)
    tracemalloc.start()
    with open_source(f"bag:{tmp_path / 'long.bag'}") as source:
        assert source.frame_count == 40
        for i, expected in enumerate(frames):
            frame = source.read(i)
            np.testing.assert_array_equal(frame.units, expected)
        peak = tracemalloc.get_traced_memory()[1]
        # seeking back replays to it
        np.testing.assert_array_equal(source.read(3).units, frames[3])
        # loops like every recording
        np.testing.assert_array_equal(source.read(43).units, frames[3])
    tracemalloc.stop()
    # a few frames and their metres, not 40
    assert peak < frames.nbytes / 3, f"{peak / 1e6:.1f} MB traced"
