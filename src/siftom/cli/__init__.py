"""The ``siftom`` command line: thin subcommands over the library.

Each area of the package contributes its commands from its own ``cli.py`` (a ``register``
function that adds click commands to the root group), so this file only wires them up.
"""

from __future__ import annotations

import signal
import sys
import threading


def _interrupted(signum: int, frame: object) -> None:
    raise SystemExit(130)  # Ctrl-C while the commands load: leave quietly, no traceback


# loading every command area takes a few tenths of a second; Ctrl-C then ends the process quietly
_SIGINT = signal.signal(signal.SIGINT, _interrupted) if threading.current_thread() is threading.main_thread() else None

import click  # noqa: E402

from siftom import __version__  # noqa: E402
from siftom.errors import SiftomError  # noqa: E402
from siftom.registry import Registry  # noqa: E402

# Command areas: each entry's ``register(root)`` adds its click commands to the root group.
# Plug-in packages add areas the same way (siftom.registry, entry points "siftom.plugins").
CLI_AREAS = Registry("CLI area")
for _area in ("world", "agents", "inference", "speech", "bench", "bench_speed", "bench_understanding", "people",
              "service", "bench_serve", "stream", "perception", "demo", "plugins", "results", "config"):
    CLI_AREAS.register(_area, f"siftom.cli.{_area}:register", summary=f"siftom.cli.{_area}")


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(version=__version__, prog_name="siftom", message="%(prog)s %(version)s")
def root() -> None:
    """siftom: follow noisy spoken instructions by inferring what the person is doing."""


def _register_all() -> None:
    # An area that fails to import is a broken install: fail loudly rather than hide its
    # commands. Areas import optional extras lazily, inside their commands.
    for entry in CLI_AREAS.entries().values():  # in registration order: later areas extend earlier groups
        entry.load()(root)


_register_all()
if _SIGINT is not None:
    signal.signal(signal.SIGINT, _SIGINT)  # from here on Ctrl-C is click's (Abort) or the command's own


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
