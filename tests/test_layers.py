"""mirrorcore is built in floors (docs/DESIGN.md, 'Layout of the code'): a package imports only from
its own floor or those below, and the library never imports the app."""
from __future__ import annotations

from pathlib import Path

import pytest

from tests.docs.scripts import load

ROOT = Path(__file__).resolve().parents[1] / "mirrorcore"
# the imports a module makes when it runs, as the architecture page draws them
ARCHITECTURE = load("architecture")
FLOORS = {
    "base": 0, "geometry": 1, "depth": 2, "io": 3, "rig": 4, "sim": 5,
    "calibration": 6, "plan": 6, "dense": 7, "sources": 8, "batch": 9,
}
# the simulator renders; fits measure
NOT_IN_SIM = ("mirrorcore.geometry.shapes", "mirrorcore.geometry.fitting")


def unit(module: str) -> str:
    """The package a module belongs to: 'mirrorcore.dense.tsdf' -> 'dense'; 'mirrorcore' -> ''."""
    return module.split(".")[1] if module.count(".") else ""


def floor_of(module: str) -> int:
    name = unit(module)
    assert name in FLOORS, f"{module} is in no floor: add its package to docs/DESIGN.md and FLOORS"
    return FLOORS[name]


def module_name(path: Path) -> str:
    return ".".join(path.relative_to(ROOT.parent).with_suffix("").parts).removesuffix(".__init__")


@pytest.mark.parametrize("path", sorted(ROOT.rglob("*.py")), ids=lambda p: str(p.relative_to(ROOT)))
def test_each_module_imports_only_its_floor_and_below(path):
    module = module_name(path)
    own = floor_of(module) if unit(module) else float("inf")
    for imported in ARCHITECTURE.imports(path):
        assert not imported.startswith("mirrorscan"), (
            f"{module} imports {imported}: the library never imports the app"
        )
        if imported == "mirrorcore" or unit(imported) == unit(module):
            continue
        assert floor_of(imported) <= own, (
            f"{module} (floor {own}) imports {imported} (floor {floor_of(imported)})"
        )
        assert not (unit(module) == "sim" and imported in NOT_IN_SIM), (
            f"{module} imports {imported}"
        )


def test_every_module_sits_in_a_package_of_a_floor():
    """No flat module beside the floors' packages: a new module goes into the package of its
    domain."""
    flat = [p.name for p in ROOT.glob("*.py") if p.name != "__init__.py"]
    assert flat == []
    assert {p.parent.name for p in ROOT.glob("*/__init__.py")} == set(FLOORS)


def test_the_floors_refuse_an_upward_import():
    """The check itself: the calibration or the dense methods inside the simulator, or a depth
    module reaching into the simulator's sensor, would be refused."""
    for above in ("mirrorcore.calibration.refine", "mirrorcore.dense.tsdf"):
        assert floor_of(above) > floor_of("mirrorcore.sim.render")
    assert floor_of("mirrorcore.depth.kinect") < floor_of("mirrorcore.sim.sensor")
    assert floor_of("mirrorcore.rig.pipeline") < floor_of("mirrorcore.calibration.refine")
