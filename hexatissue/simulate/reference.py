"""Former path of :mod:`hexatissue.simulate._reference`, kept so that ``hexatissue.simulate.reference`` still imports."""
from ._reference import *  # noqa: F401,F403
from ._reference import __all__, full_to_patches  # noqa: F401
