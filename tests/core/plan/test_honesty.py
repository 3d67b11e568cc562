"""The plan's predicted figures against the simulator: its scene rendered and reconstructed gives
the coverage predicted within 3 points and a noise within 15 % per view; and the plan folder's
files (plan.json's contract, the subject's mesh beside scene.json)."""
import json

import numpy as np
import pytest

from mirrorcore.plan.honesty import measure
from mirrorcore.plan.planfile import write_plan
from mirrorcore.plan.search import SearchSettings, plan_rig
from mirrorcore.plan.setup import parse_room, plan_camera
from mirrorcore.sim.scenefile import load_scene
from mirrorcore.sim.simulator import Simulator

QUICK = SearchSettings(coarse_samples=400, fine_samples=800, final_samples=20000, generations=3,
                       population=3)
ROOM = parse_room("3.0,3.6", 1.0)


@pytest.fixture(scope="module", params=["person:1.75", "sphere:0.15"])
def planned(request):
    return plan_rig(request.param, 2, (0.8, 1.9), ROOM, plan_camera("kinect_v1"),
                    distance=2.0, settings=QUICK)


def test_simulated_coverage_and_noise_are_the_predicted(planned):
    measured = measure(planned)
    predicted = planned.coverage
    assert measured.coverage.coverage == pytest.approx(predicted.coverage, abs=0.03)
    assert measured.coverage.coverage_2 == pytest.approx(predicted.coverage_2, abs=0.03)
    assert np.allclose(measured.coverage.per_view, predicted.per_view, atol=0.03)
    seen = predicted.per_view > 0.05
    assert seen.sum() >= 2
    ratio = measured.noise_mm[seen] / predicted.noise_mm()[seen]
    assert np.all(np.abs(ratio - 1) < 0.15), ratio


def test_plan_json_keeps_its_contract(planned, tmp_path):
    written = write_plan(planned, tmp_path)
    plan = json.loads((tmp_path / "plan.json").read_text())
    assert [p.name for p in written][-2:] == ["plan.json", "scene.json"]
    assert set(plan) >= {"camera", "mirrors", "subject", "room", "predicted", "search"}
    assert plan["room"] == {"width": 3.0, "depth": 3.6, "height": 2.5, "camera_height": 1.0}
    subject = plan["subject"]
    if subject["kind"] == "mesh":
        assert (tmp_path / subject["path"]).is_file()
    else:
        assert subject["kind"] == "sphere" and subject["radius"] == 0.15
        # the sphere rests on the floor: its centre 0.15 m above it, in the camera's frame
        up = np.array(plan["up"])
        assert up @ subject["center"] == pytest.approx(-1.0 + 0.15, abs=1e-3)
    assert plan["predicted"]["coverage"] == round(planned.coverage.coverage, 4)
    scene = load_scene(tmp_path / "scene.json")
    frame = Simulator(scene, seed=1, bounces=1).frame(0)
    assert frame.truth.object_mask.any()
