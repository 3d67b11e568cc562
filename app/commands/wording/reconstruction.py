"""What `mirrorscan reconstruct` prints: the clouds and meshes written, and how a batch went."""

from __future__ import annotations

from pathlib import Path

from mirrorcore.base.palette import source_name
from mirrorcore.batch import BatchReport
from mirrorcore.io.session import Session

from .message import Message


def colours_line(choice: str, session: Session) -> str:
    """What a written cloud's red, green and blue carry, as a details line.

    Parameters
    ----------
    choice : str
        --colour: 'scene' or 'source'.
    session : Session
        The session reconstructed.

    Returns
    -------
    str
    """
    if choice == "source":
        return "colours: the source colours (--colour source)"
    if session.colour_frames is None:
        return "colours: the source colours, the session has no colour frames"
    unset = [m.name for m in session.mirrors if m.colour_gain is None]
    return "colours: the scene's, each mirror's colour gain undone" + (
        f" ({', '.join(unset)}: no colour gain, as seen)" if unset else "")


def cloud_written(out: Path, points: int, counts: dict[int, int], colours: str = "") -> Message:
    """One frame's merged cloud (Algorithm 1).

    Parameters
    ----------
    out : Path
        The PLY file written.
    points : int
        Points in it.
    counts : dict of int to int
        {source: points}; source 0 is the direct view, > 0 the mirror views.
    colours : str, optional
        A details line saying what the points' colours are (colours_line).

    Returns
    -------
    Message
    """
    mirrors = sum(1 for source, points in counts.items() if source > 0 and points)
    return Message(
        f"wrote {out}: {points} points seen directly and in {mirrors} "
        + ("mirror view." if mirrors == 1 else "mirror views."),
        ("points per view: " + ", ".join(f"{source_name(k)} {v}" for k, v in counts.items()),
         *([colours] if colours else [])),
    )


def carved_written(out: Path, voxels: int, shape: tuple[int, ...], voxel: float) -> Message:
    """A carved cloud (reconstruct --method paper|carve).

    Parameters
    ----------
    out : Path
        The PLY file written.
    voxels : int
        Voxels on the carved surface.
    shape : tuple of int
        The volume's shape in voxels.
    voxel : float
        A voxel's edge (metres).

    Returns
    -------
    Message
    """
    return Message(
        f"wrote {out}: the carved surface, {voxels} voxels.",
        (f"volume {'x'.join(map(str, shape))} voxels of {voxel * 1e3:g} mm",),
    )


def mesh_written(
    out: Path, vertices: int, faces: int, frames: int, shape: tuple[int, ...], voxel: float
) -> Message:
    """A fused mesh (reconstruct --method tsdf).

    Parameters
    ----------
    out : Path
        The PLY file written.
    vertices, faces : int
        The mesh's size.
    frames : int
        Frames fused.
    shape : tuple of int
        The volume's shape in voxels.
    voxel : float
        A voxel's edge (metres).

    Returns
    -------
    Message
    """
    return Message(
        f"wrote {out}: a mesh of {vertices} vertices fused from {frames} frame(s).",
        (f"{faces} faces", f"volume {'x'.join(map(str, shape))} voxels of {voxel * 1e3:g} mm"),
    )


def batch_done(report: BatchReport) -> Message:
    """How a batch (reconstruct --frame all) ended, its failures aside.

    Parameters
    ----------
    report : BatchReport
        The batch's outcome.

    Returns
    -------
    Message
        Nothing to do when every frame was there already; else the files written, whether every
        frame is done, the frame rate and the manifest.
    """
    if report.complete and not report.written:
        return Message(
            f"nothing to do: the {report.total} frames are in {report.out} already.",
            (f"manifest {report.manifest}",),
        )
    done = report.kept + report.written
    headline = f"wrote {report.written} PLY files into {report.out}; " + (
        "every frame is done."
        if report.complete
        else f"{done} of {report.total} frames done: run it again to go on."
    )
    details = [
        f"{report.fps:.1f} frames/s over {report.seconds:.2f} s"
        + (
            f", after {report.startup_seconds:.1f} s starting the workers"
            if report.startup_seconds >= 1.0
            else ""
        )
    ]
    if report.kept:
        details.append(f"{report.kept} frames kept from an earlier run")
    return Message(headline, (*details, f"manifest {report.manifest}"))


def retried(worker: str, frames: list[int]) -> Message:
    """Frames run again after their worker left the cluster.

    Parameters
    ----------
    worker : str
        The worker's address.
    frames : list of int
        The frames run again.

    Returns
    -------
    Message
    """
    return Message(
        f"worker {worker} left the cluster: its {len(frames)} frame(s) were run again.",
        ("frames run again: " + ", ".join(map(str, frames)),),
    )


def frame_list(frames: list[int], most: int = 10) -> str:
    """'3, 4, 9': at most `most` frames, then ' and N more'.

    Parameters
    ----------
    frames : list of int
        The frame numbers.
    most : int, optional
        How many to list.

    Returns
    -------
    str
    """
    shown = ", ".join(map(str, frames[:most]))
    return shown + (f" and {len(frames) - most} more" if len(frames) > most else "")
