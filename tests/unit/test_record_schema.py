import json
from importlib import resources

from drboard_assembler import schema


def committed() -> str:
    """The schema as committed beside the package data (and installed with it)."""
    return resources.files("drboard_assembler").joinpath(schema.SCHEMA_FILE).read_text("utf-8")


def test_committed_record_schema_matches_the_model():
    assert committed() == schema.render(), (
        "the Record changed: run `python -m drboard_assembler.schema` and commit the schema"
    )


def test_schema_describes_the_record_fields_racers_rely_on():
    document = json.loads(committed())
    assert {"track", "racer", "model_name", "evaluations", "design", "submission_id"} <= set(
        document["required"]
    )
    assert document["additionalProperties"] is False
