"""The server (mirrorscan.server): what viser drops for a closed tab is no warning, and a recorded
session opened plays unless a camera is live."""
import warnings
from pathlib import Path

import numpy as np
from mirrorscan.demo import calibrated_session, demo_source
from mirrorscan.server import MirrorscanApp, quiet_closed_connections

from mirrorcore.io.sessionfile import load_session
from mirrorcore.sources import StackSource


def test_what_viser_drops_for_a_closed_tab_is_not_shown_as_a_warning():
    """A tab closing while it is updated or built made viser warn in the technician's terminal; only
    that warning is silenced, not viser's others. viser names the caller's line as the warning's
    place (as `app/tab.py:306: UserWarning: Queued a LocalStorageGetItemRequestMessage ...`), so
    it goes whatever module it is attributed to."""
    text = ("Queued a GuiUpdateMessage on a closed connection (e.g. via a handle owned by a "
            "disconnected client)")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        quiet_closed_connections()
        warnings.warn_explicit(
            text, UserWarning, "buffer.py", 1, module="viser.infra._async_message_buffer"
        )
        warnings.warn_explicit(
            text.replace("Gui", "SceneNode"), UserWarning, "buffer.py", 1, module="viser"
        )
        warnings.warn_explicit(text, UserWarning, "tab.py", 1, module="mirrorscan.tab")
        warnings.warn_explicit("Something else", UserWarning, "buffer.py", 1, module="viser.infra")
    assert [(str(w.message), w.filename) for w in caught] == [("Something else", "buffer.py")]


def test_opening_a_recorded_session_plays_it_unless_a_camera_is_live():
    """Over the simulator the recording's frames play (its mirrors belong to them); a live camera
    stays, to be used with the opened session's calibration; the Record step's replay plays them
    anyway."""
    recorded = load_session(Path(__file__).resolve().parents[2] / "sessions" / "demo")
    simulator = demo_source()
    app = MirrorscanApp(
        calibrated_session(simulator, Path("unused")), simulator, port=0, autosave=False
    )
    try:
        app.open_session(recorded)
        assert app.source.frame_count == len(recorded.frames)
        app.pause(True)  # the replay paused on a frame ...
        # ... then the header's "Back to ..." button
        app.back_to_start_source()
        # live plays
        assert app.source is simulator and app.editor.session is recorded and not app.paused
        camera = StackSource(
            "camera",
            simulator.intrinsics,
            np.ones((2, *simulator.intrinsics.shape)),
            1.0,
            np.arange(2.0),
        )
        camera.frame_count = None  # live: no frame count, no seeking
        assert camera.camera and simulator.live and not simulator.camera
        app.use_source(camera)
        app.open_session(recorded)
        assert app.source is camera
        app.open_session(recorded, play=True)
        assert app.source.frame_count == len(recorded.frames)
    finally:
        app.stop()
