"""Progress bars (tqdm) that stay quiet when output is not a terminal or when disabled.

Bars are shown only when stderr is a terminal, so logs, pipes and batch jobs
show none by default.  Set the environment variable ``HEXATISSUE_PROGRESS=1``
to force them there (tqdm then writes a line per update to the log), ``=0``
to silence every bar (documented in the README).  A tqdm subclass given as
``enabled`` draws the bar with that class, always (the napari widget passes
``napari.utils.progress`` so the bar appears in napari's activity dock).
"""
from __future__ import annotations

import os
import sys

from tqdm import tqdm as std_tqdm
from tqdm.auto import tqdm

__all__ = ["progress"]


def progress(iterable=None, enabled=True, **kwargs):
    """``tqdm(iterable, **kwargs)``; off when ``enabled`` is False, else shown on a terminal (or when forced).

    ``enabled`` may also be a tqdm subclass: the bar is then ``enabled(iterable, **kwargs)``, shown.
    """
    if isinstance(enabled, type) and issubclass(enabled, std_tqdm):
        return enabled(iterable, **kwargs)
    setting = os.environ.get("HEXATISSUE_PROGRESS", "")
    if not enabled:
        kwargs["disable"] = True
    elif setting in ("0", "1"):
        kwargs["disable"] = setting == "0"
    else:
        kwargs["disable"] = not sys.stderr.isatty()
    return tqdm(iterable, **kwargs)
