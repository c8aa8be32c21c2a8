"""Reference trajectories: derivatives against central differences, knots, the "M", pose sets."""
import numpy as np
import pytest

from cosim import trajectories as tr


def _fd(traj, t, h=1e-6):
    xp, _, _ = traj.evaluate(t + h)
    xm, _, _ = traj.evaluate(t - h)
    _, vp, _ = traj.evaluate(t + h)
    _, vm, _ = traj.evaluate(t - h)
    return (xp - xm) / (2 * h), (vp - vm) / (2 * h)


def test_blend_derivatives_match_central_differences():
    traj = tr.waypoints([[0, 0, 0.07, 0, 0, 0], [0.01, -0.02, 0.08, 0.02, 0, -0.03], [0, 0.01, 0.06, 0, 0.05, 0]],
                        move_time=[0.3, 0.5], hold_time=0.1)
    t = np.linspace(0.001, traj.duration - 0.001, 97)
    t = t[np.min(np.abs(t[:, None] - traj.times[None, :]), axis=1) > 1e-4]   # away from knots
    _, xd, xdd = traj.evaluate(t)
    vfd, afd = _fd(traj, t)
    np.testing.assert_allclose(xd, vfd, atol=1e-7)
    np.testing.assert_allclose(xdd, afd, atol=1e-5)
    assert np.max(np.abs(xd)) > 0.05  # the test is not vacuous


def test_knots_are_rest_points_and_continuous():
    traj = tr.waypoints([[0.0, 0.0], [1.0, 2.0], [3.0, -1.0]], move_time=[1.0, 2.0])
    for tk, xk in zip(traj.times, traj.knots):
        for eps in (-1e-9, 1e-9):
            x, xd, xdd = traj.evaluate([tk + eps])
            np.testing.assert_allclose(x[0], xk, atol=1e-8)
            np.testing.assert_allclose(xd[0], 0.0, atol=1e-7)
            np.testing.assert_allclose(xdd[0], 0.0, atol=1e-6)
    # peak speed of a minimum-jerk move is 15/8 of the mean
    _, xd, _ = traj.evaluate([0.5])
    np.testing.assert_allclose(xd[0], [15 / 8, 15 / 4])


def test_step_before_and_after():
    s = tr.step([0, 0, 0.065], [0, 0, 0.085], t_step=0.1)
    x, xd, xdd = s.evaluate([0.0, 0.0999, 0.1, 0.5])
    np.testing.assert_array_equal(x[:, 2], [0.065, 0.065, 0.085, 0.085])
    assert not xd.any() and not xdd.any()
    with pytest.raises(tr.TrajectoryError, match="x0 has shape"):
        tr.step([0, 0], [0, 0, 1])


def test_letter_m_visits_the_corners_at_constant_height():
    traj = tr.letter_m(center=(0.001, -0.002), z=0.07, width=0.03, height=0.02, segment_time=0.4, hold_time=0.1)
    corners = tr.letter_m_corners((0.001, -0.002), 0.03, 0.02)
    np.testing.assert_allclose(corners[0], [0.001 - 0.015, -0.002 - 0.01])
    np.testing.assert_allclose(corners[2], [0.001, -0.002])           # middle vertex at half height
    np.testing.assert_allclose(corners[3], [0.001 + 0.015, -0.002 + 0.01])
    t_corner = 0.1 + 0.4 * np.arange(5)
    x, xd, _ = traj.evaluate(t_corner)
    np.testing.assert_allclose(x[:, :2], corners, atol=1e-15)
    np.testing.assert_allclose(xd, 0.0, atol=1e-15)
    xs, _, _ = traj.evaluate(np.linspace(0, traj.duration, 301))
    assert np.all(xs[:, 2] == 0.07) and not xs[:, 3:].any()
    assert traj.duration == pytest.approx(0.1 + 1.6 + 0.1)
    # each stroke is a straight line: the cross-product with the chord vanishes
    xm, _, _ = traj.evaluate(np.linspace(0.5, 0.9, 50))
    d = corners[2] - corners[1]
    rel = xm[:, :2] - corners[1]
    np.testing.assert_allclose(rel[:, 0] * d[1] - rel[:, 1] * d[0], 0.0, atol=1e-16)


def test_pose_set_labels_holds():
    poses = np.array([[0, 0, 0.08, 0, 0, 0], [0.01, 0, 0.07, 0, 0, 0], [0, 0.01, 0.075, 0, 0, 0]])
    traj = tr.pose_set(poses, move_time=0.2, hold_time=0.3, start=[0, 0, 0.085, 0, 0, 0])
    t = np.arange(0, traj.duration + 1e-9, 1e-3)
    lab = traj.label(t)
    assert set(lab.tolist()) == {0, 1, 2, 3}
    x, _, _ = traj.evaluate(t)
    for k in (1, 2, 3):
        rows = lab == k
        assert 290 <= rows.sum() <= 301
        np.testing.assert_allclose(x[rows], np.tile(poses[k - 1], (rows.sum(), 1)), atol=1e-15)
    assert lab[0] == 0 and lab[150] == 0   # moving from the start pose


def test_bad_trajectories_are_named():
    with pytest.raises(tr.TrajectoryError, match="must not decrease"):
        tr.Trajectory([0.0, 1.0, 0.5], [[0], [1], [2]], ["blend", "blend"])
    with pytest.raises(tr.TrajectoryError, match="move 2 has a non-positive duration"):
        tr.waypoints([[0], [1], [2]], move_time=[1.0, 0.0])
    with pytest.raises(tr.TrajectoryError, match="unknown kind"):
        tr.Trajectory([0.0, 1.0], [[0], [1]], ["slide"])
    with pytest.raises(tr.TrajectoryError, match="finite"):
        tr.waypoints([[0], [np.nan]], move_time=1.0)


def test_rotation_and_tool_point():
    r = np.array([0.1, -0.2, 0.3])

    def rx(a):
        return np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])

    def ry(a):
        return np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])

    def rz(a):
        return np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])

    np.testing.assert_allclose(tr.rotation(r), rx(r[0]) @ ry(r[1]) @ rz(r[2]), atol=1e-15)
    x = np.array([[0.01, 0.02, 0.08, *r]])
    np.testing.assert_allclose(tr.tool_point(x, [0, 0, -0.02])[0],
                               x[0, :3] + rx(r[0]) @ ry(r[1]) @ rz(r[2]) @ [0, 0, -0.02], atol=1e-15)


@pytest.mark.parametrize("modname", ["cosim.controllers", "cosim.trajectories", "cosim.master"])
def test_every_parameter_is_documented(modname):
    """numpydoc habit (python-control): each public function documents all its parameters."""
    import importlib
    import inspect

    mod = importlib.import_module(modname)
    missing = []
    for name, fn in inspect.getmembers(mod, inspect.isfunction):
        if name.startswith("_") or fn.__module__ != modname:
            continue
        doc = fn.__doc__ or ""
        missing += [f"{name}({p})" for p in inspect.signature(fn).parameters if p not in doc]
    assert not missing, missing


def test_a_move_is_the_quintic_that_numpy_solves_from_its_rest_to_rest_conditions():
    # Oracle: the minimum-jerk rest-to-rest move is the quintic with zero speed and acceleration
    # at both ends (Flash and Hogan 1985); its six coefficients are solved here with numpy from
    # those six conditions, not taken from the module
    T, x0, x1 = 0.8, np.array([0.0, 0.07]), np.array([0.02, 0.05])
    traj = tr.waypoints([x0, x1], move_time=[T])
    A = np.array([[T ** k if d == 0 else (k * T ** (k - 1) if d == 1 else k * (k - 1) * T ** max(k - 2, 0))
                   for k in range(6)] for d in range(3)])
    A0 = np.array([[1, 0, 0, 0, 0, 0], [0, 1, 0, 0, 0, 0], [0, 0, 2, 0, 0, 0]], float)
    t = np.linspace(0.0, T, 41)
    x, xd, xdd = traj.evaluate(t)
    for j in range(2):
        c = np.linalg.solve(np.vstack([A0, A]), [x0[j], 0, 0, x1[j], 0, 0])
        p = np.polynomial.Polynomial(c)
        np.testing.assert_allclose(x[:, j], p(t), rtol=0, atol=1e-15)
        np.testing.assert_allclose(xd[:, j], p.deriv(1)(t), rtol=0, atol=1e-13)
        np.testing.assert_allclose(xdd[:, j], p.deriv(2)(t), rtol=0, atol=1e-11)


def test_rotation_is_scipys_intrinsic_xyz_euler_rotation():
    # Oracle: scipy's Rotation, intrinsic x-y-z Euler angles (R = Rx Ry Rz)
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(3)
    for r in rng.uniform(-0.5, 0.5, (20, 3)):
        np.testing.assert_allclose(tr.rotation(r), Rotation.from_euler("XYZ", r).as_matrix(), rtol=0, atol=1e-15)
