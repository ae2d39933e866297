"""The installed package's version (the one place that reads it)."""
from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("hexatissue")
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0.1.0"
