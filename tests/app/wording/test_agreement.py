"""The agreement lines' advice follows from what was measured (mirrorscan.wording.agreement): on
simulated rigs of the sphere, planes fitted to markers on 3 mm of glass send the technician to the
glass; planes off by a tilt and a shift on a rig without glass send them to the refinement."""
import numpy as np
import pytest

from mirrorscan.cli import main
from mirrorscan.results import AgreementReport, MirrorAgreement
from mirrorscan.wording.agreement import agreement, disagrees

from mirrorcore.calibration.residuals import view_agreement
from mirrorcore.io.sessionfile import load_session
from mirrorcore.rig.model import Rig
from mirrorcore.rig.pipeline import prepare_frame
from mirrorcore.sources import session_truth
from mirrorcore.sim.presets import object_extent
from tests.core.calibration.planes import nearer, with_planes

HEADLINE_WORDS = 25


@pytest.fixture(scope="module")
def rigs(tmp_path_factory):
    """{glass mm: (the rig calibrated from its markers, frames (5, H, W), masks, the object's
    middle)} for the sphere with markers on 3 mm of glass and on the silver."""
    out = {}
    for glass in (0, 3):
        folder = tmp_path_factory.mktemp("advice") / f"glass{glass}"
        assert main(["simulate", str(folder), "--marker-offset", str(glass), "--frames", "5",
                     "--seed", "1", "--quiet"]) == 0
        assert main(["calibrate", str(folder), "--quiet"]) == 0
        session = load_session(folder)
        rig = Rig.from_session(session)
        depths = session.read_frames(range(5))
        background = session.read_background()
        masks = np.stack([prepare_frame(rig, d, background)[1] for d in depths])
        middle = np.asarray(object_extent(session_truth(session)[0].objects[0])[0])
        out[glass] = rig, depths, masks, middle
    return out


def lines(rig, depths, masks) -> tuple[list, AgreementReport]:
    """The agreement lines of a rig whose planes all come from markers, and their report."""
    found = view_agreement(rig, depths, masks)
    report = AgreementReport(tuple(MirrorAgreement(rig.mirrors[j].name, found[j], True)
                                   for j in sorted(found)))
    return agreement(report), report


def test_markers_on_glass_with_no_glass_set_send_the_technician_to_the_glass(rigs):
    """3 mm hardly moves the lines' RMS and mean (they need not flag it), but the refinement's
    step measures it on every plane alike."""
    said, _ = lines(*rigs[3][:3])
    for message in said:
        assert "set each mirror's glass and fit again" in message.headline, message
        assert len(message.headline.split()) <= HEADLINE_WORDS
        step = next(d for d in message.details if d.startswith("A refinement step"))
        # the markers 3 mm in front of the silver: the step moves the plane back by about that
        assert 2.0 < float(step.split("move it ")[1].split(" mm")[0]) < 4.0, step


def test_planes_off_without_glass_send_the_technician_to_the_refinement_not_the_glass(rigs):
    rig, depths, masks, middle = rigs[0]
    planes = [m.plane for m in rig.mirrors]
    # one plane 8 mm too far (both flagged against each other, not against the camera), or tilted
    # by half a degree and the other 3 mm too far: no glass does that
    for off in ([planes[0], nearer(planes[1], middle, -0.008)],
                [nearer(planes[0], middle, 0.0, 0.5), nearer(planes[1], middle, -0.003)]):
        said, report = lines(with_planes(rig, off), depths, masks)
        flagged = [disagrees(m.found) for m in report.mirrors]
        assert any(flagged), report
        for message, flag in zip(said, flagged):
            assert not flag or "Refine from the object" in message.headline, message
            assert "glass" not in message.headline
            assert len(message.headline.split()) <= HEADLINE_WORDS
            assert not any("glass" in d for d in message.details), message
    # one plane 4 mm too near, the other right: not the glass either
    near = with_planes(rig, [nearer(planes[0], middle, 0.004), planes[1]])
    assert not any("glass" in m.headline for m in lines(near, depths, masks)[0])
    # and the planes from the markers on the silver: no glass either
    assert not any("glass" in m.headline for m in lines(*rigs[0][:3])[0])
