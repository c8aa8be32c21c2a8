"""The closed loop as FMUs other tools can run: controller FMU parameters and an SSP file.

A controller of :mod:`cosim.controllers` (PD, PD + gravity, computed torque) or any
discrete LTI controller designed with python-control becomes the parameters of the
robot's controller FMU (``build/fmu/PKM_<ROBOT>_CTRL.fmu``, the core's ``pkm_ctrl`` behind
the project's FMI layer); :func:`export_ssp` packs plant FMU + controller FMU, their
connections (plant ``q``, ``qd`` -> controller; controller ``tau`` -> plant), the
set-point and the parameters into an SSP 1.0 archive (``SystemStructure.ssd`` with the
FMUs in ``resources/``) that an SSP-capable engine runs as it is, e.g. OSP libcosim
(``CosimExecution.from_ssp_file``).

Timing: an engine that exchanges values after each step (libcosim's fixed-step
algorithm) applies the effort computed at ``t`` over ``[t + h, t + 2h]``; the same loop in
the core is :func:`cosim.master.run` on a plant with ``actuator.delay = h``
(docs/fmu.md "Controller FMUs and SSP").

Example
-------
>>> from cosim.core import Model
>>> from cosim import controllers as ctl, ssp
>>> m = Model("6pus")
>>> path = ssp.export_ssp("out/step.ssp", model=m, controller=ctl.pd_gravity(m, kp=300, kd=30),
...                       qref=m.ik(m.home() + [0, 0, 0.01, 0, 0, 0]), dt=1e-3, stop_time=1.0)
"""
from __future__ import annotations

import shutil
import tempfile
import zipfile
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from .closed_loop import KINDS
# the LTI controller lives beside the others; named here too, where the exporter takes it
from .controllers import LTIController, lti_controller  # noqa: F401
from .fmu import fmu_id, fmu_path
from .errors import InputError

__all__ = ["controller_parameters", "lti_controller", "export_ssp", "LTIController"]


def _matrix(a, nd):
    m = np.zeros((nd, nd)) if a is None else np.asarray(a, float)
    return np.broadcast_to(m, (nd, nd)) if m.ndim == 0 else m


def controller_parameters(controller, *, ndof: int, dt: float, lti_states: int) -> dict:
    """Start values of the controller FMU's parameters for a controller, by variable name."""
    kind = getattr(controller, "kind", None)
    if kind not in KINDS:
        raise InputError(f"controller kind {kind!r} has no FMU (kinds: {', '.join(KINDS)})")
    nd = ndof
    p = {"controller.kind": KINDS[kind], "controller.dt": float(dt)}
    for name in ("kp", "kd", "ki"):
        m = _matrix(getattr(controller, name, None), nd)
        p.update({f"{name}[{i + 1},{j + 1}]": float(m[i, j]) for i in range(nd) for j in range(nd)})
    p["controller.Tf"] = float(getattr(controller, "deriv_filter", 0.0) or 0.0)
    sat = getattr(controller, "saturation", None)
    if sat is not None:
        sat = np.asarray(sat, float)
        sat = np.diag(sat) if sat.ndim == 2 else np.broadcast_to(sat, (nd,))
        p.update({f"saturation[{i + 1}]": float(sat[i]) for i in range(nd)})
    p["controller.gravityAtReference"] = int(getattr(controller, "gravity", "measured") == "reference")
    p["controller.gravityFeedforward"] = int(bool(getattr(controller, "gravity_feedforward", False)))
    if kind == "lti":
        A, B, C, D = controller.A, controller.B, controller.C, controller.D
        nx = A.shape[0]
        if nx > lti_states:
            raise InputError(f"the LTI design has {nx} states; the controller FMU has room for {lti_states}")
        p["lti.nx"] = nx
        p.update({f"lti.A[{r + 1},{c + 1}]": float(A[r, c]) for r in range(nx) for c in range(nx)})
        p.update({f"lti.B[{r + 1},{j + 1}]": float(B[r, j]) for r in range(nx) for j in range(nd)})
        p.update({f"lti.C[{i + 1},{c + 1}]": float(C[i, c]) for i in range(nd) for c in range(nx)})
        p.update({f"lti.D[{i + 1},{j + 1}]": float(D[i, j]) for i in range(nd) for j in range(nd)})
    return p


def _lti_room(path) -> int:
    from fmpy import read_model_description

    md = read_model_description(str(path))
    return max([int(v.start) for v in md.modelVariables if v.name == "lti.nx"] or [0])


def _parameter_set(name, values: dict) -> str:
    rows = []
    for k, v in values.items():
        if isinstance(v, (bool, int, np.integer)) and not isinstance(v, float):
            rows.append(f'            <ssv:Parameter name={quoteattr(k)}><ssv:Integer value="{int(v)}"/></ssv:Parameter>')
        else:
            rows.append(f'            <ssv:Parameter name={quoteattr(k)}><ssv:Real value="{float(v)!r}"/></ssv:Parameter>')
    return (f'        <ssd:ParameterBindings>\n          <ssd:ParameterBinding>\n            <ssd:ParameterValues>\n'
            f'              <ssv:ParameterSet version="1.0" name={quoteattr(name)}>\n              <ssv:Parameters>\n'
            + "\n".join(rows) + '\n              </ssv:Parameters>\n              </ssv:ParameterSet>\n'
            '            </ssd:ParameterValues>\n          </ssd:ParameterBinding>\n        </ssd:ParameterBindings>\n')


def export_ssp(path, *, model, controller, qref, dt: float = 1e-3, stop_time: float = 1.0, x0=None,
               plant_parameters: dict | None = None, qdref=None) -> Path:
    """Write an SSP 1.0 archive of the closed loop: plant FMU + controller FMU + set-point.

    Parameters
    ----------
    path : str or Path
        The ``.ssp`` file to write (its folder is created).
    model : cosim.core.Model
        The plant's model: its robot picks the FMUs, its parameters become the plant
        FMU's (the "true" robot).
    controller : controller of :mod:`cosim.controllers` or :class:`LTIController`
        The law and gains; its own model (PD + gravity, computed torque) becomes the
        controller FMU's core parameters.
    qref : array_like, shape (nd,)
        Joint set-point [m or rad], held from t = 0 (a step response).
    dt : float
        Communication step [s] (the controller's period).
    stop_time : float
        Stop time of the default experiment [s].
    x0 : array_like, shape (nd,), optional
        Initial pose [m, rad] (default: the model's home pose).
    plant_parameters : dict, optional
        Further plant FMU start values by name (e.g. ``{"actuator.delay": 0.001}``).
    qdref : array_like, shape (nd,), optional
        Reference rate [m/s or rad/s] (default 0).

    Returns
    -------
    Path
        The archive.
    """
    nd = model.ndof
    qref = np.broadcast_to(np.asarray(qref, float), (nd,))
    qdref = np.zeros(nd) if qdref is None else np.broadcast_to(np.asarray(qdref, float), (nd,))
    if not (np.all(np.isfinite(qref)) and np.all(np.isfinite(qdref))):
        raise InputError("qref and qdref must be finite")
    if not (np.isfinite(dt) and dt > 0 and np.isfinite(stop_time) and stop_time > dt):
        raise InputError(f"dt = {dt} s and stop_time = {stop_time} s: need 0 < dt < stop_time")
    plant_fmu, ctrl_fmu = fmu_path(model.robot), fmu_path(fmu_id(model.robot) + "_CTRL")
    facts = model.facts
    x0 = model.home() if x0 is None else np.asarray(x0, float)
    plant_vals = {name: value for name, value in model.params().items()}
    plant_vals.update({f"{c}0": float(v) for c, v in zip(facts.pose_names, x0)})
    plant_vals.update(plant_parameters or {})
    ctrl_model = getattr(controller, "model", None) or model
    ctrl_vals = dict(ctrl_model.params())
    ctrl_vals.update(controller_parameters(controller, ndof=nd, dt=dt, lti_states=_lti_room(ctrl_fmu)))
    ctrl_vals.update({f"qref[{i + 1}]": float(qref[i]) for i in range(nd)})
    ctrl_vals.update({f"qdref[{i + 1}]": float(qdref[i]) for i in range(nd)})

    def connectors(rows):
        return ("        <ssd:Connectors>\n" + "\n".join(
            f'          <ssd:Connector name={quoteattr(n)} kind="{k}"><ssc:Real/></ssd:Connector>' for n, k in rows)
            + "\n        </ssd:Connectors>\n")

    joints = range(1, nd + 1)
    plant_conn = [(f"tau[{i}]", "input") for i in joints] + [(f"q[{i}]", "output") for i in joints] + \
                 [(f"qd[{i}]", "output") for i in joints]
    ctrl_conn = [(f"q[{i}]", "input") for i in joints] + [(f"qd[{i}]", "input") for i in joints] + \
                [(f"tau[{i}]", "output") for i in joints]
    links = [("plant", f"q[{i}]", "controller", f"q[{i}]") for i in joints] + \
            [("plant", f"qd[{i}]", "controller", f"qd[{i}]") for i in joints] + \
            [("controller", f"tau[{i}]", "plant", f"tau[{i}]") for i in joints]
    ssd = (
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        '<ssd:SystemStructureDescription xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription"\n'
        '    xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon"\n'
        '    xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues"\n'
        f'    version="1.0" name={quoteattr(f"pkm_{model.robot}_closed_loop")} generationTool="cosim.ssp">\n'
        '  <ssd:System name="closed_loop">\n    <ssd:Elements>\n'
        f'      <ssd:Component name="plant" type="application/x-fmu-sharedlibrary" '
        f'source="resources/{plant_fmu.name}" implementation="CoSimulation">\n'
        + connectors(plant_conn) + _parameter_set("plant", plant_vals) + '      </ssd:Component>\n'
        f'      <ssd:Component name="controller" type="application/x-fmu-sharedlibrary" '
        f'source="resources/{ctrl_fmu.name}" implementation="CoSimulation">\n'
        + connectors(ctrl_conn) + _parameter_set("controller", ctrl_vals) + '      </ssd:Component>\n'
        '    </ssd:Elements>\n    <ssd:Connections>\n'
        + "\n".join(f'      <ssd:Connection startElement="{a}" startConnector={quoteattr(b)} endElement="{c}" '
                    f'endConnector={quoteattr(d)}/>' for a, b, c, d in links)
        + '\n    </ssd:Connections>\n  </ssd:System>\n'
        f'  <ssd:DefaultExperiment startTime="0" stopTime="{float(stop_time)!r}"/>\n'
        '</ssd:SystemStructureDescription>\n')
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        t = Path(tmp)
        (t / "resources").mkdir()
        shutil.copy(plant_fmu, t / "resources" / plant_fmu.name)
        shutil.copy(ctrl_fmu, t / "resources" / ctrl_fmu.name)
        (t / "SystemStructure.ssd").write_text(ssd)
        with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as z:
            for f in ("SystemStructure.ssd", f"resources/{plant_fmu.name}", f"resources/{ctrl_fmu.name}"):
                z.write(t / f, f)
    return out


def export_scenario_ssp(scenario, path) -> Path:
    """The SSP archive of a step scenario (``reference.type = "step"``): its robot, its
    controller (gains given or designed), its true plant parameters, the set-point the
    step goes to, its communication step and duration.

    Parameters
    ----------
    scenario : cosim.scenario.Scenario or str or Path
        The scenario or its TOML file.
    path : str or Path
        The ``.ssp`` file to write.
    """
    from .scenario import (Scenario, ScenarioError, _angles, build_controller, build_models, build_trajectory,
                           load_scenario)

    sc = scenario if isinstance(scenario, Scenario) else load_scenario(scenario)
    r = sc.spec["reference"]
    if r["type"] != "step" or float(r.get("t_step", 0.0)) != 0.0:
        raise ScenarioError(f"{sc.path or 'scenario'}: reference.type = {r['type']!r}: an SSP archive carries a "
                            f"set-point (a step at t = 0); other references need a reference FMU (not provided)")
    nominal, true, truth = build_models(sc)
    traj = build_trajectory(sc, nominal)
    init = sc.spec["initial"]
    x0 = _angles(init["pose"], r.get("angle_unit", "rad"), nominal.facts.pose_units) if "pose" in init else traj.knots[0]
    target = traj.knots[-1]
    ctrl, _ = build_controller(sc, nominal, x0)
    return export_ssp(path, model=true, controller=ctrl, qref=nominal.ik(target), dt=float(sc.spec["step"]),
                      stop_time=float(sc.spec["duration"]), x0=x0)
