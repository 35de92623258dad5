"""The commands, one module per family; `drboard_cli.main.COMMANDS` says where each lives.

A module here imports only click and the CLI's light parts at its top, so that a command's
--help starts fast; what a command needs to run it imports in its body.
"""
