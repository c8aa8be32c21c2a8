"""When a look-alike is a tie with the effect it is listed under (:func:`tied`), and the group
that marks a fit leaving structure unexplained (:data:`UNEXPLAINED`).
"""
from __future__ import annotations

#: |delta BIC| below which two explanations are called a tie (equally good)
TIE_MARGIN = 2.0
#: group of the look-alike that marks a fit leaving structure unexplained (a tie: the effect
#: may stand in for physics the library lacks, so it is not named with confidence)
UNEXPLAINED = "unexplained"


def tied(alternative) -> bool:
    """Whether a look-alike (dict) is a tie with the effect it is listed under: its BIC or its
    fit within :data:`TIE_MARGIN`, or one column with it on the recording (``collinear``)."""
    return (alternative["delta_bic"] < TIE_MARGIN or alternative.get("delta_chi2", float("inf")) < TIE_MARGIN
            or bool(alternative.get("collinear", False)))
