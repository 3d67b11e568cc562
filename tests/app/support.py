"""Helpers shared by the tests of the browser tool: an app on a simulated scene with its true
planes, an agreement line and a mirror's refinement with plausible figures."""
from dataclasses import replace
from pathlib import Path

from mirrorscan.results import MirrorAgreement
from mirrorscan.wording.agreement import agreement_line

from mirrorcore.calibration.refine import MirrorRefinement
from mirrorcore.geometry.plane import Plane


def simulated_app(scene):
    """The app (not started, not saved) on a simulated scene, its planes the true ones (a perfect
    calibration)."""
    from mirrorscan.server import MirrorscanApp

    from mirrorcore.io.session import Session
    from mirrorcore.sim.export import session_mirrors
    from mirrorcore.sim.simulator import Simulator
    from mirrorcore.sources import SimulatedSource

    rig = Simulator(scene, seed=0)
    mirrors = tuple(
        replace(m, plane=p)
        for m, p in zip(session_mirrors(rig, rig.background().truth), rig.planes)
    )
    return MirrorscanApp(
        Session(Path("unused"), rig.intrinsics, mirrors),
        SimulatedSource(rig),
        port=0,
        autosave=False,
    )


def line(name, found, by_markers=True):
    """An agreement line's message (headline and details) for one mirror's figures."""
    return agreement_line(MirrorAgreement(name, found, by_markers))


def refined(name="left", index=0, **figures) -> MirrorRefinement:
    """A mirror's refinement with plausible figures (mm, degrees), `figures` replacing some."""
    plane = Plane.from_abcd([0.0, 0.0, -1.0, 2.0])
    values = dict(
        index=index,
        name=name,
        before=plane,
        after=plane,
        agreement_before_mm=1.42,
        agreement_after_mm=0.91,
        offset_before_mm=0.61,
        offset_after_mm=0.05,
        shift_mm=-2.7,
        tilt_deg=0.18,
        shift_std_mm=0.4,
        tilt_std_deg=0.02,
        agreements=5000,
        camera_agreements=5000,
        noise_mm=1.0,
        marker_offset=5e-4,
        marker_offset_std=1.2e-3,
    )
    return MirrorRefinement(**{**values, **figures})
