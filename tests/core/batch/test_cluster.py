"""DaskExecutor.wait: what it takes from the futures Dask reports done."""
from types import SimpleNamespace

from mirrorcore.batch import cluster
from mirrorcore.batch.cluster import DaskExecutor


class FakeFuture:
    """A future of one chunk in a given state (what distributed.Future shows)."""

    def __init__(self, key: str, status: str, result=None, exception=None):
        self.key, self.status = key, status
        self._result, self._exception = result, exception
        self.released = False

    def result(self):
        return self._result

    def exception(self):
        return self._exception

    def release(self):
        self.released = True


def executor_with(monkeypatch, futures: list[FakeFuture]) -> DaskExecutor:
    """A DaskExecutor holding `futures` (chunk (i,) for key i), whose wait() sees them all done."""
    executor = object.__new__(DaskExecutor)
    executor._chunks = {f.key: (int(f.key),) for f in futures}
    executor._pending = set(futures)
    monkeypatch.setattr(cluster, "wait", lambda *a, **k: SimpleNamespace(done=set(futures)))
    return executor


def test_a_result_lost_with_its_worker_after_wait_saw_it_stays_pending(monkeypatch):
    done = FakeFuture("1", "finished", result=(["one.ply"], {}))
    failed = FakeFuture("2", "error", exception=ValueError("bad\nframe"))
    lost = FakeFuture("3", "lost")
    retried = FakeFuture("4", "pending")
    executor = executor_with(monkeypatch, [done, failed, lost, retried])
    results = sorted(executor.wait(1.0))
    assert results == [((1,), ["one.ply"], {}), ((2,), [], {2: "ValueError: bad frame"})]
    assert executor._pending == {lost, retried} and executor.pending == 2
    assert done.released and failed.released and not lost.released
