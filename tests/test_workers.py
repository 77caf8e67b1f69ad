"""A worker process that dies (say the out-of-memory killer) ends the run with a
clear error, never a hang. Each case runs in a subprocess with a time limit: a
hang fails the test instead of holding up the suite."""

import os
import subprocess
import sys
import textwrap

import pytest

from oftimg.synthetic.phantom import sample_params, write_phantom

pytestmark = pytest.mark.slow


# Ctrl-C handled as when Python starts from a terminal: a suite run in the background
# (`make test &` in a script) starts its processes with SIGINT ignored, their spawned
# workers too, and a test that interrupts a worker then hangs (seen: a 120 s timeout)
SIGINT_HANDLED = "import signal; signal.signal(signal.SIGINT, signal.default_int_handler)\n"


def run_python(code: str, timeout: float = 120) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-c", SIGINT_HANDLED + textwrap.dedent(code)],
        capture_output=True,
        text=True,
        timeout=timeout,
    )


def test_a_pool_stuck_on_a_dead_worker_is_broken_not_hung():
    """CPython's pool hangs when a worker dies while sending a result (its manager
    thread waits for the rest of the message). Made to happen for sure here: a
    message cut short in the result pipe, then a worker killed. Without the
    watchdog the task never ends and the shutdown hangs."""
    done = run_python("""
        import os, signal, struct, time
        from oftimg.workers import WorkerLost, closing_executor, make_executor

        pool = make_executor(2)
        try:
            with closing_executor(pool):
                pool.submit(time.sleep, 0.1).result(timeout=60)          # workers up
                # the start of a 1 MB result, and no more: the pool now waits for the rest
                os.write(pool._result_queue._writer.fileno(),
                         struct.pack("!i", 2 ** 20) + b"x" * 10)
                time.sleep(0.5)
                os.kill(next(iter(pool._processes)), signal.SIGKILL)
                pool.submit(time.sleep, 0.1).result(timeout=30)
            print("no error")
        except WorkerLost as exc:
            print("lost:", exc)
        """)
    assert done.returncode == 0, done.stderr
    assert "lost: a worker process was killed by SIGKILL" in done.stdout


def test_ctrl_c_while_a_worker_sends_its_result_does_not_hang_the_shutdown():
    """Ctrl-C reaches the workers too; one interrupted while sending its result
    leaves the same cut-off message, and the shutdown waited on it for good."""
    done = run_python("""
        import os, signal, struct, time
        from oftimg.workers import closing_executor, make_executor

        pool = make_executor(2)
        try:
            with closing_executor(pool):
                pool.submit(time.sleep, 0.1).result(timeout=60)
                os.write(pool._result_queue._writer.fileno(),
                         struct.pack("!i", 2 ** 20) + b"x" * 10)
                time.sleep(0.5)
                os.kill(next(iter(pool._processes)), signal.SIGINT)
                raise KeyboardInterrupt
        except KeyboardInterrupt:
            print("interrupted")
        """)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "interrupted"


def test_run_with_a_killed_worker_says_so_and_writes_nothing(tmp_path):
    """A worker killed as the first frame of the per-frame pass comes back (the
    others still queued or running): the kill is tied to the run's progress, not
    to a clock, so it cannot fall after the workers' last task."""
    data = write_phantom(
        tmp_path / "p", sample_params("normal", 3, n_frames=6, vertices_min=2000, vertices_max=2500)
    )
    out = tmp_path / "out"
    done = run_python(f"""
        import multiprocessing as mp, os, signal, sys
        from oftimg import cli
        from oftimg.analysis import pipeline
        def kill_a_worker():  # the pool's, not the progress bar's SyncManager process
            pool = [p for p in mp.active_children() if p.name.startswith("SpawnProcess")]
            os.kill(pool[0].pid, signal.SIGKILL)

        run_tasks = pipeline.run_tasks

        def run_tasks_killing_a_worker(fn, arg_tuples, *, executor=None, progress=None):
            if fn.__name__ != "process_frame":
                return run_tasks(fn, arg_tuples, executor=executor, progress=progress)
            done = []

            def first_frame_back():
                if not done:
                    done.append(1)
                    kill_a_worker()
                progress()
            return run_tasks(fn, arg_tuples, executor=executor, progress=first_frame_back)

        pipeline.run_tasks = run_tasks_killing_a_worker
        sys.exit(cli.main(["run", {str(data)!r}, "--out", {str(out)!r}, "--jobs", "2",
                           "--quiet"]))
        """)
    assert done.returncode == 1, done.stderr
    assert "oftimg: error: a worker process was killed by SIGKILL" in done.stderr
    assert "--jobs" in done.stderr and "internal error" not in done.stderr
    assert not out.exists() and not (tmp_path / ".out.finished").exists()


def test_a_lost_dask_worker_is_named():
    distributed = pytest.importorskip("distributed")
    from types import SimpleNamespace

    from oftimg.workers import _worker_lost

    exc = distributed.KilledWorker(
        "process_frame-3", SimpleNamespace(address="tcp://node7:4321"), 3
    )
    lost = _worker_lost(exc)
    assert "a Dask worker died while running a task" in str(lost) and "node7" in str(lost)
    assert _worker_lost(ValueError("bad mesh")) is None


def test_a_worker_that_exited_with_an_error_is_not_said_killed_by_sigterm():
    """A worker that fails to start a task (say, oftimg's code changed under a run)
    exits with status 1 and the broken pool sends SIGTERM to the others: the
    message used to say "killed by SIGTERM"."""
    from concurrent.futures.process import BrokenProcessPool
    from types import SimpleNamespace

    from oftimg.workers import _worker_lost

    def pool(*codes):
        return [
            SimpleNamespace(exitcode=c, pid=100 + k, join=lambda timeout: None)
            for k, c in enumerate(codes)
        ]

    exited = str(_worker_lost(BrokenProcessPool("x"), pool(1, -15)))
    assert "ended with exit status 1" in exited and "SIGTERM" not in exited
    assert "killed by SIGKILL" in str(_worker_lost(BrokenProcessPool("x"), pool(-9, -15)))
    assert "killed by SIGTERM" in str(_worker_lost(BrokenProcessPool("x"), pool(-15, -15)))


def test_a_bad_file_descriptor_after_a_worker_died_is_the_lost_worker():
    """CPython's pool can trip over a killed worker's pipes (bpo-39995): the run then
    ended with "[Errno 9] Bad file descriptor" (once, in CI) instead of naming the
    killed worker. Such an error while a worker is dead, raised in the work or by
    the shutdown, is the lost worker; with every worker alive, or a full disk, it
    stays what it is."""
    import errno
    from types import SimpleNamespace

    from oftimg.workers import WorkerLost, _worker_lost, closing_executor, make_executor

    def procs(*codes):
        return [
            SimpleNamespace(exitcode=c, pid=100 + k, join=lambda timeout: None)
            for k, c in enumerate(codes)
        ]

    bad_fd = OSError(errno.EBADF, "Bad file descriptor")
    assert "killed by SIGKILL" in str(_worker_lost(bad_fd, procs(-9, None)))
    assert _worker_lost(bad_fd, procs(None, None)) is None
    assert _worker_lost(OSError(errno.ENOSPC, "No space left on device"), procs(-9)) is None

    for where in ("work", "shutdown"):
        pool = make_executor(2)
        with pytest.raises(WorkerLost, match="killed by SIGKILL") as caught:
            with closing_executor(pool):
                assert pool.submit(os.getpid).result() > 0
                victim = next(iter(pool._processes.values()))
                victim.kill()
                victim.join(10)
                if where == "work":
                    raise OSError(errno.EBADF, "Bad file descriptor")
                shutdown = pool.shutdown

                def shutdown_tripping(**kwargs):
                    shutdown(**kwargs)
                    raise OSError(errno.EBADF, "Bad file descriptor")

                pool.shutdown = shutdown_tripping
        assert isinstance(caught.value.__cause__, OSError), where
    pool = make_executor(2)
    with pytest.raises(OSError, match="No space"):
        with closing_executor(pool):
            pool.submit(os.getpid).result()
            raise OSError(errno.ENOSPC, "No space left on device")


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_workers_end_when_the_main_process_is_killed(tmp_path):
    """Killed by the out-of-memory killer, the main process leaves its workers:
    they end themselves instead of waiting for tasks for good."""
    import os
    import signal
    import time

    data = write_phantom(
        tmp_path / "p", sample_params("normal", 4, n_frames=8, vertices_min=2000, vertices_max=2500)
    )
    main = subprocess.Popen(
        [
            sys.executable,
            "-c",
            "import sys; from oftimg import cli; "
            f"sys.exit(cli.main(['run', {str(data)!r}, '--out', "
            f"{str(tmp_path / 'out')!r}, '--jobs', '2', '--quiet']))",
        ]
    )
    workers = []
    deadline = time.time() + 60
    while len(workers) < 2 and time.time() < deadline and main.poll() is None:
        time.sleep(0.05)
        workers = _worker_pids(main.pid)
    assert len(workers) == 2, "the run did not start its workers"
    main.send_signal(signal.SIGKILL)
    main.wait()

    def alive(pid):
        try:
            return open(f"/proc/{pid}/stat").read().split(")")[-1].split()[0] != "Z"
        except FileNotFoundError:
            return False

    deadline = time.time() + 10
    while any(alive(w) for w in workers) and time.time() < deadline:
        time.sleep(0.1)
    left = [w for w in workers if alive(w)]
    for w in left:
        os.kill(w, signal.SIGKILL)
    assert not left, "workers outlived the main process"


def _worker_pids(main_pid: int) -> list[int]:
    """The main process's pool workers; a child that ends while it is looked at (a
    short-lived helper process) is not one."""

    def cmdline(pid):
        try:
            return open(f"/proc/{pid}/cmdline", "rb").read()
        except OSError:  # ProcessLookupError: gone
            return b""

    children = open(f"/proc/{main_pid}/task/{main_pid}/children").read().split()
    return [int(c) for c in children if b"spawn_main" in cmdline(c)]


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_sigterm_ends_the_run_as_ctrl_c_does(tmp_path):
    """A job scheduler's time limit sends SIGTERM: the run used to die on the spot,
    without a word and with its semaphores leaked. Now it says so (exit status 143),
    stops its workers and writes nothing."""
    import os
    import signal
    import time

    data = write_phantom(
        tmp_path / "p",
        sample_params("normal", 4, n_frames=40, vertices_min=2000, vertices_max=2500),
    )
    out = tmp_path / "out"
    main = subprocess.Popen(
        [
            sys.executable,
            "-c",
            "import sys; from oftimg import cli; "
            f"sys.exit(cli.main(['run', {str(data)!r}, '--out', {str(out)!r}, "
            "'--jobs', '2', '--quiet']))",
        ],
        stderr=subprocess.PIPE,
        text=True,
    )
    workers, deadline = [], time.time() + 60
    while len(workers) < 2 and time.time() < deadline and main.poll() is None:
        time.sleep(0.05)
        workers = _worker_pids(main.pid)
    assert len(workers) == 2, "the run did not start its workers"
    time.sleep(0.5)
    main.send_signal(signal.SIGTERM)
    try:
        err = main.communicate(timeout=60)[1]
    finally:
        main.kill()
    assert main.returncode == 143, err
    assert "oftimg: terminated (SIGTERM); no results were written to --out" in err
    assert "leaked" not in err and "Traceback" not in err
    assert not any(
        os.path.exists(f"/proc/{w}/cmdline")
        and open(f"/proc/{w}/stat").read().split(")")[-1].split()[0] != "Z"
        for w in workers
    )
    assert not out.exists() and not (tmp_path / ".out.finished").exists()


def test_jobs_default_to_the_cores_this_job_may_use(monkeypatch):
    """On a cluster node a job may use 2 of 64 cores: 2 workers, not 64."""
    import os

    from oftimg.workers import make_executor, usable_cpus

    if not hasattr(os, "sched_getaffinity"):
        pytest.skip("no CPU affinity on this system")
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {5, 9})
    monkeypatch.setattr(os, "cpu_count", lambda: 64)
    assert usable_cpus() == 2
    pool = make_executor(None)
    try:
        assert pool._max_workers == 2
    finally:
        pool.shutdown()


def test_available_memory_reads_the_jobs_cgroup(tmp_path):
    """A SLURM job's limit sits on its cgroup or one above the process's own;
    the least room wins, MemAvailable included; 'max' and huge values are no limit."""
    from oftimg.workers import available_memory

    proc, cg = tmp_path / "proc", tmp_path / "cgroup"
    (proc / "self").mkdir(parents=True)
    (proc / "meminfo").write_text("MemTotal: 67108864 kB\nMemAvailable: 33554432 kB\n")

    def files(folder, **values):
        folder.mkdir(parents=True, exist_ok=True)
        for name, value in values.items():
            (folder / name.replace("_", ".", 1)).write_text(f"{value}\n")

    # cgroup v2: the job's limit (3 GB, 1 GB used) one level above the step's ('max')
    (proc / "self" / "cgroup").write_text("0::/slurm/job_7/step_0\n")
    files(cg / "slurm" / "job_7", memory_max=3 * 2**30, memory_current=2**30)
    files(cg / "slurm" / "job_7" / "step_0", memory_max="max", memory_current=2**29)
    assert available_memory(str(proc), str(cg)) == 2 * 2**30
    # cgroup v1, no limit set: MemAvailable (32 GiB)
    (proc / "self" / "cgroup").write_text("4:memory:/user.slice\n3:cpuset:/\n")
    files(
        cg / "memory" / "user.slice",
        memory_limit_in_bytes=9223372036854771712,
        memory_usage_in_bytes=2**30,
    )
    assert available_memory(str(proc), str(cg)) == 32 * 2**30
    # nothing to read (not Linux)
    assert available_memory(str(tmp_path / "none"), str(tmp_path / "none")) is None


def test_usable_cpus_keeps_to_a_containers_cpu_quota(tmp_path, monkeypatch):
    """docker --cpus 1.5 on an 8-core machine: 2 workers (the quota rounded up)."""
    import os

    from oftimg.workers import usable_cpus

    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: set(range(8)), raising=False)
    proc, cg = tmp_path / "proc", tmp_path / "cgroup"
    (proc / "self").mkdir(parents=True)
    (proc / "self" / "cgroup").write_text("0::/docker/abc\n")
    (cg / "docker" / "abc").mkdir(parents=True)
    (cg / "docker" / "abc" / "cpu.max").write_text("150000 100000\n")
    assert usable_cpus(str(proc), str(cg)) == 2
    (cg / "docker" / "abc" / "cpu.max").write_text("max 100000\n")  # no quota
    assert usable_cpus(str(proc), str(cg)) == 8
    (proc / "self" / "cgroup").write_text("2:cpu,cpuacct:/kubepods/pod1\n")  # v1
    (cg / "cpu,cpuacct" / "kubepods" / "pod1").mkdir(parents=True)
    (cg / "cpu,cpuacct" / "kubepods" / "pod1" / "cpu.cfs_quota_us").write_text("300000\n")
    (cg / "cpu,cpuacct" / "kubepods" / "pod1" / "cpu.cfs_period_us").write_text("100000\n")
    assert usable_cpus(str(proc), str(cg)) == 3


def test_a_killed_progress_manager_ends_the_bar_not_the_run():
    """By embryo, workers report frames to a manager process's queue for the bar. If
    that process dies (the out-of-memory killer, say), the reports and the bar stop;
    the embryos' tasks and the run go on (putting to the dead queue raised in every
    task, and closing the bar raised at the end of a run whose results were all made)."""
    import os
    import signal
    import time

    from oftimg import api

    class Bar:  # a bar on a terminal
        shown = reporting = True
        n = 0

        def advance(self, k):
            self.n += k

    bar = Bar()
    with api._frame_counter(None, bar) as queue:
        reports = api._Reports(queue)
        reports.put(2)
        deadline = time.time() + 10
        while bar.n < 2 and time.time() < deadline:
            time.sleep(0.01)
        assert bar.n == 2
        manager = queue._manager._process
        os.kill(manager.pid, signal.SIGKILL)
        manager.join(10)
        reports.put(1)  # no error: the reports end
        assert reports.queue is None
    assert bar.n == 2


def test_a_worker_imports_no_image_figure_or_video_module():
    """Spawned workers import oftimg.workers and oftimg.analysis.per_frame; the package's
    public names are read on first use, so the analysis and figure modules (and
    matplotlib, OpenCV, imageio: 0.3 s of start-up per process) stay out."""
    code = textwrap.dedent("""
        import sys, oftimg.analysis.per_frame, oftimg.workers
        heavy = ("matplotlib", "cv2", "imageio", "skimage", "xarray")
        print(sorted(m for m in sys.modules if m.split(".")[0] in heavy
                     or m in ("oftimg.api", "oftimg.analysis.pipeline", "oftimg.output.figures", "oftimg.output.video")))
    """)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_workers_run_opencv_on_one_thread_and_the_main_process_keeps_its_own(monkeypatch):
    """The workers fill the cores, so each runs OpenCV on one thread (a user's own
    OPENCV_FOR_THREADS_NUM wins); the main process, whose optical flow runs while they
    wait, is left as it was."""
    from oftimg.workers import closing_executor, make_executor

    monkeypatch.delenv("OPENCV_FOR_THREADS_NUM", raising=False)
    with closing_executor(make_executor(2)) as executor:
        assert executor.submit(os.getenv, "OPENCV_FOR_THREADS_NUM").result() == "1"
    assert "OPENCV_FOR_THREADS_NUM" not in os.environ
    monkeypatch.setenv("OPENCV_FOR_THREADS_NUM", "3")
    with closing_executor(make_executor(2)) as executor:
        assert executor.submit(os.getenv, "OPENCV_FOR_THREADS_NUM").result() == "3"


def test_every_public_name_resolves_and_others_do_not():
    import oftimg

    for name in oftimg.__all__:
        assert getattr(oftimg, name) is not None
    assert set(oftimg.__all__) <= set(dir(oftimg))
    assert oftimg.run is oftimg.api.run
    with pytest.raises(AttributeError, match="no_such_name"):
        oftimg.no_such_name
