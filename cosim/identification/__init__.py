"""Base-parameter identification of serial arms from recordings (docs/identification.md).

:func:`identify` fits a serial arm's identifiable inertial and drive parameters to a
recording, physically consistent, with intervals; the result's :meth:`Identification.write`
gives the nominal model ``cosim diagnose --model`` takes.  Modules: :mod:`.regressor` (the
regressor from the core by linearity), :mod:`.base` (the base parameters by QR),
:mod:`.consistent` (the rigid-body constraint: a semidefinite program on the pseudo-inertias),
:mod:`.identify`.
"""
from .base import BaseParameters, base_parameters
from .identify import Identification, IdentificationError, identify
from .regressor import regressor, standard_names, standard_values

__all__ = ["BaseParameters", "Identification", "IdentificationError", "base_parameters", "identify", "regressor",
           "standard_names", "standard_values"]
