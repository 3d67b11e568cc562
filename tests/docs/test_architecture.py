"""The import graph in docs/architecture.md is current, and the packages import only downwards."""
from __future__ import annotations

from tests.docs.scripts import load

arch = load("architecture")


def test_import_graph_in_architecture_page_is_current():
    page = arch.PAGE.read_text()
    assert page == arch.render(page), ("the import graph in docs/architecture.md is stale: "
                                       "run `.venv/bin/python scripts/architecture.py`")


def test_packages_import_only_their_floor_and_below():
    assert arch.upward(arch.graph()) == []


def test_import_graph_has_no_circle():
    assert arch.circles(arch.graph()) == []


def test_no_two_modules_import_each_other():
    """Within a package too: no module imports, through others, the module that imports it."""
    assert arch.circles(arch.module_graph()) == []


def test_every_module_belongs_to_a_node():
    for folder in arch.FOLDERS:
        for path in (arch.ROOT / folder).rglob("*.py"):
            name = arch.module_name(path)
            assert name == "mirrorcore" or arch.node(name) in arch.FLOORS, path


def test_checks_find_a_circle_and_an_upward_import():
    edges = {"base": {"geometry"}, "geometry": {"depth"}, "depth": {"geometry"}}
    assert arch.upward(edges) == ["base -> geometry", "geometry -> depth"]
    assert arch.circles(edges) == [["geometry", "depth", "geometry"]]
    assert arch.circles({"rig": {"io"}, "io": {"base"}, "base": set()}) == []


def test_reduction_keeps_only_arrows_no_path_implies():
    edges = {"rig": {"io", "base"}, "io": {"base"}, "base": set()}
    assert arch.reduced(edges) == {"rig": {"io"}, "io": {"base"}, "base": set()}


def test_module_names_follow_the_installed_packages():
    assert arch.module_name(arch.ROOT / "app" / "panels" / "live.py") == "mirrorscan.panels.live"
    assert arch.module_name(arch.ROOT / "bench" / "__init__.py") == "mirrorscan.bench"
    assert arch.node("mirrorscan.bench.soak") == "bench"
    assert arch.node("mirrorcore.calibration.refine") == "calibration"
