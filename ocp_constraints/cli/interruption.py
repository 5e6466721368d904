"""What a command does when SIGINT or SIGTERM arrives before its results are complete."""
from __future__ import annotations


def write_if_interrupted(exc: BaseException, mark: int, out, task: str, args) -> BaseException | None:
    """If ``exc`` is an interruption (since ``mark``), write ``out`` as an interrupted run of ``task``
    (summary.json with ``"success": false`` and the signal) and return the interruption to raise;
    else None (the caller re-raises ``exc``)."""
    from ..output.run_folder import write_interrupted_run
    from ..output.signals import as_interruption

    stop = as_interruption(exc, mark)
    if stop is not None:
        write_interrupted_run(out, task, stop, {k: str(v) for k, v in vars(args).items() if k != "handler"})
    return stop
