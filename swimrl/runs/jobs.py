r"""A job's run directory: preemption signals and the exclusive lock.

**Preemption.** A batch scheduler stops a job by a signal some time before it kills it:
Slurm sends ``SIGTERM`` at a preemption or ``scancel`` (``SIGKILL`` follows after
``GraceTime`` / ``KillWait``) and, with ``sbatch --signal=USR1@120``, ``SIGUSR1`` two minutes
before the time limit. Inside :func:`preemption_signals` these signals (:data:`SIGNALS`) only
set a flag (:class:`Preemption`); the long loops (``swimrl-train`` after each update,
``swimrl-compare`` after each flow chunk) check it at their next safe point, save their state
and call :meth:`Preemption.stop`, which logs one line and raises :class:`Preempted`: the
process exits with :data:`PREEMPTED_EXIT`, and the same command with ``resume=true``
(``compare.resume=true``) continues from the saved state.

Under submitit (``hydra/launcher=submitit_slurm``) the process already has Python handlers:
``SIGTERM`` is logged and ignored, and ``SIGUSR2`` (submitit's requeue signal, sent
``signal_delay_s`` before the time limit and after ``SIGTERM`` at a preemption) calls the
launcher's ``checkpoint()``, requeues the job with ``scontrol requeue`` and exits at once.
A signal that has a Python handler when the context is entered is also taken over, and that
handler is *chained*: :meth:`Preemption.stop` calls it after the state is saved, as if the
signal had arrived then; submitit then requeues the job, which resumes with ``resume=true``
having lost only the update (chunk) in flight. Handlers are installed only in the main
thread, never over an ignored signal (``SIG_IGN``), and the previous ones are restored on
leaving the context.

**One writer per run directory.** :func:`run_lock` holds an exclusive ``flock`` on
``<run dir>/.lock`` (:attr:`RunLayout.lock <swimrl.runs.layout.RunLayout.lock>`, one JSON line:
the holder's ``pid``, ``host``, ``command`` and start time ``since``) for the whole run; a
second process on the same directory gets :class:`RunDirInUseError` (a ``FileExistsError``:
one line, exit status 2) naming the holder. The kernel releases the lock when its process
dies, so a lock file left by a killed process does not block (its content is overwritten); the
holder deletes the file when it releases the lock. :func:`refuse_if_locked` is the same test
without taking the lock, for the checks that run before Hydra writes into the run directory.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import json
import logging
import os
import signal
import socket
import sys
import threading
import time
from collections.abc import Callable, Iterator
from datetime import datetime, timezone
from pathlib import Path
from typing import NoReturn

from swimrl.runs.layout import RunLayout

log = logging.getLogger(__name__)

#: Exit status of a preempted run: ``EX_TEMPFAIL`` of ``sysexits.h`` ("temporary failure,
#: try again later"). It is distinct from 0 (done), 1 (an error or a non-finite result), 2
#: (bad input) and from ``128 + N`` (killed by signal ``N``), so a batch script (``if [ $? -eq
#: 75 ]; then scontrol requeue ...``) or a cluster's ``RequeueExit=75`` (slurm.conf) can
#: requeue exactly the runs that saved their state and asked to be continued.
PREEMPTED_EXIT = 75

#: The signals that always stop a run at its next safe point.
SIGNALS = (signal.SIGTERM, signal.SIGUSR1)
#: Signals taken over (and chained) only where a Python handler is installed for them:
#: submitit's requeue signal.
CHAINED_SIGNALS = (signal.SIGUSR2,)

class Preempted(SystemExit):
    """A run stopped by a preemption signal after saving its state: exits the process with
    :data:`PREEMPTED_EXIT`. A ``SystemExit``, so that no ``except Exception`` on the way out
    (Hydra's job runner's, say) takes it for a failure or swallows it."""

    def __init__(self, message: str):
        super().__init__(PREEMPTED_EXIT)
        self.message = message

    def __str__(self) -> str:
        return self.message


class EvaluationInterruptedError(Exception):
    """An evaluation stopped between two decisions because a preemption signal arrived
    (:attr:`Preemption.requested`); the caller saves what it can and calls
    :meth:`Preemption.stop`. ``decision``: the decisions completed in the episode."""

    def __init__(self, decision: int):
        super().__init__(f"evaluation interrupted after decision {decision}")
        self.decision = decision


class RunDirInUseError(FileExistsError):
    """Another process holds the run directory's lock (one line naming it)."""


# -- preemption ---------------------------------------------------------------------------------
class Preemption:
    """The preemption signals received inside :func:`preemption_signals` (first come first)."""

    def __init__(self) -> None:
        self.received: list[int] = []
        #: The handler each signal had before, for the ones taken over.
        self.previous: dict[int, Callable | int | None] = {}

    @property
    def requested(self) -> bool:
        """True once a preemption signal arrived."""
        return bool(self.received)

    @property
    def names(self) -> str:
        """The signals received, e.g. ``SIGTERM`` or ``SIGTERM+SIGUSR2``."""
        return "+".join(signal.Signals(s).name for s in self.received)

    def handle(self, signum: int, frame=None) -> None:
        """The signal handler: only records the signal."""
        if signum not in self.received:
            self.received.append(signum)

    def stop(self, what: str) -> NoReturn:
        """Log ``preempted by SIGNAL WHAT`` (one line), call the chained handlers of the
        signals received (submitit's requeue), then raise :class:`Preempted`."""
        message = f"preempted by {self.names} {what}"
        log.warning("%s", message)
        for signum in list(self.received):
            handler = self.previous.get(signum)
            if callable(handler):
                handler(signum, None)
        raise Preempted(message)


@contextlib.contextmanager
def preemption_signals() -> Iterator[Preemption]:
    """Record :data:`SIGNALS` (and :data:`CHAINED_SIGNALS` where a Python handler is set)
    in the :class:`Preemption` yielded, instead of their previous action; restore the
    previous handlers on exit. Outside the main thread nothing is installed (and nothing
    is ever received)."""
    p = Preemption()
    if threading.current_thread() is not threading.main_thread():
        yield p
        return
    for signum in (*SIGNALS, *CHAINED_SIGNALS):
        current = signal.getsignal(signum)
        if current in (None, signal.SIG_IGN) or (signum in CHAINED_SIGNALS
                                                  and not callable(current)):
            continue
        p.previous[signum] = current
        signal.signal(signum, p.handle)
    try:
        yield p
    finally:
        for signum, handler in p.previous.items():
            signal.signal(signum, handler)


# -- the lock -----------------------------------------------------------------------------------
#: Lock files held by this process (resolved paths), so that its own checks pass.
_HELD: set[Path] = set()


def _holder(fd: int) -> str:
    """``PID 123 on host h (swimrl-train since ...)`` from an open lock file (the holder may
    not have written it yet: a few retries)."""
    for _ in range(10):
        os.lseek(fd, 0, os.SEEK_SET)
        text = os.read(fd, 4096).decode(errors="replace").strip()
        try:
            info = json.loads(text)
            return (f"PID {info['pid']} on host {info['host']} ({info['command']} since "
                    f"{info['since']})")
        except (ValueError, KeyError, TypeError):
            time.sleep(0.05)
    return f"an unknown process (lock file content {text[:80]!r})"


def _locked_error(path: Path, holder: str) -> RunDirInUseError:
    return RunDirInUseError(f"{path.parent} is in use: {path} is locked by {holder}; allowed: one "
                        "process per run directory (wait for it to end, or choose another run "
                        "directory)")


def _flock(fd: int, how: int, path: Path) -> bool | None:
    """``flock(fd, how | LOCK_NB)``, retried for 0.1 s (a concurrent :func:`refuse_if_locked`
    holds a shared lock for an instant): True if taken, False if held by another process;
    None if the file system has no ``flock`` (then no lock is taken: a warning)."""
    for attempt in range(6):
        try:
            fcntl.flock(fd, how | fcntl.LOCK_NB)
            return True
        except BlockingIOError:
            if attempt < 5:
                time.sleep(0.02)
        except OSError as exc:
            if exc.errno not in (errno.ENOLCK, errno.ENOSYS, errno.EOPNOTSUPP, errno.EINVAL):
                raise
            log.warning("%s: the file system does not support flock (%s); running without the "
                        "one-writer check", path, exc.strerror)
            return None
    return False


def refuse_if_locked(run_dir: Path | None) -> None:
    """:class:`RunDirInUseError` if another process holds ``run_dir``'s lock; creates nothing."""
    if run_dir is None:
        return
    path = RunLayout(run_dir).lock
    if path.resolve() in _HELD:
        return
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return  # no lock file (or an unreadable one: run_lock reports that)
    try:
        if _flock(fd, fcntl.LOCK_SH, path) is False:
            raise _locked_error(path, _holder(fd))
    finally:
        os.close(fd)  # releases the shared lock


@contextlib.contextmanager
def run_lock(run_dir: Path, command: str | None = None) -> Iterator[Path]:
    """Hold the exclusive lock of ``run_dir`` (made if missing) for the ``with`` block, or
    raise :class:`RunDirInUseError` naming the holder; yields the lock file's path."""
    run_dir = Path(run_dir)
    run_dir.mkdir(parents=True, exist_ok=True)
    path = RunLayout(run_dir).lock
    while True:
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        taken = _flock(fd, fcntl.LOCK_EX, path)
        if taken is None:  # no flock on this file system: no lock
            os.close(fd)
            yield path
            return
        if taken is False:
            holder = _holder(fd)
            os.close(fd)
            raise _locked_error(path, holder)
        try:
            if os.path.samestat(os.fstat(fd), os.stat(path)):
                break
        except FileNotFoundError:
            pass
        os.close(fd)  # the previous holder deleted this file as it released it: again
    info = {"pid": os.getpid(), "host": socket.gethostname(),
            "command": command or Path(sys.argv[0]).name,
            "since": datetime.now(timezone.utc).isoformat(timespec="seconds")}
    os.ftruncate(fd, 0)
    os.pwrite(fd, (json.dumps(info) + "\n").encode(), 0)
    key = path.resolve()
    _HELD.add(key)
    try:
        yield path
    finally:
        _HELD.discard(key)
        with contextlib.suppress(OSError):
            path.unlink()  # while still holding it: a waiting process sees a new file
        os.close(fd)
