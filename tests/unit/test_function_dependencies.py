"""The functions ship exactly what functions/requirements.lock pins, and the lock keeps to the
ranges functions/requirements.txt (the one list of their dependencies) allows."""

from __future__ import annotations

from pathlib import Path

from packaging.requirements import Requirement
from packaging.utils import canonicalize_name

FUNCTIONS = Path(__file__).parents[2] / "functions"


def requirement_lines(path: Path) -> list[str]:
    lines = (line.split("#", 1)[0].strip() for line in path.read_text().splitlines())
    return [line for line in lines if line]


def locked_versions() -> dict[str, str]:
    pins = {}
    for line in requirement_lines(FUNCTIONS / "requirements.lock"):
        name, separator, version = line.partition("==")
        assert separator and version, f"requirements.lock: {line!r} is not pinned to one version"
        pins[canonicalize_name(name)] = version
    return pins


#: What the Lambda Python runtime brings: declared, since the functions import them, not locked.
RUNTIME_PROVIDED = {"boto3", "botocore", "s3transfer", "urllib3"}


def test_every_requirement_of_the_functions_is_locked_within_its_range() -> None:
    pins = locked_versions()
    for line in requirement_lines(FUNCTIONS / "requirements.txt"):
        requirement = Requirement(line)
        if canonicalize_name(requirement.name) in RUNTIME_PROVIDED:
            continue
        version = pins.get(canonicalize_name(requirement.name))
        assert version is not None, f"{requirement.name} is not in requirements.lock (run make lock)"
        assert requirement.specifier.contains(version), (
            f"requirements.lock pins {requirement.name}=={version}, outside {requirement.specifier}")


def test_the_lock_leaves_out_what_the_lambda_runtime_brings() -> None:
    assert not RUNTIME_PROVIDED & set(locked_versions())


def test_the_card_functions_renderer_is_locked_within_its_range() -> None:
    pins = {}
    for line in requirement_lines(FUNCTIONS / "card-requirements.lock"):
        name, separator, version = line.partition("==")
        assert separator and version, f"card-requirements.lock: {line!r} is not pinned to one version"
        pins[canonicalize_name(name)] = version
    for line in requirement_lines(FUNCTIONS / "card-requirements.txt"):
        requirement = Requirement(line)
        version = pins.get(canonicalize_name(requirement.name))
        assert version is not None, f"{requirement.name} is not in card-requirements.lock (run make lock)"
        assert requirement.specifier.contains(version)
    assert not set(pins) & set(locked_versions()), "the card lock adds only what the functions lack"
