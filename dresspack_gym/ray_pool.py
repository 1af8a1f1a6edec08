"""Work spread over Ray (a cluster at an address, or this machine): one actor per worker, results as they finish."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator
from typing import Any

from .errors import ConfigError


class _Worker:
    """A Ray actor's state: built once by ``init(*init_args)`` in its process, then ``run`` item after item."""

    def __init__(self, init: Callable, init_args: tuple):
        init(*init_args)

    def run(self, fn: Callable, item: Any) -> Any:
        return fn(item)


def require_ray(field: str = "backend"):
    """The ``ray`` module, or a ConfigError naming the extra that installs it (checked before any work starts)."""
    try:
        import ray
    except ImportError:
        raise ConfigError(field, "the 'ray' backend needs Ray, the extra 'ray': "
                                 "pip install 'dresspack-gym[ray]'") from None
    return ray


def ray_imap_unordered(init: Callable, init_args: tuple, fn: Callable, items: Iterable, workers: int,
                       address: str | None = None, field: str = "backend") -> Iterator[Any]:
    """``fn(item)`` for every item on ``workers`` Ray actors (each set up by ``init(*init_args)``), yielded in the
    order they finish. Each actor takes the next item as soon as it is free, so long items do not hold up the rest.
    ``init`` and ``fn`` must be module-level functions (Ray pickles them by reference)."""
    ray = require_ray(field)
    ray.init(address=address, ignore_reinit_error=True, include_dashboard=False, log_to_driver=False)
    worker = ray.remote(_Worker)
    actors = [worker.remote(init, init_args) for _ in range(max(1, workers))]
    queue, pending = list(items), {}
    for actor in actors:
        if queue:
            pending[actor.run.remote(fn, queue.pop(0))] = actor
    while pending:
        ready, _ = ray.wait(list(pending), num_returns=1)
        actor = pending.pop(ready[0])
        if queue:
            pending[actor.run.remote(fn, queue.pop(0))] = actor
        yield ray.get(ready[0])
