import json

from drboard_assembler import schema


def test_committed_record_schema_matches_the_model():
    assert schema.committed() == schema.render(), (
        "the Record changed: run `python -m drboard_assembler.schema` and commit the schema"
    )


def test_schema_describes_the_record_fields_racers_rely_on():
    document = json.loads(schema.committed())
    assert {"track", "racer", "model_name", "evaluations", "design", "submission_id"} <= set(
        document["required"]
    )
    assert document["additionalProperties"] is False
