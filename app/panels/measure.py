"""Step 3, "Measure": fit a sphere or a cylinder to the current cloud and report radius, RMSE and
mean error as the paper does, overall and per source (on a thread of the tab's, with a progress bar
and Cancel); while tracking, fit the live frames and plot the error over time (per tab)."""

from __future__ import annotations

import threading
import time
from collections import deque
from typing import TYPE_CHECKING, Callable

import numpy as np
import viser.uplot as uplot

from mirrorcore.base.errors import Cancelled, MirrorscanError
from mirrorcore.geometry.fitting import fit_cylinder, fit_sphere
from mirrorcore.geometry.shapes import ShapeFit

from ..context import TabContext
from ..events import FrameReady
from ..jobs import unplaned
from ..markup import markdown
from ..wording.jobs import left_out
from ..wording.legend import source_names

if TYPE_CHECKING:
    from ..liveframe import LiveFrame

TITLE = "Measure"

HISTORY = 300  # fits kept in the plot
# fits per second while tracking (on a worker thread: the live loop never waits)
TRACK_HZ = 2.0
# a fit with fewer of the points within its threshold says the shape may be wrong
MIN_FITTING = 0.5
# ... and so does one whose RMSE over every point reaches this share of the threshold
MAX_SPREAD = 0.75
CANCELLED_NOTE = "Cancelled: the report below is the fit before."


def fit_report(fit: ShapeFit, name: Callable[[int], str]) -> str:
    """Markdown: radius, RMSE, mean error and mean |error| overall and per source, mm.

    A warning comes first when fewer than MIN_FITTING of the points lie within the threshold of
    the shape, or when their RMSE reaches MAX_SPREAD of it (the points fill the band instead of
    lying on the shape: a cylinder fitted to a sphere).

    Parameters
    ----------
    fit : ShapeFit
    name : callable
        A source's name from its label.

    Returns
    -------
    str
    """
    e = fit.errors
    share = float(np.mean(fit.inliers)) if len(fit.inliers) else 0.0
    shape, band = fit.shape.kind, f"{fit.threshold * 1e3:.0f} mm"
    warning = []
    if share < MIN_FITTING:
        warning = [
            f"⚠ only {share:.0%} of the points lie within {band} of the {shape}: the object may "
            "not be a "
            f"{shape}, or the selection holds more than the object.",
            "",
        ]
    elif e.rmse >= MAX_SPREAD * fit.threshold:
        warning = [
            f"⚠ the points scatter {e.rmse * 1e3:.0f} mm RMS about the {shape}, as far as the "
            f"{band} band "
            f"allows: the object may not be a {shape}.",
            "",
        ]
    lines = [
        *warning,
        f"**{fit.shape.kind}**: radius **{fit.shape.radius * 1e3:.1f} mm** · "
        f"{int(fit.inliers.sum()):,} of {e.points:,} points within {fit.threshold * 1e3:.0f} mm",
        "",
        "| view (errors in mm) | points | RMSE | mean error | mean \\|error\\| |",
        "|---|---|---|---|---|",
        f"| all | {e.points:,} | {e.rmse * 1e3:.2f} | {e.mean_error * 1e3:+.2f} | "
        f"{e.mean_abs_error * 1e3:.2f} |",
    ]
    # the unit in the corner: narrow columns keep a number on one line; the views' names are wider
    # than it
    for source, s in fit.per_source.items():
        lines.append(
            f"| {name(source)} | {s.points:,} | {s.rmse * 1e3:.2f} | {s.mean_error * 1e3:+.2f} | "
            f"{s.mean_abs_error * 1e3:.2f} |"
        )
    return "\n".join(lines)


class MeasurePanel:
    """Step 3, "Measure": fit a sphere or a cylinder to the cloud (see the module docstring).

    Parameters
    ----------
    tab : TabContext
        The tab it is built in.
    """
    TITLE = TITLE

    def __init__(self, tab: TabContext):
        gui, self.tab, self.services = tab.gui, tab, tab.services
        # (seconds, rmse mm, radius mm)
        self.history: deque[tuple[float, float, float]] = deque(maxlen=HISTORY)
        self._busy = threading.Lock()
        # fits are recorded from the tracking thread and from button clicks
        self._history_lock = threading.Lock()
        # when the plot's first fit came, and of which shape
        self._started, self._kind = time.monotonic(), ""
        self._last_track = 0.0
        self._cancel: threading.Event | None = None  # the clicked fit's, while it runs
        self.shape = gui.add_dropdown("Shape", ("sphere", "cylinder"), initial_value="sphere")
        self.threshold = gui.add_number(
            "Inlier threshold (mm)", initial_value=20.0, min=1.0, max=200.0
        )
        self.run = gui.add_button("Fit to the current cloud")
        self.cancel = gui.add_button("Cancel the fit", color="red", visible=False)
        self.progress = gui.add_progress_bar(0.0, visible=False)
        self.track = gui.add_checkbox("Track while live", initial_value=False)
        self.report = gui.add_markdown("")
        self.plot = gui.add_uplot(
            (np.zeros(1), np.zeros(1), np.zeros(1)),
            (
                uplot.Series(label="time (s)"),
                uplot.Series(label="RMSE (mm)", stroke="#e69f00", width=2),
                uplot.Series(label="radius (mm)", stroke="#0072b2", width=2, scale="radius"),
            ),
            scales={"x": uplot.Scale(time=False), "radius": uplot.Scale(auto=True)},
            axes=(
                uplot.Axis(),
                uplot.Axis(label="RMSE (mm)"),
                uplot.Axis(side=1, scale="radius", label="radius (mm)"),
            ),
            height=180,
            visible=False,
        )
        self.run.on_click(lambda _: tab.act(self.start_fit))
        self.cancel.on_click(lambda _: self.cancel_fit())
        self._unsubscribe = self.services.bus.subscribe(
            FrameReady, lambda e: self.on_frame(e.frame)
        )

    def detach(self) -> None:
        """Stop listening to the app (the tab closed)."""
        self._unsubscribe()

    def fit(
        self,
        frame: "LiveFrame",
        progress: Callable[[float], None] | None = None,
        cancel: threading.Event | None = None,
    ) -> ShapeFit:
        """The shape chosen, fitted to the frame's cloud.

        Parameters
        ----------
        frame : LiveFrame
        progress : callable, optional
            Called with the fraction done (as fit_sphere's).
        cancel : threading.Event, optional
            Stops the fit when set.

        Returns
        -------
        ShapeFit

        Raises
        ------
        MirrorscanError
            When the cloud has fewer than 10 points.
        """
        cloud = frame.cloud
        if len(cloud) < 10:
            raise MirrorscanError(f"the current cloud has {len(cloud)} points; a fit needs more")
        fitter = fit_sphere if self.shape.value == "sphere" else fit_cylinder
        return fitter(
            cloud.points,
            np.random.default_rng(0),
            threshold=self.threshold.value / 1000,
            sources=cloud.sources,
            progress=progress,
            cancel=cancel,
        )

    def fit_current(
        self, progress: Callable[[float], None] | None = None, cancel: threading.Event | None = None
    ) -> ShapeFit:
        """Fit the last frame's cloud, report it and add it to the plot.

        Parameters
        ----------
        progress : callable, optional
            Called with the fraction done.
        cancel : threading.Event, optional
            Stops the fit when set.

        Returns
        -------
        ShapeFit

        Raises
        ------
        MirrorscanError
            Before the first frame, or when the cloud is too small.
        """
        frame = self.services.last_frame
        if frame is None:
            raise MirrorscanError("no frame yet")
        result = self.fit(frame, progress, cancel)
        self._show(frame, result)
        return result

    def start_fit(self) -> threading.Thread:
        """The button: fit_current on a thread, until it ends.

        The button is disabled, a progress bar and Cancel shown until it ends (a sphere fitted to a
        walking person's cloud draws RANSAC's 20,000 samples: seconds on a busy machine, during
        which the tab's panel stays usable). Cancelled, the last fit's report stays under
        CANCELLED_NOTE; failed, the report says so.
        """
        if self._cancel is not None:
            raise MirrorscanError("a fit runs: wait for it, or cancel it")
        cancel = self._cancel = threading.Event()
        self.run.disabled, self.cancel.visible = True, True
        self.progress.value, self.progress.visible = 0.0, True
        thread = threading.Thread(
            target=self._fit_in_background, args=(cancel,), name="mirrorscan-measure", daemon=True
        )
        thread.start()
        return thread

    def cancel_fit(self) -> None:
        """The Cancel button: stop the clicked fit at RANSAC's next batch of samples."""
        cancel = self._cancel
        if cancel is not None:
            cancel.set()

    def _fit_in_background(self, cancel: threading.Event) -> None:
        """Fit the last frame's cloud on the job's thread, with a progress bar."""
        shown = [0.0]

        def progress(fraction: float) -> None:
            # a bar's step, not a message per RANSAC batch
            if 100 * fraction - shown[0] >= 1.0:
                shown[0] = self.progress.value = round(100 * fraction, 1)

        def work() -> None:
            # the last fit's report is said to be that, not left as if new
            before = self.report.content
            try:
                self.fit_current(progress, cancel)
            except Cancelled:
                earlier = before.removeprefix(f"{CANCELLED_NOTE}\n\n")
                self.report.content = CANCELLED_NOTE + (f"\n\n{earlier}" if earlier else "")
            except MirrorscanError as exc:
                self.report.content = markdown(
                    _left_out(self.services.last_frame) + f"Not done: {exc}"
                )
                raise

        try:
            self.tab.act(work)
        finally:
            self._cancel = None
            self.run.disabled, self.cancel.visible, self.progress.visible = False, False, False

    def on_frame(self, frame: "LiveFrame") -> None:
        """While tracking, start a fit of this frame on a worker thread, at most TRACK_HZ a second.

        Parameters
        ----------
        frame : LiveFrame
        """
        now = time.monotonic()
        if (
            not self.track.value
            or now - self._last_track < 1 / TRACK_HZ
            or not self._busy.acquire(blocking=False)
        ):
            return
        self._last_track = now
        threading.Thread(target=self._track, args=(frame,), daemon=True).start()

    def _track(self, frame: "LiveFrame") -> None:
        """Fit and show one tracked frame; a refusal becomes the report's line."""
        try:
            self._show(frame, self.fit(frame))
        except MirrorscanError as exc:
            self.report.content = markdown(f"tracking: {exc}")
        finally:
            self._busy.release()

    def _show(self, frame: "LiveFrame", result: ShapeFit) -> None:
        """Show the report of a fit of the frame's cloud, and the fit in the plot.

        The report says first what the cloud leaves out (a fit before any plane measures the object
        seen directly alone).
        """
        self.report.content = markdown(
            _left_out(frame) + fit_report(result, source_names(frame.snapshot.session))
        )
        self._record(result)

    def _record(self, result: ShapeFit) -> None:
        """Add a fit to the plot.

        Seconds since the plot's first fit, RMSE and radius; a fit of another shape starts a new
        plot (a cylinder's radius is not a sphere's).
        """
        now = time.monotonic()
        with self._history_lock:
            if self.history and self._kind != result.shape.kind:
                self.history.clear()
            if not self.history:
                self._started, self._kind = now, result.shape.kind
            self.history.append(
                (now - self._started, result.errors.rmse * 1e3, result.shape.radius * 1e3)
            )
            t, rmse, radius = (np.array(c) for c in zip(*self.history))
        self.plot.data = (t, rmse, radius)
        self.plot.visible = True


def _left_out(frame: "LiveFrame | None") -> str:
    """A report's first paragraph: what the frame's cloud leaves out (wording.left_out), or ''."""
    missing = "" if frame is None else left_out(unplaned(frame.snapshot.session))
    return f"⚠ {missing}.\n\n" if missing else ""
