"""The "Session" folder: where the session lives, open another, save it under a new name, upload a depth PNG as the
background, and export the current cloud as PLY (downloaded to the browser and saved in the session's exports/
folder)."""
from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import viser

from mirrorcore.atomic import write_atomic
from mirrorcore.depthio import decode_depth_png, require_readings
from mirrorcore.errors import MirrorscanError
from mirrorcore.ply import encode_ply
from mirrorcore.session import (
    BACKGROUND_FILE,
    SESSION_FILE,
    copy_session,
    load_session,
    session_folder,
)

if TYPE_CHECKING:
    from ..server import MirrorscanApp

EXPORTS = "exports"
MAX_UPLOAD_MB = 20   # a 16-bit 640x480 depth PNG is under 1 MB; 4096x4096 uncompressed is 32 MB


class FilesPanel:
    def __init__(self, app: "MirrorscanApp"):
        gui, self.app = app.server.gui, app
        with gui.add_folder("Session", expand_by_default=False):
            self.where = gui.add_markdown("")
            self.open_choice = gui.add_dropdown("Open", ("",))
            self.open = gui.add_button("Open session")
            self.new_name = gui.add_text("Save as", "")
            self.save_as = gui.add_button("Save as new session")
            self.upload = gui.add_upload_button("Upload background (16-bit depth PNG)", mime_type="image/png",
                                                hint=f"the scene without the object; at most {MAX_UPLOAD_MB} MB")
        with gui.add_folder("Export"):
            self.export = gui.add_button("Export cloud as PLY")
            self.export_mesh = gui.add_button("Export dense result as PLY")
            self.exported = gui.add_markdown("")
        self.open.on_click(lambda e: app.act(e.client, self._open))
        self.save_as.on_click(lambda e: app.act(e.client, self._save_as))
        self.upload.on_upload(lambda e: app.act(e.client, lambda: self.upload_background(e.target.value.name,
                                                                                        e.target.value.content)))
        self.export.on_click(lambda e: app.act(e.client, lambda: self.export_cloud(e.client)))
        self.export_mesh.on_click(lambda e: app.act(e.client, lambda: self.export_dense(e.client)))
        self.refresh()

    def refresh(self) -> None:
        editor = self.app.editor
        state = "autosaved after every change" if editor.autosave else "not saved yet: *Save as* to keep it"
        error = f" — **last save failed**: {editor.last_save_error}" if editor.last_save_error else ""
        self.where.content = f"`{editor.session.root}` ({state}){error}"
        names = tuple(sorted(p.parent.name for p in self.app.sessions_dir.glob(f"*/{SESSION_FILE}"))) or ("",)
        if self.open_choice.options != names:
            self.open_choice.options = names

    def _open(self) -> None:
        if not self.open_choice.value:
            raise MirrorscanError(f"no saved session in {self.app.sessions_dir}")
        self.app.open_session(load_session(session_folder(self.app.sessions_dir, self.open_choice.value)))

    def _save_as(self) -> None:
        folder = session_folder(self.app.sessions_dir, self.new_name.value)
        self.app.open_session(copy_session(self.app.editor.session, folder))
        self.new_name.value = ""

    def upload_background(self, name: str, data: bytes) -> None:
        """Use an uploaded depth PNG (`data`, the file's bytes) as the background, saved as the session's
        background.png. Refuses (MirrorscanError naming the file) more than MAX_UPLOAD_MB, a name not ending in .png,
        an image that is not 16-bit or not the camera's size, and one with no reading at all."""
        if len(data) > MAX_UPLOAD_MB * 2**20:
            raise MirrorscanError(f"{name}: {len(data) / 2**20:.1f} MB is more than the {MAX_UPLOAD_MB} MB an "
                                  "upload may have")
        if not name.lower().endswith(".png"):
            raise MirrorscanError(f"{name}: not a .png file; upload a 16-bit depth PNG")
        camera = self.app.editor.session.camera
        depth = require_readings(decode_depth_png(data, camera.depth_scale, camera.shape, name), name)
        self.app.set_background(depth, BACKGROUND_FILE)

    def export_cloud(self, client: viser.ClientHandle | None) -> Path | None:
        """The current cloud as PLY (see _export)."""
        frame = self.app.last_frame
        if frame is None:
            raise MirrorscanError("no cloud yet to export")
        saved = self._export(f"frame-{frame.index:06d}.ply", encode_ply(frame.cloud.points, frame.cloud.sources),
                             client)
        self.exported.content = f"{len(frame.cloud):,} points" + (f", saved as `{saved}`" if saved else ", downloaded")
        return saved

    def export_dense(self, client: viser.ClientHandle | None) -> Path | None:
        """The last dense result (carved voxels, or the fused mesh with its faces) as PLY (see _export)."""
        data = self.app.dense_panel.export_bytes()
        if data is None:
            raise MirrorscanError("no dense result yet: run one in the Dense folder")
        saved = self._export(f"dense-{self.app.dense_panel.method_name()}.ply", data, client)
        self.exported.content = "dense result" + (f" saved as `{saved}`" if saved else " downloaded")
        return saved

    def _export(self, name: str, data: bytes, client: viser.ClientHandle | None) -> Path | None:
        """Send PLY bytes to `client` as a download and, for a saved session, write them into its exports/ folder
        (the path returned)."""
        saved = None
        if self.app.editor.autosave:
            saved = Path(self.app.editor.session.root) / EXPORTS / name
            saved.parent.mkdir(parents=True, exist_ok=True)
            write_atomic(saved, data)
        if client is not None:
            client.send_file_download(name, data, save_immediately=True)
        return saved
