"""Command line interface ``gearrom``.

Each subcommand lives in its own module of this package and exposes::

    NAME: str                      # the subcommand name
    HELP: str                      # one-line help
    def add_args(parser) -> None   # add its arguments to an argparse parser
    def run(args) -> int           # do the work, return the exit code

Modules are discovered automatically, so adding a subcommand means adding a module.
Errors derived from :class:`gearrom.errors.GearromError` (and OSError for files)
are reported as one line on stderr with exit code 2, never as a traceback.
"""
from __future__ import annotations

import argparse
import importlib
import logging
import pkgutil
import sys
from collections.abc import Sequence

from gearrom.errors import GearromError

log = logging.getLogger(__name__)


def _subcommand_modules():
    import gearrom.cli as pkg

    for info in sorted(pkgutil.iter_modules(pkg.__path__), key=lambda i: i.name):
        if info.name.startswith("_"):
            continue
        mod = importlib.import_module(f"gearrom.cli.{info.name}")
        if hasattr(mod, "NAME") and hasattr(mod, "run"):
            yield mod


def build_parser() -> argparse.ArgumentParser:
    """Return the top-level parser with every discovered subcommand."""
    parser = argparse.ArgumentParser(prog="gearrom", description="Gear transmission error toolkit.")
    parser.add_argument("-v", "--verbose", action="count", default=0, help="more log output (-v, -vv)")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for mod in _subcommand_modules():
        p = sub.add_parser(mod.NAME, help=getattr(mod, "HELP", ""), description=getattr(mod, "HELP", ""))
        mod.add_args(p)
        p.set_defaults(_run=mod.run)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point. Returns the process exit code (0 ok, 2 user error, 1 failed check)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    level = logging.WARNING - 10 * min(args.verbose, 2)
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")
    try:
        return int(args._run(args) or 0)
    except GearromError as exc:
        print(f"gearrom {args.command}: error: {exc}", file=sys.stderr)  # noqa: T201 (CLI edge)
        return 2
    except OSError as exc:
        print(f"gearrom {args.command}: error: {exc.strerror or exc}: {exc.filename or ''}", file=sys.stderr)  # noqa: T201
        return 2
    except KeyboardInterrupt:
        print(f"gearrom {args.command}: interrupted; finished results are kept", file=sys.stderr)  # noqa: T201
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
