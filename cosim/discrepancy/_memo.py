"""The mutable workspace of a residual pipeline (:class:`.residuals.Pipeline`): its evaluation
cache and its scratch model.  The pipeline itself is fixed once built (the recording's signals,
the nominal model); what its evaluations keep and reuse lives here, as a model's mutable data
lives apart from the model."""
from __future__ import annotations

from collections import OrderedDict

import numpy as np

from .._native import PkmError

#: the evaluation cache of a pipeline: at least this many entries, and more up to CACHE_BYTES.
#: The least recently used entry leaves first: the nominal parts (the mechanism's efforts, the
#: joint motion, the readings) are read by every candidate and stay, the evaluations of one
#: selection step's Jacobian are read again within the next steps.  At 128 MB no evaluation of the
#: benchmark's 10 s recordings is computed twice that 256 MB first in, first out computed once
#: (docs/discrepancy.md, "Speed").
CACHE_ENTRIES = 64
CACHE_BYTES = 128 * 2**20


def _nbytes(v) -> int:
    """Bytes of the arrays of a cached value (an array or a tuple of arrays)."""
    return sum(a.nbytes for a in (v if isinstance(v, tuple) else (v,)) if isinstance(a, np.ndarray))


class Scratch:
    """A model copy whose parameters are moved away from the nominal ones and back."""

    def __init__(self, model, nominal):
        self.m = model.copy()
        self.nominal = nominal
        self.current = {}

    def set(self, params):
        change = {k: self.nominal[k] for k in self.current if k not in params}
        change.update({k: v for k, v in params.items() if self.current.get(k) != v})
        if not change:
            return self.m
        try:
            self.m.set_params_unchecked(change)
            self.current = dict(params)
        except PkmError:
            back = {k: self.nominal[k] for k in set(self.current) | set(change)}
            self.current = {}
            try:
                self.m.set_params_unchecked(back)
            except PkmError:
                pass
            raise
        return self.m


class Memo:
    """Values kept under keys, the least recently used leaving first when it holds more than
    CACHE_ENTRIES entries and more than CACHE_BYTES (a short recording keeps hundreds of
    evaluations, a long one's working set at least CACHE_ENTRIES); and the scratch model of the
    evaluations (:class:`Scratch`)."""

    def __init__(self, model, nominal):
        self.scratch = Scratch(model, nominal)
        self.entries: OrderedDict = OrderedDict()
        self.nbytes = 0

    def get(self, key, fn):
        """fn(), kept under ``key``."""
        v = self.entries.get(key)
        if v is not None:
            self.entries.move_to_end(key)
        else:
            v = fn()
            self.entries[key] = v
            self.nbytes += _nbytes(v)
            while len(self.entries) > CACHE_ENTRIES and self.nbytes > CACHE_BYTES:
                self.nbytes -= _nbytes(self.entries.popitem(last=False)[1])
        return v
