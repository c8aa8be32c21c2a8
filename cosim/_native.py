"""ctypes layer over the C ABI of the reference core (``c_core/include/pkm/pkm.h``).

This module only loads ``libpkm.so`` and declares the C signatures; the Pythonic
API is in :mod:`cosim.core`.  The library is looked up, in order, at ``$PKM_LIB``,
``$PKM_BUILD_DIR/lib/libpkm.so`` and ``<repo>/build/lib/libpkm.so``.
"""
from __future__ import annotations

import ctypes as C
import os
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent

c_double_p = C.POINTER(C.c_double)
c_int_p = C.POINTER(C.c_int)


from .errors import (  # noqa: F401  (re-exported: the status table maps onto them)
    ArgumentError,
    ConvergenceError,
    IntegrationError,
    JointLimitError,
    ParameterError,
    PkmError,
    SingularError,
    UnreachableError,
    UnsupportedError,
)


STATUS = {
    0: ("PKM_OK", None),
    -1: ("PKM_ERR_ARGUMENT", ArgumentError),
    -2: ("PKM_ERR_PARAMETER", ParameterError),
    -3: ("PKM_ERR_UNREACHABLE", UnreachableError),
    -4: ("PKM_ERR_SINGULAR", SingularError),
    -5: ("PKM_ERR_NO_CONVERGENCE", ConvergenceError),
    -6: ("PKM_ERR_JOINT_LIMIT", JointLimitError),
    -7: ("PKM_ERR_INTEGRATION", IntegrationError),
    -8: ("PKM_ERR_UNSUPPORTED", UnsupportedError),
    -9: ("PKM_ERR_INTERNAL", PkmError),
    -10: ("PKM_ERR_STEP_BUDGET", IntegrationError),
}


def raise_for(status: int, message: str) -> None:
    """Raise the exception class of a C status (no-op for PKM_OK)."""
    if status == 0:
        return
    name, cls = STATUS.get(status, ("PKM_ERR_UNKNOWN", PkmError))
    raise (cls or PkmError)(message or name, name)


class pkm_fk_options(C.Structure):
    _fields_ = [("tol", C.c_double), ("max_iter", C.c_int), ("damping", C.c_double)]


class pkm_fk_info(C.Structure):
    _fields_ = [("iterations", C.c_int), ("residual", C.c_double)]


class pkm_sim_options(C.Structure):
    _fields_ = [
        ("method", C.c_int),
        ("rtol", C.c_double),
        ("atol", C.c_double),
        ("max_step", C.c_double),
        ("max_steps", C.c_long),
        ("sing_min", C.c_double),
    ]


class pkm_sim_stats(C.Structure):
    _fields_ = [
        ("steps", C.c_long),
        ("rhs_evals", C.c_long),
        ("jac_evals", C.c_long),
        ("error_test_fails", C.c_long),
        ("nonlin_conv_fails", C.c_long),
    ]


class pkm_ctrl_spec(C.Structure):
    _fields_ = [
        ("kind", C.c_int),
        ("dt", C.c_double),
        ("kp", c_double_p),
        ("kd", c_double_p),
        ("ki", c_double_p),
        ("deriv_filter", C.c_double),
        ("saturation", c_double_p),
        ("gravity_at_reference", C.c_int),
        ("gravity_feedforward", C.c_int),
        ("nx", C.c_int),
        ("A", c_double_p),
        ("B", c_double_p),
        ("C", c_double_p),
        ("D", c_double_p),
        ("law", C.c_int),
        ("kv", c_double_p),
        ("pos_nb", C.c_int),
        ("pos_na", C.c_int),
        ("pos_b", c_double_p),
        ("pos_a", c_double_p),
        ("vel_nb", C.c_int),
        ("vel_na", C.c_int),
        ("vel_b", c_double_p),
        ("vel_a", c_double_p),
        ("velocity_source", C.c_int),
        ("u_min", c_double_p),
        ("u_max", c_double_p),
        ("output_gain", c_double_p),
        ("delay_samples", C.c_int),
    ]


class pkm_loop_reference(C.Structure):
    _fields_ = [("n", C.c_size_t), ("t0", C.c_double), ("dt", C.c_double), ("t", c_double_p), ("q", c_double_p),
                ("qd", c_double_p), ("qdd", c_double_p), ("x", c_double_p), ("tau_before", c_double_p),
                ("f_ext", c_double_p), ("inject_point", C.c_int), ("inject", c_double_p)]


class pkm_loop_record(C.Structure):
    _fields_ = [(name, c_double_p) for name in ("q", "qd", "q_true", "qd_true", "x", "xd", "tau_cmd", "tau",
                                                 "tau_inj")]


def library_path() -> Path:
    if os.environ.get("PKM_LIB"):
        return Path(os.environ["PKM_LIB"])
    build = Path(os.environ.get("PKM_BUILD_DIR", REPO / "build"))
    return build / "lib" / "libpkm.so"


P = C.c_void_p
D = c_double_p
I = C.c_int
S = C.c_size_t
CH = C.c_char_p

# name: (restype, argtypes).  Mirrors pkm.h; functions a build lacks are skipped
# and raise UnsupportedError when called.
_SIGNATURES = {
    "pkm_status_name": (CH, [I]),
    "pkm_model_create": (P, [CH, CH, C.c_char_p, S]),
    "pkm_model_create_status": (I, [CH, CH, C.POINTER(P), C.c_char_p, S]),
    "pkm_robot_count": (I, []),
    "pkm_robot_name": (CH, [I]),
    "pkm_robot_param_set_count": (I, [CH]),
    "pkm_robot_param_set_name": (CH, [CH, I]),
    "pkm_robot_title": (CH, [CH]),
    "pkm_chain_points": (I, [P, P, D, D]),
    "pkm_platform_pose": (I, [P, P, D, D, D]),
    "pkm_robot_file": (CH, [CH]),
    "pkm_robot_register_description": (I, [CH, CH, C.c_char_p, S]),
    "pkm_model_pose_name": (CH, [P, I]),
    "pkm_model_pose_unit": (CH, [P, I]),
    "pkm_model_tracker_count": (I, [P]),
    "pkm_model_tracker_name": (CH, [P, I]),
    "pkm_model_tracker_unit": (CH, [P, I]),
    "pkm_model_joint_unit": (CH, [P]),
    "pkm_model_effort_unit": (CH, [P]),
    "pkm_model_joint_noun": (CH, [P]),
    "pkm_model_has": (I, [P, CH]),
    "pkm_model_feature_count": (I, [P]),
    "pkm_model_feature": (CH, [P, I]),
    "pkm_model_joint_prefix": (CH, [P]),
    "pkm_model_joint_limits": (I, [P, I, c_int_p, c_int_p]),
    "pkm_model_geometry_param": (CH, [P, I]),
    "pkm_model_copy": (P, [P]),
    "pkm_model_destroy": (None, [P]),
    "pkm_model_robot": (CH, [P]),
    "pkm_model_ndof": (I, [P]),
    "pkm_model_nparam": (I, [P]),
    "pkm_param_index": (I, [P, CH]),
    "pkm_param_name": (CH, [P, I]),
    "pkm_param_unit": (CH, [P, I]),
    "pkm_param_description": (CH, [P, I]),
    "pkm_param_get": (C.c_double, [P, I]),
    "pkm_param_set_course": (I, [P, I, I, C.c_double, C.c_double, C.c_char_p, S]),
    "pkm_param_course": (I, [P, I, c_int_p, D, D]),
    "pkm_param_value_at": (I, [P, I, C.c_double, D]),
    "pkm_param_in_drive_layer": (I, [P, I]),
    "pkm_param_set": (I, [P, I, C.c_double, C.c_char_p, S]),
    "pkm_model_validate": (I, [P, C.c_char_p, S]),
    "pkm_model_home": (I, [P, D]),
    "pkm_data_create": (P, [P]),
    "pkm_data_destroy": (None, [P]),
    "pkm_data_check": (I, [P, P]),
    "pkm_data_error": (CH, [P]),
    "pkm_ik": (I, [P, P, D, D]),
    "pkm_ik_batch": (I, [P, P, S, D, D, c_int_p]),
    "pkm_fk": (I, [P, P, D, D, C.POINTER(pkm_fk_options), D, C.POINTER(pkm_fk_info)]),
    "pkm_fk_batch": (I, [P, P, S, D, D, C.POINTER(pkm_fk_options), D, c_int_p]),
    "pkm_jacobians": (I, [P, P, D, D, D, D]),
    "pkm_jacobian_dot": (I, [P, P, D, D, D]),
    "pkm_singularity": (I, [P, P, D, D]),
    "pkm_joint_velocity": (I, [P, P, D, D, D]),
    "pkm_pose_velocity": (I, [P, P, D, D, D]),
    "pkm_pose_velocity_batch": (I, [P, P, S, D, D, D, c_int_p]),
    "pkm_joint_acceleration": (I, [P, P, D, D, D, D]),
    "pkm_pose_acceleration": (I, [P, P, D, D, D, D]),
    "pkm_pose_acceleration_batch": (I, [P, P, S, D, D, D, D, c_int_p]),
    "pkm_inverse_dynamics": (I, [P, P, D, D, D, D]),
    "pkm_inverse_dynamics_batch": (I, [P, P, S, D, D, D, D, c_int_p]),
    "pkm_mechanism_inverse_dynamics_batch": (I, [P, P, S, D, D, D, D, c_int_p]),
    "pkm_add_drive_inverse_dynamics_batch": (I, [P, P, S, D, D, D, D, c_int_p]),
    "pkm_add_drive_efforts_batch": (I, [P, P, S, D, D, D, D, c_int_p]),
    "pkm_forward_dynamics": (I, [P, P, D, D, D, D]),
    "pkm_forward_dynamics_batch": (I, [P, P, S, D, D, D, D, c_int_p]),
    "pkm_mass_matrix": (I, [P, P, D, D]),
    "pkm_gravity_load": (I, [P, P, D, D]),
    "pkm_energy": (I, [P, P, D, D, D, D]),
    "pkm_joint_friction": (I, [P, P, D, D]),
    "pkm_actuator_effort": (I, [P, P, D, D]),
    "pkm_actuator_effort_batch": (I, [P, P, S, D, D, c_int_p]),
    "pkm_measure_joints": (I, [P, P, D, D, D, D]),
    "pkm_sensor_readings": (I, [P, P, D, D, D, D, D, D, D]),
    "pkm_model_two_body_joints": (I, [P]),
    "pkm_measure_joints_batch": (I, [P, P, S, D, D, D, D, c_int_p]),
    "pkm_sim_default_options": (None, [C.POINTER(pkm_sim_options)]),
    "pkm_sim_create": (P, [P, C.POINTER(pkm_sim_options), C.c_char_p, S]),
    "pkm_sim_destroy": (None, [P]),
    "pkm_sim_reset": (I, [P, C.c_double, D, D]),
    "pkm_sim_set_input": (I, [P, D]),
    "pkm_sim_advance": (I, [P, C.c_double]),
    "pkm_sim_set_time_limit": (I, [P, C.c_double]),
    "pkm_sim_get_state": (I, [P, D, D, D]),
    "pkm_sim_drive_state": (I, [P, D, D]),
    "pkm_sim_applied_effort": (I, [P, D]),
    "pkm_sim_set_external": (I, [P, D]),
    "pkm_sim_get_stats": (I, [P, C.POINTER(pkm_sim_stats)]),
    "pkm_sim_error": (CH, [P]),
    "pkm_sim_method_count": (I, []),
    "pkm_sim_method": (I, [I, c_int_p, C.POINTER(CH), C.POINTER(CH), c_int_p]),
    "pkm_reading_delay_create": (P, [P, C.c_char_p, S]),
    "pkm_reading_delay_destroy": (None, [P]),
    "pkm_reading_delay_read": (I, [P, C.c_double, D, D]),
    "pkm_reading_delay_reset": (None, [P]),
    "pkm_reading_delay_error": (CH, [P]),
    "pkm_ctrl_create": (P, [P, C.POINTER(pkm_ctrl_spec), C.c_char_p, S]),
    "pkm_ctrl_destroy": (None, [P]),
    "pkm_ctrl_reset": (I, [P, D]),
    "pkm_ctrl_update": (I, [P, C.c_double, D, D, D, D, D, D, D]),
    "pkm_ctrl_prime": (I, [P, C.c_size_t, D, D, D, D, D, D, D]),
    "pkm_effort_map": (I, [C.c_size_t, C.c_double, D, C.c_double, C.c_double, C.c_double, C.c_double, C.c_double,
                           D, C.c_char_p, C.c_size_t]),
    "pkm_ctrl_update_injected": (I, [P, C.c_double, D, D, D, D, D, D, I, D, D, D]),
    "pkm_ctrl_prime_injected": (I, [P, C.c_size_t, D, D, D, D, D, D, D, I, D]),
    "pkm_ctrl_saturated": (C.c_long, [P]),
    "pkm_ctrl_error": (CH, [P]),
    "pkm_ctrl_state_size": (S, [P]),
    "pkm_ctrl_state_save": (I, [P, D]),
    "pkm_ctrl_state_load": (I, [P, D, S]),
    "pkm_closed_loop": (I, [P, P, C.POINTER(pkm_loop_reference), D, D, I, C.POINTER(pkm_loop_record),
                            C.POINTER(C.c_size_t)]),
    "pkm_sim_state_size": (S, [P]),
    "pkm_sim_state_save": (I, [P, D]),
    "pkm_sim_state_load": (I, [P, D, S]),
    "pkm_6pus_calib_rows": (I, [P, P, D, I, D]),
    "pkm_6pus_leg_points": (I, [P, P, D, D, D]),
    "pkm_fourbar_output": (I, [P, P, C.c_double, D, D]),
    "pkm_quattro_index_name": (CH, [I]),
    "pkm_quattro_index_unit": (CH, [I]),
    "pkm_quattro_indices": (I, [P, P, S, D, D, c_int_p]),
    "pkm_quattro_gimre": (I, [P, P, D, D]),
    "pkm_quattro_points": (I, [P, P, D, D, D, D]),
    "pkm_quattro_constant_name": (CH, [I]),
    "pkm_quattro_constant_unit": (CH, [I]),
    "pkm_quattro_constants": (I, [P, P, D]),
}


class _Lib:
    def __init__(self) -> None:
        self._lib = None

    def _load(self):
        path = library_path()
        if not path.exists():
            raise ImportError(
                f"the core library {path} is not built: run ./scripts/bootstrap.sh "
                "(or set PKM_LIB to a built libpkm.so)"
            )
        lib = C.CDLL(str(path))
        for name, (res, args) in _SIGNATURES.items():
            fn = getattr(lib, name, None)
            if fn is None:
                continue
            fn.restype = res
            fn.argtypes = args
        return lib

    def __getattr__(self, name):
        if self._lib is None:
            self._lib = self._load()
        fn = getattr(self._lib, name, None)
        if fn is None:
            raise UnsupportedError(f"{name} is not in this build of libpkm", "PKM_ERR_UNSUPPORTED")
        return fn

    def register(self, name, restype, argtypes):
        """Declare a further C function (robot modules add theirs)."""
        _SIGNATURES[name] = (restype, argtypes)
        if self._lib is not None:
            fn = getattr(self._lib, name, None)
            if fn is not None:
                fn.restype = restype
                fn.argtypes = argtypes


lib = _Lib()

_FAST_DLL = None
_FAST: dict = {}


def fast(name: str):
    """The C function ``name`` with every pointer argument typed ``void*``.

    Per-item loops pass plain integer addresses to it (about 1 us a call instead of
    ~25 us with a pointer cast per argument).  A second handle on the same library
    image keeps these function objects apart from the typed ones of ``lib``.
    """
    global _FAST_DLL
    f = _FAST.get(name)
    if f is None:
        if name not in _SIGNATURES:
            raise UnsupportedError(f"{name} is not declared in cosim._native", "PKM_ERR_UNSUPPORTED")
        getattr(lib, name)  # loads and checks the library, raises if the build lacks it
        if _FAST_DLL is None:
            _FAST_DLL = C.CDLL(str(library_path()))
        res, args = _SIGNATURES[name]
        f = _FAST_DLL[name]
        f.restype = res
        f.argtypes = [C.c_void_p if (a is P or (isinstance(a, type) and issubclass(a, C._Pointer))) else a for a in args]
        _FAST[name] = f
    return f


def ptr(a) -> c_double_p:
    """Pointer to a C-contiguous float64 numpy array (None -> NULL)."""
    if a is None:
        return None
    return a.ctypes.data_as(c_double_p)
