"""A batch folder belongs to one session's contents: the manifest names the session and digests
each frame's depth file, so that another session is refused and a changed frame is done again."""

import json
import shutil
from types import SimpleNamespace

import cv2
import pytest
from tests.batch_scene import FRAMES, IN_PROCESS, ply_files
from tests.batch_scene import recording_fixture  # noqa: F401

from mirrorcore.base.errors import FileFormatError, MirrorscanError
from mirrorcore.batch import MANIFEST_FILE, BatchJob, run_batch
from mirrorcore.batch import digests
from mirrorcore.io.sessionfile import load_session


@pytest.fixture
def sessions(recording, tmp_path):
    """(A, B): the recording, and a copy of it with the same calibration and other frames."""
    a, b = tmp_path / "A", tmp_path / "B"
    shutil.copytree(recording, a)
    shutil.copytree(recording, b)
    for frame in load_session(b).frames:
        touch_pixel(b / frame)
    return a, b


def touch_pixel(path, value=1):
    """Change one depth reading of a frame (its file's bytes change, the scene hardly)."""
    depth = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    depth[0, 0] = depth[0, 0] + value
    cv2.imwrite(str(path), depth)


def manifest(out):
    return json.loads((out / MANIFEST_FILE).read_text())


def test_another_session_with_the_same_calibration_is_refused_naming_both(sessions, tmp_path):
    a, b = sessions
    out = tmp_path / "out"
    run_batch(BatchJob(a, out), IN_PROCESS)
    before = ply_files(out)
    with pytest.raises(MirrorscanError) as refused:
        run_batch(BatchJob(b, out), IN_PROCESS)
    said = str(refused.value)
    assert f"its frames are of the session {a}, not {b}" in said and "\n" not in said
    assert ply_files(out) == before and manifest(out)["session"] == str(a)
    report = run_batch(BatchJob(b, out), IN_PROCESS, overwrite=True)
    assert report.written == FRAMES and report.kept == 0 and manifest(out)["session"] == str(b)


def test_the_manifest_names_the_session_and_digests_each_depth_file(sessions, tmp_path):
    a, _ = sessions
    out = tmp_path / "out"
    run_batch(BatchJob(a, out), IN_PROCESS)
    data = manifest(out)
    assert data["version"] == 2 and len(data["session_sha256"]) == 64
    session = load_session(a)
    for frame in data["frames"]:
        path = a / session.frames[frame["index"]]
        assert frame["depth"]["sha256"] == digests.hashlib.sha256(path.read_bytes()).hexdigest()
        assert frame["depth"]["size"] == path.stat().st_size


def test_a_session_copied_whole_keeps_its_frames(sessions, tmp_path):
    a, _ = sessions
    out, moved = tmp_path / "out", tmp_path / "moved"
    run_batch(BatchJob(a, out), IN_PROCESS)
    shutil.copytree(a, moved)
    report = run_batch(BatchJob(moved, out), IN_PROCESS)
    assert report.kept == FRAMES and report.written == 0
    assert manifest(out)["session"] == str(moved)


@pytest.mark.parametrize("temporal, redone", [(0, [7]), (1, [6, 7, 8])])
def test_a_changed_depth_file_redoes_the_frames_made_from_it(sessions, tmp_path, temporal, redone):
    a, _ = sessions
    out = tmp_path / "out"
    run_batch(BatchJob(a, out, temporal=temporal), IN_PROCESS)
    before = {f["index"]: f["depth"] for f in manifest(out)["frames"]}
    touch_pixel(a / load_session(a).frames[7])
    report = run_batch(BatchJob(a, out, temporal=temporal), IN_PROCESS)
    assert report.written == len(redone) and report.kept == FRAMES - len(redone)
    after = {f["index"]: f["depth"] for f in manifest(out)["frames"]}
    assert [i for i in after if after[i] != before[i]] == [7]


def test_a_missing_depth_file_fails_its_frame_and_the_others_go_on(sessions, tmp_path):
    a, _ = sessions
    (a / load_session(a).frames[4]).unlink()
    report = run_batch(BatchJob(a, tmp_path / "out"), IN_PROCESS)
    assert list(report.failed) == [4] and report.written == FRAMES - 1


def test_a_rerun_hashes_only_the_files_that_changed(sessions, tmp_path, monkeypatch):
    a, _ = sessions
    out = tmp_path / "out"
    run_batch(BatchJob(a, out), IN_PROCESS)
    touch_pixel(a / load_session(a).frames[3])
    hashed = []
    real = digests.hashlib.sha256
    counting = SimpleNamespace(sha256=lambda data: hashed.append(data) or real(data))
    monkeypatch.setattr(digests, "hashlib", counting)
    report = run_batch(BatchJob(a, out), IN_PROCESS)
    assert report.written == 1
    # the changed frame's file, and the session's identity
    assert len(hashed) == 2


def test_a_version_1_manifest_keeps_its_frames_for_its_own_session_only(sessions, tmp_path):
    a, b = sessions
    out = tmp_path / "out"
    run_batch(BatchJob(a, out), IN_PROCESS)
    data = manifest(out)
    old = {**data, "version": 1, "frames": [
        {k: v for k, v in f.items() if k != "depth"} for f in data["frames"]]}
    del old["session_sha256"]
    (out / MANIFEST_FILE).write_text(json.dumps(old))
    with pytest.raises(MirrorscanError, match="its frames are of the session"):
        run_batch(BatchJob(b, out), IN_PROCESS)
    report = run_batch(BatchJob(a, out), IN_PROCESS)
    assert report.kept == FRAMES and report.written == 0
    # the depth files are taken as they are now
    assert manifest(out)["frames"] == data["frames"]
    assert manifest(out)["session_sha256"] == data["session_sha256"]


@pytest.mark.parametrize("index", ["3", None, 0.5, -1, True])
def test_a_frame_index_that_is_not_a_whole_number_is_refused(sessions, tmp_path, index):
    a, _ = sessions
    out = tmp_path / "out"
    run_batch(BatchJob(a, out), IN_PROCESS)
    data = manifest(out)
    data["frames"][0]["index"] = index
    (out / MANIFEST_FILE).write_text(json.dumps(data))
    with pytest.raises(FileFormatError) as refused:
        run_batch(BatchJob(a, out), IN_PROCESS)
    assert str(refused.value).endswith(
        f"frames[0].index: expected a whole number >= 0, got {index!r}")
