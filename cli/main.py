"""The ``sizefx`` command: a click group, one module per verb."""

from __future__ import annotations

import os
import signal
import sys
import threading

import click

from sizefx import __version__
from sizefx.errors import Interrupted, SizefxError
from sizefx.io.files import INTERRUPTED, interrupt

#: What the command line says after a signal: the output promise (no unfinished output is left).
SIGNAL_WORDS = {signal.SIGINT: "interrupted (SIGINT)", signal.SIGTERM: "terminated (SIGTERM)"}


def _quiet_interrupted(hook):
    """``sys.unraisablehook`` that stays silent about a swallowed :class:`Interrupted`: a signal
    landing in a weakref callback or a ``__del__`` (h5py closes objects in both) would otherwise print
    an "Exception ignored" traceback. The signal is still honoured: :func:`interrupt` recorded it in
    ``INTERRUPTED``, which :func:`~sizefx.io.files.atomic_output` and ``invoke`` look at."""

    def quiet(unraisable):
        if not isinstance(unraisable.exc_value, Interrupted):
            hook(unraisable)

    return quiet


class SizefxGroup(click.Group):
    """Turns every user-facing error into one line on stderr and exit code 2 (no traceback); SIGINT
    and SIGTERM into one line and 130 / 143 (128 + the signal, as a shell reports them), after the
    temporary outputs are removed (:func:`sizefx.io.files.atomic_output` cleans up on any exception,
    and publishes nothing once a signal has arrived)."""

    def main(self, args=None, prog_name=None, complete_var=None, standalone_mode=True, **extra):
        """Click's own errors (a bad option value, an unknown option, a missing argument) as one line
        too, naming the command and the option, exit code 2; everything else as click does it."""
        try:
            code = super().main(args, prog_name, complete_var, standalone_mode=False, **extra)
        except click.exceptions.ClickException as exc:
            ctx = getattr(exc, "ctx", None)
            if type(exc).__name__ == "NoArgsIsHelpError":  # plain `sizefx`: the help, as a help request
                click.echo(ctx.get_help())
                code = 0
            else:
                path = ctx.command_path if ctx is not None else "sizefx"
                where = path.partition(" ")[2]  # the subcommand; empty for the group's own options
                message = " ".join(exc.format_message().split())
                command = f"sizefx {where}" if where else "sizefx"
                click.echo(f"sizefx: error: {where + ': ' if where else ''}{message} (see {command} --help)", err=True)
                code = exc.exit_code
        except click.exceptions.Abort:  # Ctrl-C at a prompt, outside any command
            click.echo("sizefx: interrupted (SIGINT)", err=True)
            code = 128 + signal.SIGINT
        except BrokenPipeError:  # `sizefx ... | head`: the reader left (Python's documented recipe: no
            # second error when the interpreter flushes stdout at exit)
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
            code = 1
        if not standalone_mode:
            return code
        sys.exit(code if isinstance(code, int) else 0)

    def invoke(self, ctx):
        # signals go to the main thread only; its handlers raise Interrupted, and remember the signal
        # for atomic_output in case Python swallows that exception (sizefx.io.files.INTERRUPTED)
        handled = (signal.SIGINT, signal.SIGTERM) if threading.current_thread() is threading.main_thread() else ()
        previous = {s: signal.signal(s, interrupt) for s in handled}
        previous_hook, sys.unraisablehook = sys.unraisablehook, _quiet_interrupted(sys.unraisablehook)
        try:
            result = super().invoke(ctx)
        except SizefxError as exc:
            message = " ".join(str(exc).split())
            click.echo(f"sizefx: error: {message}", err=True)
            ctx.exit(exc.exit_code)
        except (KeyboardInterrupt, click.exceptions.Abort):
            self._interrupted(ctx, signal.SIGINT)
        except Interrupted as exc:
            self._interrupted(ctx, exc.signum)
        except Exception:
            # a signal's exception raised inside a library's C code can come out as that library's
            # own (h5py turns it into a TypeError while it writes an attribute): after a signal,
            # whatever ends the command is the signal's doing, not a bug to print
            if INTERRUPTED["signum"] is not None:
                self._interrupted(ctx, INTERRUPTED["signum"])
            raise
        finally:
            for s, handler in previous.items():
                signal.signal(s, handler)
            sys.unraisablehook = previous_hook
        if INTERRUPTED["signum"] is not None:  # arrived, but its exception was swallowed on the way
            self._interrupted(ctx, INTERRUPTED["signum"])
        return result

    @staticmethod
    def _interrupted(ctx, signum):
        words = SIGNAL_WORDS.get(signum, f"stopped by signal {signum}")
        click.echo(f"sizefx: {words}; unfinished outputs removed", err=True)
        ctx.exit(128 + signum)


@click.group(cls=SizefxGroup, context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100})
@click.version_option(__version__, prog_name="sizefx")
def main():
    """sizefx: the accelerometer size effect in strapdown INS telemetry.

    \b
    Conventions: SI units and radians inside; body frame x forward, y right,
    z down; navigation frame NED; quaternions scalar-first (Hamilton),
    rotating body vectors into NED. Files follow the sizefx/telemetry/1
    contract (see data-schemas/). Bad input exits with code 2 and one line.
    """


from . import batch as _batch  # noqa: E402  (imported after `main` exists)
from . import calibrate as _calibrate  # noqa: E402 (after `main`)
from . import compare as _compare  # noqa: E402 (after `main`)
from . import compensate as _compensate  # noqa: E402 (after `main`)
from . import demo as _demo  # noqa: E402 (after `main`)
from . import diagnose as _diagnose  # noqa: E402 (after `main`)
from . import export as _export  # noqa: E402 (after `main`)
from . import import_ as _import  # noqa: E402 (after `main`)
from . import inspect as _inspect  # noqa: E402 (after `main`)
from . import navigate as _navigate  # noqa: E402 (after `main`)
from . import paper as _paper  # noqa: E402 (after `main`)
from . import plan as _plan  # noqa: E402 (after `main`)
from . import run as _run  # noqa: E402 (after `main`)
from . import simulate as _simulate  # noqa: E402 (after `main`)

main.add_command(_batch.batch)
_batch.batch.add_command(_run.batch_run)  # the chain per flight (cli/run.py parses both chains)
main.add_command(_calibrate.calibrate)
main.add_command(_compare.compare)
main.add_command(_compensate.compensate)
main.add_command(_demo.demo)
main.add_command(_diagnose.diagnose)
main.add_command(_export.export)
main.add_command(_import.import_)
main.add_command(_inspect.inspect)
main.add_command(_navigate.navigate)
main.add_command(_paper.paper)
main.add_command(_plan.plan)
main.add_command(_run.run)
main.add_command(_simulate.simulate)
