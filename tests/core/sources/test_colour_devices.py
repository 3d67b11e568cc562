"""The cameras' colour paths through stand-ins of freenect, openni2 and pyrealsense2 that hand out
known frames and record what the source asks of them (registered depth, depth-to-colour
registration, alignment to depth)."""
import sys
from types import ModuleType, SimpleNamespace

import numpy as np
import pytest

from mirrorcore.sources import open_source
from mirrorcore.sources.devices import KINECT_V1_RGB

H, W = 480, 640
RNG = np.random.default_rng(4)
MM = RNG.integers(400, 4000, (H, W), dtype=np.uint16)
RGB = RNG.integers(0, 256, (H, W, 3), dtype=np.uint8)


def _install(monkeypatch, name: str, module: ModuleType) -> None:
    monkeypatch.setitem(sys.modules, name, module)


def _freenect(calls: list) -> ModuleType:
    fn = ModuleType("freenect")
    fn.DEPTH_11BIT, fn.DEPTH_REGISTERED, fn.VIDEO_RGB = 0, 4, 0

    def depth(index, fmt):
        calls.append(("depth", fmt))
        return (MM if fmt == fn.DEPTH_REGISTERED else np.full((H, W), 700, np.uint16)), 0

    def video(index, fmt):
        calls.append(("video", fmt))
        return RGB, 0
    fn.sync_get_depth, fn.sync_get_video, fn.sync_stop = depth, video, lambda: None
    return fn


def test_kinect_v1_registered_depth_comes_with_its_rgb_image(monkeypatch):
    calls = []
    _install(monkeypatch, "freenect", _freenect(calls))
    with open_source("freenect:0?colour=registered") as source:
        assert source.has_colour and source.intrinsics == KINECT_V1_RGB
        frame = source.read(0)
    assert ("depth", 4) in calls and ("video", 0) in calls and ("depth", 0) not in calls
    np.testing.assert_array_equal(frame.units, MM)
    np.testing.assert_allclose(frame.depth, MM * 0.001, rtol=1e-6)
    assert frame.colour.dtype == np.uint8 and frame.colour.shape == (H, W, 3)
    np.testing.assert_array_equal(frame.colour, RGB)


def test_kinect_v1_without_the_option_reads_raw_disparity_and_no_colour(monkeypatch):
    calls = []
    _install(monkeypatch, "freenect", _freenect(calls))
    with open_source("freenect:0") as source:
        assert not source.has_colour and source.read(0).colour is None
    assert set(calls) == {("depth", 0)}


class _Stream:
    def __init__(self, buffer: np.ndarray, fmt: str):
        self.buffer, self.fmt, self.started = buffer, fmt, False

    def start(self):
        self.started = True

    def stop(self):
        self.started = False

    def get_video_mode(self):
        return SimpleNamespace(pixelFormat=SimpleNamespace(name=self.fmt), resolutionX=W,
                               resolutionY=H, fps=30)

    def get_horizontal_fov(self):
        return 1.0

    def get_vertical_fov(self):
        return 0.8

    def read_frame(self):
        data = self.buffer.tobytes()
        return SimpleNamespace(get_buffer_as_uint16=lambda: data, get_buffer_as_uint8=lambda: data,
                               timestamp=2_000_000)


def _openni2(registration: list) -> ModuleType:
    ni = ModuleType("openni.openni2")
    ni.IMAGE_REGISTRATION_DEPTH_TO_COLOR = "DEPTH_TO_COLOR"
    ni.OpenNIError = RuntimeError
    ni.initialize = lambda dirs: None
    device = SimpleNamespace(
        create_depth_stream=lambda: _Stream(MM, "PIXEL_FORMAT_DEPTH_1_MM"),
        create_color_stream=lambda: _Stream(RGB, "PIXEL_FORMAT_RGB888"),
        is_image_registration_mode_supported=lambda mode: True,
        set_image_registration_mode=registration.append, close=lambda: None)
    ni.Device = SimpleNamespace(open_any=lambda: device)
    return ni


def test_openni2_registers_depth_to_colour_and_reads_both_streams(monkeypatch):
    registration = []
    package = ModuleType("openni")
    package.openni2 = _openni2(registration)
    _install(monkeypatch, "openni", package)
    _install(monkeypatch, "openni.openni2", package.openni2)
    with open_source("openni2:?colour=registered") as source:
        assert source.has_colour
        frame = source.read(0)
    assert registration == ["DEPTH_TO_COLOR"]
    np.testing.assert_array_equal(frame.units, MM)
    np.testing.assert_array_equal(frame.colour, RGB)
    assert frame.timestamp == pytest.approx(2.0)
    with open_source("openni2:") as source:
        assert not source.has_colour and source.read(0).colour is None
    assert registration == ["DEPTH_TO_COLOR"]


def _realsense(enabled: list, aligned: list) -> ModuleType:
    rs = ModuleType("pyrealsense2")
    rs.stream = SimpleNamespace(depth="depth", color="color")
    rs.format = SimpleNamespace(rgb8="rgb8")
    rs.context = lambda: SimpleNamespace(query_devices=lambda: SimpleNamespace(size=lambda: 1))
    rs.config = lambda: SimpleNamespace(enable_device=lambda s: None,
                                        enable_stream=lambda *a: enabled.append(a))
    k = SimpleNamespace(width=W, height=H, fx=600.0, fy=601.0, ppx=320.0, ppy=240.0)
    video = SimpleNamespace(get_intrinsics=lambda: k, fps=lambda: 30)
    profile = SimpleNamespace(
        get_stream=lambda s: SimpleNamespace(as_video_stream_profile=lambda: video),
        get_device=lambda: SimpleNamespace(first_depth_sensor=lambda: SimpleNamespace(
            get_depth_scale=lambda: 0.001)))
    raw = SimpleNamespace(name="unaligned")
    rs.pipeline = lambda: SimpleNamespace(start=lambda config: profile,
                                          wait_for_frames=lambda: raw, stop=lambda: None)

    def process(frames):
        aligned.append(frames.name)
        return SimpleNamespace(
            get_depth_frame=lambda: SimpleNamespace(get_data=lambda: MM,
                                                    get_timestamp=lambda: 1500.0),
            get_color_frame=lambda: SimpleNamespace(get_data=lambda: RGB))

    def align(to):
        assert to == "depth"
        return SimpleNamespace(process=process)
    rs.align = align
    return rs


def test_realsense_aligns_colour_to_the_depth_grid(monkeypatch):
    enabled, aligned = [], []
    _install(monkeypatch, "pyrealsense2", _realsense(enabled, aligned))
    with open_source("realsense:?colour=registered") as source:
        assert source.has_colour and source.intrinsics.shape == (H, W)
        frame = source.read(0)
    assert ("color", "rgb8") in enabled and aligned == ["unaligned"]
    np.testing.assert_array_equal(frame.colour, RGB)
    np.testing.assert_allclose(frame.depth, MM * 0.001, rtol=1e-6)
    assert frame.timestamp == pytest.approx(1.5)


def test_realsense_without_the_option_starts_depth_only(monkeypatch):
    enabled, aligned = [], []
    _install(monkeypatch, "pyrealsense2", _realsense(enabled, aligned))
    raw_depth = SimpleNamespace(get_data=lambda: MM, get_timestamp=lambda: 0.0)
    with open_source("realsense:") as source:
        source._pipe.wait_for_frames = lambda: SimpleNamespace(get_depth_frame=lambda: raw_depth)
        assert not source.has_colour and source.read(0).colour is None
    assert enabled == [("depth",)] and aligned == []
