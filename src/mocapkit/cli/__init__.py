"""The ``mocapkit`` command: parses arguments, calls the library, prints results.

Only this package and :mod:`mocapkit.viz` talk to people. Defaults come from the library's
function signatures, not from here. Each capability's subcommands live in their own module and
register themselves on :data:`main` when imported below.
"""

# Importing a module registers its subcommands and appends its demo step (in this order).
from mocapkit.cli import (  # noqa: F401
    clean_commands,
    demo,
    edit_commands,
    graph_commands,
    inbetween_commands,
    io_commands,
    retarget_commands,
    stitch_commands,
    view_commands,
)
from mocapkit.cli.common import CLIError, main

__all__ = ["CLIError", "main"]
