"""The ``siftom`` command line: thin subcommands over the library.

Each area of the package contributes its commands from its own ``cli.py`` (a ``register``
function that adds click commands to the root group), so this file only wires them up.
"""

from __future__ import annotations

import importlib
import sys

import click

from siftom import __version__
from siftom.errors import SiftomError

# Modules that contribute subcommands, in the order shown by --help.
_AREAS = (
    "siftom.cli.world",
    "siftom.cli.agents",
    "siftom.cli.inference",
    "siftom.cli.speech",
    "siftom.cli.bench",
    "siftom.cli.people",
    "siftom.cli.service",
    "siftom.cli.stream",
    "siftom.cli.perception",
    "siftom.cli.demo",
    "siftom.cli.plugins",
    "siftom.cli.results",
)


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(version=__version__, prog_name="siftom", message="%(prog)s %(version)s")
def root() -> None:
    """siftom: follow noisy spoken instructions by inferring what the person is doing."""


def _register_all() -> None:
    # An area that fails to import is a broken install: fail loudly rather than hide its
    # commands. Areas import optional extras lazily, inside their commands.
    for name in _AREAS:
        importlib.import_module(name).register(root)


_register_all()


def main(argv: list[str] | None = None) -> int:
    """Entry point: run the CLI and turn SiftomError into a one-line message, exit code 2."""
    try:
        root.main(args=argv, prog_name="siftom", standalone_mode=False)
    except click.exceptions.Abort:
        click.echo("aborted", err=True)
        return 130
    except click.ClickException as exc:
        exc.show()
        return exc.exit_code
    except SiftomError as exc:
        click.echo(f"error: {exc}", err=True)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
