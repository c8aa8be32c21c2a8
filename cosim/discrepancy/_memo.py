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
#: (docs/records/speed_runs.md, "Speed").
CACHE_ENTRIES = 64
CACHE_BYTES = 128 * 2**20
#: the last evaluations' residuals kept whole (:meth:`Memo.residual`), the least recently used
#: leaving first: a selection asks for the chi-square at its parameters once per group it tries
#: to remove, an interval's or a Jacobian's centre again (docs/records/speed_runs.md, "Speed")
RESIDUALS = 32


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
        self.model = model  # the nominal model (never changed here)
        self.scratch = Scratch(model, nominal)
        self.probe = None  # a model copy for moves_joints
        self.entries: OrderedDict = OrderedDict()
        self.nbytes = 0
        self.residuals: OrderedDict = OrderedDict()

    def moves_joints(self, name, motion) -> bool:
        """Does the model's parameter ``name`` change the joint motion (positions, rates,
        accelerations: ``ik``, ``joint_velocity``, ``joint_acceleration``) of the pose motion
        ``motion`` = (x, xd, xdd)?  Tried on a copy of the nominal model with the parameter moved
        twice (up by a thousandth and by a tenth of its size, and more): a value the core refuses
        counts as a change."""
        if self.probe is None:
            self.probe = self.model.copy()
        m, v = self.probe, float(self.scratch.nominal[name])

        def joints():
            x, xd, xdd = motion
            return m.ik(x), m.joint_velocity(x, xd), m.joint_acceleration(x, xd, xdd)

        before = joints()
        try:
            for moved in (v + 1e-3 * abs(v) + 1e-3, v + 0.1 * abs(v) + 0.05):
                m.set_params_unchecked({name: moved})
                if not all(np.array_equal(a, b) for a, b in zip(before, joints())):
                    return True
        except PkmError:
            return True
        finally:
            m.set_params_unchecked({name: v})
        return False

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

    def residual(self, params: dict, fn):
        """fn(), a :class:`.residuals.Residual` of the parameters ``params`` ({core name: float},
        those that differ from the nominal ones) at the pipeline's own positions, kept under the
        parameters' names and exact values (``float.hex``: -0.0 is not 0.0); a copy of its arrays
        is returned, so that a caller may change them."""
        key = tuple(sorted((k, v.hex()) for k, v in params.items()))
        r = self.residuals.get(key)
        if r is None:
            r = self.residuals[key] = fn()
            if len(self.residuals) > RESIDUALS:
                self.residuals.popitem(last=False)
        else:
            self.residuals.move_to_end(key)
        return type(r)(r.eff.copy(), None if r.kin is None else r.kin.copy())
