"""End-to-end fixtures: the integration suite's dummy AWS settings and DynamoDB Local."""

from tests.integration.conftest import aws_dummy_settings, dynamodb_local

__all__ = ["aws_dummy_settings", "dynamodb_local"]
