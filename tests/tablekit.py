"""Create the board table from its one definition: the ``BoardTable`` resource of template.yaml.

Tests (moto, DynamoDB Local) and the benchmark build their tables here, so the table they run on
has exactly the keys and indexes the stack deploys.
"""

from __future__ import annotations

import copy
from functools import cache
from pathlib import Path
from typing import Any

from samtranslator.yaml_helper import yaml_parse

TEMPLATE = Path(__file__).parents[1] / "template.yaml"
RESOURCE = "BoardTable"
# What create_table takes from the resource; the rest (PITR, SSE, policies) is deployment only.
TABLE_PROPERTIES = ("AttributeDefinitions", "KeySchema", "LocalSecondaryIndexes",
                    "GlobalSecondaryIndexes", "BillingMode")


def table_definition(template: Path = TEMPLATE) -> dict[str, Any]:
    """The BoardTable resource's create_table arguments (without TableName)."""
    return copy.deepcopy(_table_definition(template))


@cache
def _table_definition(template: Path) -> dict[str, Any]:
    resource = yaml_parse(template.read_text())["Resources"][RESOURCE]
    assert resource["Type"] == "AWS::DynamoDB::Table", resource["Type"]
    properties = resource["Properties"]
    return {name: properties[name] for name in TABLE_PROPERTIES if name in properties}


def create_board_table(client: Any, name: str, *, stream: bool = False) -> str:
    """Create the table ``name`` shaped like BoardTable with a boto3 DynamoDB client; wait for it.
    ``stream``: with the resource's stream of changes too (what the NotifyFunction reads)."""
    extra = {}
    if stream:
        spec = yaml_parse(TEMPLATE.read_text())["Resources"][RESOURCE]["Properties"]["StreamSpecification"]
        extra = {"StreamSpecification": {"StreamEnabled": True, **spec}}
    client.create_table(TableName=name, **table_definition(), **extra)
    client.get_waiter("table_exists").wait(TableName=name, WaiterConfig={"Delay": 0.05, "MaxAttempts": 200})
    return name
