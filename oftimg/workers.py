"""Where per-frame and per-embryo tasks run: making the executor, closing it, and
what the machine gives a job (:func:`usable_cpus`, :func:`available_memory`).

A local pool's worker can die without an error of oftimg's: the system's
out-of-memory killer, a signal. CPython's ProcessPoolExecutor then fails the
waiting tasks with ``BrokenProcessPool``, except when the worker died while
sending a result (~1 MB per frame): its manager thread then waits for the rest
of a message that never comes, and the run, and the interpreter's exit, hang
(seen here: SIGKILL to a worker mid-run, one time in five; Ctrl-C likewise).
:class:`closing_executor` watches for that and breaks the pool instead, and
reports any lost worker as :class:`WorkerLost`, naming the signal. The other
way round, workers end themselves when the main process is killed.
"""

from __future__ import annotations

import ast
import os
import signal
import sys
import threading
import time
import warnings
from pathlib import Path

from .errors import InputError, OftimgWarning


class WorkerLost(RuntimeError):
    """A worker process (or Dask worker) ended abruptly: killed by the system
    (most often for lack of memory) or by a signal, not by an error in oftimg."""


def make_executor(jobs: int | None, scheduler: str | None = None):
    """Where per-frame tasks run: a Dask cluster at ``scheduler`` (address), a
    process pool for ``jobs`` > 1 workers (default: :func:`usable_cpus`), else
    None (here).

    With a Dask cluster, every worker must see the dataset files at the same
    paths (a shared file system).
    """
    if scheduler:
        try:
            from distributed import Client
        except ImportError:
            raise InputError(
                "--scheduler needs dask.distributed: pip install 'oftimg[dask]'"
            ) from None
        return Client(scheduler).get_executor()
    jobs = usable_cpus() if jobs is None else int(jobs)
    if jobs < 1:
        raise InputError(f"--jobs must be at least 1, found {jobs}")
    if jobs == 1:
        return None
    unguarded = unguarded_script_line()
    if unguarded:
        warnings.warn(
            f"{unguarded}: oftimg was called from a script's top level, outside "
            '`if __name__ == "__main__":`; its worker processes would each run the '
            "script again, so this run stays in one process. Put the call under "
            f"that line to use {jobs} workers",
            OftimgWarning,
            stacklevel=2,
        )
        return None
    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor

    # One thread per worker: the workers already fill the cores, and BLAS or
    # OpenMP threads on top of them made the per-frame sections 1.9x slower
    # (49 frames, 2 jobs). Spawned workers inherit this environment; the user's
    # own setting wins.
    for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(var, "1")
    # glibc's malloc hands every array over 128 kB back to the system when it is
    # freed, so the next one costs page faults (~1400 per frame, 4-7 ms of system
    # time); with these two limits a worker reuses its memory: 8-14 % less time
    # per frame. Both are needed (either alone turns off the adaptive limit and is
    # slower); other C libraries ignore them.
    os.environ.setdefault("MALLOC_MMAP_THRESHOLD_", str(32 * 2**20))  # glibc's maximum
    os.environ.setdefault("MALLOC_TRIM_THRESHOLD_", str(64 * 2**20))
    # spawn: open3d and BLAS threads do not survive fork reliably
    return ProcessPoolExecutor(
        max_workers=jobs,
        mp_context=mp.get_context("spawn"),
        initializer=_start_worker,
        initargs=(os.getpid(),),
    )


def unguarded_script_line() -> str | None:
    """``"script.py:line"`` when this call comes from the top-level code of the
    script Python runs (``python script.py``), outside an ``if __name__ ==
    "__main__":`` block; else None (a guarded call, an import, a notebook,
    ``python -c``, pytest, a docs build). A spawned worker imports that script
    again before it takes a task, so an unguarded call would start the whole run
    again in every worker (and fail there, the output folder being taken)."""
    main = sys.modules.get("__main__")
    path = getattr(main, "__file__", None)
    if not path or not str(path).endswith(".py"):
        return None
    frame = sys._getframe(1)
    while frame is not None and not (
        frame.f_globals is vars(main) and frame.f_code.co_name == "<module>"
    ):
        frame = frame.f_back
    if frame is None:
        return None
    try:
        tree = ast.parse(Path(path).read_text(encoding="utf-8"))
    except (OSError, SyntaxError, ValueError, UnicodeDecodeError):
        return None
    line = frame.f_lineno
    if any(
        isinstance(node, ast.If)
        and _is_main_test(node.test)
        and node.lineno <= line <= node.end_lineno
        for node in ast.walk(tree)
    ):
        return None
    return f"{path}:{line}"


def _is_main_test(test: ast.expr) -> bool:
    """Whether ``test`` is ``__name__ == "__main__"`` (either way round)."""
    if not (
        isinstance(test, ast.Compare) and len(test.ops) == 1 and isinstance(test.ops[0], ast.Eq)
    ):
        return False
    sides = [test.left, test.comparators[0]]
    return any(isinstance(s, ast.Name) and s.id == "__name__" for s in sides) and any(
        isinstance(s, ast.Constant) and s.value == "__main__" for s in sides
    )


def usable_cpus(proc: str = "/proc", cgroup: str = "/sys/fs/cgroup") -> int:
    """The cores this process may run on: on a cluster node those of its job
    (SLURM and PBS confine a job to its cores), and no more than a container's
    CPU quota (docker --cpus, Kubernetes limits: a cgroup's cpu.max), not all
    the machine's."""
    try:
        cores = len(os.sched_getaffinity(0)) or 1
    except AttributeError:  # macOS, Windows: no affinity
        cores = os.cpu_count() or 1
    for values in _cgroup_levels(
        "cpu", ("cpu.max",), ("cpu.cfs_quota_us", "cpu.cfs_period_us"), proc, cgroup
    ):
        quota, period = values[0].split() if len(values) == 1 else values
        if quota.isdigit() and period.isdigit() and int(period) > 0:
            cores = min(cores, max(1, -(-int(quota) // int(period))))
    return cores


def available_memory(proc: str = "/proc", cgroup: str = "/sys/fs/cgroup") -> int | None:
    """Bytes of memory this process's job could still take: the system's
    MemAvailable, or less where a cgroup caps it (a SLURM or PBS job's memory
    limit, on this cgroup or one above it; v1 and v2). None where unknown (not Linux)."""
    room = []
    for line in (_read_text(f"{proc}/meminfo") or "").splitlines():
        if line.startswith("MemAvailable:"):
            room.append(int(line.split()[1]) * 1024)
    for limit, usage in _cgroup_levels(
        "memory",
        ("memory.max", "memory.current"),
        ("memory.limit_in_bytes", "memory.usage_in_bytes"),
        proc,
        cgroup,
    ):
        if limit.isdigit() and usage.isdigit() and int(limit) < 2**60:
            room.append(max(0, int(limit) - int(usage)))
    return min(room) if room else None


def _cgroup_levels(controller: str, v2_files: tuple, v1_files: tuple, proc: str, cgroup: str):
    """The contents (stripped) of a controller's files in this process's cgroup and
    each one above it, v2 (``v2_files``) or v1 (``v1_files``), one tuple per level
    that has them all."""
    for line in (_read_text(f"{proc}/self/cgroup") or "").splitlines():
        _, controllers, path = line.split(":", 2)
        if controllers == "":
            files, bases = v2_files, (cgroup, f"{cgroup}/unified")
        elif controller in controllers.split(","):
            files, bases = v1_files, (f"{cgroup}/{controllers}", f"{cgroup}/{controller}")
        else:
            continue
        parts = [p for p in path.split("/") if p]
        for base in bases:
            for depth in range(len(parts), -1, -1):  # this cgroup, then those above
                folder = "/".join([base] + parts[:depth])
                values = [_read_text(f"{folder}/{f}") for f in files]
                if all(v is not None for v in values):
                    yield tuple(v.strip() for v in values)


def _read_text(path: str) -> str | None:
    try:
        with open(path) as f:
            return f.read()
    except OSError:
        return None


def _start_worker(parent_pid: int) -> None:
    """A worker's start-up: OpenCV on one thread (the workers fill the cores, as for
    BLAS above; set here, not in the main process, whose optical flow runs while the
    workers wait), the user's own setting winning; and :func:`_exit_with_parent`."""
    os.environ.setdefault("OPENCV_FOR_THREADS_NUM", "1")
    _exit_with_parent(parent_pid)


def _exit_with_parent(parent_pid: int, interval: float = 1.0) -> None:
    """A worker's start-up: a thread that ends the worker once the main process
    is gone (killed, say by the out-of-memory killer). Orphaned workers would
    otherwise wait for tasks for good, each holding its memory (~270 MB)."""

    def watch():
        while os.getppid() == parent_pid:
            time.sleep(interval)
        os._exit(1)

    threading.Thread(target=watch, name="oftimg-exit-with-parent", daemon=True).start()


class closing_executor:
    """``with closing_executor(executor):`` shuts it down on leaving (a no-op for
    None). Meanwhile a local pool is watched (:class:`_Watchdog`), and leaving on
    an error that says a worker died raises :class:`WorkerLost` instead."""

    def __init__(self, executor):
        self.executor = executor
        self.watchdog = None

    def __enter__(self):
        from concurrent.futures import ProcessPoolExecutor

        if isinstance(self.executor, ProcessPoolExecutor):
            self.watchdog = _Watchdog(self.executor)
            self.watchdog.start()
        return self.executor

    def __exit__(self, exc_type, exc, tb):
        if self.executor is None:
            return
        cause = exc
        try:
            killed = self.watchdog.killed if self.watchdog is not None else set()
            workers = list((getattr(self.executor, "_processes", None) or {}).values())
            lost = _worker_lost(exc, workers, killed) if exc is not None else None
            try:
                self.executor.shutdown(cancel_futures=True)
            except TypeError:  # Dask's ClientExecutor has no cancel_futures
                self.executor.shutdown()
                self.executor._client.close()  # the connection run() opened
            except OSError as shutdown_error:  # CPython's race on a dead worker's pipes
                if isinstance(exc, KeyboardInterrupt):
                    return  # Ctrl-C ended a worker too: the interrupt is the news
                lost = lost or _worker_lost(shutdown_error, workers, killed)
                if lost is None:
                    raise
                cause = cause or shutdown_error
        finally:  # watched until here: Ctrl-C can end a worker mid-result too
            if self.watchdog is not None:
                self.watchdog.stop()
        if lost is not None:
            raise lost from cause


class _Watchdog(threading.Thread):
    """Breaks a process pool that a dead worker left hanging.

    Every ``interval`` s: has a worker died (exited, not at the shutdown's
    request) while the pool is not broken? The pool notices a dead worker within
    milliseconds, unless its manager thread is stuck reading a result the worker
    did not finish sending; after ``grace`` s the other workers are killed (they
    may wait on the queue lock the dead one held) and this process's end of the
    result pipe is closed, so the manager thread reads end-of-file, marks the
    pool broken and fails every waiting task with ``BrokenProcessPool``. Uses
    the pool's private ``_processes``, ``_broken`` and ``_result_queue``
    (CPython's, read on 3.11); without them it does nothing.
    """

    def __init__(self, pool, interval: float = 0.5, grace: float = 2.0):
        super().__init__(name="oftimg-pool-watchdog", daemon=True)
        self.pool, self.interval, self.grace = pool, interval, grace
        self.killed: set[int] = set()  # pids of the workers this killed
        self._stopped = threading.Event()

    def stop(self) -> None:
        self._stopped.set()
        self.join()

    def run(self) -> None:
        dead_since = None
        while not self._stopped.wait(self.interval):
            processes = getattr(self.pool, "_processes", None)
            if getattr(self.pool, "_broken", False) or processes is None:
                return  # broken as it should, or shut down
            if all(p.exitcode in (None, 0) for p in list(processes.values())):
                continue  # 0: a worker leaving at the shutdown
            dead_since = dead_since or time.monotonic()
            if time.monotonic() - dead_since >= self.grace:
                self._break(list(processes.values()))
                return

    def _break(self, processes) -> None:
        for p in processes:
            if p.exitcode is None:
                self.killed.add(p.pid)
                p.kill()
        for p in processes:
            p.join(5)
        try:
            self.pool._result_queue._writer.close()
        except (AttributeError, OSError):
            pass


def _one_died(processes, wait_s: float = 0.5) -> bool:
    """Has one of ``processes`` ended with an error? Waits up to ``wait_s`` for one to
    say so: a killed process closes its pipes before its exit status can be read,
    so a pipe error can come first (seen with the pool's workers)."""
    if not processes:  # a Dask cluster's, or none: nothing to wait for
        return False
    deadline = time.monotonic() + wait_s
    while not any(p.exitcode not in (None, 0) for p in processes):
        if time.monotonic() >= deadline:
            return False
        time.sleep(0.01)
    return True


def _worker_lost(exc: BaseException, processes=(), killed=frozenset()) -> WorkerLost | None:
    """:class:`WorkerLost` for ``exc`` if it says a worker died (a broken process
    pool, Dask's KilledWorker; or a bad file descriptor or broken pipe while one
    of the pool's worker ``processes`` has died: CPython's pool can trip over the
    dead worker's pipes, bpo-39995, seen here once in CI), naming the signal that
    ended it (not counting the workers in ``killed``, nor the SIGTERM a broken
    pool sends the others); else None (a full disk stays a full disk)."""
    import errno
    from concurrent.futures.process import BrokenProcessPool

    pipes = (
        isinstance(exc, OSError)
        and exc.errno in (errno.EBADF, errno.EPIPE)
        and _one_died(processes)
    )
    if isinstance(exc, BrokenProcessPool) or pipes:
        for p in processes:  # a submit can fail before the pool has ended them all
            try:
                p.join(1.0)
            except (OSError, ValueError):  # already reaped and closed by the pool
                pass
        codes = {p.exitcode for p in processes if p.exitcode and p.pid not in killed}
        signals = sorted(
            signal.Signals(-c).name for c in codes if c < 0 and -c in signal.valid_signals()
        )
        statuses = sorted(c for c in codes if c > 0)
        if len(codes) > 1 and "SIGTERM" in signals:  # the broken pool's, to the others
            signals.remove("SIGTERM")
        if signals:
            how = f"was killed by {', '.join(signals)}"
            if "SIGKILL" in signals:
                how += " (on Linux most often the out-of-memory killer)"
        elif statuses:
            how = (
                f"ended with exit status {', '.join(map(str, statuses))} (its error, if "
                "it printed one, is above)"
            )
        else:
            how = "ended abruptly"
        what = "a worker process"
    elif type(exc).__name__ == "KilledWorker":  # dask.distributed
        what, how = "a Dask worker", f"died while running a task ({exc})"
    else:
        return None
    if "exit status" in how:  # an error of its own, printed above: not memory
        return WorkerLost(f"{what} {how}")
    return WorkerLost(
        f"{what} {how}. If memory ran short, run again with fewer --jobs "
        "(by embryo, each worker holds a whole embryo: about 0.35 GB + 3 MB "
        "per frame) or with more memory"
    )
