"""The status header above the steps: the source and frame rate, one 'Start here' line that says
what to do next, the view (3D scene, depth frame or colour image), the legend with the points per
source (or, while the heat map shows, its key and each mirror's figures), the colour control
(mirrorscan.panels.colouring) and playback (pause, step, frame, point size)."""

from __future__ import annotations

import time
from collections import deque
from pathlib import Path

import numpy as np

from mirrorcore.sources import SessionSource

from ..context import TabContext
from ..events import JobProgress, LoopChanged, SessionChanged
from ..jobs import AGREEMENT, BATCH, RECORD, REFINE
from ..liveframe import LiveFrame, frame_number
from ..markup import markdown
from ..notices import place_notes
from ..page import draw_rate, keys_help, save_view, start_page
from .colouring import ColourControl
from .planes import from_markers, no_glass
from ..wording.hints import start_hint
from ..wording.jobs import recording_headline
from ..wording.saving import header_state

STATS_HZ = 4.0
# seconds the header says a tab lagged after it last did (it catches up and lags again)
LAG_NOTE_S = 5.0
# frames: the header gives the median of their processing times (one frame's jumps with whatever
# else the machine does)
PROCESS_WINDOW = 30
COLOUR_IMAGE = "Colour image"  # the depth frame's screen showing the colour image
VIEWS = {"3D scene": "3d", "Depth frame": "depth", COLOUR_IMAGE: "depth"}
PROGRESS_STEP = 0.05  # the start hint gives a calibration's progress in steps of this


def source_root(source) -> Path | None:
    """The folder of the session a source plays (a SessionSource), else None.

    Parameters
    ----------
    source : DepthSource

    Returns
    -------
    Path or None
    """
    return Path(source.session.root) if isinstance(source, SessionSource) else None


def source_title(source: str, played: Path | None, edited: Path | None) -> str:
    """The header's title: the source's name, then the session being edited when it is another.

    The folder of the session being edited is named when it is saved and not the one the source
    plays.

    Parameters
    ----------
    source : str
        The source's name.
    played : Path or None
        The folder of the session the source plays.
    edited : Path or None
        The folder of the session being edited, when it is saved.

    Returns
    -------
    str
        Markdown.
    """
    if edited is None or (played is not None and played.resolve() == Path(edited).resolve()):
        return f"**{source}**"
    return f"**{source}** · edits saved in session **{Path(edited).name}**"


def views(has_colour: bool) -> tuple[str, ...]:
    """The View buttons: the colour image only for a source that gives colour.

    Parameters
    ----------
    has_colour : bool

    Returns
    -------
    tuple of str
    """
    return tuple(VIEWS) if has_colour else tuple(v for v in VIEWS if v != COLOUR_IMAGE)


class LivePanel:
    """The status header above the steps, in one tab (see the module docstring).

    Parameters
    ----------
    tab : TabContext
        The tab it is built in.
    """
    def __init__(self, tab: TabContext):
        gui, self.tab, services = tab.gui, tab, tab.services
        # imported here: the steps' package imports this module's package
        from . import PANELS

        place_notes(tab.client)
        start_page(tab.client, tuple(panel.TITLE for panel in PANELS))
        # frames a second the page drew its 3D scene (poll_draws), None before it told
        self.draws: float | None = None
        self.title = gui.add_markdown("")
        self.back = gui.add_button(f"Back to {services.start_source.name}", visible=False)
        self.rate = gui.add_markdown("starting…")
        self.hint = gui.add_markdown("")
        self.view = gui.add_button_group("View", views(services.source.has_colour))
        self.legend = gui.add_html("")
        with gui.add_folder("Playback and view", expand_by_default=False):
            # the colour first: the heat map's legend, above the folder, would push the control
            # below the fold at 1024x600
            self.colours = ColourControl(tab, self.legend)
            self.pause = gui.add_checkbox("Pause", initial_value=services.paused)
            self.step = gui.add_button("Step one frame", disabled=not services.paused)
            self.seek = gui.add_slider(
                "Frame", min=0, max=1, step=1, initial_value=0, visible=False
            )
            self.size = gui.add_slider(
                "Point size (mm)", min=1.0, max=20.0, step=0.5, initial_value=6.0
            )
            self.frame_object = gui.add_button("Look at the object")
            self.virtual = gui.add_checkbox(
                "Virtual cameras",
                initial_value=True,
                hint="the camera as each mirror, and each sequence of mirrors, shows it",
            )
            self.pixel = gui.add_markdown("Last pixel read: none yet")
            self.save_view = gui.add_button(
                "Save the view as PNG", hint="what the 3D view shows now, at its size on the page"
            )
            gui.add_markdown(keys_help())
        self._pixel_note = None  # the notification showing the last pixel read
        self.view.on_click(lambda e: self._look(e.target.value))
        self.pause.on_update(lambda e: e.client is not None and services.pause(self.pause.value))
        self.step.on_click(lambda _: services.step())
        self.back.on_click(lambda _: tab.act(services.back_to_start_source))
        self.seek.on_update(lambda e: e.client is not None and services.seek(int(self.seek.value)))
        self.size.on_update(lambda _: tab.scene.set_point_size(self.size.value / 1000))
        self.virtual.on_update(lambda _: tab.scene.show_virtual_cameras(bool(self.virtual.value)))
        self.save_view.on_click(lambda _: save_view(tab.client, tab.act))
        self.frame_object.on_click(
            lambda _: tab.act(lambda: (tab.look("3d"), tab.look_at_object()))
        )
        tab.on_click("inspect", self.show_pixel)
        tab.on_state(lambda _: self.refresh_hint())
        # how far, while one runs
        self._calibrating = 0.0 if services.jobs.running(REFINE) else None
        self._recording = services.jobs.running(RECORD)
        # how far, while one runs
        self._batch = 0.0 if services.jobs.running(BATCH) else None
        self._unsubscribe = [
            services.bus.subscribe(LoopChanged, self._on_loop),
            services.bus.subscribe(JobProgress, self._on_job),
            services.bus.subscribe(SessionChanged, self._name),
        ]
        self._last_stats = 0.0
        # the last frames' processing times
        self._process_ms: deque[float] = deque(maxlen=PROCESS_WINDOW)
        self._follow(services.source)

    def detach(self) -> None:
        """Stop listening to the app (the tab closed)."""
        for unsubscribe in self._unsubscribe:
            unsubscribe()

    def _on_job(self, event: JobProgress) -> None:
        """A calibration from the object, a batch or a recording began or ended.

        The hint says so (for the first two, how far they are, by 5 %: at 1024x600 the calibration's
        progress bar is below the fold, the batch's in a folder of another step), then what comes
        next.
        """
        done = (
            None
            if event.fraction is None
            else PROGRESS_STEP * np.floor(event.fraction / PROGRESS_STEP)
        )
        if event.job == REFINE and done != self._calibrating:
            self._calibrating = done
            self.refresh_hint()
        elif event.job == BATCH and done != self._batch:
            self._batch = done
            self.refresh_hint()
        elif event.job == RECORD and (event.fraction is not None) != self._recording:
            self._recording = event.fraction is not None
            self.refresh_hint()
        elif event.job == AGREEMENT and event.fraction is None:
            # the mirrors it flags, or none now
            self.refresh_hint()

    def _on_loop(self, event: LoopChanged) -> None:
        """Follow the live loop: pause, step, the source's title and the hint."""
        self.pause.value = event.paused
        self.step.disabled = not event.paused
        self._follow(event.source)
        self.colours.follow()
        self.refresh_hint()

    def _follow(self, source) -> None:
        """Name the source.

        Show the frame slider for a recording (seekable), hide it for a live camera; offer the way
        back to the source served from the start while another plays.
        """
        self._name()
        self.back.visible = source is not self.tab.services.start_source
        self.view.options = views(source.has_colour)
        if source.frame_count:
            self.seek.max = max(source.frame_count - 1, 1)
        self.seek.visible = bool(source.frame_count)

    def _name(self, event: SessionChanged | None = None) -> None:
        """The header's title.

        The source, and the session being edited where it is saved and is not the one that plays
        (after Record's replay and Back to, the edits go to the recording's session); then whether
        its edits are not saved, or it is open read-only.
        """
        services = self.tab.services
        editor = services.editor
        self.title.content = markdown(
            source_title(
                services.source.name,
                source_root(services.source),
                editor.session.root if editor.autosave else None,
            )
            + header_state(editor.last_save_error, editor.read_only)
        )

    def refresh_hint(self) -> None:
        """Rewrite the 'Start here' line for the state of the work."""
        services = self.tab.services
        snapshot = services.snapshot
        playback = (
            "paused"
            if services.paused
            else "live"
            if services.source is services.start_source
            else "recording"
        )
        session, jobs = snapshot.session, services.jobs
        unused = tuple(
            m.name
            for m in session.mirrors
            if services.editor.glass_unused(m.id) and not jobs.from_object(m.id, m.plane)
        )
        hint = start_hint(
            session,
            self.tab.state,
            services.last_frame is not None,
            snapshot.background is not None,
            playback,
            self._calibrating,
            self._recording,
            no_glass(jobs, session),
            unused,
            jobs.refusals(session),
            services.start_source.name,
            self._batch,
            jobs.disagreeing,
            from_markers(jobs, services.editor, session),
        )
        self.hint.content = "➜ " + markdown(hint)

    def show(self, frame: LiveFrame) -> None:
        """Refresh the figures at STATS_HZ (every frame while paused).

        Parameters
        ----------
        frame : LiveFrame
        """
        now = time.perf_counter()
        self._process_ms.append(frame.process_ms)
        if now - self._last_stats < 1 / STATS_HZ and not self.tab.services.paused:
            return
        first = self._last_stats == 0.0
        self._last_stats = now
        services = self.tab.services
        paced = services.pacing()
        count = services.source.frame_count
        number = frame_number(frame.index, count)
        which = f"frame {number} of {count}" if count else f"frame {number}"
        rate = "**paused**" if services.paused else f"**{services.fps():.1f} fps**"
        if self.draws is not None:
            rate += f" · page draws {self.draws:.1f}/s"
        state = services.jobs.recording_state()
        recording = None if state is None else recording_headline(state)
        self.rate.content = (
            (f"{recording} · " if recording else "")
            + f"{which} · {rate} · processing {np.median(self._process_ms):.1f} ms"
            + (f" · at most {paced[0]:.0f} fps {paced[1]}" if paced and not services.paused else "")
            + (
                " · ⚠ the page draws slower than frames come: sent fewer"
                if now - self.tab.lagged_at < LAG_NOTE_S
                else ""
            )
        )
        if count:
            self.seek.value = number
        self.colours.show_legend(frame)
        if first:
            self.refresh_hint()

    def poll_draws(self) -> None:
        """Read how often the tab's page draws its 3D scene (the header shows it)."""
        self.draws = draw_rate(self.tab.client)

    def _look(self, view: str) -> None:
        """Show a view of the View buttons (VIEWS): the colour image is the depth frame's screen
        showing the colour image."""
        self.tab.state.colour_image = view == COLOUR_IMAGE
        self.tab.look(VIEWS[view])

    def show_pixel(self, u: float, v: float) -> None:
        """Show the depth read at a clicked pixel, in the header and in a notification.

        One reading shows at a time: the clicks' notifications do not stack.

        Parameters
        ----------
        u, v : float
            Pixels.
        """
        frame = self.tab.services.last_frame
        if frame is None:
            return
        rows, cols = frame.depth.shape
        depth = float(frame.depth[min(int(round(v)), rows - 1), min(int(round(u)), cols - 1)])
        reading = f"{depth:.3f} m" if depth > 0 else "no reading"
        self.pixel.content = markdown(f"pixel ({u:.1f}, {v:.1f}): {reading}")
        # one reading shown at a time: the clicks' notes do not stack
        if self._pixel_note is not None:
            self._pixel_note.remove()
        self._pixel_note = self.tab.client.add_notification(
            "Pixel", self.pixel.content, color="blue", auto_close_seconds=6.0
        )
