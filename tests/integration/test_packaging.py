"""A non-editable install must put only the drboard_* packages into site-packages."""

import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def wheel(tmp_path_factory: pytest.TempPathFactory) -> zipfile.ZipFile:
    out = tmp_path_factory.mktemp("wheel")
    # Build from a copy without local build products, as from a clean checkout.
    source = tmp_path_factory.mktemp("checkout") / "drboard"
    shutil.copytree(ROOT, source, ignore=shutil.ignore_patterns(
        ".git", ".venv", "node_modules", "build", ".aws-sam", "*.egg-info", "__pycache__"))
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q",
         "-w", str(out), str(source)],
        check=True, cwd=out,
    )
    (path,) = out.glob("drboard-*.whl")
    return zipfile.ZipFile(path)


def test_only_drboard_packages_are_installed(wheel: zipfile.ZipFile) -> None:
    top_level = {name.split("/")[0] for name in wheel.namelist()}
    packages = {name for name in top_level if not name.endswith(".dist-info")}
    assert packages == {"drboard_assembler", "drboard_functions", "drboard_cli"}


def test_the_track_catalog_and_record_schema_ship_with_the_package(wheel: zipfile.ZipFile) -> None:
    names = set(wheel.namelist())
    assert "drboard_assembler/data/tracks.csv" in names
    assert "drboard_assembler/data/record.schema.json" in names


def test_every_module_of_the_three_packages_ships(wheel: zipfile.ZipFile) -> None:
    sources = {"drboard_assembler": ROOT / "assembler", "drboard_functions": ROOT / "functions",
               "drboard_cli": ROOT / "cli"}
    modules = {path.relative_to(folder).as_posix() for folder in sources.values()
               for path in folder.glob("drboard_*/**/*.py")}
    assert modules - set(wheel.namelist()) == set()


def test_the_drboard_command_is_installed(wheel: zipfile.ZipFile) -> None:
    (entry_points,) = [n for n in wheel.namelist() if n.endswith("entry_points.txt")]
    assert "drboard = drboard_cli.main:cli" in wheel.read(entry_points).decode()


def test_the_card_fonts_their_licence_widths_and_templates_ship(wheel: zipfile.ZipFile) -> None:
    names = set(wheel.namelist())
    fonts = "drboard_functions/cards/fonts/"
    assert {fonts + "LiberationSans-Regular.ttf", fonts + "LiberationSans-Bold.ttf",
            fonts + "LICENSE", fonts + "widths.json"} <= names, "the font ships with its licence"
    assert {"drboard_functions/templates/cards/racer.svg", "drboard_functions/templates/cards/podium.svg",
            "drboard_functions/templates/podium.html"} <= names
