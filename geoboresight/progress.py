"""Progress and cancellation, passed down as one small object (docs/DEVELOPING.md, "Layers, one direction").

The CLI draws a click progress bar from it, QGIS maps it to ``QgsProcessingFeedback``, a script
may pass nothing. Kernels call :meth:`Progress.update` once per block; ``update`` raises
:class:`~geoboresight.errors.Cancelled` when the user has asked to stop, so cancelling takes
effect within one block.
"""

from __future__ import annotations

import contextlib
import logging
import warnings
from collections.abc import Callable

from .errors import Cancelled


class Progress:
    """Report a fraction done in [0, 1] and check for cancellation.

    Parameters
    ----------
    callback : callable(fraction, message) or None
        Receives the overall fraction done and an optional message.
    is_cancelled : callable() -> bool, or None
        Polled at every update; when it returns True, :class:`Cancelled` is raised.
    log : callable(str) or None
        Receives informative messages (QGIS: ``feedback.pushInfo``; CLI: stderr).

    Examples
    --------
    >>> import geoboresight as gb
    >>> seen = []
    >>> progress = gb.Progress(lambda fraction, message: seen.append(round(fraction, 2)))
    >>> _ = gb.ratio_file("sample_data/scene/vnir.hdr", "sample_data/scene/swir.hdr",
    ...                   output="out/ratio.tif", block_rows=64, progress=progress)
    >>> seen  # once per strip of 64 lines
    [0.33, 0.67, 1.0]
    """

    def __init__(
        self,
        callback: Callable[[float, str | None], None] | None = None,
        is_cancelled: Callable[[], bool] | None = None,
        log: Callable[[str], None] | None = None,
        _start: float = 0.0,
        _stop: float = 1.0,
    ):
        self._callback = callback
        self._is_cancelled = is_cancelled
        self._log = log
        self._start = _start
        self._stop = _stop

    def update(self, fraction: float, message: str | None = None) -> None:
        """Report ``fraction`` (0–1) of this (sub)task done; raise Cancelled if asked to stop."""
        if self._is_cancelled is not None and self._is_cancelled():
            raise Cancelled("cancelled by the user")
        if self._callback is not None:
            f = min(max(float(fraction), 0.0), 1.0)
            self._callback(self._start + f * (self._stop - self._start), message)

    def check(self) -> None:
        """Raise Cancelled if the user asked to stop, without reporting progress."""
        if self._is_cancelled is not None and self._is_cancelled():
            raise Cancelled("cancelled by the user")

    def info(self, message: str) -> None:
        """Log an informative message (shown in the QGIS log panel, on stderr by the CLI)."""
        if self._log is not None:
            self._log(message)

    def sub(self, start: float, stop: float) -> Progress:
        """A progress object for a sub-task occupying [start, stop] of this one."""
        span = self._stop - self._start
        return Progress(
            self._callback,
            self._is_cancelled,
            self._log,
            self._start + start * span,
            self._start + stop * span,
        )


def as_progress(progress: Progress | None) -> Progress:
    """``progress`` itself, or a silent one when None."""
    return progress if progress is not None else Progress()


@contextlib.contextmanager
def library_messages_logged(progress: Progress):
    """Within this context, a library's Python warning (pyogrio's, NumPy's ``RuntimeWarning``)
    and a GDAL warning that rasterio logs reach the user as one ``warning: ...`` line through
    ``progress.info``, never as the raw source line and logger prefix Python prints by default."""

    def show(message, category, filename, lineno, file=None, line=None):
        progress.info("warning: " + " ".join(str(message).split()))

    class _Log(logging.Handler):
        def emit(self, record):
            progress.info("warning: " + " ".join(record.getMessage().split()))

    logger = logging.getLogger("rasterio")
    handler = _Log(logging.WARNING)
    propagate = logger.propagate
    with warnings.catch_warnings():
        warnings.showwarning = show
        logger.addHandler(handler)
        logger.propagate = False  # not also printed raw by Python's last-resort handler
        try:
            yield
        finally:
            logger.removeHandler(handler)
            logger.propagate = propagate
