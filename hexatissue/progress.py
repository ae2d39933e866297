"""Progress bars (tqdm) that stay quiet when output is not a terminal or when disabled.

Set the environment variable ``HEXATISSUE_PROGRESS=0`` to silence every bar,
``=1`` to force them.
"""
from __future__ import annotations

import os
import sys

from tqdm.auto import tqdm

__all__ = ["progress"]


def progress(iterable=None, **kwargs):
    """``tqdm(iterable, **kwargs)``, disabled when stderr is not a terminal (unless forced)."""
    setting = os.environ.get("HEXATISSUE_PROGRESS", "")
    if setting in ("0", "1"):
        kwargs.setdefault("disable", setting == "0")
    else:
        kwargs.setdefault("disable", not sys.stderr.isatty())
    return tqdm(iterable, **kwargs)
