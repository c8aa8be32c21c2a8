"""The two errors of a sweep (:mod:`cosim.sweep`): a spec that cannot be run, a sweep that cannot go on."""
from ..errors import InputError


class SweepSpecError(InputError):
    """A sweep spec that cannot be run; names the file and the key."""


class SweepError(RuntimeError):
    """A sweep that cannot start or go on (results of another spec in the directory...)."""
