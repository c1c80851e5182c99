"""A Ctrl-C while the ``swpm-pipeline`` command imports the package exits 130 with one line.

The console script (``swpm-pipeline = "swpm_usd.cli:main"``) and ``python -m swpm_usd.cli`` import this
package, numpy and usd-core before any code of the command runs (numba and the encoders come later, as the
command builds): a Ctrl-C then printed the traceback of the import it cut short, and the command's own
handling (:class:`.cli._Main`: exit 130, one line) came too late. The package's ``__init__`` imports this
module before anything else, which calls :func:`exit_on_interrupt_while_importing`: in the command's process
it sets a Ctrl-C handler that writes the line and exits at once (nothing has been written yet), and the
command puts Python's handler back when it starts (:func:`restore_interrupts`).

Anywhere else (the package imported by a program, a notebook, a worker process, one the command starts with
multiprocessing's spawn included) nothing changes. This module imports nothing the interpreter has not loaded
at startup but ``signal`` (which the package imports anyway).
"""

from __future__ import annotations

import os
import signal
import sys

COMMAND = "swpm-pipeline"
#: the module ``python -m`` runs as the command
COMMAND_MODULE = "swpm_usd.cli"
#: 128 + SIGINT, as a shell reports it (the same as :data:`.cli.EXIT_INTERRUPTED`)
EXIT_INTERRUPTED = 130


def is_command(argv: list[str] | None = None, orig_argv: list[str] | None = None) -> bool:
    """Is this process the ``swpm-pipeline`` command: its console script (``argv[0]`` named so, less the
    ``.exe`` or ``-script.py`` of Windows launchers), or ``python -m swpm_usd.cli`` (the interpreter's own
    command line, ``sys.orig_argv``: while the package imports, ``sys.argv[0]`` is ``-m``)?

    Not a process the interpreter runs code given with ``-c`` in, whatever its ``sys.argv``: one that
    multiprocessing's spawn starts (``python -c 'from multiprocessing.spawn import spawn_main; ...'``, the
    workers of Dask's LocalCluster) is given its parent's ``sys.argv`` and imports its parent's script."""
    argv = sys.argv if argv is None else argv
    orig_argv = getattr(sys, "orig_argv", []) if orig_argv is None else orig_argv
    option, module = _interpreter_runs(orig_argv[1:]) if orig_argv else (None, None)
    if option == "-m":
        return module == COMMAND_MODULE
    if option == "-c":
        return False
    if argv:
        name = os.path.basename(argv[0])
        for suffix in (".exe", "-script.pyw", "-script.py"):
            name = name.removesuffix(suffix)
        if name == COMMAND:
            return True
    return False


def _interpreter_runs(args: list[str]) -> tuple[str | None, str | None]:
    """What the interpreter's arguments (``sys.orig_argv[1:]``) run: ``("-m", MODULE)``, ``("-c", None)``,
    or ``(None, None)`` (a script, stdin, or none): its options as CPython reads them, short ones clustered
    (``-Bm``) and ``-X``/``-W`` taking a value (joined or the next argument)."""
    i = 0
    while i < len(args):
        arg = args[i]
        if arg == "--check-hash-based-pycs":
            i += 2
            continue
        if not arg.startswith("-") or arg in ("-", "--"):
            return None, None  # a script, stdin
        if arg.startswith("--"):  # --help, --version
            i += 1
            continue
        for j in range(1, len(arg)):
            opt, rest = arg[j], arg[j + 1 :]
            if opt == "c":
                return "-c", None
            if opt in "mXW":
                value = rest or (args[i + 1] if i + 1 < len(args) else "")
                if opt == "m":
                    return "-m", value
                i += 0 if rest else 1
                break
        i += 1
    return None, None


def _interrupted(signum: int, frame: object) -> None:
    try:
        os.write(2, f"{COMMAND}: interrupted\n".encode())
    except OSError:
        pass
    os._exit(EXIT_INTERRUPTED)


def exit_on_interrupt_while_importing() -> None:
    """In the command's process (:func:`is_command`), a Ctrl-C from now until :func:`restore_interrupts`
    writes ``swpm-pipeline: interrupted`` and exits 130 at once. Only where Ctrl-C raises KeyboardInterrupt
    (Python's handler, in the main thread): a process started with it ignored keeps it so."""
    if signal.getsignal(signal.SIGINT) is not signal.default_int_handler or not is_command():
        return
    try:
        signal.signal(signal.SIGINT, _interrupted)
    except ValueError:  # not the main thread: no handler can be set
        pass


def restore_interrupts() -> None:
    """Python's Ctrl-C handler back, where :func:`exit_on_interrupt_while_importing` set its own."""
    if signal.getsignal(signal.SIGINT) is _interrupted:
        signal.signal(signal.SIGINT, signal.default_int_handler)


exit_on_interrupt_while_importing()
