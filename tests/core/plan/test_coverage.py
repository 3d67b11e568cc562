"""Coverage of analytic cases: a sphere seen directly and through one mirror (closed form), a
mirror that hides nothing, a mirror in the way, and a subject hiding itself."""
import numpy as np
import pytest
import trimesh

from mirrorcore.plan.coverage import CoverageModel, glass_from, view_sequences
from mirrorcore.plan.setup import plan_camera
from mirrorcore.plan.subject import make_subject, sample_surface

NO_GLASS = glass_from(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 3)), [], [])
CAMERA = plan_camera("kinect_v1")


def visible_share(d: float, r: float, incidence_deg: float = 70.0) -> float:
    """The share of a sphere's area (radius r, centre d from a pinhole) whose points face the
    pinhole within the incidence limit: the cap cos(phi) >= c0, (1 - c0) / 2."""
    k = np.cos(np.radians(incidence_deg)) ** 2
    # (d c - r)^2 = k (d^2 + r^2 - 2 d r c), the larger root
    roots = np.roots([d * d, -2 * d * r + 2 * k * d * r, r * r - k * (d * d + r * r)])
    return (1 - max(roots.real)) / 2


@pytest.fixture(scope="module")
def sphere_model():
    # floor 0.5 m below the camera: the 0.6 m sphere's centre stays level with the camera
    subject = make_subject("sphere:0.3", 2.0, 0.5)
    return CoverageModel(subject, sample_surface(subject, 20000), CAMERA, 1)


def _side_mirror(subject_centre, size=1.5):
    """A mirror at the side and behind a subject, facing half-way between it and the camera."""
    c = np.array([0.9, 0.0, 2.8])
    n = -c / np.linalg.norm(c) + (subject_centre - c) / np.linalg.norm(subject_centre - c)
    return glass_from([c], [n], [[0.0, -1.0, 0.0]], [size], [size]), c, n / np.linalg.norm(n)


def test_sphere_seen_directly_closed_form(sphere_model):
    assert sphere_model.subject.centre.tolist() == [0.0, 0.0, 2.0]
    cov = sphere_model.evaluate(NO_GLASS)
    assert cov.coverage == pytest.approx(visible_share(2.0, 0.3), abs=0.01)
    assert cov.coverage_2 == 0.0
    # axial noise 1.425e-3 Z^2 at Z of 1.7 to 2.0 m
    assert 4.0 < cov.noise_mm()[0] < 5.7


def test_closed_form_differs_with_the_incidence_limit():
    # without the limit the cap is the whole facing part, 1 - r/d of the hemisphere's reach
    assert visible_share(2.0, 0.3, 90.0) == pytest.approx((1 - 0.3 / 2.0) / 2)
    assert visible_share(2.0, 0.3) < visible_share(2.0, 0.3, 90.0) - 0.02


def test_mirror_view_is_the_virtual_camera_closed_form_and_hides_nothing(sphere_model):
    centre = sphere_model.subject.centre
    glass, c, n = _side_mirror(centre)
    cov = sphere_model.evaluate(glass)
    direct = sphere_model.evaluate(NO_GLASS)
    assert np.array_equal(cov.seen[0], direct.seen[0])
    virtual_camera = -2 * ((-c) @ n) * n
    d = np.linalg.norm(virtual_camera - centre)
    assert cov.per_view[1] == pytest.approx(visible_share(d, 0.3), abs=0.01)
    both = cov.seen.all(axis=0)
    assert cov.coverage_2 == pytest.approx(cov.weight[both].sum())
    assert cov.coverage == pytest.approx(cov.per_view.sum() - cov.coverage_2)
    # seen through the mirror: farther, noisier
    assert cov.noise_mm()[1] > 2 * cov.noise_mm()[0]


def test_small_mirror_shows_less_and_its_outline_bounds_the_view(sphere_model):
    glass, *_ = _side_mirror(sphere_model.subject.centre, size=0.2)
    cov = sphere_model.evaluate(glass)
    assert 0 < cov.per_view[1] < 0.5 * visible_share(3.0, 0.3)


def test_mirror_in_the_way_hides_the_direct_view(sphere_model):
    # a mirror between the camera and the sphere, its back to it
    glass = glass_from([[0.0, 0.0, 1.0]], [[0.0, 0.0, -1.0]], [[0.0, -1.0, 0.0]], [1.0], [1.0])
    cov = sphere_model.evaluate(glass)
    assert cov.per_view[0] == 0.0


def test_subject_hides_itself(tmp_path):
    # two equal spheres on the optical axis: the far one is wholly behind the near one
    near = trimesh.creation.icosphere(4, 0.3)
    far = trimesh.creation.icosphere(4, 0.3).apply_translation([0.0, 0.0, 1.0])
    path = tmp_path / "two.ply"
    trimesh.util.concatenate([near, far]).export(path)
    subject = make_subject(f"mesh:{path}", 2.5, 0.3)
    model = CoverageModel(subject, sample_surface(subject, 20000), CAMERA, 1)
    cov = model.evaluate(NO_GLASS)
    near_centre = np.array([0.0, 0.0, 2.0])
    assert np.allclose(subject.mesh.vertices.min(axis=0), [-0.3, -0.3, 1.7], atol=0.01)
    assert cov.coverage == pytest.approx(visible_share(2.0, 0.3) / 2, abs=0.01)
    far_side = model.samples.points[:, 2] > near_centre[2] + 0.5
    assert not cov.seen[0, far_side].any()


def test_views_up_to_the_bounces():
    assert view_sequences(2, 1) == ((), (0,), (1,))
    assert view_sequences(3, 2) == ((), (0,), (1,), (2,), (0, 1), (0, 2), (1, 0), (1, 2),
                                    (2, 0), (2, 1))
