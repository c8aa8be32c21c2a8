/*
 * pkm.h -- the C contract of the parallel-kinematic-machine (PKM) reference core.
 *
 * Everything outside c_core/ (the FMUs, the Python package, the tests) reaches the
 * physics through this header only.  Conventions:
 *
 *  1. Units are SI throughout: m, rad, kg, N, N m, s.  Angles of the 6-PUS pose are
 *     fixed-axis rotations, R = Rx(rx) Ry(ry) Rz(rz) (Tiberi 2020 eq. 2.5).
 *  2. Two handles.  pkm_model is constant while computations run: robot kind,
 *     named parameters, derived geometry.  pkm_data is mutable: work buffers, the
 *     last error, counters.  Every computation is a free function taking
 *     (const pkm_model*, pkm_data*).  A data belongs to the model it was created
 *     for (pkm_data_check); use one data per thread.  Changing a parameter of a
 *     model invalidates nothing but the results computed before the change.
 *  3. Every create has a destroy.  Handles are opaque.
 *  4. Every function that can fail returns an int status: PKM_OK (0) or a negative
 *     pkm_status.  The message, saying what failed and where (leg, item of a
 *     batch, time), is kept in the data (pkm_data_error) or, for functions without
 *     a data, written to the caller's err buffer (may be NULL).  No C++ exception
 *     crosses this boundary; no function returns a NaN in place of an error.
 *  5. Arrays are contiguous, row-major double.  Shapes are given as [rows,cols];
 *     n is the number of items of a batched call, nd = pkm_model_ndof(m).
 *     Batched calls go on past failing items, write each item's status into
 *     status[n] (may be NULL), fill failing items' outputs with NaN *and* return
 *     the first failure status, so a NaN is never silent.
 *  6. The pose x of a robot has nd coordinates, its velocity xd is the time
 *     derivative of those coordinates (for the 6-PUS: Euler-angle rates, not the
 *     angular velocity).  q are the actuated joint coordinates (slider strokes for
 *     the 6-PUS [m], arm angles at the gearbox output for the Quattro [rad]), tau the
 *     actuator efforts along them [N or N m] (Quattro: arm-side torque).
 */
#ifndef PKM_PKM_H
#define PKM_PKM_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

#if !defined(PKM_API) /* an FMU binary defines it empty: the core inside stays private */
#if defined(_WIN32)
#define PKM_API __declspec(dllexport)
#else
#define PKM_API __attribute__((visibility("default")))
#endif
#endif

/* ===================================================================== status */

typedef enum pkm_status {
  PKM_OK = 0,
  PKM_ERR_ARGUMENT = -1,      /* NULL pointer, wrong size, NaN/Inf in an input      */
  PKM_ERR_PARAMETER = -2,     /* a parameter value is invalid (name and value given) */
  PKM_ERR_UNREACHABLE = -3,   /* pose outside the workspace of a leg/arm              */
  PKM_ERR_SINGULAR = -4,      /* singular configuration (which kind, which leg)       */
  PKM_ERR_NO_CONVERGENCE = -5,/* iterative solver did not converge (iter, residual)   */
  PKM_ERR_JOINT_LIMIT = -6,   /* stroke / joint range exceeded (which joint, value)   */
  PKM_ERR_INTEGRATION = -7,   /* CVODE failure (flag, time)                           */
  PKM_ERR_UNSUPPORTED = -8,   /* the robot does not provide this function             */
  PKM_ERR_INTERNAL = -9,      /* a bug: please report the message                    */
  PKM_ERR_STEP_BUDGET = -10   /* one call used its work budget (steps, time reached)  */
} pkm_status;

/* Short constant name of a status ("PKM_ERR_SINGULAR"...). */
PKM_API const char* pkm_status_name(int status);

/* ============================================================== model / data */

typedef struct pkm_model pkm_model;
typedef struct pkm_data pkm_data;

/* Create a model of a robot: "fourbar" (written in C++), a description the core finds by
 * name (PKM_ROBOT_PATH, then the project's robots/: "6pus", "quattro", "delta_clavel", ...)
 * or a path to a description file (docs/robots.md), with a named parameter set (NULL or
 * "default"; the Quattro also has "appendix_a").  Returns NULL on error and writes the
 * reason into err[errlen] (a bad description: "file:line: field: what"). */
PKM_API pkm_model* pkm_model_create(const char* robot, const char* param_set,
                                    char* err, size_t errlen);
PKM_API pkm_model* pkm_model_copy(const pkm_model* m);
PKM_API void pkm_model_destroy(pkm_model* m);

/* The same, returning the status (PKM_ERR_ARGUMENT: unknown robot or set, the known ones
 * named; PKM_ERR_PARAMETER: a parameter of the set is invalid) and the model in *out. */
PKM_API int pkm_model_create_status(const char* robot, const char* param_set, pkm_model** out,
                                    char* err, size_t errlen);

/* ------------------------------------------------------------- robot facts */
/* What the toolkit knows of each robot, from the robot itself: the FMUs, the Python
 * package and the tests read these instead of restating them.  Strings stay valid for
 * the life of the process; out-of-range indices give "" (or -1). */
PKM_API int pkm_robot_count(void);
PKM_API const char* pkm_robot_name(int i);                          /* "6pus", ...      */
PKM_API int pkm_robot_param_set_count(const char* robot);          /* -1: unknown      */
PKM_API const char* pkm_robot_param_set_name(const char* robot, int i); /* "default", ... */
/* One line saying what the robot is, and the description file it was compiled from ("" for
 * the robots written in C++, or for an unknown robot).  Besides the names pkm_robot_name
 * lists, every robot function and pkm_model_create take a path to a description file
 * (docs/robots.md). */
PKM_API const char* pkm_robot_title(const char* robot);
PKM_API const char* pkm_robot_file(const char* robot);
/* Compiles a description given as text (an FMU carries its robot's description this way);
 * the robot then answers to its name.  file names it in messages.  PKM_ERR_ARGUMENT with
 * "file:line: ..." for a bad description. */
PKM_API int pkm_robot_register_description(const char* text, const char* file, char* err, size_t errlen);
PKM_API const char* pkm_model_robot(const pkm_model* m);   /* "6pus", ...          */
/* Pose coordinate i: name ("x", "rz", "theta") and unit ("m", "rad"). */
PKM_API const char* pkm_model_pose_name(const pkm_model* m, int i);
PKM_API const char* pkm_model_pose_unit(const pkm_model* m, int i);
/* What an external tracker measures (a recording's pose columns): count, name and unit of
 * column i.  The pose coordinates, except where the robot measures something else (the
 * four-bar: "X" [m], the coupler's mid point, pkm_fourbar_output). */
PKM_API int pkm_model_tracker_count(const pkm_model* m);
PKM_API const char* pkm_model_tracker_name(const pkm_model* m, int i);
PKM_API const char* pkm_model_tracker_unit(const pkm_model* m, int i);
/* Actuated joints: unit of q ("m" sliders, "rad" revolute), of the effort ("N", "N m"),
 * the noun messages use ("slider", "arm", "joint") and the drive parameters' prefix
 * ("rail" -> "rail[i].coulomb"). */
PKM_API const char* pkm_model_joint_unit(const pkm_model* m);
PKM_API const char* pkm_model_effort_unit(const pkm_model* m);
PKM_API const char* pkm_model_joint_noun(const pkm_model* m);
/* Robot-specific function families the model provides beyond the common set, named by
 * their C function without the "pkm_" prefix: "6pus_calib_rows", "6pus_leg_points" (a
 * described 6-PUS), "fourbar_output" (the four-bar), "quattro_indices", "quattro_gimre",
 * "quattro_points" (a described Quattro: four arm-and-rod legs on an articulated platform,
 * robots/quattro.toml).  Callers ask the model, never its name:
 * pkm_model_has returns 1 if it provides feature, else 0; count and i-th name ("" past
 * the end) list them. */
PKM_API int pkm_model_has(const pkm_model* m, const char* feature);
PKM_API int pkm_model_feature_count(const pkm_model* m);
PKM_API const char* pkm_model_feature(const pkm_model* m, int i);
PKM_API const char* pkm_model_joint_prefix(const pkm_model* m);
/* Parameter i of those a geometric (kinematic) error is described by ("leg[1].L", ...;
 * one per joint when the error is per joint), "" past the end or where the robot names
 * none (then every length parameter outside the drive layer that moves a joint is). */
PKM_API const char* pkm_model_geometry_param(const pkm_model* m, int i);
/* Parameter indices of joint i's lower and upper limit (-1 where the robot has none). */
PKM_API int pkm_model_joint_limits(const pkm_model* m, int i, int* lower_param, int* upper_param);
PKM_API int pkm_model_ndof(const pkm_model* m);            /* actuators = pose dim */

/* Named parameters (Modelica-style dotted names, e.g. "leg[1].L", "platform.m").
 * Index i runs over 0..nparam-1; names, units and descriptions stay valid for the
 * model's lifetime. */
PKM_API int pkm_model_nparam(const pkm_model* m);
PKM_API int pkm_param_index(const pkm_model* m, const char* name); /* -1 if unknown */
PKM_API const char* pkm_param_name(const pkm_model* m, int i);
PKM_API const char* pkm_param_unit(const pkm_model* m, int i);
PKM_API const char* pkm_param_description(const pkm_model* m, int i);
PKM_API double pkm_param_get(const pkm_model* m, int i);
/* 1 if parameter i belongs to the drive layer (the joints' friction, rotor inertia, joint
 * force and offset, the actuators, the sensors, "drive.*", "actuator.*", "sensor.*"), 0 if
 * to the mechanism (geometry, masses, inertias, payload, gravity, joint limits), -1 if i is
 * out of range. */
PKM_API int pkm_param_in_drive_layer(const pkm_model* m, int i);
/* Sets one parameter after checking its own range (e.g. a length > 0, a mass >= 0).
 * Cross-parameter consistency is checked by pkm_model_validate. */
PKM_API int pkm_param_set(pkm_model* m, int i, double value, char* err, size_t errlen);
/* Recomputes derived quantities and checks the parameter set as a whole (e.g. rail
 * directions of unit length, home pose reachable).  Call after pkm_param_set and
 * before computing; computations on an unvalidated model return PKM_ERR_PARAMETER. */
PKM_API int pkm_model_validate(pkm_model* m, char* err, size_t errlen);
/* Time courses of named parameters (drifts: a friction falling as a drive warms up, a
 * payload changed half way).  A course is part of the model (pkm_model_copy and
 * pkm_sim_create copy it) and acts in pkm_sim only: its integrator evaluates the parameter
 * at its own time t, while every other function uses the parameter's value p =
 * pkm_param_get (pkm_param_value_at evaluates the course):
 *   PKM_COURSE_NONE   p(t) = p (the default; setting it clears a course)
 *   PKM_COURSE_TREND  p(t) = p + change (t - t0), change a rate [unit/s], evaluated at every
 *                     stage of every step (the dynamics stay continuous in time); drive-layer
 *                     parameters only (pkm_param_in_drive_layer: friction, offsets, joint
 *                     forces, rotor inertia)
 *   PKM_COURSE_STEP   p(t) = p for t < t0, p + change from t0 on [unit]: an advance across t0
 *                     integrates to t0 and goes on from there (the state is continuous, the
 *                     parameter jumps, no step straddles the jump); any parameter but those
 *                     below, a mechanism one (a mass, the payload) recompiled at t0.
 * t0 [s] finite and >= 0 (the sim's time: a recording's), change finite.  Errors
 * (err may be NULL): PKM_ERR_ARGUMENT for an unknown index or kind, a non-finite change, a
 * negative or non-finite t0; PKM_ERR_PARAMETER for a trend on a mechanism parameter, a
 * course on a joint limit (the integrator's stops), drive.two_body, actuator.delay or
 * sensor.delay (read when a sim is created), and a step whose value after t0 is outside the
 * parameter's range.  A trend leaving the range stops pkm_sim_advance there with
 * PKM_ERR_PARAMETER naming the parameter and the time.  pkm_sim_reset and pkm_sim_state_load
 * take the values at their time (a rollback across a step repeats the run bit for bit). */
typedef enum pkm_course_kind { PKM_COURSE_NONE = 0, PKM_COURSE_TREND = 1, PKM_COURSE_STEP = 2 } pkm_course_kind;
PKM_API int pkm_param_set_course(pkm_model* m, int i, int kind, double change, double t0, char* err,
                                 size_t errlen);
/* The course of parameter i (kind PKM_COURSE_NONE, change and t0 0 if none); outputs may be NULL. */
PKM_API int pkm_param_course(const pkm_model* m, int i, int* kind, double* change, double* t0);
/* The value of parameter i at time t [s] under its course [the parameter's unit]. */
PKM_API int pkm_param_value_at(const pkm_model* m, int i, double t, double* value);
/* The robot's home pose x[nd] (a reachable, non-singular reference pose). */
PKM_API int pkm_model_home(const pkm_model* m, double* x);

PKM_API pkm_data* pkm_data_create(const pkm_model* m);
PKM_API void pkm_data_destroy(pkm_data* d);
/* PKM_OK if d was created for a model of the same robot and size as m. */
PKM_API int pkm_data_check(const pkm_model* m, const pkm_data* d);
/* Message of the last failure on d ("" if none); valid until the next call on d. */
PKM_API const char* pkm_data_error(const pkm_data* d);

/* ================================================================ kinematics */

/* Inverse kinematics: pose x[nd] -> joints q[nd].  Each leg/arm uses the branch
 * fixed by its parameters (6-PUS: leg[i].branch).  PKM_ERR_UNREACHABLE names the leg. */
PKM_API int pkm_ik(const pkm_model* m, pkm_data* d, const double* x, double* q);
PKM_API int pkm_ik_batch(const pkm_model* m, pkm_data* d, size_t n, const double* x,
                         double* q, int* status);

/* A field tol <= 0, max_iter <= 0 or damping < 0 (or opt == NULL) takes the default. */
typedef struct pkm_fk_options {
  double tol;       /* residual tolerance on the constraint, m (default 1e-13)   */
  int max_iter;     /* Newton iterations (default 50)                            */
  double damping;   /* Levenberg damping of the Newton step (default 1e-9)        */
} pkm_fk_options;

typedef struct pkm_fk_info {
  int iterations;   /* Newton iterations used                                    */
  double residual;  /* final max |q_ik(x) - q| [m or rad]                        */
} pkm_fk_info;

/* Forward kinematics by damped Newton from x_guess[nd].  Refuses (returns
 * PKM_ERR_NO_CONVERGENCE, x untouched) a pose it did not converge to.
 * opt and info may be NULL. */
PKM_API int pkm_fk(const pkm_model* m, pkm_data* d, const double* q, const double* x_guess,
                   const pkm_fk_options* opt, double* x, pkm_fk_info* info);
PKM_API int pkm_fk_batch(const pkm_model* m, pkm_data* d, size_t n, const double* q,
                         const double* x_guess, const pkm_fk_options* opt, double* x,
                         int* status);

/* Jacobians at pose x (Zavala-Yoe et al. 2015 eq. 5-6): Jx[nd,nd] xd = Jq[nd,nd] qd, and
 * J[nd,nd] = Jq^-1 Jx, so qd = J xd.  Any output may be NULL. */
PKM_API int pkm_jacobians(const pkm_model* m, pkm_data* d, const double* x, double* Jx,
                          double* Jq, double* J);
/* Time derivative of J along (x, xd): Jdot[nd,nd]. */
PKM_API int pkm_jacobian_dot(const pkm_model* m, pkm_data* d, const double* x,
                             const double* xd, double* Jdot);

/* Singularity measures at x, each in [0, 1], 0 = singular:
 *  measures[0]: inverse-kinematic (type 1, serial) singularity, min over legs of the
 *               normalised |det Jq| contribution (a leg perpendicular to its rail);
 *  measures[1]: direct (type 2, parallel) singularity, 1 / cond(scaled J). */
PKM_API int pkm_singularity(const pkm_model* m, pkm_data* d, const double* x,
                            double* measures);

/* Where each leg's chain is at pose x, for drawing it: pts[nd,3,3], per leg its fixed base
 * joint (a rail's origin, an arm's axis point, a strut's base joint), its moving proximal
 * joint (the slider, the elbow, the cylinder's end) and its platform joint [m, world].
 * Every robot but the four-bar (PKM_ERR_UNSUPPORTED there). */
PKM_API int pkm_chain_points(const pkm_model* m, pkm_data* d, const double* x, double* pts);

/* The platform's full pose X[6] = (x, y, z, rx, ry, rz) [m, rad] at pose x[nd], and the
 * motion map S[6,nd] = dX/dx (may be NULL).  The components a robot does not declare as
 * coordinates are held at 0, or, for a described robot with PRS or RPS legs, dependent:
 * solved from the legs' passive revolute joints by Newton (PKM_ERR_NO_CONVERGENCE names the
 * pose if the constraints are not met to 1e-14 m) -- the parasitic motion of 3-PRS and 3-RPS heads
 * (docs/robots.md, Dependent coordinates).  S's rows of declared coordinates are unit rows,
 * of held ones zero.  A serial arm's (docs/robots.md, Serial arms) X is its tool frame and S its
 * Jacobian in these coordinates (position rows the geometric Jacobian's); a single axis' X is
 * the pose of the carriage or link it moves.  Described robots, the 6-PUS (X = x) and the
 * Quattro (X = (x, y, z, 0, 0, theta)); PKM_ERR_UNSUPPORTED for the four-bar. */
PKM_API int pkm_platform_pose(const pkm_model* m, pkm_data* d, const double* x, double* X,
                              double* S);

/* Velocity and acceleration kinematics. */
PKM_API int pkm_joint_velocity(const pkm_model* m, pkm_data* d, const double* x,
                               const double* xd, double* qd);
PKM_API int pkm_pose_velocity(const pkm_model* m, pkm_data* d, const double* x,
                              const double* qd, double* xd);
PKM_API int pkm_joint_acceleration(const pkm_model* m, pkm_data* d, const double* x,
                                   const double* xd, const double* xdd, double* qdd);
PKM_API int pkm_pose_acceleration(const pkm_model* m, pkm_data* d, const double* x,
                                  const double* xd, const double* qdd, double* xdd);
PKM_API int pkm_pose_velocity_batch(const pkm_model* m, pkm_data* d, size_t n, const double* x,
                                    const double* qd, double* xd, int* status);
PKM_API int pkm_pose_acceleration_batch(const pkm_model* m, pkm_data* d, size_t n,
                                        const double* x, const double* xd, const double* qdd,
                                        double* xdd, int* status);

/* ================================================================== dynamics */

/* Inverse dynamics: actuator efforts tau[nd] that produce xdd at (x, xd), with
 * gravity, joint friction (Coulomb uses sign(qd), 0 at qd = 0) and payload. */
PKM_API int pkm_inverse_dynamics(const pkm_model* m, pkm_data* d, const double* x,
                                 const double* xd, const double* xdd, double* tau);
PKM_API int pkm_inverse_dynamics_batch(const pkm_model* m, pkm_data* d, size_t n,
                                       const double* x, const double* xd,
                                       const double* xdd, double* tau, int* status);
/* The two layers of pkm_inverse_dynamics_batch, for callers that change one layer's
 * parameters many times and keep the other's result (the discrepancy engine's finite
 * differences over friction, rotor inertia or a joint force):
 *   pkm_mechanism_inverse_dynamics_batch: tau[n,nd] = the mechanism's efforts alone (links,
 *     platform, payload, gravity), which no drive-layer parameter changes
 *     (pkm_param_in_drive_layer);
 *   pkm_add_drive_inverse_dynamics_batch: tau[n,nd] += the drive layer's efforts (the joint
 *     force and offset, friction, rotor inertia) at the same (x, xd, xdd), in place.
 *   pkm_add_drive_efforts_batch: the same sum from the joint motion at those poses,
 *     q[n,nd] = pkm_ik (m, rad), qd[n,nd] = pkm_joint_velocity (m/s, rad/s), qdd[n,nd] =
 *     pkm_joint_acceleration (m/s2, rad/s2), for a caller that adds several drive layers
 *     along one motion (q is read only with a joint force, qdd only with a rotor or added
 *     inertia).
 * Either adder applied to the first's output is pkm_inverse_dynamics_batch bit for bit.
 * Same shapes, units, status and NaN rows as pkm_inverse_dynamics_batch; a non-finite tau
 * row given to an adder is refused for that row. */
PKM_API int pkm_mechanism_inverse_dynamics_batch(const pkm_model* m, pkm_data* d, size_t n,
                                                 const double* x, const double* xd,
                                                 const double* xdd, double* tau, int* status);
PKM_API int pkm_add_drive_inverse_dynamics_batch(const pkm_model* m, pkm_data* d, size_t n,
                                                 const double* x, const double* xd,
                                                 const double* xdd, double* tau, int* status);
PKM_API int pkm_add_drive_efforts_batch(const pkm_model* m, pkm_data* d, size_t n, const double* q,
                                        const double* qd, const double* qdd, double* tau, int* status);
/* Forward dynamics: xdd[nd] from (x, xd, tau). */
PKM_API int pkm_forward_dynamics(const pkm_model* m, pkm_data* d, const double* x,
                                 const double* xd, const double* tau, double* xdd);
PKM_API int pkm_forward_dynamics_batch(const pkm_model* m, pkm_data* d, size_t n,
                                       const double* x, const double* xd,
                                       const double* tau, double* xdd, int* status);
/* Task-space mass matrix M[nd,nd] (symmetric positive definite away from
 * singularities): the kinetic energy is 0.5 xd' M xd. */
PKM_API int pkm_mass_matrix(const pkm_model* m, pkm_data* d, const double* x, double* M);
/* Joint-space gravity load g[nd]: the actuator efforts that hold the robot still at x
 * (what PD + gravity compensation feeds forward), the drive's constant offsets
 * "<j>[i].offset" included. */
PKM_API int pkm_gravity_load(const pkm_model* m, pkm_data* d, const double* x, double* g);
/* Kinetic and potential (gravity) energy [J]. */
PKM_API int pkm_energy(const pkm_model* m, pkm_data* d, const double* x, const double* xd,
                       double* kinetic, double* potential);

/* ========================================================= drive and sensors */
/* Every robot has a drive layer between its mechanics and its controller, with
 * per-joint parameters "<j>[i].coulomb", ".viscous", ".stribeck", ".stribeck_v",
 * ".rotor_inertia", ".effort_max", ".dead_zone", ".encoder_offset", ".backlash", ".compliance",
 * ".transmission_damping", ".offset" (<j> = "rail" for the 6-PUS, "joint" otherwise) and "drive.v_eps",
 * "drive.f_eps", "drive.two_body", "actuator.delay", "sensor.delay".  All default to "absent".
 * Backlash and compliance are reading models (below) unless drive.two_body = 1: then a
 * joint with either is a drive body (rotor_inertia, the friction, the command) and the
 * carriage joined by a spring of stiffness 1/compliance with a dead band of the gap,
 * integrated by pkm_sim (pkm_sim_drive_state; the encoder reads the drive body).  Friction and rotor
 * inertia are part of pkm_inverse_dynamics / pkm_forward_dynamics / pkm_mass_matrix /
 * pkm_energy; saturation, delays and the sensor model are applied by pkm_sim and by
 * callers through the functions below.  The sign of the velocity is smoothed,
 * tanh(qd / drive.v_eps), so the dynamics stay Lipschitz.
 *
 * A generic joint force (what the discrepancy engine's discovery step fits when no effect
 * of its library explains a residual) is part of the same functions: per joint
 * "<j>[i].force_*", with z = q - force_qc and s = tanh(qd / v_c), v_c = force_cv if positive (a
 * friction that fades below that speed [m/s | rad/s]) else drive.v_eps,
 *   F = force_k1 z + force_k2 z^2 + force_k3 z^3 + force_v2 qd|qd|
 *     + force_vpos max(qd,0) + force_vneg min(qd,0) + force_cpos max(s,0) + force_cneg min(s,0)
 *     + force_sin sin(2 pi q / force_period) + force_cos cos(2 pi q / force_period)   (period > 0)
 *     + force_step tanh((q - force_step_q) / force_step_w)                             (width > 0)
 *     + force_inertia qdd
 *     + force_qv z qd + (force_cq1 z + force_cq2 z^2) s
 *     + force_czone s (1 + tanh((q - force_czone_q) / force_czone_w)) / 2             (width != 0)
 *     + force_xk1 (q_k - force_xqc) + force_xv qd_k          (k = force_xj, another joint, 1-based; 0: none)
 *     + force_taut w softplus((q - q_k - force_taut_q) / w)  (w = force_taut_w != 0; softplus(x) = log(1 + e^x))
 *     + force_cload |tau| s + force_ceff tau s + (force_eq z + force_eg) tau
 * (tau: the effort the drive applies; the inverse dynamics solve for it, tau = b / (1 - g - mu sign(b)),
 * g = force_ceff s + force_eq z + force_eg, mu = force_cload s; an error where the drive self-locks)
 * [N | N m], an effort the drive spends on the joint like friction (added to the inverse
 * dynamics, subtracted from the applied effort in the forward dynamics and in the effort a
 * transmission carries).  All coefficients default to 0.  The force_taut term is a one-sided
 * spring (a cable carrier or hose joining two carriages, pulling once taut) [N/m | N m/rad] past
 * the slack force_taut_q [m | rad] of q - q_k, with a smooth onset of width force_taut_w [m | rad]
 * (negative: taut below force_taut_q); the reaction on joint k is k's own term with force_xj = i,
 * the same force_taut, force_taut_q and force_taut_w negated; a one-sided spring without another
 * joint (force_xj = 0) is refused.  Its constant term is the drive's
 * offset "<j>[i].offset" (pkm_joint_friction): one parameter for a constant effort, whoever
 * finds it.  Its acceleration term force_inertia [kg | kg m2] is an inertia the drive carries
 * on the joint (a coupling, pulley, belt, a mass riding on the carriage): the same physics as
 * ".rotor_inertia", to which it adds (the joint inertia rotor_inertia + force_inertia, which
 * must not be negative, is in pkm_mass_matrix, pkm_energy and the implicit forward
 * dynamics); with drive.two_body = 1 it stays on the carriage while the rotor is the drive
 * body's. */

/* A force on the platform (robots with one: the described mechanisms, not a single axis such as
 * the EMPS; the 6-PUS, the Quattro) is
 * part of the mechanism's efforts like gravity (pkm_inverse_dynamics,
 * pkm_mechanism_inverse_dynamics_batch, pkm_gravity_load; subtracted from the applied effort in
 * pkm_forward_dynamics and the integrator).  World frame, on the platform, with P = p + R r the
 * platform point r = "cable.point_*" of the full pose (pkm_platform_pose, R = Rx Ry Rz):
 *   f = "wrench.f*" + ("cable.tension" + "cable.stiffness" (|A - P| - "cable.rest_length"))
 *       (A - P) / |A - P| - "platform_drag.linear" v        (A = "cable.anchor_*", v = dp/dt)
 *   m = "wrench.m*" + (R r) x f_cable - "platform_drag.angular" w            (about p)
 * [N, N m, m, N/m, N s/m, N m s/rad]; the joints' efforts are -J^-T S' [f; E' m] (S the motion
 * map, w = E (rx, ry, rz)_dot).  Every parameter defaults to 0. */

/* Joint friction efforts f[nd] at joint velocities qd[nd] (the part of the actuator
 * effort spent on friction): (coulomb + stribeck exp(-(qd/stribeck_v)^2)) sgn(qd) + viscous qd
 * + offset.  The offset "<j>[i].offset" [N | N m] is a constant effort whatever the motion
 * (a cable carrier, an unbalanced mass on a vertical axis, a bias of the effort measurement),
 * with this sign: the effort the drive supplies is inverse dynamics + friction + offset, so a
 * constant force F pushing the joint the positive way is offset = -F. */
PKM_API int pkm_joint_friction(const pkm_model* m, pkm_data* d, const double* qd, double* f);
/* Effort reaching the mechanism for a commanded effort u: the drive's dead zone u0
 * (dead_zone > 0: |u| <= u0 gives 0, a larger command delivers u - u0 sgn(u)), then
 * clipped at effort_max (if > 0). */
PKM_API int pkm_actuator_effort(const pkm_model* m, pkm_data* d, const double* tau_cmd,
                                double* tau_applied);
PKM_API int pkm_actuator_effort_batch(const pkm_model* m, pkm_data* d, size_t n,
                                      const double* tau_cmd, double* tau_applied, int* status);
/* A drive's command-to-effort map, sampled: what a torque sensor (or a motor current
 * times its torque constant) reads against the commanded effort u.  The command u[k] is
 * held over [t_k, t_k + dt); the drive makes e_k = clip(gain u[k], +-limit) + offset
 * (limit <= 0 or inf: none) and the delivered effort follows e with a first-order lag of
 * time constant lag [s] (>= 0): y[k] = a y[k-1] + (1 - a) e_k, a = exp(-dt / lag), the
 * delivered effort at t_k + dt, exact for the held e (lag = 0: y[k] = e_k); y[-1] = y0.
 * The effort read at t_k is y[k-1].  u, y [n] in the same unit (N or N m); a non-finite
 * value or a bad parameter returns PKM_ERR_ARGUMENT with the reason in err. */
PKM_API int pkm_effort_map(size_t n, double dt, const double* u, double gain, double offset, double lag,
                           double limit, double y0, double* y, char* err, size_t errlen);
/* Joint readings at (x, xd) with applied effort tau[nd]:
 * q_meas = q + encoder_offset + backlash/2 sgn(c) + compliance c, with c the effort the
 * transmission carries.  tau is the drive's whole effort (what pkm_forward_dynamics is given),
 * not the transmitted one: this function takes c from it by removing the joint friction
 * (pkm_joint_friction at the joint rates of xd: Coulomb, Stribeck, viscous), the joint force
 * and offset, the joints' share of the platform force, and the rotor's inertial share
 * (rotor_inertia + force_inertia) qdd, qdd from the forward dynamics at (x, xd, tau).  A
 * caller that has already taken friction or the rotor's share off tau has them removed twice.
 * Without a backlash or a compliance the readings do not depend on tau (c is not computed).
 * The encoder is on the drive side, the carriage leans on the side of the gap c pushes it to
 * (smooth sign tanh(c / drive.f_eps)), and the transmission deflects by compliance c. */
PKM_API int pkm_measure_joints(const pkm_model* m, pkm_data* d, const double* x,
                               const double* xd, const double* tau, double* q_meas);
/* Readings and rates of the sensors at (x, xd) with applied effort tau[nd]: pkm_measure_joints's
 * readings and the joint rates (qd_meas may be NULL); on a joint that is two bodies
 * (drive.two_body), given its drive body theta, theta_d (pkm_sim_drive_state; either may be
 * NULL), the encoder reads theta + encoder_offset and the rate theta_d. */
PKM_API int pkm_sensor_readings(const pkm_model* m, pkm_data* d, const double* x, const double* xd,
                                const double* tau, const double* theta, const double* theta_d,
                                double* q_meas, double* qd_meas);
/* Number of joints that are two bodies: drive.two_body = 1 and a backlash or a compliance on
 * them (0 for a model without). */
PKM_API int pkm_model_two_body_joints(const pkm_model* m);
PKM_API int pkm_measure_joints_batch(const pkm_model* m, pkm_data* d, size_t n,
                                     const double* x, const double* xd, const double* tau,
                                     double* q_meas, int* status);

/* =============================================================== integration */

/* Integration methods.  PKM_ERK, the default: an explicit Runge-Kutta 5(4) pair
 * (Dormand-Prince) whose whole state is (t, x, xd) plus the step size it proposes next,
 * so nothing is lost at a communication point (a 1 ms loop costs about one step per
 * millisecond, 6 forward-dynamics calls: the first stage after a new input is the last
 * one before it plus a 6x6 product, the dynamics being affine in the effort); for
 * non-stiff motion.  PKM_ERK23: the Bogacki-Shampine 3(2) pair, 3 calls a step, for
 * throughput at looser tolerances (rtol 1e-6: one step per millisecond).  PKM_BDF:
 * CVODE's variable-order BDF with a dense Newton solver, for stiff settings (e.g.
 * Coulomb friction with a small drive.v_eps).
 * PKM_ADAMS: CVODE's Adams-Moulton.  CVODE restarts at every advance.
 * docs/integration.md compares them (speed, accuracy, when to use which). */
typedef enum pkm_lmm { PKM_BDF = 0, PKM_ADAMS = 1, PKM_ERK = 2, PKM_ERK23 = 3 } pkm_lmm;

/* The methods as a table, the one list every layer reads (the Python package's method
 * names, the scenario summary, the FMUs' check of solver.method), in the way mujoco.h
 * names its enums: for i in [0, pkm_sim_method_count()), pkm_sim_method gives the
 * method's pkm_lmm code, its short name ("erk", "erk23", "bdf", "adams": cosim's
 * method= and a scenario's [integrator] method), a title for messages ("explicit
 * Runge-Kutta 5(4)") and whether this binary carries it (0: BDF and Adams in a build
 * without SUNDIALS, PKM_NO_CVODE).  Any output pointer may be NULL.  PKM_ERR_ARGUMENT
 * for i out of range. */
PKM_API int pkm_sim_method_count(void);
PKM_API int pkm_sim_method(int i, int* code, const char** name, const char** title, int* available);

typedef struct pkm_sim_options {
  int method;        /* PKM_ERK (default), PKM_ERK23, PKM_BDF or PKM_ADAMS         */
  double rtol;       /* relative tolerance (default 1e-8)                         */
  double atol;       /* absolute tolerance (default 1e-10)                        */
  double max_step;   /* largest internal step, s (0 = unlimited)                  */
  long max_steps;    /* internal steps per advance (default 100000, at most
                        PKM_SIM_MAX_STEPS_LIMIT): the work budget of one advance     */
  double sing_min;   /* stop when measures[1] of pkm_singularity drops below (1e-4) */
} pkm_sim_options;

/* The largest max_steps: one advance must return in bounded time (a host cannot tell a
 * slow call from a hang).  An explicit step of a 6-dof robot costs ~5-20 us, a BDF step
 * more: 1e6 steps are seconds, the most a 1 ms communication step should ever take. */
#define PKM_SIM_MAX_STEPS_LIMIT 1000000L

typedef struct pkm_sim_stats {
  long steps, rhs_evals, jac_evals, error_test_fails, nonlin_conv_fails;
} pkm_sim_stats;

/* An integration of the task-space state (x, xd) under a zero-order-hold input tau.
 * The result of an advance depends only on the sim's state (pkm_sim_state_save: t, x,
 * xd, the held tau, the explicit method's next step size, the actuator-delay history)
 * and the options: loading a saved state and advancing again reproduces the trajectory
 * bit for bit, also in another sim of the same model and options. */
typedef struct pkm_sim pkm_sim;

PKM_API void pkm_sim_default_options(pkm_sim_options* opt);
/* Copies m (later parameter changes of m do not reach the sim) and starts at the home
 * pose at rest, t = 0, tau = 0.  opt NULL: defaults.  NULL on error, the reason (e.g.
 * the bad option) in err.  See docs/integration.md. */
PKM_API pkm_sim* pkm_sim_create(const pkm_model* m, const pkm_sim_options* opt, char* err,
                                size_t errlen);
PKM_API void pkm_sim_destroy(pkm_sim* s);
/* Refuses (state unchanged) a non-finite, unreachable, beyond-limit or singular state;
 * keeps the held input. */
PKM_API int pkm_sim_reset(pkm_sim* s, double t0, const double* x, const double* xd);
/* Holds tau[nd] from now on, saturated at <j>[i].effort_max; with actuator.delay > 0
 * the mechanism feels each command that much later. */
PKM_API int pkm_sim_set_input(pkm_sim* s, const double* tau);
/* Integrates to t_end.  On a stroke/joint limit, a singularity or a CVODE failure,
 * stops at the event time with the state there and returns the status; the message
 * names the leg and the time.  At most max_steps internal steps (explicit attempts and
 * CVODE steps): then PKM_ERR_STEP_BUDGET at the last accepted state.  The explicit methods
 * hand a stiff stretch to CVODE BDF by themselves (docs/integration.md, Bounded work). */
PKM_API int pkm_sim_advance(pkm_sim* s, double t_end);
/* A wall-clock limit on each pkm_sim_advance [s] (0, the default: none).  Past it the
 * advance stops at its last accepted state with PKM_ERR_STEP_BUDGET, as when max_steps
 * runs out.  The only result of a sim that depends on the machine: for hosts that must get
 * an answer in bounded time (the FMUs set 1 s per fmi2DoStep; docs/integration.md). */
PKM_API int pkm_sim_set_time_limit(pkm_sim* s, double seconds);
PKM_API int pkm_sim_get_state(const pkm_sim* s, double* t, double* x, double* xd);
/* Drive-side position and rate per joint [m or rad, m/s or rad/s]: the drive body's for a
 * joint that is two bodies (drive.two_body = 1 with a backlash or a compliance), the joint's
 * own otherwise.  Either pointer may be NULL. */
PKM_API int pkm_sim_drive_state(pkm_sim* s, double* theta, double* theta_d);
/* Effort tau[nd] acting on the mechanism at the sim's current time from the commands held
 * so far [N or N m]: the held input (saturated), or with actuator.delay > 0 the one issued
 * delay earlier (zero before the first).  The effort the sensor model's compliance reads
 * under at a sample (pkm_closed_loop, the stepwise loop of cosim.closed_loop). */
PKM_API int pkm_sim_applied_effort(const pkm_sim* s, double* tau);
/* A known external effort f[nd] per joint [N or N m], positive along +q (e.g. a measured
 * force on a carriage), held from now on and added to the effort reaching the mechanism,
 * with no saturation and no delay (zero at creation).  An input like tau: the caller sets
 * it before each advance; it is not part of the saved state. */
PKM_API int pkm_sim_set_external(pkm_sim* s, const double* f);
/* Pose acceleration xdd[nd] at the sim's current state under the command tau[nd] (its dead
 * zone and saturation applied, no delay): the forward dynamics, with a two-body joint's
 * carriage driven by what its transmission carries. */
PKM_API int pkm_sim_acceleration(pkm_sim* s, const double* tau, double* xdd);
/* The sim's whole state as doubles, for rollback (FMU get/set/serialize state):
 * pkm_sim_state_size values (it varies with the actuator-delay history), saved by
 * pkm_sim_state_save and restored by pkm_sim_state_load, which checks the layout, the
 * robot's size and the state itself as pkm_sim_reset does (a refused state leaves the
 * sim unchanged).  pkm_sim_reset, in contrast, starts afresh: the explicit method then
 * chooses its first step again. */
PKM_API size_t pkm_sim_state_size(const pkm_sim* s);
PKM_API int pkm_sim_state_save(const pkm_sim* s, double* buf);
PKM_API int pkm_sim_state_load(pkm_sim* s, const double* buf, size_t n);
/* Integration counters summed over every advance since pkm_sim_create (steps, RHS
 * evaluations, error-test failures; for PKM_ERK nonlin_conv_fails counts steps retried
 * because a trial state left the workspace). */
PKM_API int pkm_sim_get_stats(const pkm_sim* s, pkm_sim_stats* stats);
PKM_API const char* pkm_sim_error(const pkm_sim* s);

/* The delay line of a closed loop's joint readings (drive parameter sensor.delay), the
 * one the sim keeps for pkm_closed_loop, for a loop stepped from outside the core (the
 * stepwise loop of cosim.closed_loop around any plant).  Created from a validated model
 * (its sensor.delay at creation); NULL on error, the reason in err. */
typedef struct pkm_reading_delay pkm_reading_delay;
PKM_API pkm_reading_delay* pkm_reading_delay_create(const pkm_model* m, char* err, size_t errlen);
PKM_API void pkm_reading_delay_destroy(pkm_reading_delay* r);
/* Records the sample (t, q[nd], qd[nd]) and replaces q and qd by the reading and rate of
 * t - sensor.delay, interpolated linearly between the samples around it (the first
 * sample's before it); without a delay q and qd stay.  Sample times must not decrease. */
PKM_API int pkm_reading_delay_read(pkm_reading_delay* r, double t, double* q, double* qd);
/* Forgets every sample (a new run). */
PKM_API void pkm_reading_delay_reset(pkm_reading_delay* r);
PKM_API const char* pkm_reading_delay_error(const pkm_reading_delay* r);

/* ================================================================= control */
/* Sampled joint-space controllers (docs/scenarios.md), the same laws as cosim.controllers.
 * At each sample t_k the controller reads the joint readings q, qd [m or rad, per s] and
 * the reference (qref, qdref, qddref, and the reference pose xref if known) and returns the
 * efforts tau [N or N m] held until the next sample; e = qref - q, ed = qdref - qd.
 *
 *  PKM_CTRL_PD                tau = Kp e + Kd ed
 *  PKM_CTRL_PD_GRAVITY        tau = Kp e + Kd ed + g(x), g = pkm_gravity_load at x: the pose
 *                             of the measured joints by pkm_fk from the previous sample's pose
 *                             (gravity_at_reference = 0) or xref (1)
 *  PKM_CTRL_COMPUTED_TORQUE   qdd_cmd = qddref + Kd ed + Kp e, tau = ID(x, xd, xdd) with x by FK,
 *                             xd = pose velocity of qd, xdd = pose acceleration of qdd_cmd
 *  PKM_CTRL_PID               tau = Kp e + Ki i + Kd d (+ g(x) if gravity_feedforward), with the
 *                             integral i_k = i_{k-1} + dt e_k (frozen while the output is saturated
 *                             and e pushes further into the limit: anti-windup) and the filtered
 *                             derivative of e by backward difference, d_k = (Tf d_{k-1} + (e_k -
 *                             e_{k-1})) / (Tf + dt) (Tf = deriv_filter [s]; the first sample has d = 0)
 *  PKM_CTRL_LTI               any discrete LTI controller on the error (e.g. a python-control design
 *                             after c2d at dt): xc_{k+1} = A xc_k + B e_k, tau = C xc_k + D e_k
 *                             (+ g(x) if gravity_feedforward)
 *  PKM_CTRL_DISCRETE          a rig's sampled controller described as data (docs/scenarios.md,
 *                             "discrete"), per joint on the readings q, qd:
 *                               qf = position filter (b, a) of q        (pos_b/pos_a; none: qf = q)
 *                               v  = (qf_k - qf_{k-1}) / dt (velocity_source 0), or qd (1),
 *                                    then the velocity filter (vel_b/vel_a; none: as is)
 *                               law PKM_LAW_CASCADE_PP: u = Kv (Kp (qref - qf) - v)
 *                               law PKM_LAW_PID:        u = Kp (qref - qf) + Ki i + Kd (qdref - v),
 *                                                       i_k = i_{k-1} + dt (qref - qf) (anti-windup
 *                                                       as PKM_CTRL_PID on [u_min, u_max])
 *                               u clipped to [u_min, u_max] (controller units, e.g. V), then
 *                               tau = output_gain u (effort units) applied delay_samples later
 *                               (zero before).
 *                             A filter is y_k = (sum_i b_i x_{k-i} - sum_{i>=1} a_i y_{k-i}) / a_0,
 *                             starting at rest at the first sample (past inputs = the first one).
 * Every kind then clips tau at +-saturation[i] (if given). */
typedef enum pkm_ctrl_kind {
  PKM_CTRL_PD = 0,
  PKM_CTRL_PD_GRAVITY = 1,
  PKM_CTRL_COMPUTED_TORQUE = 2,
  PKM_CTRL_PID = 3,
  PKM_CTRL_LTI = 4,
  PKM_CTRL_DISCRETE = 5
} pkm_ctrl_kind;

/* Laws of PKM_CTRL_DISCRETE. */
enum { PKM_LAW_CASCADE_PP = 0, PKM_LAW_PID = 1 };
/* Longest filter (coefficients of b or a) and longest computation delay [samples]. */
enum { PKM_CTRL_MAX_TAPS = 16, PKM_CTRL_MAX_DELAY = 64 };

typedef struct pkm_ctrl_spec {
  int kind;                 /* pkm_ctrl_kind                                              */
  double dt;                /* sample period [s] (> 0)                                    */
  const double* kp;         /* [nd,nd] (PD, PD_GRAVITY, PID: N/m or N m/rad; CT: 1/s^2)   */
  const double* kd;         /* [nd,nd] (N s/m or N m s/rad; CT: 1/s)                      */
  const double* ki;         /* [nd,nd] PID only (N/(m s) or N m/(rad s)), may be NULL     */
  double deriv_filter;      /* PID: derivative filter time constant Tf [s] (>= 0)         */
  const double* saturation; /* [nd] largest |tau_i| [N or N m] (> 0), or NULL for none   */
  int gravity_at_reference; /* PD_GRAVITY: 1 = g at xref instead of the measured pose     */
  int gravity_feedforward;  /* PID, LTI: 1 = add g(x) at the measured pose                */
  int nx;                   /* LTI: controller states (>= 0, <= 64)                       */
  const double *A, *B, *C, *D; /* LTI: A[nx,nx], B[nx,nd], C[nd,nx], D[nd,nd]            */
  /* DISCRETE (kp [nd,nd] as above in controller units per joint unit, or 1/s in a cascade;
   * ki, kd for the PID law, may be NULL):                                                 */
  int law;                  /* PKM_LAW_CASCADE_PP or PKM_LAW_PID                          */
  const double* kv;         /* [nd,nd] cascade velocity gain (controller units per m/s)   */
  int pos_nb, pos_na;       /* position filter: coefficients in pos_b, pos_a (0, 0: none) */
  const double *pos_b, *pos_a;
  int vel_nb, vel_na;       /* velocity filter (0, 0: none)                               */
  const double *vel_b, *vel_a;
  int velocity_source;      /* 0: backward difference of qf, 1: the reading qd            */
  const double *u_min, *u_max; /* [nd] output limits in controller units, or NULL (none) */
  const double* output_gain;   /* [nd] effort per controller unit, or NULL (1)            */
  int delay_samples;        /* computation delay [samples] (0 .. PKM_CTRL_MAX_DELAY)      */
} pkm_ctrl_spec;

typedef struct pkm_ctrl pkm_ctrl;

/* Copies the spec's arrays and a copy of m (for g, FK and ID).  NULL on error, the reason
 * (which field, which entry) in err. */
PKM_API pkm_ctrl* pkm_ctrl_create(const pkm_model* m, const pkm_ctrl_spec* spec, char* err,
                                  size_t errlen);
PKM_API void pkm_ctrl_destroy(pkm_ctrl* c);
/* Starts a run: clears integrator, filter and LTI states, the saturation counter; x0 (may
 * be NULL: the home pose) is the first guess of the forward kinematics of the measured joints. */
PKM_API int pkm_ctrl_reset(pkm_ctrl* c, const double* x0);
/* One sample at time t: tau[nd] from the readings and the reference (qddref and xref may
 * be NULL where the kind does not need them).  A non-finite reading, a failed FK or ID
 * returns the status and a message naming the joint and the time (pkm_ctrl_error). */
PKM_API int pkm_ctrl_update(pkm_ctrl* c, double t, const double* q, const double* qd,
                            const double* qref, const double* qdref, const double* qddref,
                            const double* xref, double* tau);
/* Primes the controller's history: feeds n past samples (oldest first; rows of t [n], q, qd,
 * qref, qdref, qddref, xref [n,nd], qddref and xref may be NULL where the kind does not need
 * them) through pkm_ctrl_update, outputs discarded, the saturation counter unchanged.  A run
 * that starts in the middle of a recording (the replay of a held-out part) calls it after
 * pkm_ctrl_reset with the recorded readings and reference of the samples before its start:
 * filters, backward differences, integrators and the computation-delay line then hold what
 * the rig's controller held instead of starting at rest (a DISCRETE controller at rest
 * outputs zero for delay_samples samples and sees no velocity at first).  A failure names
 * the sample's time like pkm_ctrl_update; the samples before it have been taken. */
PKM_API int pkm_ctrl_prime(pkm_ctrl* c, size_t n, const double* t, const double* q, const double* qd,
                           const double* qref, const double* qdref, const double* qddref,
                           const double* xref);
/* A signal injected into the loop (an identification test signal, a dither), at one of:
 *   PKM_INJECT_COMMAND            w [N or N m] added to the controller's output before its
 *                                 saturation (a DISCRETE controller: w / output_gain added
 *                                 to u before the clamp to [u_min, u_max]; e.g. a test
 *                                 voltage added to the command, in effort units);
 *   PKM_INJECT_COMMAND_AFTER_SAT  the same, after the saturation;
 *   PKM_INJECT_REFERENCE          w [m or rad] added to qref (not to qdref);
 *   PKM_INJECT_MEASUREMENT        w [m or rad] added to the position reading q the law sees.
 * A command signal is part of the output of the sample it is given at: it goes through
 * the output gain and the computation delay (delay_samples) with it. */
typedef enum pkm_inject_point {
  PKM_INJECT_NONE = 0,
  PKM_INJECT_COMMAND = 1,
  PKM_INJECT_COMMAND_AFTER_SAT = 2,
  PKM_INJECT_REFERENCE = 3,
  PKM_INJECT_MEASUREMENT = 4
} pkm_inject_point;
/* pkm_ctrl_update with w[nd] injected at point (w may be NULL with PKM_INJECT_NONE);
 * tau_inj[nd] (may be NULL) receives the part of tau the signal makes, tau minus what tau
 * would be without it (saturation and delay included): what a recording of the
 * controller's output without the signal lacks.  That part is a record, not state: it is
 * not in pkm_ctrl_state_save (no future output depends on it). */
PKM_API int pkm_ctrl_update_injected(pkm_ctrl* c, double t, const double* q, const double* qd,
                                     const double* qref, const double* qdref, const double* qddref,
                                     const double* xref, int point, const double* w, double* tau,
                                     double* tau_inj);
/* pkm_ctrl_prime with the signal w [n,nd] of those samples injected at point. */
PKM_API int pkm_ctrl_prime_injected(pkm_ctrl* c, size_t n, const double* t, const double* q,
                                    const double* qd, const double* qref, const double* qdref,
                                    const double* qddref, const double* xref, int point,
                                    const double* w);
/* Samples at which the saturation clipped an effort since the last reset. */
PKM_API long pkm_ctrl_saturated(const pkm_ctrl* c);
PKM_API const char* pkm_ctrl_error(const pkm_ctrl* c);
/* Everything that determines the controller's future outputs (states, last error, pose
 * guess), as pkm_ctrl_state_size doubles, for FMU get/set state.  The block starts with
 * its layout (version, kind, joints, LTI states); a DISCRETE controller's state ends with
 * its own block, led by its layout (joints, filter lengths, delay).  pkm_ctrl_state_load
 * checks both against the controller before taking anything and refuses, naming what, a
 * block of another length or layout, a non-finite value, a flag that is not 0 or 1 or a
 * count that is not whole, and then leaves the controller unchanged. */
PKM_API size_t pkm_ctrl_state_size(const pkm_ctrl* c);
PKM_API int pkm_ctrl_state_save(const pkm_ctrl* c, double* buf);
PKM_API int pkm_ctrl_state_load(pkm_ctrl* c, const double* buf, size_t n);

/* ============================================================== closed loop */
/* A whole sampled closed loop in one call (the way MuJoCo's rollout runs many steps):
 * plant s, controller c and a reference table (the compiled back end of
 * cosim.closed_loop.ClosedLoop, whose stepwise back end runs the same sequence).  At
 * each sample k = 0..n-1 (time t_k):
 *   1. readings: q_k = the plant's joints, or with measure = 1 the sensor model
 *      (pkm_sensor_readings at the effort acting at the sample: the last command's, or
 *      with actuator.delay the sim's delayed one, pkm_sim_applied_effort), and qd_k = the
 *      plant's joint rates; with sensor.delay = d > 0, both are those of t_k - d,
 *      interpolated linearly between the samples around it (the first sample's before
 *      it; the sim keeps the line across calls, pkm_sim_reset drops what follows t0);
 *      then plus q_noise[k] and qd_noise[k] (noise arrays may be NULL);
 *   2. tau_k = pkm_ctrl_update(c, t_k, q_k, qd_k, reference row k), with the signal
 *      inject[k] at inject_point if given (pkm_ctrl_update_injected: q_k is recorded as
 *      read, the law sees q_k + inject[k] with PKM_INJECT_MEASUREMENT);
 *   3. the row is recorded; the plant then holds tau_k (pkm_sim_set_input: saturation,
 *      actuator delay) and the known external effort f_ext[k] if given, and advances to
 *      t_k + dt (not after the last sample).
 * The plant starts from its current state, at time t0.  On a failure (controller, limit,
 * singularity, integration) the loop stops, *n_done says how many rows were recorded
 * (the rows before the failure), and the status is returned with the message, naming
 * the time, in pkm_sim_error(s). */
typedef struct pkm_loop_reference {
  size_t n;                 /* samples (>= 1)                                            */
  double t0, dt;            /* time of sample 0 and the period [s]                        */
  const double* t;          /* [n] sample times [s], or NULL for t0 + k dt; the plant
                               advances from t_k to t_k + dt                             */
  const double *q, *qd;     /* [n,nd] joint reference and its rate                        */
  const double *qdd, *x;    /* [n,nd] joint acceleration and pose reference, may be NULL */
  const double* tau_before; /* [nd] effort applied before sample 0 (for the sensor model's
                               compliance), NULL for none: lets a loop go on in pieces  */
  const double* f_ext;      /* [n,nd] known external effort per joint, held over the step
                               after each sample like the command (pkm_sim_set_external),
                               or NULL (the sim's own setting stays)                     */
  int inject_point;         /* pkm_inject_point of inject (PKM_INJECT_NONE: none)         */
  const double* inject;     /* [n,nd] the injected signal, or NULL                        */
} pkm_loop_reference;

typedef struct pkm_loop_record {
  /* [n,nd] each, any may be NULL: readings (sensor model, delay and noise; not the
   * injected signal), the plant's true joints, pose and pose rate at the sample, the
   * command (with the injected signal) and the effort applied (saturated); tau_inj: the
   * part of tau_cmd the injected signal makes (pkm_ctrl_update_injected). */
  double *q, *qd, *q_true, *qd_true, *x, *xd, *tau_cmd, *tau, *tau_inj;
} pkm_loop_record;

PKM_API int pkm_closed_loop(pkm_sim* s, pkm_ctrl* c, const pkm_loop_reference* ref,
                            const double* q_noise, const double* qd_noise, int measure,
                            pkm_loop_record* out, size_t* n_done);

/* ====================================================== 6-PUS specific (Tiberi 2020) */

enum { PKM_FRAME_WORLD = 0, PKM_FRAME_PLATFORM = 1 };

/* Calibration regression rows rows[6,10]: dq_i / d eta_i for each leg i, eta_i =
 * [X, Y, Z, S0x, S0y, S0z, L, sx, sy, sz] (Tiberi 2020 eq. 4.1).  frame selects the
 * coordinates of the platform point: PKM_FRAME_WORLD differentiates with respect to
 * the world position of P_i at this pose (the source's tables), PKM_FRAME_PLATFORM with
 * respect to its platform-frame coordinates leg[i].px/py/pz (what calibration needs:
 * constant over poses).  The rail-direction columns are the implicit derivatives of
 * the constraint without keeping |s| = 1, i.e. -q w / (s . w). */
PKM_API int pkm_6pus_calib_rows(const pkm_model* m, pkm_data* d, const double* x, int frame,
                                double* rows);
/* World positions of the platform points P[6,3] and of the sliders S[6,3] at pose x. */
PKM_API int pkm_6pus_leg_points(const pkm_model* m, pkm_data* d, const double* x, double* P,
                                double* S);

/* ==================================================== four-bar specific (Vitali 2020) */

/* Output of the four-bar at crank angle theta [rad]: X [m] of the mid point of
 * link 2, and dX/dl[4] with respect to the link lengths l1..l4 (may be NULL). */
PKM_API int pkm_fourbar_output(const pkm_model* m, pkm_data* d, double theta, double* X,
                               double* dX_dl);

/* ================================================ Quattro specific (Virzi 2010) */

/* Quattro conventions: pose x = (x, y, z, theta), the tool point in the source's model
 * frame (arm 1 along +x, arm 2 along +y, z up) with the Adept origin `base.h` above the
 * motor-axis plane [m], and the platform articulation angle theta (source symbol theta_0) [rad].
 * q_i is the source's arm angle at the gearbox output (positive downwards) [rad] and tau_i
 * the arm-side torque [N m] = gear.ratio x motor torque (rotor inertia included).
 *
 * Performance indices per pose, one column each (source ch. 3-5; docs/quattro.md):
 *  0 mu_T      translational manipulability 1/sqrt(det(JD^T JD)), JD = b_r J[:,0:3] [-]
 *  1 mu_xy     horizontal, sub-matrix variant (columns x, y of b_r J)           [-]
 *  2 mu_z      vertical, sub-matrix variant (column z of b_r J)                  [-]
 *  3 mu_T_eig  translational, eigenvalue variant: 3 largest eigenvalues of b_r^2 J^T J
 *  4 mu_xy_eig horizontal, eigenvalue variant (the two middle eigenvalues)       [-]
 *  5 mu_z_eig  vertical, eigenvalue variant (the largest eigenvalue)             [-]
 *  6 kappa_T   condition number of b_r J[:,0:3] (>= 1)                           [-]
 *  7 dTIM      dynamic isotropy 27 det(TIM) / tr(TIM)^3 of the GIMRE             [-]
 *  8 dTIM_xy   sqrt(det(N[0:2,:] N[0:2,:]^T))                                    [kg^2]
 *  9 dTIM_x   10 dTIM_y   11 dTIM_z: norms of rows 1..3 of the GIMRE N            [kg]
 * 12 kat      mean of kat_x, kat_y, kat_z                                        [kg]
 * 13 kat_xy   mean of kat_x, kat_y                                               [kg]
 * 14 kat_x    15 kat_y    16 kat_z: norms of the rows of L = M[0:3,0:3]          [kg]
 * 17 Fcc_z    |translational Coriolis/centrifugal force| at xd = (0,0,1,0) m/s  [N]
 * 18 Fcc_xy   the same at xd = (1,1,0,0)/sqrt(2) m/s                             [N]
 * 19 Fgr      |translational gravity force| (task-space gradient of V)           [N]
 * 20 alfa_z   largest vertical acceleration with every |tau_i| <= ratio x tau_nominal,
 *             from rest, gravity left out as in the source                         [m/s^2]
 * 21 alfa_x   the same along (-1,-1,0)/sqrt(2), the Adept platform x axis        [m/s^2] */
enum { PKM_QUATTRO_NINDEX = 22 };

/* Name ("mu_T", ...) and unit of index column i; "" if i is out of range. */
PKM_API const char* pkm_quattro_index_name(int i);
PKM_API const char* pkm_quattro_index_unit(int i);
/* Indices of n poses x[n,4] into out[n,PKM_QUATTRO_NINDEX], one pass in C++.  Batched
 * convention: an unreachable pose, a pose beyond the joint range or a singular pose
 * gets its status in status[n] (may be NULL) and a NaN row. */
PKM_API int pkm_quattro_indices(const pkm_model* m, pkm_data* d, size_t n, const double* x,
                                double* out, int* status);
/* Generalized inertia matrix reduced to the end effector N[4,4] (source ch. 4; no motor
 * rotors): kinetic energy of links and platform = 0.5 xd' N xd. */
PKM_API int pkm_quattro_gimre(const pkm_model* m, pkm_data* d, const double* x, double* N);
/* Points at pose x, each [4,3] in the world frame [m]: A (motor axes), B (elbows,
 * forearm upper ends), C (platform joints).  Any output may be NULL. */
PKM_API int pkm_quattro_points(const pkm_model* m, pkm_data* d, const double* x, double* A,
                               double* B, double* C);
/* The Quattro's constants that the indices and the cycle-time search read, out[PKM_QUATTRO_NCONSTANT]
 * (feature "quattro_indices"); a description carries no drive rating, so the first two are
 * the s650H's (source ch. 5.6):
 *  0 tau_arm_max  arm-side torque limit of the alfa indices, gear_ratio x nominal motor torque [N m]
 *  1 gear_ratio   motor to arm [-]
 *  2 base_height  the Adept origin's height above the motor-axis plane (source symbol base) [m]
 *  3 link_length  arm 1's link length b_r, which scales J in the indices [m] */
enum { PKM_QUATTRO_NCONSTANT = 4 };
PKM_API const char* pkm_quattro_constant_name(int i);
PKM_API const char* pkm_quattro_constant_unit(int i);
PKM_API int pkm_quattro_constants(const pkm_model* m, pkm_data* d, double* out);

#ifdef __cplusplus
}
#endif
#endif /* PKM_PKM_H */
