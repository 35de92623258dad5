"""A board's export and import: the lines of an export file and the receipts of an import."""

from datetime import datetime
from typing import Annotated, Any, Literal

from drboard_assembler.record import Record
from pydantic import Field, PrivateAttr, SerializerFunctionWrapHandler, model_serializer
from pydantic_core import from_json

from .domain import Board, Entry, Model, Submission


class ExportedBoard(Model):
    kind: Literal["board"] = "board"
    format: Literal["drboard-export/1"] = "drboard-export/1"
    exported_at: datetime
    board: Board


class ExportedEntry(Model):
    kind: Literal["entry"] = "entry"
    entry: Entry


class ExportedSubmission(Model):
    kind: Literal["submission"] = "submission"
    submission: Submission
    record: Record


class StoredSubmissionLine(ExportedSubmission):
    """A submission line as an export reads it from the board's own store: the record stays the
    JSON it was stored as (validated when it was pushed) and is written out as it is. It is
    parsed only when ``record`` is read, so exporting a big board validates no record."""

    _record_json: str | bytes = PrivateAttr(default="")

    @classmethod
    def of(cls, submission: Submission, record_json: str | bytes) -> "StoredSubmissionLine":
        fields: dict[str, Any] = {"submission": submission}  # no record: see __getattr__
        line = cls.model_construct(**fields)
        line._record_json = record_json
        return line

    def __getattr__(self, name: str) -> Any:
        if name == "record" and "record" not in self.__dict__:
            record = Record.model_validate_json(self._record_json, context={"draft": True})
            self.__dict__["record"] = record
            return record
        return super().__getattr__(name)  # type: ignore[misc]

    @model_serializer(mode="wrap")
    def _as_stored(self, handler: SerializerFunctionWrapHandler) -> Any:
        if "record" in self.__dict__:
            return handler(self)
        return {"kind": self.kind, "submission": self.submission.model_dump(mode="json"),
                "record": from_json(self._record_json)}


ExportLine = Annotated[ExportedBoard | ExportedEntry | ExportedSubmission, Field(discriminator="kind")]


class ExportPage(Model):
    """One page of a board's export: the board first, then its entries, then every submission."""

    lines: list[ExportLine]
    next_cursor: str | None = None


class ImportReceipt(Model):
    status: Literal["created", "duplicate"]
    board_id: str
    submission_id: str
