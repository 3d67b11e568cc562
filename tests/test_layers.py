"""mirrorcore is built in floors (docs/DESIGN.md, 'Layout of the code'): a module imports only from its own floor or
those below; the simulator stands between the rig and the calibration (it uses floors 0 to 4 only, and only the
sources use it); app/ is never imported by the library."""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1] / "mirrorcore"
FLOORS = {
    "errors": 0, "atomic": 0, "jsonfile": 0, "palette": 0, "budget": 0, "progress": 0, "words": 0,
    "geometry": 1,
    "noise": 2, "kinect": 2, "depthops": 2, "depthio": 2, "selection": 2, "temporal": 2,
    "session": 3, "ply": 3, "outputs": 3,
    "rig": 4, "paths": 4, "cloud": 4, "reconstruct": 4,
    "shapes": 1.5, "fitting": 1.5,
    "calibration": 5, "markers": 5, "readings": 5, "agreement": 5, "spheretarget": 5, "refine": 5, "search": 5,
    "pipeline": 6,
    "dense": 7,
    "sources": 9,
    "batch": 10,
    "sim": 4.5,
}
NOT_IN_SIM = ("shapes", "fitting")   # below the simulator since the calibration's sphere target uses them, still not
                                     # for it: the simulator renders, the experiments measure


def unit(module: str) -> str:
    """'mirrorcore.dense.tsdf' -> 'dense' (the top-level module or package that the floors table names)."""
    return module.split(".")[1] if module.count(".") else ""


def imported_modules(path: Path) -> set[str]:
    """The absolute mirrorcore modules (and 'app...' imports) a source file imports, relative imports resolved."""
    package = ".".join(path.relative_to(ROOT.parent).with_suffix("").parts[:-1])
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                found.add(".".join(base + ([node.module] if node.module else [])))
            elif node.module:
                found.add(node.module)
        elif isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
    return {m for m in found if m.split(".")[0] in ("mirrorcore", "app")}


def floor_of(module: str) -> float:
    name = unit(module)
    assert name in FLOORS, f"{module} is in no floor: add it to docs/DESIGN.md and FLOORS"
    return FLOORS[name]


@pytest.mark.parametrize("path", sorted(ROOT.rglob("*.py")), ids=lambda p: str(p.relative_to(ROOT)))
def test_each_module_imports_only_its_floor_and_below(path):
    module = ".".join(path.relative_to(ROOT.parent).with_suffix("").parts).removesuffix(".__init__")
    own = floor_of(module) if unit(module) else float("inf")
    for imported in imported_modules(path):
        assert not imported.startswith("app"), f"{module} imports {imported}: the library never imports the app"
        if imported == "mirrorcore" or unit(imported) == unit(module):
            continue
        assert floor_of(imported) <= own, (f"{module} (floor {own}) imports {imported} "
                                               f"(floor {floor_of(imported)})")
        assert not (unit(module) == "sim" and unit(imported) in NOT_IN_SIM), f"{module} imports {imported}"


def test_the_floors_refuse_what_the_issue_found():
    """The check itself: the experiments (calibration, dense, fitting) inside the simulator, or a driver reaching into
    the simulator's sensor, would be refused."""
    for above in ("mirrorcore.calibration", "mirrorcore.dense.tsdf", "mirrorcore.pipeline"):
        assert floor_of(above) > floor_of("mirrorcore.sim.render")
    assert unit("mirrorcore.fitting") in NOT_IN_SIM
    assert floor_of("mirrorcore.kinect") < floor_of("mirrorcore.sim.sensor")
