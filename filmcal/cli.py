"""The `filmcal` command.

A thin dispatcher: each subcommand lives in `filmcal.commands.<name>` with an
``add_parser(subparsers)`` that registers its options and sets
``func(args) -> int``. No science lives here. Errors in the user's input
(`ValueError`, a missing file) become one line on stderr and exit status 2.
"""
from __future__ import annotations

import argparse
import importlib
import pkgutil
import sys

import filmcal.commands

# The order in which `--help` lists the subcommands; any other module in
# `filmcal.commands` (not starting with "_") follows in alphabetical order.
ORDER = ["pipeline", "fem", "doe", "campaign", "calibrate", "profile", "wheelrail", "correct", "report"]


def command_modules() -> list[str]:
    """Names of the subcommand modules in `filmcal.commands`."""
    names = [m.name for m in pkgutil.iter_modules(filmcal.commands.__path__) if not m.name.startswith("_")]
    return sorted(names, key=lambda n: (ORDER.index(n) if n in ORDER else len(ORDER), n))


class OneLineParser(argparse.ArgumentParser):
    """An `ArgumentParser` whose usage errors are one line on stderr, exit 2."""

    def error(self, message: str) -> None:  # noqa: D401 - argparse API
        sys.stderr.write(f"{self.prog}: error: {message}\n")
        raise SystemExit(2)


def build_parser() -> argparse.ArgumentParser:
    """Return the top-level parser with every subcommand registered."""
    parser = OneLineParser(
        prog="filmcal",
        description="Calibrate a finite-element model of Prescale film against "
                    "sphere-on-flat experiments and correct wheel-rail contact areas "
                    "measured with film, with their uncertainty.",
    )
    from filmcal import __version__
    parser.add_argument("--version", action="version", version=f"filmcal {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=OneLineParser)
    for name in command_modules():
        importlib.import_module(f"filmcal.commands.{name}").add_parser(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run the `filmcal` command line; return the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        return int(args.func(args) or 0)
    except (ValueError, FileNotFoundError, KeyError) as exc:
        msg = str(exc).strip().strip("'\"").splitlines()
        sys.stderr.write(f"filmcal {args.command}: error: {msg[0] if msg else type(exc).__name__}\n")
        return 2
    except KeyboardInterrupt:
        sys.stderr.write("filmcal: interrupted\n")
        return 130
    except BrokenPipeError:  # output piped into e.g. `head`
        sys.stderr.close()
        return 0


if __name__ == "__main__":
    sys.exit(main())
