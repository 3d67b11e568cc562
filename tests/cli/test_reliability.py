"""Bad input that the other tests did not cover (absurd sizes, non-finite camera values, blank
frames, damaged intrinsics), the browser's background upload (size, type, content; refusals become
notifications, nothing lost) and security (loopback by default, no way out of the sessions folder,
no pickle, eval or exec in the source)."""

import json
import re
import struct
from pathlib import Path

import cv2
import numpy as np
import pytest

from mirrorscan.cli import build_parser, main
from mirrorscan.panels.session import SessionPanel
from mirrorcore.depth.files import encode_depth_png, read_depth_png
from mirrorcore.base.errors import FileFormatError, MirrorscanError
from mirrorcore.geometry.camera import MAX_IMAGE_SIDE, Intrinsics
from mirrorcore.geometry.camerafiles import load_opencv_yaml
from mirrorcore.io.session import Session
from mirrorcore.io.sessionfile import load_session, session_folder
from mirrorcore.sources import open_source

ROOT = Path(__file__).resolve().parents[2]
CAMERA = Intrinsics.primesense()


def test_a_png_claiming_an_absurd_size_is_refused_before_decoding(tmp_path):
    """A few hundred bytes whose header says 100000 x 100000 pixels (20 GB as uint16) are not
    decoded."""
    png = bytearray(encode_depth_png(np.ones((4, 4)), 0.001))
    png[16:24] = struct.pack(">II", 100_000, 100_000)
    (tmp_path / "bomb.png").write_bytes(bytes(png))
    with pytest.raises(
        FileFormatError,
        match=f"bomb.png: size 100000x100000 is too large for a depth image "
        f"\\(at most {MAX_IMAGE_SIDE} pixels a side\\)",
    ):
        read_depth_png(tmp_path / "bomb.png", 0.001)
    png[16:24] = struct.pack(">II", 640, 480)  # the right size in the header, 4 x 4 inside: broken
    (tmp_path / "liar.png").write_bytes(bytes(png))
    with pytest.raises(FileFormatError, match="liar.png: not a readable image"):
        read_depth_png(tmp_path / "liar.png", 0.001, CAMERA.shape)


@pytest.mark.parametrize(
    "value, message",
    [
        ("Infinity", "width and height must be integers, got infx480"),
        ("NaN", "width and height must be integers, got nanx480"),
        ("1e300", "width and height must be 1 to 16384 pixels, got 1e\\+300x480"),
        ("0", "width and height must be 1 to 16384 pixels, got 0x480"),
    ],
)
def test_camera_sizes_that_no_camera_has(tmp_path, value, message):
    """Python's JSON reads Infinity and NaN, which int() cannot take; a huge size would allocate its
    ray table."""
    text = json.dumps(Session(tmp_path, CAMERA).to_json()).replace(
        '"width": 640', f'"width": {value}'
    )
    (tmp_path / "session.json").write_text(text)
    with pytest.raises(FileFormatError, match=f"session.json: camera: {message}"):
        load_session(tmp_path)
    assert (tmp_path / "session.json").read_text() == text


@pytest.mark.parametrize("plane", [["a", 0, 1, 2], {"a": 1}, [[0, 0], [1]], [0, 0, 1]])
def test_planes_that_are_not_numbers(tmp_path, plane):
    data = Session(tmp_path, CAMERA).to_json()
    data["mirrors"] = [{"name": "m", "markers": [], "boundary": [], "plane": plane}]
    (tmp_path / "session.json").write_text(json.dumps(data))
    with pytest.raises(
        FileFormatError, match=r"mirrors\[0\] \(m\): plane: a plane needs 4 finite numbers"
    ):
        load_session(tmp_path)


def test_empty_and_damaged_intrinsics_files(tmp_path):
    (tmp_path / "empty.yaml").write_bytes(b"")
    with pytest.raises(FileFormatError, match="empty.yaml: not an OpenCV YAML file"):
        load_opencv_yaml(tmp_path / "empty.yaml")
    (tmp_path / "inf.yaml").write_text(
        "%YAML:1.0\n---\nimage_width: .inf\nimage_height: 480\n"
        "camera_matrix: !!opencv-matrix\n  rows: 3\n  cols: 3\n  dt: d\n"
        "  data: [525., 0., 319.5, 0., 525., 239.5, 0., 0., 1.]\n"
    )
    with pytest.raises(FileFormatError, match="inf.yaml: needs camera_matrix"):
        load_opencv_yaml(tmp_path / "inf.yaml")


def test_blank_frames_are_named_by_calibrate_and_reconstruct_and_change_nothing(tmp_path, capsys):
    assert main(["simulate", str(tmp_path / "s"), "--noise", "none", "--quiet"]) == 0
    assert main(["calibrate", str(tmp_path / "s")]) == 0
    for name in ["background.png", "frames/000000.png"]:
        cv2.imwrite(str(tmp_path / "s" / name), np.zeros(CAMERA.shape, np.uint16))
    before = (tmp_path / "s/session.json").read_bytes()
    capsys.readouterr()
    assert main(["calibrate", str(tmp_path / "s")]) == 2
    assert (
        "session.json: the frames and the background: no depth reading at all (every pixel is 0)"
        in capsys.readouterr().err
    )
    assert main(["calibrate", str(tmp_path / "s"), "--frame", "0"]) == 2
    assert "frames/000000.png: no depth reading at all" in capsys.readouterr().err
    assert (tmp_path / "s/session.json").read_bytes() == before
    for method in ["raw", "tsdf"]:
        assert (
            main(
                [
                    "reconstruct",
                    str(tmp_path / "s"),
                    "-o",
                    str(tmp_path / "out.ply"),
                    "--method",
                    method,
                ]
            )
            == 2
        )
        assert "frames/000000.png: no depth reading at all" in capsys.readouterr().err
    assert not (tmp_path / "out.ply").exists()


# ----------------------------------------------------------------- the browser's background upload
@pytest.fixture(scope="module")
def files(sphere):
    """(app, the Session step of its tab)."""
    app, headless = sphere
    return app, next(p for p in headless.tab.panels if isinstance(p, SessionPanel))


def saved_files(root: Path) -> dict:
    return {p.name: p.read_bytes() for p in root.iterdir() if p.is_file()}


def test_uploaded_background_is_used_and_saved(files, notes):
    app, panel = files
    said = notes(app)
    depth = app.source.background()
    app.act(None, lambda: panel.upload_background("bg.png", encode_depth_png(depth, 0.001)))
    assert said == [] and app.editor.session.background == "background.png"
    np.testing.assert_allclose(
        load_session(app.editor.session.root).read_background(), depth, atol=0.0006
    )
    np.testing.assert_allclose(app.snapshot.background, depth, atol=0.0006)


@pytest.mark.parametrize(
    "name, data, message",
    [
        (
            "big.png",
            b"\0" * (20 * 2**20 + 1),
            "big.png: 20.0 MB is more than the 20 MB an upload may have",
        ),
        ("depth.jpg", encode_depth_png(np.ones(CAMERA.shape), 0.001), "depth.jpg: not a .png file"),
        (
            "eight.png",
            cv2.imencode(".png", np.ones(CAMERA.shape, np.uint8))[1].tobytes(),
            "eight.png: a depth image is 16-bit",
        ),
        (
            "small.png",
            encode_depth_png(np.ones((240, 320)), 0.001),
            "small.png: size 320x240 does not match the camera's 640x480",
        ),
        (
            "blank.png",
            encode_depth_png(np.zeros(CAMERA.shape), 0.001),
            "blank.png: no depth reading at all",
        ),
        ("junk.png", b"\x89PNG\r\n\x1a\n" + bytes(100), "junk.png: not a readable image"),
    ],
)
def test_bad_uploads_are_notified_and_change_nothing(files, notes, name, data, message):
    app, panel = files
    said = notes(app)
    root = Path(app.editor.session.root)
    before, background = saved_files(root), app.snapshot.background
    app.act(None, lambda: panel.upload_background(name, data))
    assert len(said) == 1 and message in said[0]
    assert saved_files(root) == before and app.snapshot.background is background


# ---------------------------------------------------------------------------- security
def listening_addresses(port: int) -> set[str]:
    """The local addresses (hex, as in /proc/net/tcp) of sockets listening on `port`."""
    found = set()
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        for line in Path(table).read_text().splitlines()[1:]:
            local, state = line.split()[1], line.split()[3]
            address, hexport = local.rsplit(":", 1)
            if state == "0A" and int(hexport, 16) == port:  # 0A = LISTEN
                found.add(address)
    return found


def test_the_server_listens_on_loopback_only_by_default(files):
    app, _ = files
    assert build_parser().parse_args(["serve"]).host == "127.0.0.1"
    assert listening_addresses(app.port) == {"0100007F"}  # 127.0.0.1, nothing on 0.0.0.0 or ::


@pytest.mark.parametrize(
    "name",
    [
        "..",
        "../escape",
        "a/../../b",
        "a/b",
        "/etc",
        "C:\\x",
        "a\\..\\b",
        ".hidden",
        "",
        "x" * 101,
        "~root",
        "a\0b",
        "a\nb",
    ],
)
def test_session_names_cannot_leave_the_sessions_folder(files, notes, tmp_path, name):
    app, panel = files
    said = notes(app)
    with pytest.raises(MirrorscanError, match="session name"):
        session_folder(tmp_path / "sessions", name)
    outside = sorted(p.name for p in Path(app.sessions_dir).parent.iterdir())
    panel.new_name.value = name
    app.act(None, panel._save_as)
    assert len(said) == 1 and "session name" in said[0]
    assert sorted(p.name for p in Path(app.sessions_dir).parent.iterdir()) == outside


def test_good_session_names_and_exports_stay_inside(files, tmp_path):
    app, panel = files
    for name in ["scan 1", "a.b-c_d", "_x"]:
        assert session_folder(tmp_path, name).resolve().parent == tmp_path.resolve()
    saved = panel.export_cloud()
    assert saved.resolve().parent == (Path(app.editor.session.root) / "exports").resolve()


def test_a_pickled_npz_is_never_unpickled(tmp_path):
    """The object array would run code when unpickled; loading refuses it by name whatever the entry
    point."""
    np.savez(tmp_path / "evil.npz", depth=np.array([{"x": 1}], dtype=object), K=np.eye(3))
    with pytest.raises(
        FileFormatError,
        match="evil.npz: holds pickled \\(object\\) arrays, which mirrorscan never loads",
    ):
        open_source(f"npz:{tmp_path / 'evil.npz'}", None)


FORBIDDEN = {
    r"\beval\(": "eval",
    r"\bexec\(": "exec",
    r"\bimport pickle|\bfrom pickle|\bcPickle|\bdill\b": "pickle",
    r"allow_pickle\s*=\s*True": "allow_pickle=True",
    r"shell\s*=\s*True": "shell=True",
    r"yaml\.load\(|yaml\.unsafe_load": "unsafe YAML",
    r"\bos\.system\(": "os.system",
}


def test_the_source_has_no_eval_exec_pickle_or_shell():
    sources = [
        p
        for folder in ("mirrorcore", "app", "bench", "scripts")
        for p in (ROOT / folder).rglob("*.py")
    ]
    found = [
        f"{p.relative_to(ROOT)}:{n}: {what}"
        for p in sources
        for n, line in enumerate(p.read_text().splitlines(), 1)
        for pattern, what in FORBIDDEN.items()
        if re.search(pattern, line)
    ]
    assert sources and found == []
    loads = [
        f"{p.relative_to(ROOT)}:{n}"
        for p in sources
        for n, line in enumerate(p.read_text().splitlines(), 1)
        if "np.load(" in line and "allow_pickle=False" not in line
    ]
    assert loads == []


def test_opencv_yaml_is_read_without_opencvs_parser(tmp_path):
    """Damaged camera YAML once made cv2.FileStorage abort the process (found by the fuzzer); files
    written by OpenCV still read back exactly."""
    from mirrorcore.geometry.camera import Intrinsics
    from mirrorcore.geometry.camerafiles import save_opencv_yaml

    camera = Intrinsics(640, 480, 580.5, 581.25, 319.5, 239.75, 0.00025)
    save_opencv_yaml(camera, tmp_path / "k.yaml")
    assert load_opencv_yaml(tmp_path / "k.yaml", 0.001) == camera
    for text in (
        "%YAML:1.0\n---\ncamera_matrix: !!opencv-matrix\n  rows: [",
        "a: &x [*x]",
        "\x00\x01",
        "- 1\n- 2",
    ):
        (tmp_path / "bad.yaml").write_text(text)
        with pytest.raises(
            FileFormatError, match="bad.yaml: (not an OpenCV YAML file|needs camera_matrix)"
        ):
            load_opencv_yaml(tmp_path / "bad.yaml")
