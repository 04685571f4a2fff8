"""The reference sampler (alias of ``ardy_export.sampling``; see that package)."""

from ardy_export.sampling import *  # noqa: F403
from ardy_export.sampling import __all__  # noqa: F401
