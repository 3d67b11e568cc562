"""Installing mirrorscan adds two top-level packages of its own, `mirrorcore` and `mirrorscan`, and
no generic name (`app`, `bench`) to site-packages."""
from __future__ import annotations

import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FOLDERS = {"mirrorcore": "mirrorcore", "app": "mirrorscan", "bench": "mirrorscan.bench"}


def installed_name(init: Path) -> str:
    """The package name a folder with an __init__.py installs as: app/panels ->
    mirrorscan.panels."""
    parts = init.parent.relative_to(ROOT).parts
    return ".".join([FOLDERS[parts[0]], *parts[1:]])


def test_every_package_folder_is_installed_under_the_project_names():
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    folders = {
        installed_name(init) for top in FOLDERS for init in (ROOT / top).rglob("__init__.py")
    }
    assert set(config["packages"]) == folders
    assert {name.split(".")[0] for name in config["packages"]} == {"mirrorcore", "mirrorscan"}
    assert config["package-dir"] == {"mirrorscan": "app", "mirrorscan.bench": "bench"}


def test_the_installed_packages_are_the_repository_folders():
    import mirrorcore
    import mirrorscan
    import mirrorscan.bench

    assert Path(mirrorscan.__file__).parent == ROOT / "app"
    assert Path(mirrorscan.bench.__file__).parent == ROOT / "bench"
    assert Path(mirrorcore.__file__).parent == ROOT / "mirrorcore"
