"""Batches at once in forked processes: results, errors and a lost child (``neuraluv.solver.pool``)."""
import os
import signal

import numpy as np
import pytest
import torch

from neuraluv.solver.pool import batch_pool, map_batches

pytestmark = pytest.mark.skipif(not hasattr(os, "fork"), reason="no os.fork on this platform")


def test_forked_batches_return_every_group_with_results_made_in_children():
    parent = os.getpid()
    out = dict((tuple(idx), res) for idx, res in
               map_batches(lambda idx, a: (os.getpid(), torch.get_num_threads(), [i * a for i in idx]),
                           [[0, 1], [2], [3, 4, 5]], 3, 2, [2, 1, 3], pool="process"))
    assert sorted(out) == [(0, 1), (2,), (3, 4, 5)]
    assert all(pid != parent for pid, _, _ in out.values())
    assert all(n == 1 for _, n, _ in out.values())   # one torch thread per forked child
    assert out[(3, 4, 5)][2] == [9, 12, 15]


def test_an_error_in_a_forked_batch_is_raised_in_the_parent():
    def run(idx, a):
        if idx == [1]:
            raise ValueError("chart 1 is broken")
        return idx

    with pytest.raises(ValueError, match="chart 1 is broken"):
        list(map_batches(run, [[0], [1], [2]], 0, 2, [1, 1, 1], pool="process"))


def test_a_batch_whose_child_dies_is_run_again_in_the_parent():
    parent = os.getpid()

    def run(idx, a):
        if idx == [1] and os.getpid() != parent:
            os.kill(os.getpid(), signal.SIGKILL)   # a child lost to the out-of-memory killer, say
        return os.getpid()

    with pytest.warns(RuntimeWarning, match="ended without a result"):
        out = dict((idx[0], pid) for idx, pid in map_batches(run, [[0], [1], [2]], 0, 2, [1, 1, 1], pool="process"))
    assert out[1] == parent and out[0] != parent and out[2] != parent


def test_pool_choice(monkeypatch):
    assert batch_pool("thread", "cpu") == "thread"
    assert batch_pool("process", "cuda") == "thread"
    monkeypatch.setenv("NEURALUV_BATCH_POOL", "thread")
    assert batch_pool("auto", "cpu") == "thread"
    monkeypatch.setenv("NEURALUV_BATCH_POOL", "nope")
    with pytest.raises(ValueError, match="NEURALUV_BATCH_POOL"):
        batch_pool("auto", "cpu")


def test_charts_prepared_in_forked_children_equal_those_prepared_here():
    from neuraluv import datasets
    from neuraluv.solver.chart import prepare_chart, prepare_charts

    charts = [datasets.spherical_cap(3), datasets.disk(5), datasets.glove(res=2)]
    here = [prepare_chart(V, F, "fast") for V, F in charts]
    there = prepare_charts(charts, "fast", workers=2, pool="process")
    for a, b in zip(here, there):
        assert np.array_equal(a.X, b.X) and np.array_equal(a.u_start, b.u_start) and a.start == b.start


def test_a_chart_that_cannot_be_prepared_gets_its_error_in_its_place():
    from neuraluv import datasets
    from neuraluv.errors import TopologyError
    from neuraluv.solver.chart import prepare_charts

    cap, closed = datasets.spherical_cap(3), datasets.sphere()   # a closed surface is no disk
    out = prepare_charts([cap, closed], "fast", workers=2, pool="process", errors="return")
    assert out[0].X.shape[0] == len(cap[0]) and isinstance(out[1], Exception)
    with pytest.raises(TopologyError):
        prepare_charts([cap, closed], "fast", workers=2, pool="process")


def test_a_child_still_running_long_after_the_deadline_is_ended_and_its_batch_run_here(monkeypatch):
    import time

    from neuraluv.solver import pool

    parent = os.getpid()

    def run(idx, a):
        if os.getpid() != parent:
            time.sleep(600)                        # a hung child
        return os.getpid()

    monkeypatch.setattr(pool, "LATE", 0.3)
    t = time.perf_counter()
    with pytest.warns(RuntimeWarning, match="after the deadline"):
        out = list(map_batches(run, [[0], [1]], 0, 2, [1, 1], pool="process", deadline=time.perf_counter()))
    assert sorted(i for i, _ in out) == [[0], [1]] and all(pid == parent for _, pid in out)
    assert time.perf_counter() - t < 60
