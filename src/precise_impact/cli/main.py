"""The ``precise-impact`` entry point: parse, dispatch to the command's ``run``, map errors.

Exit statuses: 0 ok, 2 bad input (argparse's own status too), a missing optional component or
reference dataset, 3 a budget was hit (a run whose estimate is over its budget is refused with 3
before any work) or an integration or Newton iteration stopped (or missed an impact, or ngspice
failed), 4 an I/O error during the run (finished files are
complete: every write is atomic), 130 interrupted (Ctrl-C or SIGTERM).  The commands are the
modules of :mod:`precise_impact.cli.commands`.
"""

from __future__ import annotations

import argparse
import contextlib
import re
import sys
import warnings
from collections.abc import Sequence

import heyoka

from precise_impact.cli.args import EXIT_BAD_INPUT, Parser, check_outputs
from precise_impact.cli.commands import MODULES, load
from precise_impact.cli.entry import EXIT_INTERRUPTED, interrupts
from precise_impact.errors import (
    BudgetExceededError,
    ConvergenceError,
    IntegrationError,
    MissedImpactError,
    OptionalDependencyError,
    OverBudgetError,
    ParameterError,
    PreciseImpactError,
    ReferenceDataError,
)
from precise_impact.version import __version__

__all__ = ["main", "build_parser", "EXIT_BAD_INPUT", "EXIT_BUDGET", "EXIT_IO", "EXIT_INTERRUPTED"]

EXIT_BUDGET = 3
EXIT_IO = 4


def build_parser(argv: Sequence[str] | None = None) -> argparse.ArgumentParser:
    """The ``precise-impact`` parser: one subparser per command of
    :data:`~precise_impact.cli.commands.MODULES`, or, when ``argv`` names a command, that
    command's alone (only its module is imported)."""
    parser = Parser(
        prog="precise-impact",
        description="Verification suite for the piecewise-linear impact oscillator and its "
        "electronic equivalent.",
    )
    parser.add_argument("--version", action="version", version=f"precise-impact {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=Parser)
    for name in _named(argv):
        load(name).register(sub)
    return parser


def _named(argv: Sequence[str] | None) -> tuple[str, ...]:
    """The command ``argv`` runs (its first word that is not an option: the top level has no
    option taking a value), or every command (no argv, ``--help``, an unknown word: argparse's
    own help and error list them all)."""
    word = next((a for a in argv or () if not a.startswith("-")), None)
    return (word,) if word in MODULES else tuple(MODULES)


def _glue_negative_values(argv: list[str]) -> list[str]:
    """Negative numbers that argparse would read as options (``-1e-9``, ``-inf``) made values.

    argparse takes ``-1`` and ``-0.5`` as values by itself but ``-1e-3`` or ``-inf`` as an
    unknown option.  A leading space makes any such token a value, wherever it stands: after a
    one-value flag (``--tol -1e-9``), inside a flag's several values (``--guess -1e-3 0``,
    ``--y0 -1e-3 0``: gluing ``--guess=-1e-3`` gave the flag one value of its two) or in
    ``--axis x_w -1e-3 2 3``; :func:`_strip_glued` takes the space off after parsing, so the
    validators, not argparse, report a value out of range, naming it as typed.
    """
    out: list[str] = []
    for a in argv:
        if (
            len(a) > 1
            and a[0] == "-"
            and not a.startswith("--")
            and not re.fullmatch(r"-\d+|-\d*\.\d+", a)  # argparse reads these as values
            and (a[1].isdigit() or a[1] == "." or _is_number(a))
        ):
            a = " " + a
        out.append(a)
    return out


def _strip_glued(ns: argparse.Namespace) -> argparse.Namespace:
    """The leading space :func:`_glue_negative_values` put before a negative number, removed
    from every parsed value (strings and lists of strings)."""
    for k, v in vars(ns).items():
        if isinstance(v, str) and v.startswith(" -"):
            setattr(ns, k, v[1:])
        elif isinstance(v, list):
            setattr(ns, k, [x[1:] if isinstance(x, str) and x.startswith(" -") else x for x in v])
    return ns


def _is_number(s: str) -> bool:
    try:
        float(s)
    except ValueError:
        return False
    return True


def _say(message: str) -> None:
    """One line on stderr however the message was written (a newline would make it two)."""
    print("precise-impact: " + " ".join(message.splitlines()), file=sys.stderr)


@contextlib.contextmanager
def _deprecations_as_lines():
    """The package's own :class:`DeprecationWarning` (an old scene name, ...): one line on
    stderr each, the first time, as soon as it is raised."""
    seen: set[str] = set()

    def show(message, category, filename, lineno, file=None, line=None):
        text = str(message)
        if text not in seen:
            seen.add(text)
            _say(f"warning: {text}")

    with warnings.catch_warnings():
        warnings.filterwarnings("always", category=DeprecationWarning, module="precise_impact")
        warnings.showwarning = show
        yield


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``precise-impact`` with ``argv`` (default ``sys.argv[1:]``); returns the exit status."""
    args = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser(args)
    ns = _strip_glued(parser.parse_args(_glue_negative_values(args)))
    # heyoka logs its warnings (e.g. root finding near grazing) to stdout, which would
    # corrupt --json output; the CLI keeps only errors.
    heyoka.set_logger_level_error()
    with interrupts():  # Ctrl-C and SIGTERM: KeyboardInterrupt, never half-way through an import
        return _run(ns)


def _run(ns: argparse.Namespace) -> int:
    """Run the parsed command; every error the package names becomes one line and a status."""
    try:
        with _deprecations_as_lines(), check_outputs(ns):  # --out locked until the run ends
            return ns.run(ns)
    except OverBudgetError as e:  # a budget (also a ParameterError): refused before any work
        _say(f"over budget: {e}")
        return EXIT_BUDGET
    except (ParameterError, OptionalDependencyError) as e:  # bad input, or a missing component
        _say(f"error: {e}")
        return EXIT_BAD_INPUT
    except BudgetExceededError as e:
        _say(f"budget exceeded: {e}")
        return EXIT_BUDGET
    except ConvergenceError as e:  # a Newton iteration that found no orbit
        _say(f"no periodic orbit: {e}")
        return EXIT_BUDGET
    except IntegrationError as e:
        _say(f"integration stopped: {e}")
        return EXIT_BUDGET
    except MissedImpactError as e:  # a result that cannot be trusted is not printed
        _say(f"integration stopped: {e}")
        return EXIT_BUDGET
    except ReferenceDataError as e:  # the stored reference is missing or damaged
        _say(f"error: {e}")
        return EXIT_BAD_INPUT
    except PreciseImpactError as e:  # any other failure of the package's own (e.g. ngspice's)
        _say(f"run stopped: {e}")
        return EXIT_BUDGET
    except BrokenPipeError:  # e.g. piped into `head`
        sys.stderr.close()
        return 0
    except (
        KeyboardInterrupt
    ) as e:  # Ctrl-C or SIGTERM: finished files (tiles, outputs) are complete
        print(
            f"precise-impact: {getattr(e, 'kept', 'interrupted; finished results are kept')}",
            file=sys.stderr,
        )
        return EXIT_INTERRUPTED
    except OSError as e:  # a full or read-only file system mid-run: one line, finished files intact
        print(
            f"precise-impact: I/O error: {e.strerror or e}: {e.filename or ''}".rstrip(": "),
            file=sys.stderr,
        )
        return EXIT_IO


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
