"""cosim: parallel-kinematic robot co-simulation, calibration and model-discrepancy toolkit.

The physics lives in the C++ reference core (``c_core/``); :mod:`cosim.core` binds it.
"""
__version__ = "0.1.0"
