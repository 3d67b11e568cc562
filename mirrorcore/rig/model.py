"""The rig: the depth camera's intrinsics and the mirrors (plane + image boundary), how many
reflections a ray is followed through, and the per-pixel tables of Algorithm 1 (boundary masks, the
first mirror, the paths through further mirrors), built once."""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from mirrorcore.base.budget import check_memory
from mirrorcore.base.errors import MirrorscanError
from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.geometry.plane import Plane
from mirrorcore.geometry.polygon import polygon_mask, validate_polygon
from mirrorcore.base.palette import MAX_MIRRORS, MAX_ORDER, source_sequence
from mirrorcore.rig.colour import correction_table
from mirrorcore.rig.raypaths import Chains, VirtualCamera, trace_chains
from mirrorcore.io.session import Session

# reflections followed unless the session or the command says otherwise
DEFAULT_BOUNCES = MAX_ORDER
# the rig's per-pixel tables and one frame through Algorithm 1: 47 bytes a pixel measured at 640x480
PIXEL_BYTES = 64


@dataclass(frozen=True)
class Mirror:
    """One mirror of a rig.

    Attributes
    ----------
    name : str
    plane : Plane or None
        None until calibrated.
    boundary : (m, 2) array or None
        Polygon (u, v), pixels.
    """

    name: str
    plane: Plane | None
    boundary: np.ndarray | None

    def __hash__(self) -> int:
        return hash((self.name, self.plane,
                     None if self.boundary is None else self.boundary.tobytes()))

    def __eq__(self, other: object) -> bool:
        return (isinstance(other, Mirror) and self.name == other.name and self.plane == other.plane
                and np.array_equal(self.boundary, other.boundary))


@dataclass(frozen=True, eq=False)
class Rig:
    """The camera and its mirrors, in session order (mirror j of the sources is mirrors[j - 1]).

    Attributes
    ----------
    intrinsics : Intrinsics
        The depth camera.
    mirrors : tuple of Mirror
        Session order.
    bounces : int
        The most mirrors a ray is followed through, 1 to MAX_ORDER (mirrorcore.rig.raypaths; at 1,
        Algorithm 1 as the paper writes it, with the points seen through a second mirror left out
        rather than misplaced).
    colour_gains : tuple of (3,) tuple of float or None
        Each mirror's colour gain (SessionMirror.colour_gain), session order, None where not
        measured; empty for none at all. Not part of the rays (`same_rays`).
    """

    intrinsics: Intrinsics
    mirrors: tuple[Mirror, ...]
    bounces: int = DEFAULT_BOUNCES
    colour_gains: tuple[tuple[float, float, float] | None, ...] = ()

    def __post_init__(self) -> None:
        """Raises MirrorscanError for more than MAX_MIRRORS mirrors, MemoryBudgetError for a camera
        whose per-pixel work (PIXEL_BYTES a pixel) would not fit in the memory budget."""
        if len(self.mirrors) > MAX_MIRRORS:
            raise MirrorscanError(f"rig: at most {MAX_MIRRORS} mirrors, got {len(self.mirrors)}")
        w, h = self.intrinsics.width, self.intrinsics.height
        check_memory(w * h * PIXEL_BYTES, f"rig: the per-pixel tables of a {w}x{h} camera")
        check_bounces(self.bounces)

    def same_rays(self, other: "Rig") -> bool:
        """Tell whether `other` traces the same rays: then its per-pixel tables serve this rig too.

        Same camera, mirrors with their names, planes and boundaries, and bounces (rigs compare by
        identity, as they hold caches).

        Parameters
        ----------
        other : Rig

        Returns
        -------
        bool
        """
        return (self.intrinsics, self.mirrors, self.bounces) == (
            other.intrinsics, other.mirrors, other.bounces)

    @classmethod
    def from_session(cls, session: Session, bounces: int | None = None) -> "Rig":
        """Return the session's rig.

        Parameters
        ----------
        session : Session
        bounces : int, optional
            The reflections followed (default: the session's setting).

        Returns
        -------
        Rig
        """
        mirrors = tuple(
            Mirror(m.name, m.plane,
                   validate_polygon(m.boundary, session.camera.shape,
                                    f"{m.name}: boundary") if m.boundary else None)
            for m in session.mirrors)
        return cls(session.camera, mirrors, session.bounces if bounces is None else bounces,
                   tuple(m.colour_gain for m in session.mirrors))

    @property
    def planes(self) -> tuple[Plane | None, ...]:
        """Each mirror's plane in session order, None where uncalibrated."""
        return tuple(m.plane for m in self.mirrors)

    @cached_property
    def inside_bits(self) -> np.ndarray:
        """(H, W) uint32: bit j-1 set where the pixel is inside (or on) mirror j's boundary."""
        bits = np.zeros(self.intrinsics.shape, dtype=np.uint32)
        for j, mirror in enumerate(self.mirrors):
            if mirror.boundary is not None:
                bits[polygon_mask(mirror.boundary, self.intrinsics.shape)] |= np.uint32(1 << j)
        bits.flags.writeable = False
        return bits

    @cached_property
    def colour_correction(self) -> np.ndarray:
        """(LAST_LABEL + 1, 4) float32: by source label, the factors that undo the colour gains of
        the mirrors the label's view reflects on (mirrorcore.rig.colour.correction_table)."""
        return correction_table(self.colour_gains)

    @cached_property
    def reflection_table(self) -> "ReflectionTable":
        """Per-pixel geometry of Algorithm 1, computed once per rig (see ReflectionTable)."""
        return ReflectionTable.from_rig(self)

    def virtual_cameras(self) -> tuple[VirtualCamera, ...]:
        """Return the views of the rig up to `bounces` mirrors.

        The camera, each calibrated mirror with a boundary, then each sequence of mirrors that some
        pixel's ray follows (mirrorcore.rig.raypaths), in label order. A mirror's `pixels` are those
        Algorithm 1 gives it first; a sequence's, those whose ray meets its mirrors in turn.

        Returns
        -------
        tuple of VirtualCamera
        """
        table = self.reflection_table
        counts = np.bincount(table.label.reshape(-1), minlength=len(self.mirrors) + 1)
        views = [VirtualCamera.of(self.planes, (), self.intrinsics.width * self.intrinsics.height)]
        views += [VirtualCamera.of(self.planes, (j,), counts[j]) for j,
                  m in enumerate(self.mirrors, start=1)
                  if m.plane is not None and m.boundary is not None]
        labels, pixels = np.unique(table.chains.label[table.chains.label > 0], return_counts=True)
        views += [VirtualCamera.of(self.planes, source_sequence(int(s)), n) for s,
                  n in zip(labels, pixels)]
        return tuple(views)


def check_bounces(bounces: int) -> int:
    """Check a number of reflections to follow.

    Parameters
    ----------
    bounces : int

    Returns
    -------
    int
        `bounces`.

    Raises
    ------
    MirrorscanError
        Naming --bounces, when it is not a whole number from 1 to MAX_ORDER.
    """
    if isinstance(bounces, bool) or not isinstance(bounces, (
        int, np.integer)) or not 1 <= bounces <= MAX_ORDER:
        raise MirrorscanError(
            f"--bounces: the reflections followed must be 1 to {MAX_ORDER}, got {bounces!r}")
    return int(bounces)


def calibrated_rig(session: Session, bounces: int | None = None) -> Rig:
    """Return the session's rig, refusing one that cannot reconstruct.

    Parameters
    ----------
    session : Session
    bounces : int, optional
        The mirrors followed in turn (default: the session's setting).

    Returns
    -------
    Rig

    Raises
    ------
    MirrorscanError
        Naming session.json: a session without mirrors, or with a mirror that cannot reconstruct
        (no plane or no boundary).
    """
    if not session.mirrors:
        raise MirrorscanError(f"{session.path}: the session has no mirrors")
    for m in session.mirrors:
        if m.plane is None:
            raise MirrorscanError(
                f"{session.path}: {m.name} has no plane; run `mirrorscan calibrate {session.root}`")
        if not m.boundary:
            raise MirrorscanError(f"{session.path}: {m.name} has no boundary polygon")
    return Rig.from_session(session, bounces)


@dataclass(frozen=True, eq=False)
class ReflectionTable:
    """Algorithm 1 per pixel, precomputed.

    A pixel at depth z is reflected through the first calibrated mirror whose boundary holds it
    (`label`) exactly when z > threshold, since its point z * ray is behind plane (n, d) when
    z (n . ray) + d < 0. The per-pixel arrays are (H, W); all are read-only. `chains` holds the few
    pixels whose ray then meets further mirrors (mirrorcore.rig.raypaths), followed up to the rig's
    `bounces`.

    Attributes
    ----------
    label : (H, W) uint8 array
        That mirror (1-based), 0 for pixels in no calibrated mirror's boundary.
    threshold : (H, W) float32 array
        Metres; inf where the pixel can never be behind it (label 0, or its ray leaves the glass).
    ray_dot : (H, W) float32 array
        n . (x/z, y/z, 1) of the pixel's ray, n that mirror's normal (0 for label 0).
    overlap : (H, W) bool array
        Inside the boundaries of more than one calibrated mirror (later mirrors are tried there
        too).
    uncalibrated : (H, W) bool array
        Inside the boundary of a mirror that has no plane yet.
    planes : (M + 1, 4) float32 array
        Row j the offset d and normal nx, ny, nz of mirror j (row 0 and uncalibrated mirrors zeros):
        a frame reads a reflected pixel's plane from this small table by its label, and only ray_dot
        per pixel (a fifth of the bytes of per-pixel rows of all five, with the same values bit for
        bit).
    chains : Chains
        The pixels whose ray meets further mirrors.
    """

    label: np.ndarray
    threshold: np.ndarray
    ray_dot: np.ndarray
    overlap: np.ndarray
    uncalibrated: np.ndarray
    planes: np.ndarray
    chains: Chains

    @cached_property
    def any_overlap(self) -> bool:
        """Whether any pixel is inside more than one calibrated mirror."""
        return bool(self.overlap.any())

    @cached_property
    def any_uncalibrated(self) -> bool:
        """Whether any pixel is inside a mirror that has no plane yet."""
        return bool(self.uncalibrated.any())

    @cached_property
    def chain_row(self) -> np.ndarray:
        """(H, W) int32 read-only: each pixel's row in `chains`, -1 for the pixels not in it."""
        rows = np.full(self.label.shape, -1, np.int32)
        rows.reshape(-1)[self.chains.pixel] = np.arange(len(self.chains), dtype=np.int32)
        rows.flags.writeable = False
        return rows

    @classmethod
    def from_rig(cls, rig: Rig) -> "ReflectionTable":
        """Compute the table of a rig.

        Parameters
        ----------
        rig : Rig

        Returns
        -------
        ReflectionTable
        """
        shape, rays = rig.intrinsics.shape, rig.intrinsics.rays
        label = np.zeros(shape, np.uint8)
        count = np.zeros(shape, np.uint8)
        uncalibrated = np.zeros(shape, bool)
        planes = np.zeros((len(rig.mirrors) + 1, 4), np.float32)
        for j, mirror in enumerate(rig.mirrors, start=1):
            if mirror.boundary is None:
                continue
            inside = polygon_mask(mirror.boundary, shape)
            if mirror.plane is None:
                uncalibrated |= inside
                continue
            first = inside & (label == 0)
            label[first] = j
            planes[j] = mirror.plane.d, *mirror.plane.n
            count += inside
        offset, nx, ny, nz = (np.take(planes[:, k], label) for k in range(4))      # (H, W) each
        ray_dot = nx * rays[0] + ny * rays[1] + nz
        with np.errstate(divide="ignore", invalid="ignore"):
            threshold = np.where((label > 0) & (ray_dot < 0), -offset / ray_dot,
                                 np.inf).astype(np.float32)
        arrays = dict(label=label, threshold=threshold, ray_dot=ray_dot, overlap=count > 1,
                      uncalibrated=uncalibrated, planes=planes)
        chains = trace_chains(rig.intrinsics,
                              tuple(m.plane if m.boundary is not None else None
                                                    for m in rig.mirrors),
                              rig.inside_bits, label, threshold, rig.bounces)
        for a in (*arrays.values(), *vars(chains).values()):
            a.flags.writeable = False
        return cls(**arrays, chains=chains)
