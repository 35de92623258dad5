"""Integration fixtures: dummy AWS settings everywhere, and one DynamoDB Local per session.

Without Java or the DynamoDB Local JAR the tests that need it are skipped, except on CI
(``CI=true``), where a missing DynamoDB Local fails them: CI must never skip them silently.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.integration.dynamodb_local import REGION, DynamoDbLocal, Unavailable


@pytest.fixture(autouse=True)
def aws_dummy_settings(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """No integration test can reach real AWS: dummy keys, a fixed region, no profiles."""
    monkeypatch.setenv("AWS_ACCESS_KEY_ID", "dummy")
    monkeypatch.setenv("AWS_SECRET_ACCESS_KEY", "dummy")
    monkeypatch.setenv("AWS_DEFAULT_REGION", REGION)
    monkeypatch.setenv("AWS_REGION", REGION)
    monkeypatch.setenv("AWS_CONFIG_FILE", str(tmp_path / "no-aws-config"))
    monkeypatch.setenv("AWS_SHARED_CREDENTIALS_FILE", str(tmp_path / "no-aws-credentials"))
    monkeypatch.setenv("AWS_EC2_METADATA_DISABLED", "true")
    for variable in ("AWS_PROFILE", "AWS_SESSION_TOKEN", "AWS_SECURITY_TOKEN", "AWS_ENDPOINT_URL",
                     "AWS_ENDPOINT_URL_DYNAMODB"):
        monkeypatch.delenv(variable, raising=False)


@pytest.fixture(scope="session")
def dynamodb_local() -> Iterator[DynamoDbLocal]:
    """A running in-memory DynamoDB Local, shared by the session; stopped at its end."""
    try:
        server = DynamoDbLocal()
    except Unavailable as error:
        message = f"DynamoDB Local is not available: {error}"
        if os.environ.get("CI") == "true":
            pytest.fail(message + " (CI=true: these tests must run on CI)", pytrace=False)
        pytest.skip(message)
    with server:
        yield server
