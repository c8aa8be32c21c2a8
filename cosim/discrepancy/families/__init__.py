"""Term families of the discovery step beyond one joint's position and rate.

:mod:`.products` holds the candidates that multiply a function of the velocity's sign by one of
the load (the applied effort) or of the position, the terms of one joint in another joint's
motion and the effort x position and position x velocity terms, each a named parameter of the
core's joint force (``<j>[i].force_*``, ``pkm.h``); :mod:`.generator` draws physics at random
from every family for the unnamed-force bench (``bench/unnamed_bench.py``).
"""
from .products import FAMILIES, excluded, searched, without  # noqa: F401
