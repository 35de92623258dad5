"""Unit-test fixtures: moto's fake AWS (see tests/awskit.py)."""

from tests.awskit import aws

__all__ = ["aws"]
