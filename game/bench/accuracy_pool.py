"""Where the accuracy sweep's tasks run: local worker processes, or a Dask distributed cluster.

Both hand back each task's result as it finishes, in whatever order, and both check for Ctrl-C
between results. Dask distributed is an optional extra (``pip install -e '.[cluster]'``):
``--cluster`` without it fails in one line.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ThreadPoolExecutor

from game.app import interrupts
from game.bench.accuracy_tasks import CHILDREN, AccuracyTask, run_task
from game.errors import GameError

POLL_S = 0.25           # how often a waiting sweep looks for finished tasks and for Ctrl-C
CONNECT_TIMEOUT_S = 20  # to reach a scheduler that is not there
CLUSTER_HINT = "pip install -e '.[cluster]'"


def _finished(futures: dict, failed_row: Callable[[AccuracyTask, BaseException], dict]
              ) -> Iterator[dict]:
    """Each future's result as it finishes; a task that raised gives ``failed_row``."""
    pending = dict(futures)
    while pending:
        interrupts.check()
        done = [f for f in pending if f.done()]
        if not done:
            time.sleep(POLL_S)
            continue
        for future in done:
            task = pending.pop(future)
            try:
                yield future.result()
            except Exception as exc:  # noqa: BLE001 - a worker lost or killed: one failed row
                yield failed_row(task, exc)


def failed_result(task: AccuracyTask, exc: BaseException) -> dict:
    first = str(exc).splitlines()[0][:300] if str(exc) else ""
    return {"row": {"seed": task.seed, "method": task.method, "width": task.size[0],
                    "height": task.size[1], "frames": task.frames,
                    "scene_sha256": task.scene_sha256,
                    "status": f"failed: {type(exc).__name__}: {first}"}, "files": {}}


def local_results(tasks: Sequence[AccuracyTask], workers: int) -> Iterator[dict]:
    """The tasks on ``workers`` threads, each running its task's processes."""
    pool = ThreadPoolExecutor(max_workers=workers, thread_name_prefix="accuracy")
    futures: dict = {}
    try:
        futures = {pool.submit(run_task, task): task for task in tasks}
        yield from _finished(futures, failed_result)
    except BaseException:
        for future in futures:
            future.cancel()
        CHILDREN.stop()  # the running captures end now, not when they would have finished
        raise
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


def address_problem(address: str) -> str | None:
    """Why ``address`` is no scheduler's address, in one line; None where Dask can read it (or
    is missing: :func:`connect` says so). An address is checked before a client is made: a
    client that fails to start tries to close itself at exit, for tens of seconds, with a
    traceback."""
    try:
        from distributed.comm.addressing import get_address_host_port
    except ImportError:
        return None
    try:
        _, port = get_address_host_port(address)
    except ValueError as exc:
        return f"--cluster {address!r}: not a scheduler's address such as tcp://HOST:PORT ({exc})"
    if not 0 < port < 65536:
        return f"--cluster {address}: port {port} is not in 1..65535"
    return None


def connect(address: str):
    """A Dask client of the scheduler at ``address``; one line where Dask is missing or the
    scheduler cannot be reached."""
    try:
        from distributed import Client
    except ImportError:
        raise GameError(f"--cluster needs Dask distributed: {CLUSTER_HINT}") from None
    problem = address_problem(address)
    if problem is not None:
        raise GameError(problem)
    try:
        return Client(address, timeout=CONNECT_TIMEOUT_S, set_as_default=False)
    except (OSError, TimeoutError, ValueError, TypeError) as exc:
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise GameError(f"--cluster {address}: no Dask scheduler reached there ({first})") \
            from None


def cluster_results(tasks: Sequence[AccuracyTask], address: str) -> Iterator[dict]:
    """The tasks on the Dask cluster at ``address``: each one a task of its own, which runs its
    capture and verify as processes of the worker's machine."""
    client = connect(address)
    try:
        futures = client.map(run_task, list(tasks), pure=False)
        try:
            yield from _finished(dict(zip(futures, tasks, strict=True)), failed_result)
        except BaseException:
            client.cancel(futures)
            raise
    finally:
        client.close()
