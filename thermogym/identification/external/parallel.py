"""Evaluating non-batched external models: serially, in local processes, on Ray.

Paper 000 (``000_24627a5308ee07db.txt``, section 4.2.4) took 60 minutes of
Monte Carlo because each parameter set was one script call. External models
cannot be vectorised, but independent parameter sets can run side by side:

``process`` (default)
    A pool of local worker processes, started on the first call and reused
    until :meth:`Executor.close`. Each worker sets the adapter up once
    (compiles the script, starts Octave, loads the FMU) and evaluates the
    parameter sets it is handed, ``chunksize`` at a time, reporting each
    result as soon as it is done.
``ray``
    The same with Ray actors (one CPU each), on the running Ray instance or
    cluster, or on a local one started with the options given
    (``ray.init(**ray_options)``; the instance is left running for others).
``serial``
    One after the other in this process (debugging; timeouts are soft only).

Results come back in the order of the parameter sets and are computed by
the same function (:func:`~._evaluate.evaluate_task`) whichever the backend,
so they are identical.

Time limits
-----------
Each evaluation has ``timeout`` seconds. Inside the worker a signal
interrupts Python code that overruns (the worker survives and goes on);
subprocess-based adapters (batch jobs, Octave) stop their child themselves.
A worker that still has not answered ``kill_grace`` seconds later (stuck in
compiled code, or it ignores signals) is killed with its whole process group,
the evaluation is reported as timed out, the rest of its chunk is handed to a
fresh worker, and the run goes on. A worker that dies (segmentation fault in
an FMU, ``os._exit``) is reported and replaced the same way.

Local workers and time limits rely on POSIX (Linux, macOS): socket pairs
passed to the child, process groups and ``SIGALRM``; on other systems use
``serial`` or ``ray``.

Why not ``concurrent.futures.ProcessPoolExecutor``: it cannot stop a hung
evaluation (``kill_workers`` arrives only in Python 3.14) and a killed worker
breaks the whole pool; pebble's pool applies its timeout per chunk. This
small pool on :mod:`multiprocessing` kills and replaces single workers and
streams results per evaluation, which per-evaluation timeouts need.
"""

from __future__ import annotations

import contextlib
import logging
import math
import os
import pickle
import signal
import socket
import subprocess
import sys
import time as _time
import weakref
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass, field
from multiprocessing.connection import Connection
from multiprocessing.connection import wait as _mp_wait
from typing import Any

import cloudpickle

from thermogym.errors import ConfigError, ExternalModelError
from thermogym.identification.external._evaluate import (
    Evaluator,
    ExperimentData,
    Result,
    Task,
    WorkerStats,
    evaluate_task,
)

__all__ = [
    "Executor",
    "ProcessExecutor",
    "RayExecutor",
    "SerialExecutor",
    "available_cpus",
    "make_executor",
]

log = logging.getLogger(__name__)

#: Seconds a worker may take to start and set its adapter up.
STARTUP_TIMEOUT = 120.0
#: Experiments a worker keeps (an optimisation cycles through a few recordings).
_EXP_CACHE = 8


def available_cpus() -> int:
    """CPUs this process may use (affinity-aware)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not on Linux
        return max(1, os.cpu_count() or 1)


def default_kill_grace(timeout: float | None) -> float:
    """Extra seconds after ``timeout`` before an unresponsive worker is killed."""
    if timeout is None:
        return math.inf
    return max(2.0, 0.25 * timeout)


def _dumps(evaluator: Evaluator) -> bytes:
    """Pickle the evaluator for the workers.

    cloudpickle (when installed) sends importable functions by reference and
    the others (defined in ``__main__``, closures, lambdas) by value; plain
    pickle only handles importable ones.
    """
    try:
        dumps = cloudpickle.dumps
    except ImportError:  # pragma: no cover - cloudpickle comes with the package
        dumps = pickle.dumps
    try:
        return dumps(evaluator, protocol=pickle.HIGHEST_PROTOCOL)
    except Exception as e:
        raise ConfigError(
            f"{evaluator.label} cannot be sent to worker processes ({type(e).__name__}: {e}); "
            "define the function at module level, or use backend='serial'"
        ) from e


class Executor:
    """Runs tasks of one evaluator; results in task order.

    Attributes
    ----------
    backend : str
    workers : int
        Most workers used at once.
    stats : WorkerStats
        Start-up time, workers started and killed, evaluations and failures.
    """

    backend = "serial"

    def __init__(
        self,
        evaluator: Evaluator,
        *,
        timeout: float | None,
        kill_grace: float | None = None,
        workers: int | None = None,
        chunksize: int | None = None,
    ) -> None:
        self.evaluator = evaluator
        self.timeout = timeout
        self.kill_grace = default_kill_grace(timeout) if kill_grace is None else float(kill_grace)
        self.workers = int(workers) if workers is not None else available_cpus()
        self.chunksize = chunksize
        self.stats = WorkerStats()
        self.closed = False

    def map(self, exp: ExperimentData, tasks: Sequence[Task]) -> list[Result]:
        """Evaluate ``tasks`` on ``exp``; one :data:`Result` per task, in order."""
        raise NotImplementedError

    def close(self) -> None:
        """Stop the workers; a later :meth:`map` starts new ones."""
        self.closed = True

    def _count(self, results: Sequence[Result]) -> None:
        self.stats.evaluations += len(results)
        self.stats.failed += sum(r[1] is not None for r in results)
        self.stats.eval_s += sum(r[2] for r in results)


class SerialExecutor(Executor):
    """Evaluate one after the other in this process (soft timeouts only)."""

    backend = "serial"

    def __init__(self, evaluator: Evaluator, **kwargs: Any) -> None:
        kwargs["workers"] = 1
        super().__init__(evaluator, **kwargs)

    def map(self, exp: ExperimentData, tasks: Sequence[Task]) -> list[Result]:
        """Evaluate ``tasks`` in order in this process."""
        if not self.evaluator._ready:
            t0 = _time.perf_counter()
            try:
                self.evaluator.ensure_setup()
            except Exception as e:
                msg = f"{self.evaluator.label} could not be set up: {type(e).__name__}: {e}"
                return [(None, msg, 0.0) for _ in tasks]
            self.stats.startup_s += _time.perf_counter() - t0
            self.stats.workers_started += 1
        results = [evaluate_task(self.evaluator, exp, t, self.timeout) for t in tasks]
        self._count(results)
        return results

    def close(self) -> None:
        """Release what the evaluator set up in this process."""
        if self.evaluator._ready:
            with contextlib.suppress(Exception):
                self.evaluator.teardown()
            self.evaluator._ready = False
        super().close()


# --------------------------------------------------------------------- pooled
@dataclass
class _Slot:
    """One worker (process or actor) and the tasks it holds, in order."""

    handle: Any = None
    queue: deque[int] = field(default_factory=deque)
    refs: deque[Any] = field(default_factory=deque)  # Ray object refs, parallel to queue
    since: float = 0.0  # when the task at the head started (the last progress)
    exps: list[str] = field(default_factory=list)  # keys the worker holds, oldest first
    disabled: bool = False  # a replacement worker could not be started


class _PoolExecutor(Executor):
    """Scheduler shared by the process and Ray backends."""

    def __init__(self, evaluator: Evaluator, **kwargs: Any) -> None:
        super().__init__(evaluator, **kwargs)
        self._payload = _dumps(evaluator)
        self._slots: list[_Slot] = []
        self._setup_error: str | None = None

    # backend hooks ------------------------------------------------------
    def _start(self, n: int) -> list[Any]:
        raise NotImplementedError

    def _submit(self, slot: _Slot, exp: ExperimentData, tasks: list[Task]) -> None:
        raise NotImplementedError

    def _poll(self, slots: list[_Slot], timeout: float | None) -> list[tuple[_Slot, str, Any]]:
        """Events ``(slot, "result", Result)`` or ``(slot, "dead", reason)``."""
        raise NotImplementedError

    def _kill(self, slot: _Slot) -> None:
        raise NotImplementedError

    def _begin_map(self, exp: ExperimentData) -> None:
        """Called once per :meth:`map` before the first submit."""

    def close(self) -> None:
        """Forget a set-up failure too: the next call tries to start workers again."""
        self._setup_error = None
        super().close()

    # scheduler -----------------------------------------------------------
    def _ensure_workers(self, n: int) -> None:
        alive = [s for s in self._slots if s.handle is not None]
        self._slots = [s for s in alive if not s.disabled]
        missing = n - len(self._slots)
        if missing <= 0:
            return
        t0 = _time.perf_counter()
        handles = self._start(missing)
        took = _time.perf_counter() - t0
        self.stats.startup_s += took
        self.stats.workers_started += len(handles)
        self._slots.extend(_Slot(handle=h) for h in handles)
        log.info(
            "started %d %s worker(s) for %s in %.2f s",
            len(handles),
            self.backend,
            self.evaluator.label,
            took,
        )

    def _chunk(self, n_tasks: int, n_workers: int) -> int:
        if self.chunksize is not None:
            return self.chunksize
        return max(1, math.ceil(n_tasks / (4 * n_workers)))

    def _replace(self, slot: _Slot) -> None:
        self._kill(slot)
        self.stats.workers_killed += 1
        slot.queue.clear()
        slot.refs.clear()
        slot.exps.clear()
        slot.handle = None

    def map(self, exp: ExperimentData, tasks: Sequence[Task]) -> list[Result]:
        """Evaluate ``tasks`` on the workers; results in task order."""
        if not tasks:
            return []
        if self._setup_error is not None:
            return [(None, self._setup_error, 0.0) for _ in tasks]
        self.closed = False
        n_workers = max(1, min(self.workers, len(tasks)))
        try:
            # all workers start together on first use (their start-ups overlap), so
            # that a first call with one parameter set does not serialise them later
            self._ensure_workers(self.workers)
        except _SetupFailed as e:
            self.close()
            self._setup_error = str(e)  # kept until close(): every set would fail alike
            return [(None, self._setup_error, 0.0) for _ in tasks]
        slots = self._slots[:n_workers]
        self._begin_map(exp)
        chunk = self._chunk(len(tasks), n_workers)
        hard = None if self.timeout is None else self.timeout + self.kill_grace
        results: list[Result | None] = [None] * len(tasks)
        pending: deque[int] = deque(range(len(tasks)))
        try:
            while True:
                for s in slots:
                    if s.queue or not pending or s.disabled:
                        continue
                    if s.handle is None:  # replaced after a kill: start a fresh worker
                        t0 = _time.perf_counter()
                        try:
                            s.handle = self._start(1)[0]
                        except _SetupFailed as e:
                            self._setup_error = str(e)
                            s.disabled = True
                            continue
                        self.stats.startup_s += _time.perf_counter() - t0
                        self.stats.workers_started += 1
                    take = [pending.popleft() for _ in range(min(chunk, len(pending)))]
                    s.since = _time.monotonic()
                    s.queue.extend(take)
                    self._submit(s, exp, [tasks[p] for p in take])
                busy = [s for s in slots if s.queue]
                if not busy:
                    if pending:  # no worker could be (re)started
                        msg = self._setup_error or "no worker available"
                        for p in pending:
                            results[p] = (None, msg, 0.0)
                        pending.clear()
                    break
                wait = None
                if hard is not None:
                    now = _time.monotonic()
                    wait = max(0.0, min(s.since + hard for s in busy) - now)
                for s, kind, payload in self._poll(busy, wait):
                    if not s.queue:
                        continue
                    p = s.queue.popleft()
                    if s.refs:
                        s.refs.popleft()
                    if kind == "result":
                        results[p] = payload
                        s.since = _time.monotonic()
                    else:  # the worker died while evaluating task p
                        results[p] = (None, f"{self.evaluator.label}: {payload}", 0.0)
                        pending.extendleft(reversed(s.queue))
                        self._replace(s)
                if hard is not None:
                    now = _time.monotonic()
                    for s in slots:
                        if s.queue and now - s.since >= hard:
                            p = s.queue.popleft()
                            results[p] = (
                                None,
                                f"evaluation timed out after {self.timeout:g} s (the worker did "
                                f"not respond within {self.kill_grace:g} s more and was killed)",
                                now - s.since,
                            )
                            pending.extendleft(reversed(s.queue))
                            self._replace(s)
                            log.warning(
                                "killed a worker of %s after a timeout", self.evaluator.label
                            )
        except BaseException:
            # interrupted (Ctrl-C) or a bug: busy workers are mid-evaluation, stop them
            for s in slots:
                if s.queue:
                    self._replace(s)
            raise
        out = [r if r is not None else (None, "not evaluated", 0.0) for r in results]
        self._count(out)
        return out


class _SetupFailed(ExternalModelError):
    """A worker could not set the adapter up (every evaluation would fail alike)."""


# ------------------------------------------------------------ local processes
# A worker is a fresh interpreter started with subprocess (not multiprocessing's
# spawn, which re-runs the user's main script in every worker and fails without
# an ``if __name__ == "__main__"`` guard). It talks to the parent over a socket
# pair wrapped in multiprocessing.connection.Connection; the parent's sys.path
# is sent first, so everything the parent imports can be imported there too.
_BOOT = (
    "import sys\n"
    "from multiprocessing.connection import Connection\n"
    "c = Connection(int(sys.argv[1]))\n"
    "sys.path[:0] = [p for p in c.recv() if p not in sys.path]\n"
    "from thermogym.identification.external.parallel import _process_worker\n"
    "_process_worker(c)\n"
)


def _process_worker(conn: Connection) -> None:
    """Main function of a local worker process."""
    try:
        payload = conn.recv()
        evaluator: Evaluator = pickle.loads(payload)
        evaluator.ensure_setup()
    except BaseException as e:
        label = getattr(locals().get("evaluator"), "label", "external model")
        with contextlib.suppress(Exception):
            conn.send(("setup_failed", f"{label} could not be set up: {type(e).__name__}: {e}"))
        return
    conn.send(("ready", os.getpid()))
    exps: dict[str, ExperimentData] = {}
    try:
        while True:
            try:
                msg = conn.recv()
            except (EOFError, OSError):
                break
            if msg[0] == "stop":
                break
            if msg[0] == "exp":
                exp: ExperimentData = msg[1]
                exps[exp.key] = exp
                while len(exps) > _EXP_CACHE:
                    exps.pop(next(iter(exps)))
            elif msg[0] == "run":
                _, key, tasks, timeout = msg
                for task in tasks:
                    if key in exps:
                        res = evaluate_task(evaluator, exps[key], task, timeout)
                    else:  # pragma: no cover - the parent mirrors this cache
                        res = (None, "internal error: experiment data missing in the worker", 0.0)
                    conn.send(("result", task.index, res))
    finally:
        with contextlib.suppress(Exception):
            evaluator.teardown()


@dataclass
class _Proc:
    process: subprocess.Popen[bytes]
    conn: Connection

    def alive(self) -> bool:
        return self.process.poll() is None


def _stop_processes(procs: list[_Proc], graceful: bool = True) -> None:
    """Stop worker processes (also called by a finaliser at exit)."""
    if graceful:
        for p in procs:
            with contextlib.suppress(Exception):
                p.conn.send(("stop",))
        deadline = _time.monotonic() + 5.0
        for p in procs:
            with contextlib.suppress(subprocess.TimeoutExpired):
                p.process.wait(max(0.0, deadline - _time.monotonic()))
    for p in procs:
        if p.alive():
            _kill_proc(p)
        with contextlib.suppress(Exception):
            p.conn.close()
    procs.clear()


def _kill_proc(p: _Proc) -> None:
    """Kill a worker with its process group (Octave, batch-job children)."""
    if hasattr(os, "killpg"):
        with contextlib.suppress(OSError):
            os.killpg(p.process.pid, signal.SIGKILL)
    with contextlib.suppress(Exception):
        p.process.kill()
    with contextlib.suppress(subprocess.TimeoutExpired):
        p.process.wait(5.0)


class ProcessExecutor(_PoolExecutor):
    """A pool of local worker processes (see the module docstring)."""

    backend = "process"

    def __init__(self, evaluator: Evaluator, **kwargs: Any) -> None:
        super().__init__(evaluator, **kwargs)
        self._procs: list[_Proc] = []
        self._finalizer = weakref.finalize(self, _stop_processes, self._procs, False)

    def _launch(self) -> _Proc:
        parent_sock, child_sock = socket.socketpair()
        fd = child_sock.fileno()
        try:
            proc = subprocess.Popen(
                [sys.executable, "-c", _BOOT, str(fd)],
                pass_fds=(fd,),
                stdin=subprocess.DEVNULL,
                start_new_session=True,  # own process group: a kill reaches its children
            )
        finally:
            child_sock.close()
        conn = Connection(parent_sock.detach())
        conn.send(list(sys.path))
        conn.send(self._payload)
        return _Proc(proc, conn)

    def _start(self, n: int) -> list[Any]:
        new = [self._launch() for _ in range(n)]
        self._procs.extend(new)
        deadline = _time.monotonic() + STARTUP_TIMEOUT
        waiting = list(new)
        error = None
        while waiting:
            ready = _mp_wait([p.conn for p in waiting], max(0.0, deadline - _time.monotonic()))
            if not ready:
                error = f"{self.evaluator.label}: worker did not start within {STARTUP_TIMEOUT:g} s"
                break
            for p in [w for w in waiting if w.conn in ready]:
                waiting.remove(p)
                try:
                    msg = p.conn.recv()
                except (EOFError, OSError):
                    with contextlib.suppress(subprocess.TimeoutExpired):
                        p.process.wait(2.0)
                    error = (
                        f"{self.evaluator.label}: worker process exited while starting "
                        f"(exit code {p.process.returncode})"
                    )
                    continue
                if msg[0] != "ready":
                    error = msg[1]
        if error is not None:
            for p in new:
                self._procs.remove(p)
            _stop_processes(new, graceful=False)
            raise _SetupFailed(error)
        return new

    def _submit(self, slot: _Slot, exp: ExperimentData, tasks: list[Task]) -> None:
        p: _Proc = slot.handle
        try:
            if exp.key not in slot.exps:
                p.conn.send(("exp", exp))
                slot.exps.append(exp.key)  # the worker keeps the last _EXP_CACHE, like this
                del slot.exps[:-_EXP_CACHE]
            p.conn.send(("run", exp.key, tasks, self.timeout))
        except OSError:
            pass  # the worker died; _poll reports it

    def _poll(self, slots: list[_Slot], timeout: float | None) -> list[tuple[_Slot, str, Any]]:
        by_conn: dict[Any, _Slot] = {s.handle.conn: s for s in slots}
        # wake up now and then to notice a dead worker whose socket stays open
        ready = _mp_wait(list(by_conn), 5.0 if timeout is None else min(timeout, 5.0))
        events = []
        for ready_conn in ready:
            s = by_conn[ready_conn]  # wait() hands back the connections it was given
            c = s.handle.conn
            try:
                while c.poll():
                    msg = c.recv()
                    if msg[0] != "result":
                        raise ExternalModelError(f"unexpected message {msg[0]!r} from a worker")
                    events.append((s, "result", msg[2]))
            except (EOFError, OSError):
                with contextlib.suppress(subprocess.TimeoutExpired):
                    s.handle.process.wait(2.0)
                events.append((s, "dead", _exit_reason(s.handle.process.returncode)))
        for s in slots:
            if s.handle.conn not in ready and not s.handle.alive():
                events.append((s, "dead", _exit_reason(s.handle.process.returncode)))
        return events

    def _kill(self, slot: _Slot) -> None:
        p: _Proc = slot.handle
        _kill_proc(p)
        with contextlib.suppress(Exception):
            p.conn.close()
        if p in self._procs:
            self._procs.remove(p)

    def close(self) -> None:
        """Stop the worker processes (they tear their adapter down first)."""
        _stop_processes(self._procs, graceful=True)
        self._slots = []
        super().close()


def _exit_reason(code: int | None) -> str:
    if code is not None and code < 0:
        try:
            name = signal.Signals(-code).name
        except ValueError:
            name = str(-code)
        return f"the worker process died of signal {name} during this evaluation"
    return f"the worker process exited (code {code}) during this evaluation"


# ------------------------------------------------------------------------ Ray
class _RayWorker:
    """Ray actor holding one set-up evaluator (wrapped with ``ray.remote`` lazily)."""

    def __init__(self, payload: bytes) -> None:
        self.error: str | None = None
        self.exps: dict[str, ExperimentData] = {}
        try:
            self.evaluator: Evaluator = pickle.loads(payload)
            self.evaluator.ensure_setup()
        except Exception as e:
            label = getattr(getattr(self, "evaluator", None), "label", "external model")
            self.error = f"{label} could not be set up: {type(e).__name__}: {e}"

    def ready(self) -> tuple[int, str | None]:
        return os.getpid(), self.error

    def run(self, key: str, holder: list[Any], task: Task, timeout: float | None) -> Result:
        import ray

        exp = self.exps.get(key)
        if exp is None:
            exp = ray.get(holder[0])
            self.exps[key] = exp
            while len(self.exps) > _EXP_CACHE:
                self.exps.pop(next(iter(self.exps)))
        return evaluate_task(self.evaluator, exp, task, timeout)

    def stop(self) -> None:
        with contextlib.suppress(Exception):
            self.evaluator.teardown()


class RayExecutor(_PoolExecutor):
    """Ray actors, one CPU each (see the module docstring)."""

    backend = "ray"

    def __init__(
        self, evaluator: Evaluator, *, ray_options: dict[str, Any] | None = None, **kwargs: Any
    ) -> None:
        try:
            import ray
        except ImportError as e:
            raise ConfigError("backend 'ray' needs Ray (pip install 'thermogym[ray]')") from e
        self._ray = ray
        if not ray.is_initialized():
            opts: dict[str, Any] = {"include_dashboard": False, "log_to_driver": False}
            opts.update(ray_options or {})
            ray.init(**opts)
        if kwargs.get("workers") is None:
            kwargs["workers"] = max(1, int(ray.cluster_resources().get("CPU", 1)))
        super().__init__(evaluator, **kwargs)
        self._actor_cls = ray.remote(num_cpus=1, max_restarts=0)(_RayWorker)
        self._exp_ref: Any = None

    def _start(self, n: int) -> list[Any]:
        ray = self._ray
        # ray actor handles: their methods gain .remote (not in ray's stubs)
        actors: list[Any] = [self._actor_cls.remote(self._payload) for _ in range(n)]
        try:
            answers = ray.get([a.ready.remote() for a in actors], timeout=STARTUP_TIMEOUT)
        except Exception as e:
            for a in actors:
                with contextlib.suppress(Exception):
                    ray.kill(a, no_restart=True)
            raise _SetupFailed(f"{self.evaluator.label}: Ray actors did not start: {e}") from e
        errors = [err for _, err in answers if err]
        if errors:
            for a in actors:
                with contextlib.suppress(Exception):
                    ray.kill(a, no_restart=True)
            raise _SetupFailed(errors[0])
        return actors

    def _begin_map(self, exp: ExperimentData) -> None:
        self._exp_ref = self._ray.put(exp)

    def _submit(self, slot: _Slot, exp: ExperimentData, tasks: list[Task]) -> None:
        for t in tasks:
            slot.refs.append(slot.handle.run.remote(exp.key, [self._exp_ref], t, self.timeout))

    def _poll(self, slots: list[_Slot], timeout: float | None) -> list[tuple[_Slot, str, Any]]:
        ray = self._ray
        heads = {s.refs[0]: s for s in slots if s.refs}
        ray.wait(list(heads), num_returns=1, timeout=5.0 if timeout is None else min(timeout, 5.0))
        events = []
        for s in slots:
            refs = list(s.refs)
            done, _ = ray.wait(refs, num_returns=len(refs), timeout=0)
            done_set = set(done)
            for r in refs:  # actor calls finish in order: take the finished prefix
                if r not in done_set:
                    break
                try:
                    events.append((s, "result", ray.get(r)))
                except Exception as e:
                    events.append((s, "dead", f"the Ray actor died during this evaluation ({e})"))
                    break
        return events

    def _kill(self, slot: _Slot) -> None:
        with contextlib.suppress(Exception):
            self._ray.kill(slot.handle, no_restart=True)

    def close(self) -> None:
        """Stop the actors (the Ray instance itself is left running)."""
        ray = self._ray
        actors = [s.handle for s in self._slots if s.handle is not None]
        if actors and ray.is_initialized():
            with contextlib.suppress(Exception):
                ray.get([a.stop.remote() for a in actors], timeout=10.0)
            for a in actors:
                with contextlib.suppress(Exception):
                    ray.kill(a, no_restart=True)
        self._slots = []
        self._exp_ref = None
        super().close()


def make_executor(
    evaluator: Evaluator,
    *,
    backend: str = "process",
    timeout: float | None,
    kill_grace: float | None = None,
    workers: int | None = None,
    chunksize: int | None = None,
    ray_options: dict[str, Any] | None = None,
) -> Executor:
    """Build the executor of ``backend`` (``process``, ``ray`` or ``serial``).

    Parameters
    ----------
    evaluator : Evaluator
    backend : {"process", "ray", "serial"}
    timeout : float or None
        Time limit of one evaluation [s].
    kill_grace : float, optional
        Seconds after ``timeout`` before an unresponsive worker is killed
        (default ``max(2, timeout / 4)``).
    workers, chunksize : int, optional
    ray_options : dict, optional
        ``ray.init`` keyword arguments when no Ray instance runs.

    Returns
    -------
    Executor
    """
    common = dict(timeout=timeout, kill_grace=kill_grace, workers=workers, chunksize=chunksize)
    if backend == "serial":
        return SerialExecutor(evaluator, **common)
    if backend == "process":
        return ProcessExecutor(evaluator, **common)
    if backend == "ray":
        return RayExecutor(evaluator, ray_options=ray_options, **common)
    raise ConfigError(f"backend is {backend!r}, expected 'process', 'ray' or 'serial'")
