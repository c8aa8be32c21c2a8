"""Model-discrepancy engine: where a recording and the core disagree, which missing
physics explains it, with what parameters, and how much better the model gets.

>>> from cosim.discrepancy import diagnose
>>> d = diagnose("recording.csv", out="report/")      # doctest: +SKIP
>>> print(d.conclusion)                                # doctest: +SKIP
missing physics: Coulomb friction, joint 3 (rail[3].coulomb = 0.0312 +- 0.0011 N)

The engine in parts a reader can hold: residuals and their noise (:mod:`.residuals`),
the library of effects (:mod:`.effects`), the attribution engine (:mod:`.engine`: the fit state
:mod:`.fitstate`, regressors :mod:`.regressors`, the noise model :mod:`.noise`, the shared fits
:mod:`.fitting`, forward selection :mod:`.selection`, inference: intervals, ties,
detectability :mod:`.inference`), localisation (:mod:`.localisation`), structure left
unexplained (:mod:`.structure`), the diagnosis that puts them together (:mod:`.diagnosis`),
the replay (:mod:`.runs`; a fitted gap or compliance as two bodies: :mod:`.drive_bodies`) and
the report (:mod:`.report`).  Blind cases and the benchmark:
:mod:`.blind`.  See docs/discrepancy.md.
"""
from .diagnosis import (TIE_MARGIN, Diagnosis, DiagnosisError, convention_contradictions,  # noqa: F401
                        diagnose, heldout_fit)
from .effects import LIBRARY

__all__ = ["diagnose", "Diagnosis", "DiagnosisError", "LIBRARY"]
