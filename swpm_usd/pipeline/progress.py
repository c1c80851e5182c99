"""What a run shows as it builds: a rich progress bar on a terminal, a plain line an asset elsewhere (CI).

Separate from the runner: display only; the records and the summary after the run say the same things.
"""

from __future__ import annotations

import sys
import threading

#: seconds with no asset finished before a run says it is still working: a fresh install's first run printed
#: its first line, then nothing for 135 s while numba compiled (helper-238's walk-through; warm, the README's
#: samples finish in under a second each)
STILL_WORKING_S = 30.0


class _Progress:
    """A rich progress bar on a terminal, plain lines elsewhere (CI logs)."""

    def __init__(self, total: int, still_working_s: float = STILL_WORKING_S, compiles: bool = True) -> None:
        """``compiles``: whether the run may build a mesh, so wait for numba's first compile (False: every
        asset a broken input retried, which fails before any build: the first line says nothing of it)."""
        self.total = total
        self.done = 0
        self.bar = None
        self.timer: threading.Timer | None = None
        # (the timer's line and its cancelling one at a time: none printed once an asset is done or closed)
        self._lock = threading.Lock()
        if total:  # (a first run printed nothing for minutes while numba compiled: users took it for a hang)
            compile_note = "; on a new machine numba compiles its kernels first (a minute or more, once)"
            print(
                f"[0/{total}] building {total} asset{'s' * (total != 1)}{compile_note * compiles}",
                file=sys.stderr,
                flush=True,
            )
        if sys.stderr.isatty() and total:
            from rich.console import Console
            from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

            self.bar = Progress(
                TextColumn("[bold]building"),
                BarColumn(),
                MofNCompleteColumn(),
                TimeRemainingColumn(),
                TextColumn("{task.description}"),
                transient=False,
                # (on stderr, the terminal it was asked of: rich's own console, stdout, put the bar and the
                # "still working" line into `run --json > report.json`'s JSON; stdout left where it goes)
                console=Console(file=sys.stderr),
                redirect_stdout=False,
            )
            self.bar.start()
            self.task = self.bar.add_task("", total=total)
        if total:
            self.timer = threading.Timer(still_working_s, self._still_working, args=(still_working_s,))
            self.timer.daemon = True
            self.timer.start()

    def _still_working(self, seconds: float) -> None:
        with self._lock:
            if self.timer is not None:  # (None: stopped as this thread woke; an asset done, or closed)
                self._say_still_working(seconds)

    def _say_still_working(self, seconds: float) -> None:
        line = (
            f"[0/{self.total}] still working after {seconds:.0f} s, no asset finished yet: a first run on "
            "this machine compiles numba's kernels (a minute or more, once), and a large asset takes longer"
        )
        if self.bar is not None:
            self.bar.console.print(line, markup=False, highlight=False)
        else:
            print(line, file=sys.stderr, flush=True)

    def stop_timer(self) -> None:
        with self._lock:
            if self.timer is not None:
                self.timer.cancel()
                self.timer = None

    def advance(self, rec: dict, path: str | None = None) -> None:
        """One more asset done; ``path``, its file as the worker's error names it, is left out of the line
        (which names the asset already): a deep folder's path filled the 100 characters kept of the error,
        and the line lost its cause (the summary after the run prints the error whole)."""
        self.stop_timer()
        self.done += 1
        error = rec.get("error", "")
        if path:
            error = error.replace(f"{path}: ", "", 1)
        status = rec["status"]
        if status == "failed":
            # the problem code first, bracketed, as the summary's FAILED line has it: a log greps by cause
            code = f" [{rec['code']}]" if rec.get("code") else ""
            # (cut to 100 characters with "..." where it was cut: a cause cut at a comma read as whole,
            # "refers to vertex 99999, the file"; the summary after the run prints it whole)
            short = error if len(error) <= 100 else error[:97] + "..."
            status = f"FAILED{code} ({short})"
        if rec.get("kept_previous"):
            status += "; its previous outputs are kept"
        if self.bar is not None:
            self.bar.update(self.task, advance=1, description=f"{rec['id']}: {status}")
        else:
            print(
                f"[{self.done}/{self.total}] {rec['id']}: {status} ({rec.get('seconds', 0):.2f} s)",
                file=sys.stderr,
                flush=True,
            )

    def close(self) -> None:
        self.stop_timer()
        if self.bar is not None:
            self.bar.stop()
