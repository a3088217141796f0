"""One module per CLI subcommand; each defines ``add_parser(subparsers)``.

Shared option helpers live in :mod:`pencilbot.commands.common`.
"""
