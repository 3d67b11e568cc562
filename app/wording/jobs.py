"""The words of the long jobs other than the calibration: dense reconstruction, background capture,
recording and batch, and how any job ended (refused, failed, cancelled)."""

from __future__ import annotations

from mirrorcore.base.words import listed
from mirrorcore.batch import BatchProgress, BatchReport

from ..results import (
    AgreementReport,
    BackgroundCaptured,
    BatchStarting,
    CalibrationRefused,
    CalibrationReport,
    CalibrationWork,
    Cancelled,
    Checking,
    Collecting,
    DenseResult,
    DenseWork,
    Failed,
    Recorded,
    RecordingState,
    Refused,
)
from . import Message, joined, refusal
from . import agreement, refinement

CANCELLED = Message("cancelled")


def left_out(names: tuple[str, ...]) -> str:
    """What a cloud leaves out.

    Parameters
    ----------
    names : tuple of str
        The mirrors with no plane yet.

    Returns
    -------
    str
        'mirror 1 and mirror 2 have no plane yet: what is seen inside their outlines is not in
        it', '' for none.
    """
    if not names:
        return ""
    one = len(names) == 1
    return (
        f"{listed(names)} {'has' if one else 'have'} no plane yet: what is seen inside "
        f"{'its outline' if one else 'their outlines'} is not in it"
    )


def dense(result: DenseResult) -> Message:
    """A dense reconstruction done: what it made; a warning of the mirrors left out.

    Parameters
    ----------
    result : DenseResult

    Returns
    -------
    Message
    """
    if result.faces is None:
        voxel = f"{result.voxel * 1e3:.1f} mm"
        made = f"{result.method}: {len(result.vertices):,} surface voxels of {voxel}"
    else:
        made = f"tsdf: mesh of {len(result.vertices):,} vertices, {len(result.faces):,} faces"
    missing = left_out(result.left_out)
    return Message(f"{made}; ⚠ {missing}" if missing else made)


def dense_work(work: DenseWork) -> Message:
    """A dense reconstruction under way.

    Parameters
    ----------
    work : DenseWork
        Frames being prepared, or the volume's shape once known.

    Returns
    -------
    Message
    """
    if work.shape is None:
        return Message(f"{work.method}: preparing {work.frames} frame(s)")
    return Message(f"{work.method}: {'x'.join(map(str, work.shape))} voxels")


def collecting(work: Collecting) -> Message:
    """Frames collected of all.

    Parameters
    ----------
    work : Collecting

    Returns
    -------
    Message
    """
    return Message(f"{work.done} of {work.total} frames")


def captured(result: BackgroundCaptured) -> Message:
    """A background captured, or waiting for the answer when the object was in view.

    Parameters
    ----------
    result : BackgroundCaptured

    Returns
    -------
    Message
    """
    if result.waiting:
        return Message(
            "captured: the object was in view, so it is used only once you answer the question"
        )
    return Message(f"captured from {result.frames} frames")


def batch_status(p: BatchProgress) -> Message:
    """A batch under way: frames done of all, the time left, failures.

    Parameters
    ----------
    p : BatchProgress

    Returns
    -------
    Message
        The rate and the dashboard link in the details.
    """
    left = "" if p.seconds_left is None else f", {p.seconds_left:.0f} s left"
    extra = "".join(
        f", {n} {what}" for n, what in ((p.failed, "failed"), (len(p.retried), "retried")) if n
    )
    details = (f"{p.fps:.1f} fps",) + ((f"[Dask dashboard]({p.dashboard})",) if p.dashboard else ())
    return Message(f"{p.done:,} of {p.total:,} frames{left}{extra}", details)


def batch_summary(report: BatchReport) -> Message:
    """How a batch ended and where its files are.

    Parameters
    ----------
    report : BatchReport

    Returns
    -------
    Message
        The frames that failed in the details.
    """
    how = "stopped" if report.cancelled else "done"
    failed = (
        (f"failed: frames {', '.join(map(str, sorted(report.failed)))}",) if report.failed else ()
    )
    warn = f"; ⚠ {len(report.failed)} failed" if report.failed else ""
    return Message(
        f"batch {how}: {report.kept + report.written:,} of {report.total:,} frames in "
        f"`{report.out}`{warn}",
        failed,
    )


def batch_starting(work: BatchStarting) -> Message:
    """A batch starting.

    Parameters
    ----------
    work : BatchStarting

    Returns
    -------
    Message
    """
    return Message(f"starting {work.method} on every frame…")


def recording(state: RecordingState) -> Message:
    """How a recording stands.

    Parameters
    ----------
    state : RecordingState

    Returns
    -------
    Message
        Its error, or the end of the recording that plays, or the frames taken; where the
        recording that plays is, in the details.
    """
    behind = f" ({state.written} written so far)" if state.written < state.taken else ""
    if state.error is not None:
        return Message(f"the recording stopped: {state.error}")
    if state.replay_ended:
        return Message(
            f"the recording that plays came to its last frame: {state.taken} frames taken into "
            f"`{state.folder}`{behind}; **Stop recording** saves them",
            ("None is taken twice.",),
        )
    details = ()
    if state.replay is not None:
        at, count = state.replay.at, state.replay.count
        details = (
            f"The recording that plays is at frame {at} of {count}: it is taken up to its last one "
            f"({count - 1 - at} more)"
            + (
                "; to take all of it, stop, set the Frame slider to 0, and record again."
                if at > 0
                else "."
            ),
        )
    return Message(f"recording: {state.taken} frames into `{state.folder}`{behind}", details)


def recording_headline(state: RecordingState) -> str:
    """The header's word on a recording (Markdown, short: it is in view from every step).

    Parameters
    ----------
    state : RecordingState

    Returns
    -------
    str
    """
    if state.replay_ended or state.error is not None:
        return f"● **recording ended** at {state.taken} frames: *Record › Stop recording* saves it"
    return f"● **recording** {state.taken} frames"


def recorded(result: Recorded) -> Message:
    """A recording saved, with the frames dropped because the disk was too slow.

    Parameters
    ----------
    result : Recorded

    Returns
    -------
    Message
    """
    dropped = f" ({result.dropped} dropped: the disk was too slow)" if result.dropped else ""
    return Message(f"recorded {result.frames} frames into `{result.root}`{dropped}")


def ended(result: object) -> Message:
    """How any job ended other than with its own result: refused, failed on a bug, or cancelled.

    Parameters
    ----------
    result : Refused, Failed or Cancelled

    Returns
    -------
    Message

    Raises
    ------
    TypeError
        For any other result.
    """
    if isinstance(result, Refused):
        return refusal(f"not done: {result.reason}")
    if isinstance(result, Failed):
        return Message(f"failed: {result.error}: {result.message}")
    if isinstance(result, Cancelled):
        return CANCELLED
    raise TypeError(f"no words for {type(result).__name__}")


SAYS = {
    DenseResult: dense,
    DenseWork: dense_work,
    Collecting: collecting,
    BackgroundCaptured: captured,
    BatchProgress: batch_status,
    BatchReport: batch_summary,
    BatchStarting: batch_starting,
    RecordingState: recording,
    Recorded: recorded,
    CalibrationWork: refinement.working,
    Checking: lambda _: agreement.CHECKING,
    CalibrationRefused: lambda r: refinement.calibration_refused(r.reason, r.mirrors, r.search),
}
REPORTS = {CalibrationReport: refinement.report, AgreementReport: agreement.agreement}


def say(result: object) -> list[Message]:
    """The messages of a job's typed result or progress (a report has several, a line each).

    Parameters
    ----------
    result : object
        A result or progress of SAYS or REPORTS, or how the job ended (see ended).

    Returns
    -------
    list of Message
    """
    if type(result) in REPORTS:
        return REPORTS[type(result)](result)
    said = SAYS.get(type(result))
    return [said(result) if said is not None else ended(result)]


def status(result: object) -> str:
    """A job's typed result or progress as a panel's Markdown (JobProgress.status).

    Parameters
    ----------
    result : object
        As for say.

    Returns
    -------
    str
    """
    return joined(say(result))
