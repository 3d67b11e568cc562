"""The layout planned in the browser (`mirrorscan plan --serve`): the mirrors as the technician
drags and turns them, their coverage re-evaluated on every move, the search started from them,
and the plan folder written. No viser here: mirrorscan.planapp draws it."""
from __future__ import annotations

import dataclasses
import threading
from pathlib import Path

import numpy as np

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.base.progress import Progress
from mirrorcore.plan.coverage import Coverage, CoverageModel
from mirrorcore.plan.layout import PER_MIRROR
from mirrorcore.plan.planfile import write_plan
from mirrorcore.plan.report import write_documents
from mirrorcore.plan.search import PlanResult, plan_rig
from mirrorcore.plan.subject import sample_surface

# views that see a sample: 0, 1, 2, 3 or more (the colours of the subject's points)
MOST_COUNTED = 3


def yaw_quaternion(yaw_deg: float) -> np.ndarray:
    """(4,) wxyz of a turn by `yaw_deg` about the level frame's y axis (a mirror's yaw)."""
    half = np.radians(yaw_deg) / 2
    return np.array([np.cos(half), 0.0, np.sin(half), 0.0])


def quaternion_yaw(wxyz) -> float:
    """The turn about y, degrees, of a rotation given as wxyz (its other turns are ignored)."""
    w, x, y, z = np.asarray(wxyz, np.float64) / np.linalg.norm(wxyz)
    # R[0, 2] and R[2, 2] of the rotation: sin and cos of the turn about y
    return float(np.degrees(np.arctan2(2 * (x * z + w * y), 1 - 2 * (x * x + y * y))))


class PlanDesk:
    """A layout being edited, with its coverage on the plan's final samples; thread-safe.

    Parameters
    ----------
    result : PlanResult
        The layout to start from (a plan's search, or any vector of its LayoutSpace).
    """

    def __init__(self, result: PlanResult):
        self._lock = threading.Lock()
        self._result = result
        subject, settings = result.space.subject, result.settings
        # the samples of the plan's final figures (plan_rig): the same figures as plan.json
        self.model = CoverageModel(subject, sample_surface(subject, settings.final_samples,
                                                           settings.seed + 2),
                                   result.camera, result.bounces)

    @property
    def result(self) -> PlanResult:
        """The layout as it stands, with its coverage."""
        with self._lock:
            return self._result

    @property
    def coverage(self) -> Coverage:
        """The coverage of the layout as it stands."""
        return self.result.coverage

    def counts(self) -> np.ndarray:
        """(n,) int: how many views see each sample, at most MOST_COUNTED."""
        return np.minimum(self.coverage.counts, MOST_COUNTED)

    def pose(self, j: int) -> tuple[np.ndarray, np.ndarray]:
        """Mirror j's handle: its centre (3,) metres and its turn about y as wxyz (4,)."""
        result = self.result
        yaw = result.x[1 + PER_MIRROR * j + 2]
        return result.glass.centre[j].copy(), yaw_quaternion(yaw)

    def move(self, j: int, position, wxyz) -> Coverage:
        """Place mirror j's centre at `position` on the floor and turn it to `wxyz`'s yaw.

        Its height, lean and size stay. The layout is kept only when it keeps every limit.

        Parameters
        ----------
        j : int
            0-based mirror.
        position : (3,) array
            Metres, level frame (y is ignored).
        wxyz : (4,) array
            Its turn (about y).

        Returns
        -------
        Coverage
            The new layout's.

        Raises
        ------
        MirrorscanError
            The layout breaks a limit (LayoutSpace.check); the layout stays as it was.
        """
        result = self.result
        x = result.x.copy()
        at = 1 + PER_MIRROR * j
        x[at], x[at + 1], x[at + 2] = position[0], position[2], quaternion_yaw(wxyz)
        result.space.check(x)
        return self._set(result, x)

    def _set(self, result: PlanResult, x: np.ndarray) -> Coverage:
        """Keep vector x of `result`'s space with its coverage (unless another change came
        between)."""
        cov = self.model.evaluate(result.space.glass(x), float(x[0]))
        with self._lock:
            if self._result is not result:
                raise MirrorscanError("the layout changed meanwhile: move the mirror again")
            self._result = dataclasses.replace(result, x=x, coverage=cov)
        return cov

    def optimise(self, progress: Progress | None = None, cancel=None) -> PlanResult:
        """Search from the layout as it stands (plan_rig's `start`) and keep the result.

        Raises
        ------
        Cancelled
            When `cancel` asks to stop; the layout stays.
        """
        result = self.result
        space = result.space
        found = plan_rig(result.spec, space.mirrors, space.size, space.room, result.camera,
                         float(space.subject.centre[2]), result.bounces, result.settings,
                         progress, cancel, start=result.x)
        # its coverage is on the same final samples as self.model's
        with self._lock:
            self._result = found
        return found

    def save(self, folder: str | Path) -> list[Path]:
        """Write the plan folder of the layout as it stands: plan.json, scene.json, the drawing
        and the report (the folder is made when missing)."""
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        return write_plan(self.result, folder) + write_documents(folder)
