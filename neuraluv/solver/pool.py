"""Several solver batches at once: in forked worker processes, or in threads.

A round of a batch is a few hundred small torch calls, each of which gives up
the interpreter lock and takes it back. Two batches in two threads of one
process therefore wait on each other; two processes do not. On Linux, CPU
batches are optimised in **forked** children (:func:`map_batches`,
``pool="process"``): the child inherits the prepared charts and torch already
loaded (no pickling of the inputs, no second import), runs one batch on one
torch thread (GNU OpenMP's pool does not survive ``fork``), sends the result
back through a pipe and ends with ``os._exit`` (nothing of the parent's is
flushed or torn down twice); there are as many children as torch may use
threads. A child that ends without a result (killed, out of memory) has its
batch run again in the parent, so a solve never loses a batch to its pool.
"""
from __future__ import annotations

import os
import pickle
import signal
import sys
import time
import warnings

import torch

__all__ = ["BATCH_WORKERS", "LATE", "batch_workers", "batch_pool", "map_batches", "split_even"]

#: Batches optimised at once on the CPU (``workers="auto"``), when torch may use as many threads.
BATCH_WORKERS = 2


def batch_workers(workers, device, pool="thread"):
    """Batches to optimise at once: ``workers``, or for ``"auto"`` on the CPU where torch may use several threads:
    one per torch thread in forked processes (``pool="process"``, each child on one thread), else
    :data:`BATCH_WORKERS` threads; 1 on CUDA or where torch may use one thread.

    Examples
    --------
    >>> batch_workers(3, "cpu"), batch_workers("auto", "cuda")
    (3, 1)
    """
    if workers != "auto":
        return max(1, int(workers))
    n = torch.get_num_threads()
    if torch.device(device).type != "cpu" or n < 2:
        return 1
    return n if pool == "process" else min(BATCH_WORKERS, n)


def batch_pool(pool, device):
    """How batches run at once: ``"process"`` (forked children) or ``"thread"``.

    ``"auto"`` is ``"process"`` on Linux for CPU batches (where ``fork`` is safe with torch's
    CPU thread pools once a child uses one thread per batch), else ``"thread"``; the environment
    variable ``NEURALUV_BATCH_POOL`` (``process`` or ``thread``) overrides ``"auto"``.

    Examples
    --------
    >>> batch_pool("thread", "cpu"), batch_pool("auto", "cuda")
    ('thread', 'thread')
    """
    if pool not in ("auto", "process", "thread"):
        raise ValueError(f"pool must be 'auto', 'process' or 'thread', not {pool!r}")
    if pool == "auto":
        pool = os.environ.get("NEURALUV_BATCH_POOL", "auto")
        if pool not in ("auto", "process", "thread"):
            raise ValueError(f"NEURALUV_BATCH_POOL must be 'process' or 'thread', not {pool!r}")
    if pool == "thread" or torch.device(device).type != "cpu" or not hasattr(os, "fork"):
        return "thread"
    if pool == "auto" and not sys.platform.startswith("linux"):
        return "thread"
    return "process"


def split_even(cost, n):
    """Items split into at most ``n`` groups of about equal total cost (largest first, each to the lightest group).

    Parameters
    ----------
    cost : (k,) float array-like
    n : int

    Returns
    -------
    list of list of int
        Non-empty groups of item indices, each costliest item first.

    Examples
    --------
    >>> split_even([5, 1, 4, 2, 3], 2)
    [[0, 3, 1], [2, 4]]
    """
    groups, load = [[] for _ in range(max(1, n))], [0.0] * max(1, n)
    for i in sorted(range(len(cost)), key=lambda i: -cost[i]):
        g = load.index(min(load))
        groups[g].append(i)
        load[g] += cost[i]
    return [g for g in groups if g]


#: Seconds past the solve's deadline after which a forked child still running is taken for hung: it is ended and
#: its batch run again in the parent (which stops at once, at the deadline, with its start map).
LATE = 30.0


def map_batches(run, groups, a, n_workers, cost, pool="thread", deadline=None):
    """``(idx, run(idx, a))`` for every group, yielded as the groups finish.

    Parameters
    ----------
    run : callable
        ``run(idx, a)`` optimises the batch of charts ``idx`` (attempt ``a``); its result must pickle
        for ``pool="process"``.
    groups : list of list of int
    a : int
    n_workers : int
        Batches at once; 1 (or one group): in order, in this thread.
    cost : list of float
        Per group; the costliest groups start first.
    pool : ``"process"`` or ``"thread"`` (see :func:`batch_pool`)
    deadline : float, optional
        The solve's ``time.perf_counter()`` deadline; a forked child still running :data:`LATE`
        seconds after it is ended, with a warning, and its batch run here.

    Notes
    -----
    A thread worker gets ``torch.get_num_threads() // n_workers`` torch threads (at least one); a
    forked child always one: GNU OpenMP's thread pool does not survive ``fork``, and a child that
    starts a parallel region after its parent used one can hang (pytorch issues 17199, 58962).
    Each batch's result depends only on its own charts, so the pools give the same results.

    Examples
    --------
    >>> run = lambda idx, a: sum(idx) + a
    >>> sorted(map_batches(run, [[0, 1], [2], [3, 4]], 10, 2, [2, 1, 2], pool="process"))
    [([0, 1], 11), ([2], 12), ([3, 4], 17)]
    """
    if n_workers <= 1 or len(groups) <= 1:
        for idx in groups:
            yield idx, run(idx, a)
        return
    n_workers = min(n_workers, len(groups))
    order = sorted(range(len(groups)), key=lambda g: -cost[g])
    if pool == "process":
        yield from _forked(run, [groups[g] for g in order], a, n_workers, deadline)
        return
    old = torch.get_num_threads()
    threads = max(1, old // n_workers)
    from concurrent.futures import ThreadPoolExecutor, as_completed

    torch.set_num_threads(threads)
    try:
        with ThreadPoolExecutor(n_workers, thread_name_prefix="neuraluv-batch") as ex:
            futures = {ex.submit(run, groups[g], a): groups[g] for g in order}
            for fut in as_completed(futures):
                yield futures[fut], fut.result()
    finally:
        torch.set_num_threads(old)


def _child(run, idx, a, w):
    """In a forked child: run one batch on one torch thread, write ``(ok, result or exception)`` to fd ``w``, end
    without teardown."""
    code = 0
    try:
        signal.signal(signal.SIGINT, signal.SIG_IGN)   # the parent handles Ctrl-C and ends its children
        torch.set_num_threads(1)
        from threadpoolctl import threadpool_limits

        threadpool_limits(limits=1, user_api="blas")  # NumPy/SciPy's BLAS too: two spinning pools per core thrash
        try:
            msg = (True, run(idx, a))
        except Exception as exc:                       # sent to the parent, raised there
            msg = (False, exc)
        try:
            data = pickle.dumps(msg, protocol=pickle.HIGHEST_PROTOCOL)
        except Exception as exc:                       # an unpicklable result or exception
            data = pickle.dumps((False, RuntimeError(f"batch worker: {type(exc).__name__}: {exc}")))
        with os.fdopen(w, "wb") as f:
            f.write(data)
    except BaseException:
        code = 1
    finally:
        os._exit(code)


def _forked(run, groups, a, n_workers, deadline=None):
    """Run ``groups`` in at most ``n_workers`` forked children at once; yield ``(idx, result)`` as they finish."""
    import selectors

    sel = selectors.DefaultSelector()
    todo = list(groups)
    running = {}                                       # read fd -> (pid, idx, chunks)

    def start(idx):
        r, w = os.pipe()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DeprecationWarning)   # Python 3.12+: fork of a process with threads
            pid = os.fork()
        if pid == 0:                                   # pragma: no cover - the child never returns
            os.close(r)
            _child(run, idx, a, w)
        os.close(w)
        running[r] = (pid, idx, [])
        sel.register(r, selectors.EVENT_READ)

    def rerun(idx, why):
        warnings.warn(f"a batch worker process {why}; its batch is run again in this process", RuntimeWarning,
                      stacklevel=3)
        return run(idx, a)

    def end(r):
        pid, idx, chunks = running.pop(r)
        sel.unregister(r)
        os.close(r)
        return pid, idx, chunks

    try:
        while todo or running:
            while todo and len(running) < n_workers:
                start(todo.pop(0))
            timeout = None if deadline is None else max(0.0, deadline + LATE - time.perf_counter())
            events = sel.select(timeout)
            if not events and deadline is not None and time.perf_counter() > deadline + LATE:
                for r in list(running):                # hung: end them, run their batches here (at the deadline)
                    pid, idx, _ = end(r)
                    os.kill(pid, signal.SIGKILL)
                    os.waitpid(pid, 0)
                    yield idx, rerun(idx, f"still ran {LATE:g} s after the deadline and was ended")
                continue
            for key, _ in events:
                r = key.fd
                pid, idx, chunks = running[r]
                chunk = os.read(r, 1 << 20)
                if chunk:
                    chunks.append(chunk)
                    continue
                end(r)
                _, status = os.waitpid(pid, 0)
                try:
                    ok, value = pickle.loads(b"".join(chunks)) if chunks else (None, None)
                except Exception:
                    ok = None
                if ok is None:                         # the child died without a result: run it here
                    yield idx, rerun(idx, f"ended without a result (wait status {status})")
                elif ok:
                    yield idx, value
                else:
                    raise value
    finally:
        for r, (pid, _, _) in running.items():          # interrupted or failed: end the other children
            try:
                os.kill(pid, signal.SIGKILL)
                os.waitpid(pid, 0)
            except OSError:
                pass
            os.close(r)
        sel.close()
