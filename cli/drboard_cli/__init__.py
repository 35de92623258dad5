"""The `drboard` command: a thin layer over the assembler and the leaderboard service."""
