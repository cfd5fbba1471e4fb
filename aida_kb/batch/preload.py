"""Dask worker preload of a batch's local cluster: Ctrl-C is for the client to handle.

A terminal sends Ctrl-C's SIGINT to every process of the run, the local workers too; a worker
would end with a KeyboardInterrupt traceback. The client stops the run and closes the cluster,
which ends the workers; so they ignore SIGINT.
"""

from __future__ import annotations

import contextlib
import signal


def dask_setup(worker: object) -> None:
    """Called by Dask in each worker process as it starts: ignore SIGINT there."""
    with contextlib.suppress(ValueError):  # not a main thread (workers as threads: tests)
        signal.signal(signal.SIGINT, signal.SIG_IGN)
