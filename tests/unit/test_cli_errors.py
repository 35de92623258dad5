"""Every error the service raises on purpose reaches the racer as one line and an exit code."""

from __future__ import annotations

import inspect
import typing
from collections.abc import Iterator

import pytest
from drboard_assembler import AssemblyError
from drboard_cli.main import BAD_INPUT, BAD_INPUT_ERRORS, FAILURE, FAILURE_ERRORS, edge
from drboard_cli.transfer import BadExportFile
from drboard_functions import errors as domain


def _subclasses(kind: type[domain.DomainError]) -> Iterator[type[domain.DomainError]]:
    for subclass in kind.__subclasses__():
        yield subclass
        yield from _subclasses(subclass)


DOMAIN_ERRORS = sorted(set(_subclasses(domain.DomainError)), key=lambda kind: kind.__name__)
MESSAGE = "the board said [no]\n  twice"


def _decided_by(kind: type[domain.DomainError]) -> str | None:
    """The class whose listing gives ``kind`` its exit code: itself or its nearest listed base."""
    return next((base.__name__ for base in kind.__mro__
                 if base.__name__ in BAD_INPUT_ERRORS | FAILURE_ERRORS), None)


def _instance(kind: type[domain.DomainError]) -> domain.DomainError:
    """``kind`` built with MESSAGE and a plain value for any other argument it requires."""
    hints = typing.get_type_hints(kind.__init__)
    required = [p for p in list(inspect.signature(kind.__init__).parameters.values())[2:]
                if p.default is inspect.Parameter.empty]
    plain = {int: 30, str: "x", float: 1.5}
    return kind(MESSAGE, **{p.name: plain[hints[p.name]] for p in required})


def _answer(error: Exception, capsys: pytest.CaptureFixture[str]) -> tuple[int, list[str]]:
    with pytest.raises(SystemExit) as exited, edge():
        raise error
    assert isinstance(exited.value.code, int)
    return exited.value.code, capsys.readouterr().err.splitlines()


def test_every_domain_error_is_given_an_exit_code() -> None:
    """A new error class must be listed in main.py as bad input or as a failure (or subclass
    one that is); until then the CLI calls it a failure, and this test names it."""
    defined = {kind for kind in vars(domain).values()
               if isinstance(kind, type) and issubclass(kind, domain.DomainError)} - {domain.DomainError}
    assert defined <= set(DOMAIN_ERRORS), "the walk finds subclasses of subclasses too"
    unmapped = [kind.__name__ for kind in DOMAIN_ERRORS if _decided_by(kind) is None]
    assert not unmapped, f"list in BAD_INPUT_ERRORS or FAILURE_ERRORS of drboard_cli/main.py: {unmapped}"


def test_the_listed_names_are_domain_errors_listed_once() -> None:
    names = {kind.__name__ for kind in DOMAIN_ERRORS}
    assert names.issuperset(BAD_INPUT_ERRORS | FAILURE_ERRORS)
    assert not BAD_INPUT_ERRORS & FAILURE_ERRORS


@pytest.mark.parametrize("kind", DOMAIN_ERRORS, ids=lambda kind: kind.__name__)
def test_each_domain_error_is_one_line_and_its_exit_code(kind: type[domain.DomainError],
                                                         capsys: pytest.CaptureFixture[str]) -> None:
    code, lines = _answer(_instance(kind), capsys)
    expected = BAD_INPUT if _decided_by(kind) in BAD_INPUT_ERRORS else FAILURE
    assert code == expected
    assert lines == ["error: the board said [no] twice"], "one line, the markup-like text kept as is"


@pytest.mark.parametrize(("kind", "code"), [
    (domain.InvalidSubmission, BAD_INPUT), (domain.BoardExists, BAD_INPUT), (domain.BoardLocked, BAD_INPUT),
    (domain.InvalidQuery, BAD_INPUT), (domain.BoardNotFound, FAILURE), (domain.TooSoon, FAILURE),
    (domain.BoardClosed, FAILURE), (domain.NotSignedIn, FAILURE), (domain.BoardUnreachable, FAILURE),
], ids=lambda value: getattr(value, "__name__", str(value)))
def test_bad_input_is_2_and_failures_are_1_as_the_readme_says(
        kind: type[domain.DomainError], code: int, capsys: pytest.CaptureFixture[str]) -> None:
    assert _answer(_instance(kind), capsys)[0] == code


def test_an_error_class_added_later_is_a_failure_with_its_message(capsys: pytest.CaptureFixture[str]) -> None:
    class CalendarClash(domain.DomainError):
        """An error class no list names yet."""

    assert _decided_by(CalendarClash) is None  # the first test above would name it
    assert _answer(CalendarClash("the race clashes with another: pick a new time"), capsys) == (
        FAILURE, ["error: the race clashes with another: pick a new time"])


def test_files_that_do_not_read_are_bad_input(capsys: pytest.CaptureFixture[str]) -> None:
    assembly = AssemblyError("model_metadata.json", "action_space", "is not a list", flag="--model")
    assert _answer(assembly, capsys) == (
        BAD_INPUT, ["error: model_metadata.json: action_space: is not a list (use --model)"])
    export = BadExportFile("board.jsonl:3: record.track: field required")
    assert _answer(export, capsys) == (BAD_INPUT, ["error: board.jsonl:3: record.track: field required"])


def test_an_os_error_names_the_file(capsys: pytest.CaptureFixture[str]) -> None:
    error = PermissionError(13, "Permission denied", "/boards/club.db")
    assert _answer(error, capsys) == (FAILURE, ["error: /boards/club.db Permission denied"])


def test_an_unexpected_error_is_not_disguised() -> None:
    with pytest.raises(ZeroDivisionError), edge():
        _ = 1 / 0
