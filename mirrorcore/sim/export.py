"""Writing a simulated rig to disk: a session folder (docs/DESIGN.md: markers and mirror outlines in
pixels, background, frames and colour frames) plus truth.json with the true objects, planes and
tints, all or nothing (built in a temporary folder, then renamed); `session_mirrors` gives the
session's mirrors in memory and `true_rig` the rig of a perfect calibration."""
from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np
from tqdm import tqdm

from mirrorcore.base.atomic import new_folder
from mirrorcore.depth.files import write_colour_png, write_depth_png
from mirrorcore.base.errors import MirrorscanError
from mirrorcore.geometry.camera import Intrinsics, project_points
from mirrorcore.rig.model import Mirror, Rig
from mirrorcore.io.session import BACKGROUND_FILE, TRUTH_FILE, Session, SessionMirror
from mirrorcore.io.sessionfile import save_session
from mirrorcore.sim.render import MARKER, GroundTruth
from mirrorcore.sim.scene import Scene, SceneMirror
from mirrorcore.sim.simulator import Simulator

COLOUR_NAME = "frames/{:06d}_colour.png"


def mirror_outline(camera: Intrinsics, mirror: SceneMirror) -> np.ndarray:
    """Project a mirror's 4 corners into the image, clipped to it.

    Parameters
    ----------
    camera : Intrinsics
    mirror : SceneMirror

    Returns
    -------
    (b, 2) float64 array
        (u, v) pixels, a convex simple polygon.

    Raises
    ------
    MirrorscanError
        A corner is behind the camera, or the mirror is out of view.
    """
    uv, z = project_points(camera, mirror.corners())
    if np.any(z <= 0):
        raise MirrorscanError(f"{mirror.name}: part of the mirror is behind the camera")
    w, h = camera.width - 0.5, camera.height - 0.5
    image = np.array([[-0.5, -0.5], [w, -0.5], [w, h], [-0.5, h]], dtype=np.float32)
    area, clipped = cv2.intersectConvexConvex(uv.astype(np.float32), image)
    if clipped is None or area <= 1.0:
        raise MirrorscanError(f"{mirror.name}: the mirror is not in the camera's view")
    return np.clip(clipped.reshape(-1, 2).astype(np.float64), -0.5, [w, h])


def true_rig(scene: Scene) -> Rig:
    """Return the rig of a scene as a perfect calibration would give it.

    The true planes and each mirror's outline in the image (`mirror_outline`), in session order.

    Parameters
    ----------
    scene : Scene

    Returns
    -------
    Rig

    Raises
    ------
    MirrorscanError
        A mirror is out of view.
    """
    return Rig(scene.camera,
               tuple(Mirror(m.name, m.plane, mirror_outline(scene.camera, m))
                                   for m in scene.mirrors))


def visible_markers(camera: Intrinsics, mirror: SceneMirror, index: int,
                    truth: GroundTruth) -> np.ndarray:
    """Return the marker centres of a mirror that the camera sees directly.

    A centre is seen when the ideal render shows that mirror's marker face at the rounded pixel.

    Parameters
    ----------
    camera : Intrinsics
    mirror : SceneMirror
    index : int
        The mirror, 1-based.
    truth : GroundTruth
        The ideal render.

    Returns
    -------
    (k, 2) float64 array
        (u, v) pixels.
    """
    uv, z = project_points(camera, mirror.marker_centres())
    pix = np.round(uv[z > 0]).astype(int)
    inside = (pix[:, 0] >= 0) & (pix[:, 0] < camera.width) & (pix[:, 1] >= 0) & (pix[
        :, 1] < camera.height)
    uv, pix = uv[z > 0][inside], pix[inside]
    seen = (truth.surface[pix[:, 1], pix[:, 0]] == MARKER) & (truth.first_mirror[pix[:, 1], pix[
        :, 0]] == 0)
    points = truth.points[pix[:, 1], pix[:, 0]]
    on_this = np.abs(mirror.plane.signed_distance(points.astype(
        np.float64)) - mirror.marker_lift) < 1e-3
    return uv[seen & on_this]


def jitter_clicks(camera: Intrinsics, uv: np.ndarray, jitter_px: float,
                  rng: np.random.Generator) -> np.ndarray:
    """Move pixels as a person's clicks do, kept inside the image.

    Parameters
    ----------
    camera : Intrinsics
    uv : (k, 2) float64 array
        Pixels.
    jitter_px : float
        Radial RMS of the Gaussian offsets, pixels (std jitter_px / sqrt(2) per axis).
    rng : numpy.random.Generator
        The offsets' source.

    Returns
    -------
    (k, 2) float64 array
        Pixels.
    """
    moved = uv + rng.normal(0.0, jitter_px / np.sqrt(2.0), np.shape(uv))
    return np.clip(moved, -0.5, [camera.width - 0.5, camera.height - 0.5])


def session_mirrors(rig: Simulator, truth: GroundTruth, rng: np.random.Generator | None = None
                    ) -> tuple[SessionMirror, ...]:
    """Return the rig's mirrors as a session holds them (session order).

    The pixels (u, v) of the marker centres that `truth` shows directly (`visible_markers`),
    clicked with the scene's click_jitter_px (`jitter_clicks`), and each mirror's outline in the
    image (`mirror_outline`); no planes, and marker_offset 0 (the glass is the user's unknown).

    Parameters
    ----------
    rig : Simulator
    truth : GroundTruth
        The ideal render of the background.
    rng : numpy.random.Generator, optional
        The clicks' jitter; by default np.random.default_rng([rig.seed, 3]).

    Returns
    -------
    tuple of SessionMirror

    Raises
    ------
    MirrorscanError
        A mirror is out of view.
    """
    camera, jitter = rig.intrinsics, rig.scene.click_jitter_px
    rng = np.random.default_rng([rig.seed, 3]) if rng is None else rng
    mirrors = []
    for j, m in enumerate(rig.scene.mirrors, start=1):
        clicks = visible_markers(camera, m, j, truth)
        if jitter > 0:
            clicks = jitter_clicks(camera, clicks, jitter, rng)
        mirrors.append(SessionMirror(m.name, tuple(map(tuple, clicks.tolist())),
                                     tuple(map(tuple, mirror_outline(camera, m).tolist()))))
    return tuple(mirrors)


def truth_json(rig: Simulator, noise: str) -> dict:
    """Return the truth.json object.

    Scene, true planes [a, b, c, d] (docs/DESIGN.md convention; the reflecting surfaces), objects,
    seed, fps, noise; per mirror its plane, corners, marker face centres, marker_offset
    (metres) and tint (red, green, blue reflectance, 0 to 1).

    Parameters
    ----------
    rig : Simulator
    noise : str
        The sensor model's name.

    Returns
    -------
    dict
    """
    scene = rig.scene
    objects = [o.to_json() for o in scene.objects]
    return {"version": 1, "seed": rig.seed, "fps": rig.fps, "noise": noise,
            "object": objects[0] if objects else None, "objects": objects,
            "planes": [p.to_list() for p in rig.planes],
            "mirrors": [{"name": m.name, "plane": m.plane.to_list(),
                         "corners": m.corners().tolist(),
                         "markers": m.marker_centres().tolist(), "marker_offset": m.marker_offset,
                         "tint": list(m.tint)}
                        for m in scene.mirrors],
            "scene": scene.to_json()}


def write_session(rig: Simulator, out: str | Path, n_frames: int, noise: str = "kinect",
                  progress: bool = True, true_planes: bool = False) -> Path:
    """Render a simulated rig's background, frames and colour frames into a new session folder with
    truth.json.

    Nothing is left behind on error.

    Parameters
    ----------
    rig : Simulator
    out : str or Path
        The folder; it must not exist or be an empty folder.
    n_frames : int
        Frames rendered.
    noise : str
        The sensor model's name, for truth.json.
    progress : bool
        Show progress.
    true_planes : bool
        Give the mirrors their true planes (a perfect calibration); otherwise they are left to
        calibrate.

    Returns
    -------
    Path
        The folder.

    Raises
    ------
    MirrorscanError, OSError
    """
    out = Path(out)
    if n_frames < 1:
        raise MirrorscanError(f"--frames: at least one frame, got {n_frames}")
    with new_folder(out) as work:
        _write(rig, work, n_frames, noise, progress, true_planes)
    return out


def _write(rig: Simulator, folder: Path, n_frames: int, noise: str, progress: bool,
           true_planes: bool) -> None:
    """Write the background, frames, colour frames, session.json and truth.json into
    `folder`."""
    camera, scale = rig.intrinsics, rig.intrinsics.depth_scale
    (folder / "frames").mkdir()
    write_depth_png(folder / BACKGROUND_FILE, rig.background().depth, scale)
    frames, colours = [], []
    for i in tqdm(range(n_frames), desc="frames", unit="frame", disable=not progress):
        frame = rig.frame(i)
        if i == 0:
            first_truth = frame.truth
        frames.append(f"frames/{i:06d}.png")
        write_depth_png(folder / frames[-1], frame.depth, scale)
        colours.append(COLOUR_NAME.format(i))
        write_colour_png(folder / colours[-1], frame.colour)
    mirrors = session_mirrors(rig, first_truth)
    if true_planes:
        mirrors = tuple(replace(m, plane=plane) for m, plane in zip(mirrors, rig.planes))
    save_session(Session(folder, camera, mirrors, BACKGROUND_FILE, tuple(frames),
                         colour_frames=tuple(colours)))
    (folder / TRUTH_FILE).write_text(json.dumps(truth_json(rig, noise), indent=2) + "\n",
                                     encoding="utf-8")
