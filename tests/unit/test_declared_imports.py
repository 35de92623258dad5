"""Every package drboard imports at run time is declared where it is used: the functions' in
functions/requirements.txt, the CLI's there or in cli/requirements.txt (which pip installs
together), so a fresh install never misses one that happened to come along with another."""

from __future__ import annotations

import ast
import sys
from importlib.metadata import packages_distributions
from pathlib import Path

from packaging.requirements import Requirement
from packaging.utils import canonicalize_name

ROOT = Path(__file__).parents[2]
FUNCTIONS_REQUIREMENTS = ROOT / "functions" / "requirements.txt"
CLI_REQUIREMENTS = ROOT / "cli" / "requirements.txt"
CARD_REQUIREMENTS = ROOT / "functions" / "card-requirements.txt"
#: The card renderer runs in the CardFunction, which adds its own list, and in the CLI.
CARD_MODULES = {"functions/drboard_functions/cards/png.py"}
#: The writer of the card fonts' widths table, a developer's tool (`python -m
#: drboard_functions.cards.widths`) that runs with the test extra's fontTools, never in a function.
DEVELOPER_TOOLS = {"functions/drboard_functions/cards/widths.py": {"fonttools"}}


def declared(path: Path) -> set[str]:
    lines = (line.split("#", 1)[0].strip() for line in path.read_text().splitlines())
    return {canonicalize_name(Requirement(line).name) for line in lines if line}


def is_type_checking(node: ast.If) -> bool:
    return isinstance(node.test, ast.Name) and node.test.id == "TYPE_CHECKING"


def runtime_imports(tree: ast.AST) -> set[str]:
    """Top-level module names imported outside ``if TYPE_CHECKING:`` blocks."""
    names: set[str] = set()
    for node in ast.iter_child_nodes(tree):
        if isinstance(node, ast.If) and is_type_checking(node):
            names |= {n for child in node.orelse for n in runtime_imports(ast.Module([child], []))}
            continue
        if isinstance(node, ast.Import):
            names |= {alias.name.split(".")[0] for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module.split(".")[0])
        else:
            names |= runtime_imports(node)
    return names


def distributions_imported_by(folder: Path) -> dict[str, set[str]]:
    """The distributions each third-party module imported under ``folder`` comes from."""
    owners = packages_distributions()
    found: dict[str, set[str]] = {}
    for path in sorted(folder.rglob("*.py")):
        for module in runtime_imports(ast.parse(path.read_text())):
            if module in sys.stdlib_module_names or module.startswith("drboard_"):
                continue
            dists = {canonicalize_name(d) for d in owners.get(module, [module])}
            found.setdefault(path.relative_to(ROOT).as_posix(), set()).update(dists)
    return found


def test_the_functions_and_the_assembler_declare_what_they_import() -> None:
    functions = declared(FUNCTIONS_REQUIREMENTS)
    everything = functions | declared(CLI_REQUIREMENTS)
    allowed = {path: functions | declared(CARD_REQUIREMENTS) for path in CARD_MODULES}
    allowed |= {path: functions | tools for path, tools in DEVELOPER_TOOLS.items()}
    undeclared = {path: dists - allowed.get(path, functions) for path, dists
                  in distributions_imported_by(ROOT / "functions" / "drboard_functions").items()
                  if dists - allowed.get(path, functions)}
    # The assembler runs in the functions (the Record schema) and in the CLI (reading files).
    undeclared |= {path: dists - everything for path, dists
                   in distributions_imported_by(ROOT / "assembler" / "drboard_assembler").items()
                   if dists - everything}
    assert undeclared == {}


def test_the_cli_declares_what_it_imports() -> None:
    everything = declared(FUNCTIONS_REQUIREMENTS) | declared(CLI_REQUIREMENTS)
    undeclared = {path: dists - everything for path, dists
                  in distributions_imported_by(ROOT / "cli" / "drboard_cli").items()
                  if dists - everything}
    assert undeclared == {}


def test_a_library_imported_through_another_is_declared_too() -> None:
    # Authlib's client for the browser sign-in is built on requests, which Authlib itself
    # leaves to its users to install.
    source = (ROOT / "cli" / "drboard_cli" / "login.py").read_text()
    assert "authlib.integrations.requests_client" in source
    assert "requests" in declared(CLI_REQUIREMENTS)


def renderer_requirement(path: Path) -> str:
    lines = (line.split("#", 1)[0].strip() for line in path.read_text().splitlines())
    (found,) = [Requirement(line) for line in lines
                if line and canonicalize_name(Requirement(line).name) == "resvg-py"]
    return str(found.specifier)


def test_the_cli_draws_the_cards_with_the_card_functions_renderer() -> None:
    assert renderer_requirement(CARD_REQUIREMENTS) == renderer_requirement(CLI_REQUIREMENTS)
    pyproject = (ROOT / "pyproject.toml").read_text()
    assert all(f'"{tool}' in pyproject for tools in DEVELOPER_TOOLS.values() for tool in tools), \
        "the developer tools' packages are in the test extra"
