"""The ``mocapkit`` command: parses arguments, calls the library, prints results.

Only this package and :mod:`mocapkit.viz` talk to people. Defaults come from the library's
function signatures, not from here. Each capability's subcommands live in their own module and
register themselves on :data:`main` when imported below.
"""

from mocapkit.cli import demo, io_commands  # noqa: F401  (registers the subcommands)
from mocapkit.cli.common import CLIError, main

__all__ = ["CLIError", "main"]
