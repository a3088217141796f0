"""Many inputs at once: expand folders, name the outputs, run the files on every core.

``pencilbot plan`` and ``pencilbot export`` share this. One input behaves like a single command
(an error is the command's error; a terminal shows the time spent while it works). Several inputs, or a folder, run in a process pool: each file
that fails is reported on one line naming it while the others carry on, a progress bar counts the
files, and a summary line ends the run.
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import sys
import threading
import traceback
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from tqdm import tqdm

from pencilbot.commands.common import IMAGE_SUFFIXES
from pencilbot.commands.options import number
from pencilbot.errors import PencilbotError
from pencilbot.fileio import refuse_overwriting_inputs


def add_jobs_option(parser: argparse.ArgumentParser) -> None:
    """``-j/--jobs``: how many files to work on at once."""
    parser.add_argument(
        "-j",
        "--jobs",
        type=number("--jobs", low=1, high=MAX_JOBS, whole=True),
        metavar="N",
        help=f"files worked on at once with several inputs (default: all {os.cpu_count()} cores; 1: one by one)",
    )


#: Most files worked on at once: a process each, so past a few hundred the machine thrashes.
MAX_JOBS = 256


@dataclass(frozen=True)
class Inputs:
    """Input files in command-line order; ``batch`` when there are several or a folder was given."""

    paths: list[Path]
    batch: bool


def collect_inputs(names: Sequence[str]) -> Inputs:
    """Input files from the command line, each folder replaced by the photos in it (by name).

    Raises
    ------
    PencilbotError
        A folder holds no photo.
    """
    paths: list[Path] = []
    for name in map(Path, names):
        if not name.is_dir():
            paths.append(name)
            continue
        photos = sorted(p for p in name.iterdir() if p.is_file() and p.suffix.lower() in IMAGE_SUFFIXES)
        if not photos:
            raise PencilbotError(
                f"folder {name} holds no photo ({', '.join(IMAGE_SUFFIXES)}); give files or another folder"
            )
        paths.extend(photos)
    return Inputs(paths, batch=len(paths) > 1 or any(Path(n).is_dir() for n in names))


def output_paths(inputs: Inputs, output: str, *, what: str, suffixes: Sequence[str]) -> list[Path]:
    """Where each input's result goes: ``output`` itself, or ``output/<input name><suffix>``.

    ``output`` is a folder when it is one, or when the run is a batch (then :func:`make_folders`
    creates it: its parent must exist); otherwise a file, which must end with one of ``suffixes`` (the first is the
    one given to files in a folder).

    Raises
    ------
    PencilbotError
        A single file for a batch, a wrong suffix, a file in a folder that does not exist, or two
        inputs that would write the same file.
    """
    out = Path(output)
    if not out.is_dir() and not inputs.batch:
        if out.suffix.lower() not in suffixes:
            raise PencilbotError(f"name the {what} {out} with {' or '.join(suffixes)}")
        if not out.parent.is_dir():
            # Now, not after minutes of planning, and before a plan is written without its preview.
            raise PencilbotError(
                f"cannot write the {what} {out}: folder {out.parent} does not exist; create it first"
            )
        return [out]
    if not out.is_dir():
        if out.suffix.lower() in suffixes or out.exists():
            raise PencilbotError(
                f"{len(inputs.paths)} inputs need a folder for the {what}, not the file {out}"
            )
        if not out.parent.is_dir():
            raise PencilbotError(f"cannot create the {what} folder {out}: {out.parent} does not exist")
    return distinct([out / f"{p.stem}{suffixes[0]}" for p in inputs.paths], inputs.paths)


def outputs_or_beside(
    inputs: Inputs, output: str | None, *, what: str, suffixes: Sequence[str]
) -> list[Path]:
    """:func:`output_paths` of ``-o``; without one, each input's result beside it, named as the
    input with ``suffixes[0]`` (``photo.jpg`` → ``photo.svg``)."""
    if output is None:
        return distinct([p.with_suffix(suffixes[0]) for p in inputs.paths], inputs.paths)
    return output_paths(inputs, output, what=what, suffixes=suffixes)


def make_folders(paths: Sequence[Path | None]) -> None:
    """Create the folders :func:`output_paths` named but that do not exist yet."""
    for folder in {p.parent for p in paths if p is not None}:
        try:
            folder.mkdir(exist_ok=True)
        except OSError as err:
            raise PencilbotError(
                f"cannot create the folder {folder} ({err.strerror}); choose another -o"
            ) from None


def distinct(targets: list[Path], sources: Sequence[Path]) -> list[Path]:
    """``targets`` unchanged, after checking no two sources would overwrite each other's result."""
    seen: dict[Path, Path] = {}
    for source, target in zip(sources, targets):
        if target in seen:
            raise PencilbotError(f"{seen[target]} and {source} would both be written to {target}; rename one")
        seen[target] = source
    refuse_overwriting_inputs(sources, targets)
    return targets


@dataclass(frozen=True)
class Failure:
    """Why one file failed: the message, and the exit code it would have had on its own."""

    message: str
    exit_code: int


def run_batch(
    work: Callable[..., str], jobs: Sequence[tuple], *, workers: int | None, quiet: bool, verbose: int
) -> int:
    """Call ``work(*job)`` for every job, each job's first item being the input file it is about.

    ``work`` returns the line reporting what it wrote. With one job its errors propagate as they
    would from a single command. With several, failures are reported per file on stderr,
    successes only with ``verbose``, and a summary line follows.

    Parameters
    ----------
    work : callable
        A module-level function (it is sent to worker processes).
    jobs : sequence of tuple
        Arguments of each call; ``job[0]`` is the input path.
    workers : int or None
        Processes to use; None: one per core; 1 runs in this process.
    quiet, verbose : bool, int
        ``-q`` hides the progress bar and summary; ``-v`` prints each file's report.

    Returns
    -------
    int
        0 if every file was written, else the highest exit code of the failures.
    """
    if len(jobs) == 1:
        with _elapsed(f"{jobs[0][0].name}", quiet):
            report = work(*jobs[0])
        if not quiet:
            print(report)
        return 0
    failures: list[Failure] = []
    with tqdm(total=len(jobs), unit="file", file=sys.stderr, disable=quiet, leave=False) as bar:
        for source, outcome in _outcomes(work, jobs, workers or os.cpu_count() or 1, verbose):
            if isinstance(outcome, Failure):
                failures.append(outcome)
                bar.write(_error_line(source, outcome.message), file=sys.stderr)
            elif verbose:
                bar.write(outcome, file=sys.stdout)
            bar.update()
    if not quiet:
        print(f"{len(jobs) - len(failures)} written, {len(failures)} failed")
    return max((failure.exit_code for failure in failures), default=0)


@contextmanager
def _elapsed(what: str, quiet: bool) -> Iterator[None]:
    """A live 'working on X: 3s' line on a terminal's stderr while one file is worked on."""
    bar = tqdm(
        total=None,
        desc=f"working on {what}",
        bar_format="{desc}: {elapsed}",
        file=sys.stderr,
        disable=True if quiet else None,
        leave=False,
    )
    done = threading.Event()

    def tick() -> None:
        while not done.wait(0.5):
            bar.refresh()

    ticker = threading.Thread(target=tick, daemon=True)
    ticker.start()
    try:
        yield
    finally:
        done.set()
        ticker.join()
        bar.close()


def _outcomes(
    work: Callable[..., str], jobs: Sequence[tuple], workers: int, verbose: int
) -> Iterator[tuple[Path, str | Failure]]:
    """Each job's input with its report or failure, in the order they finish."""
    if workers == 1:
        for job in jobs:
            yield job[0], _attempt(work, job, verbose)
        return
    workers = min(workers, len(jobs))
    # Not fork: a copy of this process would inherit OpenCV's and SciPy's thread pools without
    # their threads and can hang in them. The fork server starts clean, imports the pipeline once
    # and forks each worker from there.
    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload(["pencilbot.commands.common"])
    with ProcessPoolExecutor(workers, context, initializer=_share_cores, initargs=(workers,)) as pool:
        futures = {pool.submit(_attempt, work, job, verbose): job[0] for job in jobs}
        for future in as_completed(futures):
            try:
                outcome = future.result()
            except BrokenProcessPool:
                outcome = Failure("its worker process died (out of memory?); retry it with --jobs 1", 1)
            yield futures[future], outcome


def _attempt(work: Callable[..., str], job: tuple, verbose: int) -> str | Failure:
    """``work(*job)``, with any error turned into a picklable :class:`Failure`."""
    try:
        return work(*job)
    except PencilbotError as err:
        return Failure(str(err), err.exit_code)
    except Exception as err:  # noqa: BLE001 - one file's bug must not stop the others
        detail = traceback.format_exc() if verbose else "run with -v for the traceback"
        return Failure(f"unexpected {type(err).__name__}: {err} ({detail})", 1)


def _share_cores(workers: int) -> None:
    """Split the cores between the worker processes instead of each running one thread per core."""
    import cv2

    cv2.setNumThreads(max(1, (os.cpu_count() or 1) // workers))


def _error_line(source: Path, message: str) -> str:
    """One line naming the failed file (once: most messages already start with it)."""
    named = message if str(source) in message else f"{source}: {message}"
    return f"pencilbot: error: {named}"
