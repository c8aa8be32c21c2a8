"""Discovery: the joint force no effect of the library names, as an equation.

After the library's selection, every effort channel is searched for a per-joint force built
from a function library of the joint's position, rate and acceleration (the core's generic joint force,
``<j>[i].force_*``, ``pkm.h``): a constant (the drive's ``<j>[i].offset``, the library's
offset effect: one parameter, so the library and the search can never fit the same column
twice with opposite signs, and a coefficient the library has fitted on a channel is not
searched again there), a spring and its quadratic and cubic terms about
the recording's mean position, quadratic drag qd|qd|, viscous and Coulomb terms split by the
direction of motion, Coulomb levels that fade below a velocity scale v, tanh(qd / v) (from a grid of
scales), a ripple sin/cos(2 pi q / P) with the period P found from the residual's
spectrum over position, a smooth step in position, and an added inertia force_inertia qdd, the
rotor inertia's physics, not searched where the library fits that (a selected step's position and
width, a selected ripple's period and a fading friction's velocity scale are then fitted, with
intervals from the fit linearised in them; the library's offset on the joint is refitted with the
terms).  Each candidate column is a finite
difference of the residual pipeline over its core parameter (the core evaluates the force;
nothing here restates it), the columns of the rate terms and the inertia get instruments (the
same column along the reference motion, free of the rate and acceleration noise), as the
library's masses and viscous frictions do.

Selection per channel is stepwise (forward with BIC, then backward), with the threshold of the
library plus the look-elsewhere cost of the search: ``2 ln M`` for M candidate terms tried
over all channels (a Bonferroni bound: the chance that the best of M noise-only terms passes
is at most M times that of one).  A selected set is kept only if its terms come back in most
block-bootstrap resamples of the fitted part (stability) and it lowers the chi-square of the
held-out part by more than the threshold.  Intervals are the larger of the instrumental
sandwich and the block-bootstrap spread (the residual is autocorrelated and the model may be
wrong: the bootstrap covers both).

A library effect acting on the same channels is then put on trial (:func:`judge_library`):
the discovered terms in its place replace it only when they fit the held-out part
significantly better (:func:`significant`: the held-out chi-square lower by more than the
threshold a term pays to enter, look-elsewhere cost included, and by more than Z_ONE_SIDED
standard errors of that difference over blocks of the held-out part); otherwise the library
effect is named, because it carries a physics name, and the discovered terms are listed as
a tie when they fit about as well.  Two effects on a common channel then go on trial together
(Coulomb friction and an offset are, while the joint moves, friction that differs by
direction; a friction restated alone in place of two effects makes the other a stand-in).
"""
from __future__ import annotations

from .channel import discover_channel  # noqa: F401
from .fit import SPAN_CONSTANT, bootstrap, fit_terms, offset_refit, stepwise  # noqa: F401
from .judgement import (ONE_FORCE, heldout_chi2, heldout_samples, judge_library, library_named,  # noqa: F401
                                  restates, significant)
from .search import FADE_GRID, FADE_RANGE, Search, make_search  # noqa: F401
from .terms import (ADDS_TO, BLOCK, Coefficient, DISSIPATIVE, DiscoveredTerm, MAX_STEPS, MECHANISMS,  # noqa: F401
                              N_BOOT, RATE_TERMS, SAME_COLUMN, SIGNED, STABILITY, TERMS, Z_ONE_SIDED, equation)
