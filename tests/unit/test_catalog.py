"""The track catalog: the names racers type, ambiguous and unknown names, custom tracks."""

from __future__ import annotations

import csv
import shutil
from pathlib import Path

import pytest
from drboard_assembler import (
    AssemblyError,
    Overrides,
    Record,
    UnknownTrackError,
    assemble,
    default_catalog,
)

EXAMPLES = Path(__file__).parents[2] / "examples"


@pytest.mark.parametrize("name", [
    "reInvent2019", "reinvent2019_track", "reInvent2019_track", "Smile Speedway",
    "smile speedway", "  reInvent2019_track  ",
])
def test_aliases_resolve_to_the_world_name(name: str) -> None:
    resolved = default_catalog().resolve(name)
    assert resolved.track_id == "reInvent2019_track"
    assert resolved.direction is None
    assert resolved.track is not None
    assert resolved.track.length_m == 23.12
    assert resolved.display_name == "Smile Speedway"


@pytest.mark.parametrize(("name", "direction"), [
    ("reInvent2019_track_cw", "cw"),
    ("reInvent2019_track_ccw", "ccw"),
    ("reInvent2019_track_CW", "cw"),
])
def test_direction_suffix(name: str, direction: str) -> None:
    resolved = default_catalog().resolve(name)
    assert (resolved.track_id, resolved.direction) == ("reInvent2019_track", direction)


def test_wide_variant_is_a_different_track() -> None:
    assert default_catalog().resolve("reInvent2019_wide").track_id == "reInvent2019_wide"
    assert default_catalog().resolve("A to Z Speedway").track_id == "reInvent2019_wide"


def test_ambiguous_name_lists_the_candidates() -> None:
    with pytest.raises(UnknownTrackError) as caught:
        default_catalog().resolve("penbay")
    error = caught.value
    assert error.ambiguous
    assert error.candidates == ["penbay_open", "penbay_pro"]
    assert str(error) == "track 'penbay' is ambiguous: it could be penbay_open, penbay_pro"


def test_unknown_name_lists_the_closest_matches() -> None:
    with pytest.raises(UnknownTrackError) as caught:
        default_catalog().resolve("reInvent2091")
    error = caught.value
    assert not error.ambiguous
    assert error.candidates[0] == "reInvent2019_track (Smile Speedway)"
    assert 1 <= len(error.candidates) <= 5
    assert "closest matches" in str(error)


def test_nonsense_has_no_matches() -> None:
    with pytest.raises(UnknownTrackError) as caught:
        default_catalog().resolve("zzzzqqqq")
    assert caught.value.candidates == []
    assert str(caught.value) == "unknown track 'zzzzqqqq'"


def test_custom_track_is_taken_exactly() -> None:
    resolved = default_catalog().resolve_custom("club_garage_2025")
    assert (resolved.track_id, resolved.direction, resolved.track) == (
        "club_garage_2025", None, None)
    assert resolved.display_name == "club_garage_2025"


def test_custom_resolution_still_prefers_an_official_track() -> None:
    assert default_catalog().resolve_custom("reInvent2019").track_id == "reInvent2019_track"
    with pytest.raises(UnknownTrackError):
        default_catalog().resolve_custom("penbay")


@pytest.mark.parametrize("name", ["has space", "../etc", "", "x" * 65, "-leading-dash"])
def test_custom_track_names_must_be_plain(name: str) -> None:
    with pytest.raises(UnknownTrackError):
        default_catalog().resolve_custom(name)


def test_custom_track_needs_the_flag_and_then_gets_its_own_board(tmp_path: Path) -> None:
    run = EXAMPLES / "speedy-ppo-console"
    with pytest.raises(AssemblyError, match="--custom-track"):
        assemble(run, Overrides(track="club_garage_2025"))

    custom = tmp_path / "speedy-ppo-console"
    shutil.copytree(run, custom)
    params = next(custom.glob("eval_params_*.yaml"))
    params.write_text(params.read_text().replace('"reInvent2019_track"', '"club_garage_2025"'))
    record = assemble(custom, Overrides(track="club_garage_2025", custom_track=True))
    assert record.track == "club_garage_2025"
    assert record.custom_track
    assert Record.model_validate_json(record.model_dump_json()) == record


def test_official_track_cannot_be_claimed_as_custom() -> None:
    record = assemble(EXAMPLES / "speedy-ppo-console")
    data = record.model_dump(mode="json")
    data["custom_track"] = True
    with pytest.raises(ValueError, match="official track"):
        Record.model_validate(data)


def test_catalog_matches_the_official_track_list(fixtures_dir: Path) -> None:
    catalog = default_catalog()
    with (fixtures_dir / "tracks.csv").open(encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    assert rows
    for row in rows:
        track = catalog.get(row["world_name"])
        assert track is not None, row["world_name"]
        assert track.display_name == row["display_name"]
        assert track.length_m == float(row["length_m"])
        assert catalog.resolve(row["world_name"]).track_id == row["world_name"]
