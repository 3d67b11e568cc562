"""The status header above the steps: the source and frame rate, one 'Start here' line that says what to do next,
the view (3D scene or depth frame), the legend with the points per source (or, while the heat map shows, its key and
each mirror's figures), and playback (pause, step, frame, point size)."""
from __future__ import annotations

import time
from collections import deque
from pathlib import Path
from typing import Callable

import numpy as np

from mirrorcore.base.palette import (FIRST_MULTI_LABEL, HEAT_NEGATIVE, HEAT_POSITIVE, HEAT_UNCOMPARED, HEAT_ZERO,
                                SOURCE_COLOURS, source_colour, source_name)
from mirrorcore.io.session import Session
from mirrorcore.sources import SessionSource
from mirrorcore.base.words import listed

from ..context import TabContext, TabState
from ..events import JobProgress, LoopChanged, SessionChanged
from ..jobs import AGREEMENT, BATCH, HEAT_LIMIT_MM, RECORD, REFINE, Jobs
from ..live import LiveFrame, frame_number
from ..markup import escape, markdown
from ..wording.hints import start_hint
from ..wording.jobs import recording_headline

STATS_HZ = 4.0
LAG_NOTE_S = 5.0           # seconds the header says a tab lagged after it last did (it catches up and lags again)
PROCESS_WINDOW = 30        # frames: the header gives the median of their processing times (one frame's jumps
                           # with whatever else the machine does)
VIEWS = {"3D scene": "3d", "Depth frame": "depth"}
PROGRESS_STEP = 0.05       # the start hint gives a calibration's progress in steps of this
EVERY_MIRROR = "every mirror"    # the heat map of every mirror's points (Heat map of)
LEGEND_STYLE = "font-size:0.85em;line-height:1.5;padding:0 12px"   # the panel's text is inset so; raw HTML is not


def source_names(session: Session) -> Callable[[int], str]:
    """A source label's name with the session's mirror names: 'direct', 'left', 'left then right'."""
    names = [m.name for m in session.mirrors]
    return lambda label: source_name(label, names)


def legend_html(counts: dict[int, int], name: Callable[[int], str], mirror_ids: tuple[int, ...],
                unplaned: tuple[str, ...] = ()) -> str:
    """One line: a swatch in each source's colour, its name and its point count; counts {label: points}; then the
    mirrors with no plane yet (unplaned: their names), whose part of the frame is left out."""
    items = "".join(_swatch(source_colour(j, mirror_ids), f"{escape(name(j))} <b>{count:,}</b>")
                    for j, count in counts.items())
    if unplaned:
        items += (f"<br>{escape(listed(unplaned))}: no plane yet, so all inside "     # the object in front of
                  f"{'its outline' if len(unplaned) == 1 else 'their outlines'} is left out "     # them too: a helper
                  "(the object in front too)")                                           # took "direct 0" for none
    return f'<div style="{LEGEND_STYLE}">{items}</div>'


HEAT_KEY = ((HEAT_ZERO, "on the direct surface"), (HEAT_POSITIVE, f"{HEAT_LIMIT_MM:g} mm outside"),
            (HEAT_NEGATIVE, f"{HEAT_LIMIT_MM:g} mm inside"), (SOURCE_COLOURS[0], "the camera's points"),
            (HEAT_UNCOMPARED, "not seen by the camera"))


# what the map can show, as measured on the glass sphere (seed 1, ten frames: README) and on a box between three
# mirrors (seed 2, a helper), and what measures the glass
HEAT_READS = ("A tilted plane or a wrong boundary colours a mirror's points; a glass hardly does (3 mm read 0.2 mm "
              "on the sphere)")            # a helper found "(the sphere: 0.5° read 6 mm)" hard to read, and a scale:
HEAT_GLASS = ": <b>Refine from the object</b> measures it."                    # its figure's 1.6° read 4 mm
HEAT_REFINED = "; these planes come from the object, where the glass plays no part."
HEAT_FEW = 0.05             # a view with fewer of its points compared than this is told where it is checked
FEW_COMPARED = (" (it sees little of what the camera sees: its agreement under Mirrors compares it with every "
                "view)")          # an arc's middle mirror: "under 1%", with no advice (a helper)
FEW_COMPARED_MULTI = " (seen through several mirrors: the agreement lines of those mirrors under Mirrors check it)"


def heat_legend_html(figures: dict[int, tuple[float, float]], frames: int, name: Callable[[int], str],
                     refined: bool = False, planes: bool = True, no_glass: bool = True) -> str:
    """The heat map's key (its colours) and, per view seen in a mirror, the median distance to the direct surface
    and the share of its points compared over the heat maps of the last `frames` frames (figures as in HeatChanged;
    empty until the first map arrives), against the camera's surface (the agreement lines beside it compare every
    view); then what the map can show (HEAT_READS) and what measures the glass: the refinement, while `no_glass`
    (a plane from markers has none set: after the glass was typed in, it still said so: a helper), or (`refined`:
    every plane came from it) that it did; without `planes` (no mirror has one) what to do first (it had said
    "computing the heat map…" for good: a helper)."""
    if not planes:
        return (f'<div style="{LEGEND_STYLE}">No mirror has a plane yet: the heat map compares the points seen in a '
                "mirror with the camera's surface. Fit the planes from markers, or find them from the object "
                "(Mirrors).</div>")
    key = "".join(_swatch(colour, text) for colour, text in HEAT_KEY)

    def few(j: int) -> str:       # a view through several mirrors has no agreement line (a helper looked for one)
        return FEW_COMPARED_MULTI if j >= FIRST_MULTI_LABEL else FEW_COMPARED

    lines = [f"{escape(name(j))}: median {median:+.1f} mm, {_share(share)} of its points compared"
             + (few(j) if share < HEAT_FEW else "")
             if np.isfinite(median) else f"{escape(name(j))}: none of its points seen by the camera{few(j)}"
             for j, (median, share) in figures.items()]
    over = "this frame" if frames == 1 else f"the last {frames} frames"
    body = ("<br>".join([f"{over}, against the camera's surface (> 0: outside it):", *lines]) if figures
            else "computing the heat map…")
    reads = HEAT_READS + (HEAT_REFINED if refined else HEAT_GLASS if no_glass else ".")
    return f'<div style="{LEGEND_STYLE}">{key}<br>{body}<br><i>{reads}</i></div>'


def _share(share: float) -> str:
    """A share of a view's points, as a percentage: 'under 1%' for a few ('over 0% of its points' read as nothing
    behind the median: a helper)."""
    return f"{share:.0%}" if share >= 0.005 else "under 1%"


def _from_markers(jobs: Jobs, editor, session: Session) -> tuple[str, ...]:
    """The names of the mirrors whose planes a markers fit of this editor (SessionEditor.fitted_on_its_markers) set
    behind the glass typed in: a refinement then still makes them more accurate (on the walking figure at 3 m, 2 px
    clicks: tilts of 0.08 to 0.28 degrees from the markers, 0.01 to 0.02 refined)."""
    return tuple(m.name for m in session.mirrors if m.plane is not None and m.glass_typed
                 and not jobs.from_object(m.id, m.plane) and editor.fitted_on_its_markers(m.id))


def _from_object(jobs: Jobs, session: Session) -> bool:
    """Whether every plane of the session came from a refinement or search of this app (and there is one)."""
    planes = [(m.id, m.plane) for m in session.mirrors if m.plane is not None]
    return bool(planes) and all(jobs.from_object(*plane) for plane in planes)


def _swatch(colour, text: str) -> str:
    r, g, b = (int(c) for c in colour)
    return (f'<span style="white-space:nowrap;margin-right:0.8em"><span style="display:inline-block;width:0.8em;'
            f'height:0.8em;background:rgb({r},{g},{b});margin-right:0.3em;border-radius:50%;'
            f'border:1px solid #999"></span>{text}</span>')


def source_root(source) -> Path | None:
    """The folder of the session a source plays (a SessionSource), else None."""
    return Path(source.session.root) if isinstance(source, SessionSource) else None


def source_title(source: str, played: Path | None, edited: Path | None) -> str:
    """The header's title: the source's name, then the folder of the session being edited (saved: `edited`) when
    it is not the one the source plays (`played`)."""
    if edited is None or (played is not None and played.resolve() == Path(edited).resolve()):
        return f"**{source}**"
    return f"**{source}** · edits saved in session **{Path(edited).name}**"


def _no_glass(jobs: Jobs, session: Session) -> tuple[str, ...]:
    """The names of the mirrors whose planes come from their markers (not from the object) with no glass set: on an
    ordinary mirror the markers stand 3 to 6 mm in front of the silver."""
    return tuple(m.name for m in session.mirrors if m.markers and m.plane is not None and not m.glass_set
                 and not jobs.from_object(m.id, m.plane))


class LivePanel:
    def __init__(self, tab: TabContext):
        gui, self.tab, services = tab.gui, tab, tab.services
        self.title = gui.add_markdown("")
        self.back = gui.add_button(f"Back to {services.start_source.name}", visible=False)
        self.rate = gui.add_markdown("starting…")
        self.hint = gui.add_markdown("")
        self.view = gui.add_button_group("View", tuple(VIEWS))
        self.legend = gui.add_html("")
        with gui.add_folder("Playback and view", expand_by_default=False):
            # the heat map first: its legend, above the folder, pushed its box below the fold at 1024x600 (a helper)
            self.heat = gui.add_checkbox("Heat map", initial_value=False,
                                         hint="the mirrors' points by their distance to the surface the camera sees "
                                         "directly: white on it, red outside, blue inside (10 mm and more "
                                         "saturated), grey where there is nothing to compare; a frame a "
                                         "second, in the 3D scene, on the object (the colours are on its rims). It "
                                         "shows a tilt, hardly the glass: Refine from the object measures that")
            self.heat_of = gui.add_dropdown("Heat map of", (EVERY_MIRROR,), initial_value=EVERY_MIRROR,
                                            visible=False)      # which strip was whose could not be told (a helper)
            self.pause = gui.add_checkbox("Pause", initial_value=services.paused)
            self.step = gui.add_button("Step one frame", disabled=not services.paused)
            self.seek = gui.add_slider("Frame", min=0, max=1, step=1, initial_value=0, visible=False)
            self.size = gui.add_slider("Point size (mm)", min=1.0, max=20.0, step=0.5, initial_value=6.0)
            self.frame_object = gui.add_button("Look at the object")
            self.virtual = gui.add_checkbox("Virtual cameras", initial_value=True,
                                            hint="the camera as each mirror, and each sequence of mirrors, shows it")
            self.pixel = gui.add_markdown("Last pixel read: none yet")
        self._pixel_note = None                     # the notification showing the last pixel read
        self.view.on_click(lambda e: tab.look(VIEWS[e.target.value]))
        self.pause.on_update(lambda e: e.client is not None and services.pause(self.pause.value))
        self.step.on_click(lambda _: services.step())
        self.back.on_click(lambda _: tab.act(services.back_to_start_source))
        self.seek.on_update(lambda e: e.client is not None and services.seek(int(self.seek.value)))
        self.size.on_update(lambda _: tab.scene.set_point_size(self.size.value / 1000))
        self.virtual.on_update(lambda _: tab.scene.show_virtual_cameras(bool(self.virtual.value)))
        self.heat.on_update(lambda e: self._show_heat(ticked=e.client is not None))
        self.heat_of.on_update(lambda _: tab.heat_only(self._heat_mirror()))
        self.frame_object.on_click(lambda _: tab.act(lambda: (tab.look("3d"), tab.look_at_object())))
        tab.on_click("inspect", self.show_pixel)
        tab.on_state(lambda _: self.refresh_hint())
        self._calibrating = 0.0 if services.jobs.running(REFINE) else None      # how far, while one runs
        self._recording = services.jobs.running(RECORD)
        self._batch = 0.0 if services.jobs.running(BATCH) else None              # how far, while one runs
        self._unsubscribe = [services.bus.subscribe(LoopChanged, self._on_loop),
                             services.bus.subscribe(JobProgress, self._on_job),
                             services.bus.subscribe(SessionChanged, self._name)]
        self._last_stats = 0.0
        self._process_ms: deque[float] = deque(maxlen=PROCESS_WINDOW)   # the last frames' processing times
        self._follow(services.source)

    def detach(self) -> None:
        """Stop listening to the app (the tab closed)."""
        for unsubscribe in self._unsubscribe:
            unsubscribe()

    def _on_job(self, event: JobProgress) -> None:
        """A calibration from the object, a batch or a recording began or ended: the hint says so (for the first
        two, how far they are, by 5 %: at 1024x600 the calibration's progress bar is below the fold, the batch's in a
        folder of another step), then what comes next."""
        done = None if event.fraction is None else PROGRESS_STEP * np.floor(event.fraction / PROGRESS_STEP)
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
            self.refresh_hint()                                          # the mirrors it flags, or none now

    def _on_loop(self, event: LoopChanged) -> None:
        self.pause.value = event.paused
        self.step.disabled = not event.paused
        self._follow(event.source)
        self.refresh_hint()

    def _follow(self, source) -> None:
        """Name the source; show the frame slider for a recording (seekable), hide it for a live camera; offer the
        way back to the source served from the start while another plays."""
        self._name()
        self.back.visible = source is not self.tab.services.start_source
        if source.frame_count:
            self.seek.max = max(source.frame_count - 1, 1)
        self.seek.visible = bool(source.frame_count)

    def _name(self, event: SessionChanged | None = None) -> None:
        """The header's title: the source, and the session being edited where it is saved and is not the one that
        plays (after Record's replay and Back to, a helper took the edits of the recording's session for those of the
        session served, which the header named)."""
        services = self.tab.services
        self.title.content = markdown(source_title(services.source.name, source_root(services.source),
                                                   services.editor.session.root if services.editor.autosave else None))

    def refresh_hint(self) -> None:
        services = self.tab.services
        snapshot = services.snapshot
        playback = ("paused" if services.paused else "live" if services.source is services.start_source
                    else "recording")
        session, jobs = snapshot.session, services.jobs
        unused = tuple(m.name for m in session.mirrors if services.editor.glass_unused(m.id)
                       and not jobs.from_object(m.id, m.plane))
        hint = start_hint(session, self.tab.state, services.last_frame is not None, snapshot.background is not None,
                          playback, self._calibrating, self._recording, _no_glass(jobs, session), unused,
                          jobs.refusals(session), services.start_source.name, self._batch, jobs.disagreeing,
                          _from_markers(jobs, services.editor, session))
        self.hint.content = "➜ " + markdown(hint)

    def show(self, frame: LiveFrame) -> None:
        """Refresh the figures at STATS_HZ (every frame while paused)."""
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
        state = services.jobs.recording_state()
        recording = None if state is None else recording_headline(state)
        self.rate.content = ((f"{recording} · " if recording else "")
                             + f"{which} · {rate} · processing {np.median(self._process_ms):.1f} ms"
                             + (f" · at most {paced[0]:.0f} fps {paced[1]}" if paced and not services.paused else "")
                             + (" · ⚠ this browser draws slower than frames come: it is sent fewer of them"
                                if now - self.tab.lagged_at < LAG_NOTE_S else ""))
        if count:
            self.seek.value = number
        names = source_names(frame.snapshot.session)
        heat = self.tab.heat and self.tab.state.view == "3d"     # its key only where it shows
        session = frame.snapshot.session
        self.legend.content = (heat_legend_html(self.tab.heat_figures, self.tab.heat_frames, names,
                                                _from_object(services.jobs, session),
                                                any(m.plane is not None for m in session.mirrors),
                                                bool(_no_glass(services.jobs, session))) if heat
                               else legend_html(frame.counts, names, frame.mirror_ids, tuple(
                                   m.name for m in frame.snapshot.session.mirrors if m.plane is None)))
        self._heat_choices()
        if first:
            self.refresh_hint()

    def _show_heat(self, ticked: bool = False) -> None:
        """The heat map on or off as the box says; `ticked` by the technician while the depth frame is in view, the
        view goes to the 3D scene, where it is drawn (it had changed nothing on the screen: a helper; a reload
        taking up a heat map keeps its view)."""
        on = bool(self.heat.value)
        if on and ticked and self.tab.state.view == "depth":
            self.tab.look("3d")
        self.tab.show_heat(on)
        self._heat_choices()

    def _heat_choices(self) -> None:
        """Offer, while the heat map shows, to colour one mirror's points alone: every mirror with a plane, when
        there are two or more; a mirror chosen and since removed (or its plane cleared) goes back to all."""
        names = tuple(m.name for m in self.tab.services.snapshot.session.mirrors if m.plane is not None)
        choices = (EVERY_MIRROR, *names)
        if self.heat_of.options != choices:
            if self.heat_of.value not in choices:
                self.heat_of.value = EVERY_MIRROR
                self.tab.heat_only(None)
            self.heat_of.options = choices
        self.heat_of.visible = self.tab.heat and len(names) > 1

    def _heat_mirror(self) -> int | None:
        """The id of the mirror the heat map is of (the dropdown's name), None for every mirror."""
        session = self.tab.services.snapshot.session
        return next((m.id for m in session.mirrors if m.name == self.heat_of.value), None)

    def show_pixel(self, u: float, v: float) -> None:
        frame = self.tab.services.last_frame
        if frame is None:
            return
        rows, cols = frame.depth.shape
        depth = float(frame.depth[min(int(round(v)), rows - 1), min(int(round(u)), cols - 1)])
        reading = f"{depth:.3f} m" if depth > 0 else "no reading"
        self.pixel.content = markdown(f"pixel ({u:.1f}, {v:.1f}): {reading}")
        if self._pixel_note is not None:             # one reading shown at a time: the clicks' notes do not stack
            self._pixel_note.remove()
        self._pixel_note = self.tab.client.add_notification("Pixel", self.pixel.content, color="blue",
                                                             auto_close_seconds=6.0)

