"""The `drboard` command: a thin layer over the assembler and the leaderboard service."""

#: The distribution's version, written out: reading the installed metadata costs `drboard
#: --version` more than the rest of its start (a unit test holds the two equal).
__version__ = "0.1.0"
