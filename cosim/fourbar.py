"""Four-bar linkage of Vitali 2020: output X of the coupler mid point and its link-length Jacobian.

The core's ``pkm_fourbar_output`` through :meth:`cosim.core.Model.fourbar_output` (the core computes everything).  Lengths are the
model parameters ``link[1].l`` .. ``link[4].l`` [m]; the crank angle theta [rad] is the
pose and the joint.

Example
-------
>>> import numpy as np
>>> from cosim.core import Model
>>> from cosim.fourbar import output
>>> m = Model("fourbar")
>>> X, A = output(m, np.radians([30, 35]))      # X [m], A = dX/dl [m/m], shape (2, 4)
>>> round(X[0] * 1e3, 4)                        # Vitali 2020: 815.2891 mm
815.2891
"""
from __future__ import annotations


__all__ = ["LENGTHS", "output"]

#: the four link-length parameters, in the order of the columns of dX/dl
LENGTHS = ["link[1].l", "link[2].l", "link[3].l", "link[4].l"]


def output(model, theta, jacobian: bool = True):
    """X of the coupler mid point at crank angle(s) ``theta`` [rad].

    Parameters
    ----------
    model : cosim.core.Model
        A ``"fourbar"`` model.
    theta : float or array_like, shape (n,)
        Crank angles [rad].
    jacobian : bool
        Also return dX/dl.

    Returns
    -------
    X : ndarray, shape like ``theta``
        [m].
    dX_dl : ndarray, shape ``theta.shape + (4,)``
        dX / d(l1, l2, l3, l4) [m/m] (only if ``jacobian``).

    Raises
    ------
    UnreachableError
        The linkage cannot be assembled at one of the angles (the message names it).
    SingularError
        A dead point (coupler and rocker aligned) where dX/dl is unbounded.
    """
    return model.fourbar_output(theta, jacobian=jacobian)
