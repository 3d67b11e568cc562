"""The issue's figures on the simulator, through the command line as a user runs it: two mirrors
hinged at 60, 72 and 90 degrees, rendered with up to three bounces, noiseless and with Kinect v1
noise: simulate -> calibrate (markers) -> reconstruct (up to 3 mirrors, and --bounces 1) -> fit
sphere. No ghost, the radius, the cloud's growth, and the error of the views through two mirrors
against the views through one."""
import contextlib
import io
import json

import numpy as np
import pytest

from mirrorscan.cli import main
from mirrorcore.depth.ops import smooth_depth
from mirrorcore.base.palette import source_orders, source_sequence
from mirrorcore.rig.pipeline import prepare_frame
from mirrorcore.io.ply import read_ply
from mirrorcore.rig.reconstruct import reconstruct_raw
from mirrorcore.rig.model import Rig
from mirrorcore.io.sessionfile import load_session

TRUE_RADIUS = 0.115


def run_ok(*argv) -> str:
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main([str(a) for a in argv]) == 0
    return out.getvalue()


@pytest.fixture(scope="module", params=[(n, a) for n in ("none", "kinect") for a in (60, 72, 90)],
                ids=lambda p: f"{p[0]}-{p[1]}")
def scanned(request, tmp_path_factory):
    """(noise, angle, session, truth, points and sources followed through 3 mirrors, the point count
    with 1, fit JSON of the 3-mirror cloud)."""
    noise, angle = request.param
    root = tmp_path_factory.mktemp(f"kaleidoscope-{noise}-{angle}")
    session = root / "session"
    run_ok("simulate", session, "--kaleidoscope", "--angle", angle, "--noise", noise, "--frames", 3,
           "--seed", 3,
           "--quiet")
    run_ok("calibrate", session)
    run_ok("reconstruct", session, "-o", root / "three.ply", "--frame", 1)
    run_ok("reconstruct", session, "-o", root / "one.ply", "--frame", 1, "--bounces", 1)
    points, sources = read_ply(root / "three.ply")
    one, _ = read_ply(root / "one.ply")
    fit = json.loads(run_ok("fit", "sphere", root / "three.ply", "--json"))
    truth = json.loads((session / "truth.json").read_text())
    return noise, angle, session, truth, points, sources, len(one), fit


def test_no_ghost(scanned):
    """Today's Algorithm 1 put 15-27 % of such a cloud more than 2 cm from the object."""
    _, _, _, truth, points, *_ = scanned
    error = np.linalg.norm(points - np.asarray(truth["object"]["centre"]), axis=1) - TRUE_RADIUS
    assert np.abs(error).max() < 0.02


def test_radius_within_half_a_millimetre(scanned):
    fit = scanned[-1]
    assert abs(fit["radius_mm"] - 1e3 * TRUE_RADIUS) < 0.5


def test_the_views_through_two_mirrors_are_used(scanned):
    """At least 20 % more points than following one mirror, labelled with their sequences; the fit
    reports them."""
    _, angle, _, _, points, sources, one_bounce, fit = scanned
    assert len(points) >= 1.2 * one_bounce
    multi = sorted(set(sources.tolist()) - {0, 1, 2})
    assert multi and all(len(source_sequence(s)) in (2, 3) for s in multi)
    assert {f"mirror {' then '.join(map(str, source_sequence(s)))}"
            for s in multi} <= set(fit["per_source"])
    # the image through 3 mirrors
    assert (angle == 60) == any(len(source_sequence(s)) == 3 for s in multi)


def test_the_views_through_two_mirrors_are_as_good_as_those_through_one(scanned):
    """The RMSE (to the fitted sphere, as the fit reports per source) of the views through two
    mirrors is at most 1.5 times that of the views through one, though the sensor's own noise at
    their longer (virtual) depths grows more (Kinect v1: sigma = 1.425e-3 z^2, 1.62 times at 60
    degrees): their depth is fitted by local quadratic surfaces over 9 x 9 pixels
    (pipeline.prepare_frame), which the measured 1.25 to 1.38 times at 60 degrees owe to."""
    *_, fit = scanned
    per_order = {}
    for name, errors in fit["per_source"].items():
        order = 0 if name == "direct" else len(name.split(" then "))
        per_order.setdefault(order, []).append((errors["points"], errors["rmse_mm"]))
    rmse = {k: np.sqrt(sum(n * e ** 2 for n, e in v) / sum(n for n, _ in v)) for k,
            v in per_order.items()}
    assert rmse[2] <= 1.5 * rmse[1], rmse


def test_only_the_views_through_several_mirrors_are_fitted(scanned):
    """prepare_frame smooths the direct view and the views through one mirror as before
    (smooth_depth, bit for bit) and fits the others by local quadratic surfaces."""
    session = load_session(scanned[2])
    rig, depth = Rig.from_session(session), session.read_frame(1)
    prepared, mask = prepare_frame(rig, depth, session.read_background(), session.selection)
    averaged = smooth_depth(depth, mask)
    cloud = reconstruct_raw(rig, averaged, mask)
    several = np.zeros(mask.shape, bool)
    several.reshape(-1)[cloud.pixel_index[source_orders(cloud.sources) >= 2]] = True
    np.testing.assert_array_equal(prepared[~several], averaged[~several])
    assert np.mean(prepared[several] != averaged[several]) > 0.95
