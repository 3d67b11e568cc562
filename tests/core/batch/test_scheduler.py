"""Never hang: an address that is not a Dask scheduler's is refused in one line within a few
seconds, and Ctrl-C stops `reconstruct --frame all` at once, while it connects and while it runs."""

import http.server
import json
import signal
import socket
import subprocess
import sys
import threading
import time

import pytest
from tests.batch_scene import recording_fixture  # noqa: F401

from mirrorcore.base.errors import Cancelled, MirrorscanError
from mirrorcore.batch import Where
from mirrorcore.batch.scheduler import PROBE_SECONDS, probe_scheduler, scheduler_address
from mirrorscan.cli import main
from tests.waiting import wait_for

# seconds from SIGINT to the command's "cancelled": it looks every 0.1 s (0.25 s on Dask); the
# rest is slack for a loaded 2-core machine
CTRL_C_SECONDS = 2.0
# seconds from SIGINT to the end of a batch on local Dask workers: the figure (0.1 to
# 0.4 s measured on a loaded machine; a graceful close of the workers takes 1.6 to 1.9 s)
CTRL_C_EXIT_SECONDS = 1.0
# seconds a refusal may take beyond PROBE_SECONDS on a loaded machine
SLACK_SECONDS = 10.0


@pytest.fixture
def silent():
    """The port of a listener that accepts connections and never says a word."""
    server = socket.create_server(("127.0.0.1", 0))
    held = []
    accepted = threading.Event()

    def accept():
        while True:
            try:
                held.append(server.accept()[0])
            except OSError:
                return
            accepted.set()

    threading.Thread(target=accept, daemon=True).start()
    yield server.getsockname()[1], accepted
    server.close()
    for connection in held:
        connection.close()


@pytest.fixture
def web():
    """The port of an HTTP server (as a Dask dashboard's)."""
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), http.server.SimpleHTTPRequestHandler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    yield server.server_address[1]
    server.shutdown()
    server.server_close()


@pytest.fixture
def babbler():
    """The port of a server that greets each connection with a line of text (as SSH does)."""
    server = socket.create_server(("127.0.0.1", 0))

    def greet():
        while True:
            try:
                connection = server.accept()[0]
            except OSError:
                return
            connection.sendall(b"SSH-2.0-OpenSSH_9.6\r\n")
            connection.close()

    threading.Thread(target=greet, daemon=True).start()
    yield server.getsockname()[1]
    server.close()


def refused_in_one_line(capsys, recording, tmp_path, scheduler: str) -> tuple[str, float]:
    """Run a batch on `scheduler`: (its one-line error, seconds taken); nothing written."""
    capsys.readouterr()
    start = time.monotonic()
    argv = ["reconstruct", str(recording), "-o", str(tmp_path / "out"), "--frame", "all",
            "--scheduler", scheduler]
    assert main(argv) == 2
    seconds = time.monotonic() - start
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert not (tmp_path / "out").exists()
    return err, seconds


@pytest.mark.parametrize("address, message", [
    ("", "--scheduler '': not a scheduler's address"),
    ("ucx://127.0.0.1:8786", "--scheduler ucx://127.0.0.1:8786: only tcp:// schedulers"),
    ("tcp://127.0.0.1", "not a scheduler's address"),
    ("127.0.0.1:0", "not a scheduler's address"),
    ("tcp://:8786", "not a scheduler's address"),
])
def test_an_address_of_no_scheduler_is_refused_before_any_work(
        recording, tmp_path, capsys, address, message):
    err, _ = refused_in_one_line(capsys, recording, tmp_path, address)
    assert message in err
    # refused where it is given: no "starting N local Dask workers" before it
    assert "starting" not in capsys.readouterr().out


def test_the_forms_of_an_address():
    assert scheduler_address("tcp://10.0.0.5:8786") == ("10.0.0.5", 8786)
    assert scheduler_address("node7:8786") == ("node7", 8786)
    assert scheduler_address("tcp://[::1]:8786") == ("::1", 8786)
    with pytest.raises(MirrorscanError, match="only tcp://"):
        Where(scheduler="tls://node7:8786")


def test_a_silent_listener_is_refused_within_seconds(recording, tmp_path, capsys, silent):
    port, accepted = silent
    err, seconds = refused_in_one_line(capsys, recording, tmp_path, f"127.0.0.1:{port}")
    assert f"--scheduler 127.0.0.1:{port}: no answer as a Dask scheduler in time" in err
    assert accepted.is_set() and PROBE_SECONDS <= seconds < PROBE_SECONDS + SLACK_SECONDS


def test_an_http_server_is_refused_within_seconds(recording, tmp_path, capsys, web):
    err, seconds = refused_in_one_line(capsys, recording, tmp_path, f"tcp://127.0.0.1:{web}")
    assert "no answer as a Dask scheduler in time" in err and "EiB" not in err
    assert seconds < PROBE_SECONDS + SLACK_SECONDS


def test_a_peer_that_answers_otherwise_is_refused_at_once(babbler):
    start = time.monotonic()
    with pytest.raises(MirrorscanError, match="answers, but not as a Dask scheduler"):
        probe_scheduler(f"127.0.0.1:{babbler}", seconds=30)
    assert time.monotonic() - start < SLACK_SECONDS


def test_nothing_listening_is_refused_at_once():
    with socket.create_server(("127.0.0.1", 0)) as closed:
        port = closed.getsockname()[1]
    with pytest.raises(MirrorscanError, match="no Dask scheduler answered"):
        probe_scheduler(f"127.0.0.1:{port}", seconds=30)


def test_a_cancel_request_stops_the_probe(silent):
    port, _ = silent
    cancel = threading.Event()
    threading.Timer(0.3, cancel.set).start()
    start = time.monotonic()
    with pytest.raises(Cancelled):
        probe_scheduler(f"127.0.0.1:{port}", cancel, seconds=30)
    assert time.monotonic() - start < CTRL_C_SECONDS


def interrupted(argv: list[str], ready, exited: list | None = None) -> tuple[int, float, str]:
    """Run `mirrorscan argv` in a process, send it SIGINT once ready() is true.

    Returns its exit status, the seconds from SIGINT to its 'cancelled' line, and its stderr;
    `exited`, when given, receives the seconds from SIGINT to the process's end and the process
    ids its children had just before.
    """
    import psutil

    process = subprocess.Popen([sys.executable, "-m", "mirrorscan.cli", *argv],
                               stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    lines, said = [], {}

    def read():
        for line in process.stderr:
            lines.append(line)
            if "cancelled" in line:
                said["at"] = time.monotonic()

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    try:
        wait_for(lambda: ready() or process.poll() is not None, seconds=120)
        children = [c.pid for c in psutil.Process(process.pid).children(recursive=True)]
        sent = time.monotonic()
        process.send_signal(signal.SIGINT)
        status = process.wait(timeout=120)
        if exited is not None:
            exited += [time.monotonic() - sent, children]
        reader.join(10)
    finally:
        process.kill()
    return status, said.get("at", float("inf")) - sent, "".join(lines)


def test_ctrl_c_stops_a_connection_attempt_at_once(recording, tmp_path, silent):
    port, accepted = silent
    status, seconds, err = interrupted(
        ["reconstruct", str(recording), "-o", str(tmp_path / "out"), "--frame", "all",
         "--scheduler", f"127.0.0.1:{port}"], accepted.is_set)
    assert status == 130 and seconds < CTRL_C_SECONDS, err


def frames_done(out) -> int:
    """The frames a batch folder's manifest holds (0 before it is written)."""
    try:
        return len(json.loads((out / "manifest.json").read_text())["frames"])
    except (OSError, ValueError):
        return 0


def alive(pid: int) -> bool:
    """Whether a process runs (a zombie does not)."""
    import psutil

    try:
        return psutil.Process(pid).status() != psutil.STATUS_ZOMBIE
    except psutil.NoSuchProcess:
        return False


def test_ctrl_c_stops_a_batch_at_once_and_keeps_its_frames(recording, tmp_path):
    out = tmp_path / "out"
    # frames of a second or so each, in this process
    status, seconds, err = interrupted(
        ["reconstruct", str(recording), "-o", str(out), "--frame", "all", "--workers", "1",
         "--method", "tsdf", "--voxel", "0.003"], lambda: frames_done(out) >= 1)
    assert status == 130 and seconds < CTRL_C_SECONDS, err
    assert 1 <= frames_done(out) < 20


def test_ctrl_c_ends_a_batch_on_local_dask_workers_at_once_and_leaves_no_process(recording,
                                                                                  tmp_path):
    out = tmp_path / "out"
    exited = []
    # the two workers are busy with frames of a second or so each
    status, seconds, err = interrupted(
        ["reconstruct", str(recording), "-o", str(out), "--frame", "all", "--workers", "2",
         "--method", "tsdf", "--voxel", "0.003"], lambda: frames_done(out) >= 1, exited)
    took, children = exited
    assert status == 130 and seconds < CTRL_C_SECONDS and took < CTRL_C_EXIT_SECONDS, (took, err)
    assert 1 <= frames_done(out) < 20 and len(children) >= 2
    assert wait_for(lambda: not any(alive(pid) for pid in children), seconds=5)
