"""The "Session" step: where the session lives and whether it is saved, open another, save it under
a new name (or, while it cannot be saved, in another folder), upload a depth PNG as the background,
and export the current cloud as PLY, in the scene's colours when it has them (downloaded by the
tab, kept in the session's exports/ folder under a new name each time)."""

from __future__ import annotations

from pathlib import Path

from mirrorcore.depth.files import decode_depth_png, require_readings
from mirrorcore.base.errors import MirrorscanError
from mirrorcore.io.session import SESSION_FILE
from mirrorcore.io.sessionfile import copy_session, load_session, session_folder

from ..context import TabContext
from ..events import SessionChanged
from ..exports import cloud_ply, export_ply
from ..jobs import unplaned
from ..liveframe import frame_number
from ..markup import markdown
from ..wording.jobs import left_out
from ..wording.saving import read_only, unsaved

TITLE = "Session"
CHOOSE = ""  # the Open list's first entry: nothing is opened by a stray click on the button
MAX_UPLOAD_MB = 20  # a 16-bit 640x480 depth PNG is under 1 MB; 4096x4096 uncompressed is 32 MB


def session_names(sessions_dir: Path) -> tuple[list[str], int]:
    """The names of the session folders in `sessions_dir` that can be opened, sorted.

    Parameters
    ----------
    sessions_dir : Path

    Returns
    -------
    names : list of str
        Those that `session_folder` accepts.
    skipped : int
        How many others hold a session.json (names that are not UTF-8 among them, which the
        browser could not be sent).
    """
    names, skipped = [], 0
    for path in sessions_dir.glob(f"*/{SESSION_FILE}"):
        try:
            session_folder(sessions_dir, path.parent.name)
        except MirrorscanError:
            skipped += 1
            continue
        names.append(path.parent.name)
    return sorted(names), skipped


class SessionPanel:
    """The "Session" step of one tab (see the module docstring).

    Parameters
    ----------
    tab : TabContext
        The tab it is built in.
    """
    TITLE = TITLE

    def __init__(self, tab: TabContext):
        gui, self.tab, self.services = tab.gui, tab, tab.services
        self.where = gui.add_markdown("")
        self.export = gui.add_button("Export the cloud as PLY", color="blue")
        self.exported = gui.add_markdown("")
        self._root = self.services.editor.session.root  # the session the export line speaks of
        self.open_choice = gui.add_dropdown("Open", (CHOOSE,))
        # the session folders left out of the Open list, said under it
        self.skipped = gui.add_markdown("")
        self.open = gui.add_button("Open session")
        self.new_name = gui.add_text("Save as", "")
        self.save_as = gui.add_button("Save as new session")
        # while the session cannot be saved where it is (or is open read-only)
        self.elsewhere = gui.add_text("Folder", "", visible=False,
                                      hint="a new or empty folder on a disk that can be written")
        self.save_elsewhere = gui.add_button("Save elsewhere", visible=False)
        # the question asked before an unsaved session goes
        self.confirm_open = None
        self.upload = gui.add_upload_button(
            f"Upload background (16-bit depth PNG, at most {MAX_UPLOAD_MB} MB)",
            mime_type="image/png",
        )
        act = tab.act
        self.open.on_click(lambda _: act(self._open))
        self.save_as.on_click(lambda _: act(self._save_as))
        self.save_elsewhere.on_click(lambda _: act(self._save_elsewhere))
        self.upload.on_upload(
            lambda e: act(
                lambda: self.upload_background(e.target.value.name, e.target.value.content)
            )
        )
        self.export.on_click(lambda _: act(self.export_cloud))
        self._unsubscribe = self.services.bus.subscribe(SessionChanged, lambda _: self.refresh())
        self.refresh()

    def detach(self) -> None:
        """Stop listening to the app (the tab closed)."""
        self._unsubscribe()

    def refresh(self) -> None:
        """Show where the session lives and whether it is saved; refresh the Open list."""
        editor = self.services.editor
        state = (
            "autosaved after every change"
            if editor.autosave
            else "not saved yet: *Save as* to keep it"
        )
        if editor.read_only is not None:
            trouble = read_only(editor.read_only)
        elif editor.last_save_error is not None:
            trouble = unsaved(editor.session.root, editor.last_save_error)
        else:
            trouble = None
        self.where.content = markdown(f"`{editor.session.root}` ({state})") + (
            "\n\n" + trouble.markdown() if trouble else "")
        self.elsewhere.visible = self.save_elsewhere.visible = trouble is not None
        # another session: the last export was another's
        if editor.session.root != self._root:
            self._root, self.exported.content = editor.session.root, ""
        names, skipped = session_names(self.services.sessions_dir)
        if self.open_choice.options != (CHOOSE, *names):
            self.open_choice.options = (CHOOSE, *names)
        self.skipped.content = (
            markdown(
                f"Not listed: {skipped} session folder{'s' if skipped > 1 else ''} whose name has "
                "more than letters, digits, spaces and _ - . (rename it to open it)"
            )
            if skipped
            else ""
        )

    def _open(self) -> None:
        """Open the chosen session.

        While the current one is not saved (the built-in demo), only once the user has confirmed
        that its calibration goes.
        """
        name = self.open_choice.value
        if name == CHOOSE:
            raise MirrorscanError(
                f"choose a session in the Open list first (saved sessions are in "
                f"{self.services.sessions_dir})"
            )
        session = load_session(session_folder(self.services.sessions_dir, name))
        if self.services.editor.autosave:
            self.services.open_session(session)
            return
        self.confirm_open = self.tab.ask(
            f"Open {name}?",
            "This session is not saved: its mirrors and calibration go when another one opens. "
            "*Save as* first to keep them.",
            f"Open {name}, discard this one",
            lambda: self.services.open_session(session),
            "Keep this session",
        )

    def _save_as(self) -> None:
        """Save the session as a new one in the sessions folder and go on editing that one.

        A background captured while the session was not saved (held in memory) is written with it.
        """
        folder = session_folder(self.services.sessions_dir, self.new_name.value)
        services = self.services
        held = (
            services.snapshot.background
            if services.background_captured and not services.editor.autosave
            else None
        )
        services.open_session(copy_session(services.editor.session, folder))
        if held is not None:
            services.set_background(held)
        self.new_name.value = ""

    def _save_elsewhere(self) -> None:
        """Save the session, as edited, in the folder typed, and go on editing it there.

        Raises
        ------
        MirrorscanError
            One line: no folder typed, or it cannot be written (nothing changed).
        """
        typed = self.elsewhere.value.strip()
        if not typed:
            raise MirrorscanError("type a folder to save in first (a new or empty one)")
        folder = Path(typed).expanduser()
        try:
            copy = copy_session(self.services.editor.session, folder)
        except OSError as exc:
            raise MirrorscanError(f"{folder}: cannot save there ({exc.strerror or exc})") from None
        self.services.open_session(copy)
        self.elsewhere.value = ""

    def upload_background(self, name: str, data: bytes) -> None:
        """Use an uploaded depth PNG as the background, saved as the session's background.png.

        Parameters
        ----------
        name : str
            The file's name.
        data : bytes
            The file's bytes.

        Raises
        ------
        MirrorscanError
            Naming the file: more than MAX_UPLOAD_MB, a name not ending in .png, an image that is
            not 16-bit or not the camera's size, and one with no reading at all.
        """
        if len(data) > MAX_UPLOAD_MB * 2**20:
            raise MirrorscanError(
                f"{name}: {len(data) / 2**20:.1f} MB is more than the {MAX_UPLOAD_MB} MB an "
                "upload may have"
            )
        if not name.lower().endswith(".png"):
            raise MirrorscanError(f"{name}: not a .png file; upload a 16-bit depth PNG")
        camera = self.services.editor.session.camera
        depth = require_readings(
            decode_depth_png(data, camera.depth_scale, camera.shape, name), name
        )
        self.services.set_background(depth)

    def export_cloud(self) -> Path | None:
        """Export the current cloud as PLY, in the scene's colours when the frame has them.

        Downloaded and, for a saved session, kept under a new name in exports/.

        Returns
        -------
        Path or None
            The file kept, if any.
        """
        frame = self.services.last_frame
        if frame is None:
            raise MirrorscanError("no cloud yet to export")
        data = cloud_ply(frame.cloud)
        root = self.services.editor.session.root if self.services.editor.autosave else None
        count = self.services.source.frame_count
        # as the header names it
        number = frame_number(frame.index, count)
        saved = export_ply(root, f"frame-{number:06d}", data, self.tab.client)
        # as the header says
        which = f"Frame {number} of {count}" if count else f"Live frame {number}"
        missing = left_out(unplaned(frame.snapshot.session))
        self.exported.content = markdown(
            f"{which}: {len(frame.cloud):,} points"
            + (f", saved as `{saved}`" if saved else ", downloaded")
            + (f". ⚠ {missing}" if missing else "")
        )
        # 1,946 points of a person mostly inside the outlines, said as done
        if missing:
            self.services.notify(
                self.tab.client,
                "Exported, not all of the object",
                f"{which}: {len(frame.cloud):,} points; {missing}.",
                "warning",
            )
        return saved
