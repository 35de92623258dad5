"""The Record's JSON Schema, committed beside the package data; a test fails when it drifts.

Regenerate after changing the Record: ``python -m drboard_assembler.schema``.
"""

from __future__ import annotations

import json
from pathlib import Path

from .record import record_json_schema

SCHEMA_FILE = "data/record.schema.json"


def render() -> str:
    return json.dumps(record_json_schema(), indent=2, sort_keys=True) + "\n"


def main() -> None:
    target = Path(__file__).parent / SCHEMA_FILE
    target.write_text(render(), "utf-8")
    print(f"wrote {target}")


if __name__ == "__main__":
    main()
