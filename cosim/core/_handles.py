"""The core's handles from Python: a buffer for the messages of the calls that create one, and
their release once (``__del__``).
"""
from __future__ import annotations

import ctypes as C

from .._native import lib


def _errbuf():
    return C.create_string_buffer(1024)



def _release(obj, attr: str, destroy: str) -> None:
    """Destroy the core handle ``obj.<attr>`` once (for ``__del__``; quiet at interpreter shutdown)."""
    try:
        h = getattr(obj, attr, None)
        if h:
            getattr(lib, destroy)(h)
            setattr(obj, attr, None)
    except Exception:  # interpreter shutdown
        pass
