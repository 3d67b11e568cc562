"""Property-based tests of every loader (hypothesis): session JSON, depth PNG bytes, PLY bytes,
scene JSON, .npz stacks and intrinsics files, given random input and valid files with random damage.
Any input ends in a result or our own one-line error (a MirrorscanError subclass, or an OSError
naming the file); never another exception."""
import io
import json
import zipfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mirrorcore.depth.files import encode_depth_png, read_depth_png
from mirrorcore.base.errors import MirrorscanError
from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.geometry.camerafiles import (
    load_open3d_json,
    load_opencv_yaml,
    save_open3d_json,
    save_opencv_yaml,
)
from mirrorcore.io.ply import encode_ply, read_ply
from mirrorcore.io.session import Session, SessionMirror
from mirrorcore.io.sessionfile import load_session, session_from_json
from mirrorcore.sim.layouts import paper_scene
from mirrorcore.sim.scenefile import load_scene
from mirrorcore.sources.npz import open_npz

EXAMPLES = settings(max_examples=120, deadline=None,
                    suppress_health_check=[HealthCheck.function_scoped_fixture])
CAMERA = Intrinsics(64, 48, 50.0, 50.0, 31.5, 23.5)
SESSION = Session(Path("."), CAMERA,
                  (SessionMirror("m", ((5.0, 5.0), (20.0, 6.0), (8.0, 30.0)),
                                                    ((0, 0), (40, 0), (0, 40))),),
                  None, ("frames/000000.png",)).to_json()
SCENE = paper_scene(object="sphere").to_json()

json_values = st.recursive(
    st.none() | st.booleans() | st.integers(-10**6, 10**6) | st.floats(
        allow_nan=True, allow_infinity=True)
    | st.text(max_size=12),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(
        max_size=8), inner, max_size=4),
    max_leaves=12)


def ends_cleanly(load, *args) -> object | None:
    """load(*args): its result, or None after our own error (one line; an OSError must name its
    file)."""
    try:
        return load(*args)
    except MirrorscanError as exc:
        assert "\n" not in str(exc), str(exc)
    except OSError as exc:
        assert exc.filename, repr(exc)
    return None


@st.composite
def damaged_json(draw, valid: dict) -> object:
    """`valid` (a JSON object) with one value somewhere inside replaced, removed or added."""
    data = json.loads(json.dumps(valid))
    node = data
    while True:
        keys = list(node) if isinstance(node, dict) else list(range(len(node)))
        if not keys:
            break
        key = draw(st.sampled_from(keys))
        child = node[key]
        if not isinstance(child, (dict, list)) or not child or draw(st.booleans()):
            action = draw(st.sampled_from(["replace", "remove", "add"]))
            if action == "replace":
                node[key] = draw(json_values)
            elif action == "remove":
                node.pop(key)
            elif isinstance(node, dict):
                node[draw(st.text(max_size=8))] = draw(json_values)
            else:
                node.append(draw(json_values))
            break
        node = child
    return data


@st.composite
def damaged_bytes(draw, valid: bytes) -> bytes:
    """`valid` with a few bytes overwritten and possibly cut short."""
    data = bytearray(valid)
    for _ in range(draw(st.integers(0, 6))):
        data[draw(st.integers(0, len(data) - 1))] = draw(st.integers(0, 255))
    return bytes(data[:draw(st.integers(0, len(data)))] if draw(st.booleans()) else data)


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("fuzz")


@EXAMPLES
@given(st.one_of(json_values, damaged_json(SESSION)))
def test_session_json(folder, data):
    session = ends_cleanly(session_from_json, data, folder)
    # what was accepted is a session that writes back to itself
    if session is not None:
        assert session_from_json(session.to_json(), folder) == session


@EXAMPLES
@given(st.one_of(st.binary(max_size=200), damaged_bytes(json.dumps(SESSION).encode())))
def test_session_file_bytes(folder, raw):
    (folder / "session.json").write_bytes(raw)
    ends_cleanly(load_session, folder)


@EXAMPLES
@given(st.one_of(damaged_json(SCENE), json_values))
def test_scene_file(folder, data):
    (folder / "scene.json").write_text(json.dumps(data))
    ends_cleanly(load_scene, folder / "scene.json")


PNG = encode_depth_png(np.random.default_rng(0).uniform(0.5, 4, CAMERA.shape), 0.001)
png_headers = st.builds(lambda n, rest: PNG[:n] + rest, st.integers(8, 33), st.binary(max_size=40))


@EXAMPLES
@given(st.one_of(st.binary(max_size=300), damaged_bytes(PNG), png_headers),
       st.sampled_from([None, CAMERA.shape]))
def test_depth_png_bytes(folder, raw, shape):
    (folder / "d.png").write_bytes(raw)
    depth = ends_cleanly(read_depth_png, folder / "d.png", 0.001, shape)
    assert depth is None or (depth.dtype == np.float32 and depth.ndim == 2
                             and np.isfinite(depth).all())


PLY = encode_ply(np.random.default_rng(1).normal(size=(20, 3)), np.arange(20) % 3,
                 np.arange(18).reshape(6, 3))


@EXAMPLES
@given(st.one_of(st.binary(max_size=300), damaged_bytes(PLY),
                 st.builds(lambda head, body: b"ply\nformat " + head + b"\nend_header\n" + body,
                           st.binary(max_size=60), st.binary(max_size=60))))
def test_ply_bytes(folder, raw):
    (folder / "c.ply").write_bytes(raw)
    cloud = ends_cleanly(read_ply, folder / "c.ply")
    assert cloud is None or cloud[0].shape[1] == 3


def npz_bytes(arrays: dict) -> bytes:
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    return buf.getvalue()


NPZ = npz_bytes({"depth": np.full((2, 6, 8), 1000, np.uint16),
                 "K": np.array([[5.0, 0, 3.5], [0, 5, 2.5], [0, 0, 1]]),
                 "depth_scale": np.array(0.001)})
dtypes = st.sampled_from(["u1", "u2", "i4", "f4", "f8", "c8", "?", "U3", "M8[s]"])


@st.composite
def npz_arrays(draw) -> bytes:
    """An archive of arrays named like ours (or not), of random dtypes and shapes, values including
    NaN and inf."""
    arrays = {}
    for name in draw(st.sets(st.sampled_from(["depth", "K", "depth_scale", "timestamps", "colour",
                                              "other"]))):
        shape = tuple(draw(st.lists(st.integers(0, 4), max_size=4)))
        dtype = np.dtype(draw(dtypes))
        values = np.array([np.nan, np.inf, -1, 0, 1.5,
                           3e9])[np.arange(int(np.prod(shape))) % 6].reshape(shape)
        with np.errstate(invalid="ignore", over="ignore"):
            arrays[name] = values.astype(dtype) if dtype.kind not in "UM" else np.zeros(
                shape, dtype)
    return npz_bytes(arrays)


@EXAMPLES
@given(st.one_of(st.binary(max_size=200), damaged_bytes(NPZ), npz_arrays()))
def test_npz_bytes(folder, raw):
    (folder / "s.npz").write_bytes(raw)
    source = ends_cleanly(open_npz, folder / "s.npz")
    if source is not None:
        frame = ends_cleanly(source.read, 0)
        assert frame is None or np.isfinite(frame.depth).all()


def test_a_damaged_npz_member_is_refused_by_name(folder):
    raw = bytearray(NPZ)
    start = raw.index(b"\x93NUMPY")
    raw[start:start + 6] = b"XXXXXX"
    assert zipfile.is_zipfile(io.BytesIO(bytes(raw)))
    (folder / "s.npz").write_bytes(bytes(raw))
    with pytest.raises(MirrorscanError, match="s.npz"):
        open_npz(folder / "s.npz")


def intrinsics_bytes(save, name: str, folder: Path) -> bytes:
    save(CAMERA, folder / name)
    return (folder / name).read_bytes()


@EXAMPLES
@given(st.data())
def test_intrinsics_files(folder, data):
    for save, load, name in [(save_open3d_json, load_open3d_json, "k.json"),
                             (save_opencv_yaml, load_opencv_yaml, "k.yaml")]:
        raw = data.draw(st.one_of(st.binary(max_size=120),
                                  damaged_bytes(intrinsics_bytes(save, name, folder))))
        (folder / name).write_bytes(raw)
        camera = ends_cleanly(load, folder / name)
        # what was accepted is a camera that saves and loads to itself
        if camera is not None:
            save(camera, folder / name)
            again = load(folder / name)
            assert (again.width, again.height) == (camera.width, camera.height)
            assert np.allclose(again.K, camera.K) and camera.fx > 0 and camera.fy > 0
