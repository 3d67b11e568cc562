"""`mirrorscan serve` in a process of its own whose session editor takes edits on stdin, as the
browser would make them, for tests of real processes (two servers, a full disk, the stop message).

Run as `python -m tests.cli.serving SESSION`; each line of stdin is a command, each answered by one
line of stdout:

- `add NAME`: add a mirror (answers `ok ID` or `refused REASON`);
- `rename ID NAME`: rename a mirror;
- `full` / `back`: every write into the session's folder fails with ENOSPC from now on / writes
  again;
- `state`: JSON of the save error, the read-only reason and the lasting notification.

It answers `ready` once the server listens. SIGTERM stops it as it stops `mirrorscan serve`.
"""
import errno
import json
import sys
import threading
from pathlib import Path

import mirrorcore.io.sessionfile as sessionfile
from mirrorcore.base.errors import MirrorscanError
from mirrorscan.cli import main
from mirrorscan.server import MirrorscanApp

WRITE = sessionfile.write_atomic


def full_disk(path, *args, **kwargs):
    """write_atomic with the session's folder on a full disk."""
    if Path(sys.argv[1]).resolve() in Path(path).resolve().parents:
        raise OSError(errno.ENOSPC, "No space left on device", str(path))
    WRITE(path, *args, **kwargs)


def answer(app: MirrorscanApp, command: str, args: list[str]) -> str:
    """One command's answer."""
    editor = app.editor
    if command == "add":
        return f"ok {editor.add_mirror(args[0])}"
    if command == "rename":
        editor.rename_mirror(int(args[0]), args[1])
        return "ok"
    if command in ("full", "back"):
        sessionfile.write_atomic = full_disk if command == "full" else WRITE
        return "ok"
    return json.dumps({"error": editor.last_save_error, "read_only": editor.read_only,
                       "note": app.unsaved.shown})


def drive(app: MirrorscanApp) -> None:
    """Answer the commands of stdin until it closes."""
    print("ready", flush=True)
    for line in sys.stdin:
        command, *args = line.split()
        try:
            reply = answer(app, command, args)
        except MirrorscanError as exc:
            reply = f"refused {exc}"
        print(reply, flush=True)


def start(app: MirrorscanApp, started=MirrorscanApp.start) -> None:
    """Start the app, then the thread that drives it."""
    started(app)
    threading.Thread(target=drive, args=(app,), daemon=True).start()


if __name__ == "__main__":
    MirrorscanApp.start = start
    sys.exit(main(["serve", *sys.argv[1:], "--port", "0"]))
