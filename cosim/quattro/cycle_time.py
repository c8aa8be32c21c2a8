"""Pick-and-place cycle times of the Adept Quattro predicted by the core's dynamics,
compared with the measured Adept Cycle tables of Virzi 2010 (Tables 6.1-6.5).

The cycle (seed ch. 3.3, Fig. 3.1): from the pick/place height z, lift ``lift`` vertically,
travel ``travel`` along the Adept platform x axis at z + lift, set down, and come back the
same way; one cycle is these six straight segments, each from rest to rest (the measured
figure is the time of 10 cycles).

Each segment is timed by the torque-limited time-optimal profile along the straight path
(a time-optimal path parameterization by reachability analysis): along the path
x(s) = x_a + s u, the arm torques are tau(s) = a(s) s_dd + b(s) s_d^2 + c(s), with a, b, c
obtained from three batched calls of the core's inverse dynamics (nothing re-derived
here), and every |tau_i| must stay below the gear ratio times the nominal motor torque
(``Model.quattro_constants()["tau_arm_max"]``, 119.5 N m at
the arm).  Optionally the arm speed is limited too.  The planned motion can be replayed
through the core's forward dynamics (:func:`simulate_segment`).

Example
-------
>>> from cosim import cycle_time as ct
>>> r = ct.cycle_time(z=-0.95, cycle="standard", layout="centred_x0")   # seconds, 1 cycle
>>> cmp = ct.compare()                  # every table row: predicted vs measured
>>> cmp.table("6.1").spearman, cmp.table("6.1").z_min_pred
"""
from __future__ import annotations

import csv
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..core.model import Model
from .maps import adept_to_model, require_indices
from .maps import model as quattro_model
from ..errors import InputError

__all__ = ["CYCLES", "LAYOUTS", "Profile", "topp_segment", "cycle_waypoints", "cycle_time", "load_measured",
           "compare", "Comparison", "TableComparison", "spearman", "simulate_segment", "plot_comparison"]

# lift / travel / set-down [m] (seed ch. 3.3)
CYCLES = {"standard": (0.025, 0.305, 0.025), "extended": (0.040, 0.700, 0.040)}
# Start and end of the travel in the Adept x coordinate [m], per layout (seed ch. 6.3).
LAYOUTS = {
    "centred_x0": lambda L: (-L / 2, L / 2),
    "centred_x75": lambda L: (0.075 - L / 2, 0.075 + L / 2),
    "start_x0": lambda L: (0.0, L),
    "start_x75": lambda L: (0.075, 0.075 + L),
}

# A copy of shared/data/adept_quattro_cycle_times.csv (Tables 6.1-6.5 of Virzi 2010) ships with the
# project so the comparison does not depend on the checkout layout.
DATA = Path(__file__).resolve().parents[2] / "data" / "adept_quattro_cycle_times.csv"


@dataclass
class Profile:
    """Time-optimal motion along one straight segment.

    Attributes
    ----------
    s : ndarray
        Arc length grid [m].
    sd : ndarray
        Path speed at the grid points [m/s].
    t : ndarray
        Time at the grid points [s]; ``t[-1]`` is the segment time.
    tau : ndarray
        Arm torques at the grid points, shape (n, 4) [N m].
    x0, u : ndarray
        Start pose and unit direction of the segment.
    """

    s: np.ndarray
    sd: np.ndarray
    t: np.ndarray
    tau: np.ndarray
    x0: np.ndarray
    u: np.ndarray

    @property
    def duration(self) -> float:
        return float(self.t[-1])


def _limits(m: Model) -> float:
    return m.quattro_constants()["tau_arm_max"]


def topp_segment(m: Model, xa, xb, n: int = 300, tau_max: float | None = None,
                 qd_max: float | None = None) -> Profile:
    """Torque-limited time-optimal rest-to-rest motion along the straight path xa -> xb.

    Parameters
    ----------
    m : Model
        Quattro model (friction-free: the path dynamics are taken as quadratic in s_d).
    xa, xb : array_like
        Start and end poses (x, y, z, rz) [m, rad]; rz is kept (translation).
    n : int
        Grid intervals along the path.
    tau_max : float, optional
        Arm torque limit [N m] (default the core's ``tau_arm_max``, :meth:`Model.quattro_constants`).
    qd_max : float, optional
        Arm speed limit [rad/s] (default none).

    Returns
    -------
    Profile
    """
    xa, xb = np.asarray(xa, float), np.asarray(xb, float)
    L = float(np.linalg.norm(xb[:3] - xa[:3]))
    if not L > 0:
        raise InputError("topp_segment: start and end positions coincide")
    u = np.zeros(4)
    u[:3] = (xb[:3] - xa[:3]) / L
    tmax = _limits(m) if tau_max is None else float(tau_max)
    s = np.linspace(0.0, L, n + 1)
    X = xa[None, :] + s[:, None] * u[None, :]
    Z = np.zeros_like(X)
    U = np.broadcast_to(u, X.shape)
    c = m.inverse_dynamics(X, Z, Z)
    a = m.inverse_dynamics(X, Z, U) - c
    b = m.inverse_dynamics(X, U, Z) - c
    ds = L / n
    # Bounds of s_dd per joint: lo_j(b) = al_j + be_j b <= s_dd <= up_j(b) = ga_j + de_j b.
    if np.any(np.abs(a) < 1e-12):
        raise InputError("topp_segment: an arm does not move along this path (a = 0); not supported")
    lo_num = np.where(a > 0, -tmax, tmax) - c
    up_num = np.where(a > 0, tmax, -tmax) - c
    al, be = lo_num / a, -b / a
    ga, de = up_num / a, -b / a
    # Static bound on b = s_d^2 at each grid point: every lower <= every upper, b >= 0, speed.
    bstat = np.full(n + 1, np.inf)
    for j in range(4):
        for k in range(4):
            cf = be[:, j] - de[:, k]
            rhs = ga[:, k] - al[:, j]
            with np.errstate(divide="ignore", invalid="ignore"):
                bound = np.where(cf > 0, rhs / cf, np.inf)
            bstat = np.minimum(bstat, bound)
    if np.any(np.abs(c) >= tmax):
        raise InputError("topp_segment: gravity alone exceeds the torque limit on this path")
    if qd_max is not None:
        qs = np.abs(m.joint_velocity(X, U))  # dq/ds
        with np.errstate(divide="ignore"):
            bstat = np.minimum(bstat, np.min((qd_max / np.maximum(qs, 1e-300)) ** 2, axis=1))
    bstat = np.maximum(bstat, 0.0)
    # Backward pass: the largest b at s_k from which s_{k+1} stays controllable.
    P, Q = 2 * ds * al, 1 + 2 * ds * be
    hi = np.empty(n + 1)
    hi[n] = 0.0
    Pl, Ql, bl = P.tolist(), Q.tolist(), bstat.tolist()
    for k in range(n - 1, -1, -1):
        h = bl[k]
        nxt = hi[k + 1]
        for j in range(4):
            q = Ql[k][j]
            if q > 0:
                v = (nxt - Pl[k][j]) / q
                if v < h:
                    h = v
        hi[k] = max(h, 0.0)
    # Forward pass: accelerate as hard as the limits and the controllable set allow.
    bb = np.empty(n + 1)
    bb[0] = 0.0
    gl, dl = ga.tolist(), de.tolist()
    for k in range(n):
        umax = min(gl[k][j] + dl[k][j] * bb[k] for j in range(4))
        bb[k + 1] = min(hi[k + 1], max(bb[k] + 2 * ds * umax, 0.0))
    bb[n] = 0.0
    sd = np.sqrt(bb)
    den = sd[:-1] + sd[1:]
    if np.any(den <= 0):
        raise InputError("topp_segment: the path speed drops to zero inside the segment (limits too tight)")
    t = np.concatenate([[0.0], np.cumsum(2 * ds / den)])
    sdd = np.diff(bb) / (2 * ds)
    sdd = np.append(sdd, sdd[-1])
    tau = a * sdd[:, None] + b * bb[:, None] + c
    return Profile(s, sd, t, tau, xa.copy(), u)


def cycle_waypoints(m: Model, z: float, cycle: str = "standard", layout: str = "centred_x0",
                    theta: float = 0.0) -> np.ndarray:
    """The 7 poses (6 segments) of one cycle at pick/place height z [m] (Adept frame x, y = 0)."""
    if cycle not in CYCLES:
        raise InputError(f"unknown cycle {cycle!r} (known: {', '.join(CYCLES)})")
    if layout not in LAYOUTS:
        raise InputError(f"unknown layout {layout!r} (known: {', '.join(LAYOUTS)})")
    lift, travel, down = CYCLES[cycle]
    xs, xe = LAYOUTS[layout](travel)
    pts = []
    for xa, zz in [(xs, z), (xs, z + lift), (xe, z + lift), (xe, z + lift - down), (xe, z + lift),
                   (xs, z + lift), (xs, z)]:
        mx, my = adept_to_model(xa, 0.0)
        pts.append([float(mx), float(my), zz, theta])
    return np.array(pts)


def cycle_time(m: Model | None = None, z: float = -0.95, cycle: str = "standard", layout: str = "centred_x0",
               n: int = 300, qd_max: float | None = None, param_set: str | None = None,
               detail: bool = False):
    """Predicted time of ONE cycle [s] (sum of the six rest-to-rest time-optimal segments).

    With ``detail=True`` returns ``(time, [Profile, ...])``.
    """
    m = require_indices(m) if m is not None else quattro_model(param_set)
    w = cycle_waypoints(m, z, cycle, layout)
    profs = [topp_segment(m, w[i], w[i + 1], n=n, qd_max=qd_max) for i in range(len(w) - 1)]
    T = sum(p.duration for p in profs)
    return (T, profs) if detail else T


# ------------------------------------------------------------------ measurements

@dataclass
class Measured:
    table: str
    cycle: str
    layout: str
    z: np.ndarray        # [m]
    t10: np.ndarray      # time of 10 cycles [s]


def load_measured(path=None) -> dict:
    """Tables 6.1-6.5 from ``data/adept_quattro_cycle_times.csv`` as {table: Measured}."""
    path = Path(path) if path else DATA
    if not path.exists():
        raise FileNotFoundError(f"measured cycle times not found: {path}")
    rows = {}
    with open(path) as f:
        lines = [ln for ln in f if not ln.startswith("#")]
    for r in csv.DictReader(lines):
        rows.setdefault(r["table"], []).append(r)
    out = {}
    for t, rs in rows.items():
        out[t] = Measured(t, rs[0]["cycle"], rs[0]["layout"], np.array([float(r["z_mm"]) for r in rs]) * 1e-3,
                          np.array([float(r["time_10_cycles_s"]) for r in rs]))
    return out


def spearman(a, b) -> float:
    """Spearman rank correlation (average ranks for ties)."""
    from scipy.stats import spearmanr

    return float(spearmanr(a, b).statistic)


@dataclass
class TableComparison:
    """Predicted vs measured for one table."""

    table: str
    cycle: str
    layout: str
    z: np.ndarray
    measured_t10: np.ndarray
    predicted_t10: np.ndarray
    spearman: float
    z_min_meas: float
    z_min_pred: float
    level_ratio: float       # mean measured / mean predicted
    variation_meas: float    # (max - min) / min
    variation_pred: float

    def summary(self) -> str:
        return (f"Table {self.table} ({self.cycle}, {self.layout}): Spearman {self.spearman:+.2f}, "
                f"min measured at z = {self.z_min_meas * 1e3:.0f} mm, predicted at {self.z_min_pred * 1e3:.0f} mm, "
                f"measured/predicted level {self.level_ratio:.2f}, variation measured "
                f"{self.variation_meas * 100:.1f} % vs predicted {self.variation_pred * 100:.1f} %")


@dataclass
class Comparison:
    tables: dict = field(default_factory=dict)
    param_set: str = "default"
    qd_max: float | None = None

    def table(self, name: str) -> TableComparison:
        return self.tables[name]


def compare(param_set: str = "default", params: dict | None = None, tables=None, n: int = 300,
            qd_max: float | None = None, measured=None) -> Comparison:
    """Predict every measured row and compare, table by table.

    Parameters
    ----------
    param_set, params : model choice (see :class:`cosim.core.Model`).
    tables : list of str, optional
        Table names ("6.1"...); default all.
    n : int
        Grid intervals per segment of the time-optimal profile.
    qd_max : float, optional
        Arm speed limit [rad/s].
    """
    m = quattro_model(param_set, params)
    meas = measured or load_measured()
    out = Comparison(param_set=param_set, qd_max=qd_max)
    for name in tables or sorted(meas):
        ms = meas[name]
        pred = np.array([10 * cycle_time(m, z=z, cycle=ms.cycle, layout=ms.layout, n=n, qd_max=qd_max)
                         for z in ms.z])
        out.tables[name] = TableComparison(
            name, ms.cycle, ms.layout, ms.z, ms.t10, pred, spearman(pred, ms.t10),
            float(ms.z[np.argmin(ms.t10)]), float(ms.z[np.argmin(pred)]), float(ms.t10.mean() / pred.mean()),
            float(np.ptp(ms.t10) / ms.t10.min()), float(np.ptp(pred) / pred.min()))
    return out


# ------------------------------------------------------------------- simulation

def simulate_segment(m: Model, prof: Profile, kp: float = 4.0e4, kd: float = 4.0e2, dt: float = 1e-4):
    """Replay a planned segment through the core's forward dynamics.

    The planned torques are fed forward, with a joint PD (gains in N m/rad, N m s/rad)
    on the planned joint trajectory to hold the unstable open loop; RK4 on
    ``Model.forward_dynamics``.  Returns ``(t, x, tau)`` of the simulation.
    """
    T = prof.duration
    # Planned path position and speed as functions of time.
    def plan(t):
        t = min(max(t, 0.0), T)
        s = np.interp(t, prof.t, prof.s)
        sd = np.interp(t, prof.t, prof.sd)
        return prof.x0 + s * prof.u, sd * prof.u

    def tau_ff(t):
        return np.array([np.interp(min(max(t, 0.0), T), prof.t, prof.tau[:, j]) for j in range(4)])

    def ctrl(t, x, xd):
        xr, vr = plan(t)
        q, qr = m.ik(x), m.ik(xr)
        qd, qdr = m.joint_velocity(x, xd), m.joint_velocity(xr, vr)
        return tau_ff(t) + kp * (qr - q) + kd * (qdr - qd)

    x, xd = prof.x0.copy(), np.zeros(4)
    ts, xs, taus = [0.0], [x.copy()], [ctrl(0.0, x, xd)]
    t = 0.0
    nsteps = int(math.ceil(T / dt))
    h = T / nsteps
    for _ in range(nsteps):
        def f(tt, xx, vv):
            return vv, m.forward_dynamics(xx, vv, ctrl(tt, xx, vv))
        k1x, k1v = f(t, x, xd)
        k2x, k2v = f(t + h / 2, x + h / 2 * k1x, xd + h / 2 * k1v)
        k3x, k3v = f(t + h / 2, x + h / 2 * k2x, xd + h / 2 * k2v)
        k4x, k4v = f(t + h, x + h * k3x, xd + h * k3v)
        x = x + h / 6 * (k1x + 2 * k2x + 2 * k3x + k4x)
        xd = xd + h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v)
        t += h
        ts.append(t)
        xs.append(x.copy())
        taus.append(ctrl(t, x, xd))
    return np.array(ts), np.array(xs), np.array(taus)


# ---------------------------------------------------------------------- figures

def plot_comparison(cmp: Comparison, out_dir, fmt: str = "png", fit: "CycleFit | None" = None) -> list:
    """Predicted (time of 10 cycles) vs measured against z, one panel per table.

    With ``fit`` (:func:`cosim.quattro.cycle_fit.fit_cycle_model`) the fitted model is drawn on the same axis and each
    panel says whether its table was used for the fit or held out.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    names = sorted(cmp.tables)
    fig, axes = plt.subplots(1, len(names), figsize=(4.0 * len(names), 3.9), squeeze=False)
    for ax, name in zip(axes[0], names):
        tc = cmp.tables[name]
        zz = tc.z * 1e3
        # one axis for both: the level gap (the model is 2-3x too fast) must stay visible
        ax.plot(zz, tc.measured_t10, "o-", color="C0", label="measured")
        ax.plot(zz, tc.predicted_t10, "s--", color="C3", label="torque-limited model")
        role = ""
        if fit is not None and name in fit.model_t10:
            held = name not in fit.fit_tables
            ax.plot(zz, fit.model_t10[name], "^-" if held else "^:", color="C2",
                    label=f"fitted model ({'held out' if held else 'fit'}, RMS {fit.rms_pct[name]:.1f} %)")
            role = " [HELD OUT]" if held else " [fit]"
        ax.set_xlabel("pick/place height z [mm]")
        ax.set_ylabel("time of 10 cycles [s]")
        ax.set_ylim(0, 1.08 * max(tc.measured_t10.max(), tc.predicted_t10.max()))
        ax.set_title(f"Table {name}{role}: {tc.cycle}, {tc.layout}\nSpearman {tc.spearman:+.2f}, "
                     f"measured / model x{tc.level_ratio:.2f}", fontsize=9)
        ax.axvline(tc.z_min_meas * 1e3, color="C0", lw=0.8, ls=":")
        ax.axvline(tc.z_min_pred * 1e3, color="C3", lw=0.8, ls=":")
        ax.legend(fontsize=7, loc="lower left")
    fig.suptitle(f"Adept Cycle times: torque-limited time-optimal model (set '{cmp.param_set}') vs Tables 6.1-6.5 "
                 "(dotted: the fastest height of each)", fontsize=10)
    fig.tight_layout()
    f = out / f"quattro_cycle_times.{fmt}"
    fig.savefig(f, dpi=110)
    plt.close(fig)
    return [f]
