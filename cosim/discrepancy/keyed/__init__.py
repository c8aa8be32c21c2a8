"""A library effect whose level is keyed on something else: the confidence rule's products.

* :mod:`.own`: the effect's force times bands of the joint's own stroke, powers of its position and the
  time since its last reversal;
* :mod:`.elsewhere`: the effect's force times another joint's inputs, and the ties that follow
  (docs/discrepancy.md, section 4);
* :mod:`.power`: the smallest change of the effect's level the products could show, and the
  largest one the products the residual leans on cannot exclude; an effect too weak for a change
  of its level as large as itself, or one whose recording leans to such a change, is not named
  with confidence either;
* :mod:`.carried`: a platform mass, inertia or payload fitted where the flexible stage claims a
  part on the platform's motion through a resonance (a body the platform carries on a spring) is
  not named with confidence.
"""
