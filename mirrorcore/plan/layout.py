"""A rig's layout as the search's vector: the camera's tilt, then per mirror its place on the floor,
its turn, its lean, its height above the floor and its size; the limits a layout must keep (inside
the room, facing the camera, clear of the subject and of each other); and the hand-made layouts it
is compared with (a symmetric V behind the subject, mirrors on an arc around it).

Per mirror the vector holds x, z (metres, the centre, level frame), yaw (degrees: 0 faces the
camera straight, 90 faces -x), pitch (degrees: positive faces down), elevation (0 to 1: its centre
from half its height above the floor to half its height below the ceiling) and the width and height
as fractions of the largest size.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.plan.coverage import Glass, glass_from, tilt_rotation
from mirrorcore.plan.setup import PlanCamera, PlanRoom
from mirrorcore.plan.subject import Subject

PER_MIRROR = 7
TILT_LIMIT = 30.0          # degrees, the camera's tilt either way
YAW_LIMIT = 120.0          # degrees
PITCH_LIMIT = 30.0         # degrees
SMALLEST_SIZE = 0.5        # of the largest size, per side
CLEARANCE = 0.05           # metres between a mirror and the subject's bounding cylinder
APEX_GAP = 0.02            # metres between a V's mirrors and its apex
IN_FRONT = 0.05            # metres every corner of a mirror keeps ahead of the camera
# the limits whose amount is in metres (LayoutSpace.check says by how much)
_IN_METRES = ("outside the room", "too near the subject", "behind or beside the camera")


@dataclass(frozen=True)
class LayoutSpace:
    """The layouts of `mirrors` mirrors of at most `size` in a room around a subject.

    Attributes
    ----------
    mirrors : int
    size : (float, float)
        The largest width and height, metres.
    room : PlanRoom
    subject : Subject
    camera : PlanCamera
    """

    mirrors: int
    size: tuple[float, float]
    room: PlanRoom
    subject: Subject
    camera: PlanCamera

    def bounds(self) -> list[tuple[float, float]]:
        """The search's bounds of each entry of the vector."""
        w, d = self.room.width / 2, self.room.depth
        one = [(-w, w), (0.1, d), (-YAW_LIMIT, YAW_LIMIT), (-PITCH_LIMIT, PITCH_LIMIT), (0.0, 1.0),
               (SMALLEST_SIZE, 1.0), (SMALLEST_SIZE, 1.0)]
        return [(-TILT_LIMIT, TILT_LIMIT)] + one * self.mirrors

    def glass(self, x: np.ndarray) -> Glass:
        """The mirrors of vector x."""
        m = np.asarray(x[1:], np.float64).reshape(self.mirrors, PER_MIRROR)
        yaw, pitch = np.radians(m[:, 2]), np.radians(m[:, 3])
        normal = np.stack([-np.sin(yaw) * np.cos(pitch), np.sin(pitch),
                           -np.cos(yaw) * np.cos(pitch)], axis=1)
        width, height = m[:, 5] * self.size[0], m[:, 6] * self.size[1]
        above = height / 2 + m[:, 4] * np.maximum(self.room.height - height, 0.0)
        centre = np.stack([m[:, 0], self.room.floor_y - above, m[:, 1]], axis=1)
        return glass_from(centre, normal, np.tile([0.0, -1.0, 0.0], (self.mirrors, 1)), width,
                          height)

    def violation(self, x: np.ndarray) -> float:
        """How far vector x is from a layout that can be built: 0 when it keeps every limit.

        Metres outside the room, inside the subject's bounding cylinder (plus CLEARANCE), short of
        facing the camera or of IN_FRONT ahead of it, plus 1 per pair of mirrors that cross and per
        mirror out of the image (a simulated rig needs every mirror in view).
        """
        parts, crossing = self._limits(x)
        return float(sum(p.sum() for p in parts.values()) + len(crossing))

    def check(self, x: np.ndarray) -> None:
        """Refuse a layout that breaks a limit, naming the first mirror and limit.

        Parameters
        ----------
        x : (1 + 7 m,) array

        Raises
        ------
        MirrorscanError
            A mirror outside the room, not facing the camera, too near the subject, out of the
            image, or crossing another.
        """
        parts, crossing = self._limits(x)
        for limit, amount in parts.items():
            for j in np.flatnonzero(amount > 0):
                by = f" by {amount[j]:.2f} m" if limit in _IN_METRES else ""
                raise MirrorscanError(f"mirror {j + 1}: {limit}{by}")
        if crossing:
            a, b = crossing[0]
            raise MirrorscanError(f"mirror {a + 1} crosses mirror {b + 1}")

    def _limits(self, x: np.ndarray) -> tuple[dict[str, np.ndarray], list[tuple[int, int]]]:
        """Per limit, how far each mirror breaks it (m,), and the pairs of mirrors that cross."""
        glass = self.glass(x)
        corners = glass.corners()
        r = self.room
        out = (np.maximum(np.abs(corners[..., 0]) - r.width / 2, 0)
               + np.maximum(-corners[..., 2], 0) + np.maximum(corners[..., 2] - r.depth, 0)
               + np.maximum(corners[..., 1] - r.floor_y, 0)
               + np.maximum(r.ceiling_y - corners[..., 1], 0)).sum(axis=1)
        facing = (glass.normal * -glass.centre).sum(axis=1) / np.linalg.norm(glass.centre, axis=1)
        parts = {"outside the room": out, "turned away from the camera":
                 np.maximum(0.05 - facing, 0), "too near the subject": self._into_subject(glass)}
        behind, unseen = self._out_of_view(glass, float(x[0]))
        parts["behind or beside the camera"] = behind
        parts["out of the camera's image"] = unseen
        crossing = [(a, b) for a in range(len(glass)) for b in range(a + 1, len(glass))
                    if _crossing(corners[a], corners[b])]
        return parts, crossing

    def _out_of_view(self, glass: Glass, tilt: float) -> tuple[np.ndarray, np.ndarray]:
        """Per mirror (m,): metres of corners less than IN_FRONT ahead of the tilted camera, and
        1 when neither a corner nor the centre projects into the image."""
        points = np.concatenate([glass.corners(), glass.centre[:, None]], axis=1)
        cam = points @ tilt_rotation(tilt).T
        z = cam[..., 2]
        behind = np.maximum(IN_FRONT - z[:, :4], 0).sum(axis=1)
        intr = self.camera.intrinsics
        with np.errstate(divide="ignore", invalid="ignore"):
            u = intr.fx * cam[..., 0] / z + intr.cx
            v = intr.fy * cam[..., 1] / z + intr.cy
        inside = (z > 0) & (u >= 0) & (u <= intr.width - 1) & (v >= 0) & (v <= intr.height - 1)
        return behind, (~inside.any(axis=1)).astype(np.float64)

    def _into_subject(self, glass: Glass) -> np.ndarray:
        """(m,) metres by which each mirror enters the subject's bounding cylinder widened by
        CLEARANCE."""
        s = np.linspace(-1, 1, 9)
        grid = np.stack(np.meshgrid(s, s), axis=-1).reshape(-1, 2)
        pts = (glass.centre[:, None] + grid[None, :, :1] * glass.half[:, None, :1]
               * glass.right[:, None] + grid[None, :, 1:] * glass.half[:, None, 1:]
               * glass.up[:, None])
        top, bottom = self.subject.y_range
        level = (pts[..., 1] > top - CLEARANCE) & (pts[..., 1] < bottom + CLEARANCE)
        near = np.linalg.norm(pts[..., [0, 2]] - self.subject.centre[[0, 2]], axis=-1)
        return np.where(level, np.maximum(self.subject.radius + CLEARANCE - near, 0),
                        0).sum(axis=1)

    def vector(self, tilt: float, centre: np.ndarray, normal: np.ndarray,
               fraction: np.ndarray | None = None) -> np.ndarray:
        """The vector of a layout of full-size mirrors given by their centres and normals (m, 3)
        (the centres' heights become elevations, clipped to the room).

        Parameters
        ----------
        tilt : float
            Degrees.
        centre, normal : (m, 3) arrays
            Level frame.
        fraction : (m, 2) array, optional
            Width and height as fractions of the largest size (default 1).

        Returns
        -------
        (1 + 7 m,) float64 array
        """
        normal = normal / np.linalg.norm(normal, axis=1, keepdims=True)
        frac = np.ones((len(centre), 2)) if fraction is None else fraction
        height = frac[:, 1] * self.size[1]
        above = self.room.floor_y - centre[:, 1]
        spare = np.maximum(self.room.height - height, 1e-9)
        elevation = np.clip((above - height / 2) / spare, 0.0, 1.0)
        yaw = np.degrees(np.arctan2(-normal[:, 0], -normal[:, 2]))
        pitch = np.degrees(np.arcsin(np.clip(normal[:, 1], -1, 1)))
        per = np.stack([centre[:, 0], centre[:, 2], yaw, pitch, elevation, frac[:, 0],
                        frac[:, 1]], axis=1)
        return np.concatenate([[tilt], per.reshape(-1)])

    def hand_made(self, tilt: float, angle_deg: float, reach: float,
                  shift: float = 0.0) -> np.ndarray:
        """A symmetric hand-made layout of vertical full-size mirrors around the subject.

        Two mirrors: a V with `angle_deg` between them, its apex `reach` metres behind the
        subject's middle, each mirror `shift` metres farther from the apex than touching it.
        Three or more: mirrors spread over `angle_deg` of an arc of radius `reach` around the
        subject, centred behind it, each facing half-way between the camera and the subject.
        Mirrors stand on the floor, or level with the middle of a subject shorter than them.

        Returns
        -------
        (1 + 7 m,) float64 array
        """
        c = self.subject.centre
        w, h = self.size
        y = max(self.room.floor_y - h / 2, c[1]) if self.subject.height < h else \
            self.room.floor_y - h / 2
        if self.mirrors == 2:
            half = np.radians(angle_deg) / 2
            apex = np.array([c[0], y, c[2] + reach])
            centres, normals = [], []
            for sign in (-1.0, 1.0):
                along = np.array([sign * np.sin(half), 0.0, -np.cos(half)])
                centres.append(apex + (APEX_GAP + w / 2 + shift) * along)
                normals.append([-sign * np.cos(half), 0.0, -np.sin(half)])
        else:
            phi = np.radians(np.linspace(-angle_deg / 2, angle_deg / 2, self.mirrors))
            centres = np.stack([c[0] + reach * np.sin(phi), np.full_like(phi, y),
                                c[2] + reach * np.cos(phi)], axis=1)
            to_subject = np.array([c[0], y, c[2]]) - centres
            normals = (-centres / np.linalg.norm(centres, axis=1, keepdims=True)
                       + to_subject / np.linalg.norm(to_subject, axis=1, keepdims=True))
        return self.vector(tilt, np.asarray(centres), np.asarray(normals))


def _crossing(a: np.ndarray, b: np.ndarray) -> float:
    """1.0 when rectangle a (4, 3) and rectangle b cross (an edge of one passes through the
    other), else 0.0."""
    return float(_edges_through(a, b) or _edges_through(b, a))


def _edges_through(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether an edge of rectangle a passes through rectangle b."""
    origin, u, v = b[0], b[1] - b[0], b[3] - b[0]
    n = np.cross(u, v)
    start, end = a, np.roll(a, -1, axis=0)
    ds, de = (start - origin) @ n, (end - origin) @ n
    crosses = ds * de < 0
    if not crosses.any():
        return False
    t = ds[crosses] / (ds[crosses] - de[crosses])
    p = start[crosses] + t[:, None] * (end[crosses] - start[crosses]) - origin
    s, r = p @ u / (u @ u), p @ v / (v @ v)
    return bool(np.any((s >= 0) & (s <= 1) & (r >= 0) & (r <= 1)))
