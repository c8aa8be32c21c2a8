"""What the sets of bench/foreign/mujoco_unlisted.py's mechanisms share: small helpers of
their draws (a random direction, an RMS, a smooth one-sided ramp, a first-order low-pass, the
time a hook's state advances by, the platform's body and free joint in MuJoCo), the judgement of
the flexible stage against a declaration (:func:`judge`), the confidence rule's statistics read
from its log (:class:`RuleLog`) and the printed tables."""
from __future__ import annotations

import math

import numpy as np


def slider_groups() -> tuple:
    """``(positions, rates, accelerations, pose)``: the flexible stage's group names (sets) of the
    6-PUS's six sliders and of its platform's pose, the words a declaration is written in."""
    return ({f"position of slider {i}" for i in range(1, 7)}, {f"rate of slider {i}" for i in range(1, 7)},
            {f"acceleration of slider {i}" for i in range(1, 7)}, {"the platform pose"})


def unit_direction(rng):
    """A direction drawn uniformly on the sphere (3,)."""
    d = rng.normal(size=3)
    return d / np.linalg.norm(d)


def rms(x) -> float:
    return float(np.sqrt(np.mean(np.square(x))))


def softplus(x):
    return np.logaddexp(0.0, x)


def excess(x, at) -> float:
    """The RMS of ``x``'s magnitude beyond ``at`` (0 below it)."""
    return rms(np.maximum(np.abs(x) - at, 0.0))


def lowpass(x, dt, tau):
    """First-order low-pass of ``x`` (rows, sample step ``dt`` [s]) with time constant ``tau`` [s],
    from ``x[0]``."""
    a = math.exp(-dt / tau)
    y = np.empty_like(np.asarray(x, float))
    for i, v in enumerate(np.asarray(x, float)):
        y[i] = v if i == 0 else a * y[i - 1] + (1 - a) * v
    return y


def elapsed(state, t) -> float:
    """The time [s] since the last call with this ``state`` (a dict holding ``"t"``; 0 at the first
    call or where ``t`` does not advance): how far a hook's own state moves in MuJoCo's step."""
    last, state["t"] = state.get("t"), t
    return 0.0 if last is None or t <= last else t - last


def platform_dof(model):
    """(body id, the free joint's first dof) of MuJoCo's platform."""
    b = model.body("platform").id
    return b, int(model.jnt_dofadr[model.body_jntadr[b]])


def judge(fits, key, joint) -> tuple:
    """(inputs right, share, named groups per explained channel) of the flexible stage, on the
    channels of ``joint`` (a rail, rails, or None: every channel)."""
    on = None if joint is None else set(joint) if isinstance(joint, (list, tuple)) else {joint}
    told = [f for f in fits if f.explained and (on is None or f.joint in on)]
    named = {f.channel: [x.group for x in f.inputs] for f in told}
    if not told or not any(named.values()):
        return False, max([f.share for f in told], default=0.0), named
    union = set().union(*map(set, named.values()))
    ok = all(set(g) <= key["allowed"] for g in named.values()) and key["need"] <= union
    ok = ok and (not key["any"] or bool(union & key["any"]))
    return ok, max(f.share for f in told), named


class RuleLog:
    """The confidence rule's statistics (cosim.discrepancy.keyed.elsewhere logs, per effect and
    kind of product, its strongest product's chi-square less ln n_eff against the bar, at DEBUG):
    collected as ``{"effect", "tied_already", "where", "feature", "stat", "bar"}`` rows."""

    PATTERN = (r"^(?P<effect>\S+?)(?P<tied> \(tied already\))?: (?P<where>elsewhere|position|reversal) "
               r"(?P<feature>.*) chi2 - ln n_eff = (?P<stat>\S+) against (?P<bar>\S+)$")
    #: the smallest change of the level the rule could see (cosim.discrepancy.keyed.power), where no product passed
    POWER = (r"^(?P<effect>\S+?): (?P<where>elsewhere|position|reversal) smallest visible change of the level "
             r"(?P<delta>\S+) \((?P<feature>.*)\)$")
    #: a product the residual leans on whose interval reaches the level (cosim.discrepancy.keyed.power.leaning_change)
    LEANING = (r"^(?P<effect>\S+?): (?P<where>elsewhere|position|reversal) largest change of the level not excluded "
               r"(?P<change>\S+) \((?P<feature>.*); chi2 - ln n_eff = (?P<stat>\S+)\)$")

    def __init__(self):
        import logging

        self.rows, self.power, self.leaning, self.handler = [], [], [], logging.Handler(logging.DEBUG)
        self.handler.emit = self._emit
        self.logger = logging.getLogger("cosim.discrepancy.keyed.elsewhere")

    def _emit(self, record):
        import re

        m = re.match(self.PATTERN, record.getMessage())
        if m:
            self.rows.append({"effect": m["effect"], "tied_already": bool(m["tied"]), "where": m["where"],
                              "feature": m["feature"], "stat": float(m["stat"]), "bar": float(m["bar"])})
        m = re.match(self.POWER, record.getMessage())
        if m:
            self.power.append({"effect": m["effect"], "where": m["where"], "feature": m["feature"],
                               "delta": float(m["delta"])})
        m = re.match(self.LEANING, record.getMessage())
        if m:
            self.leaning.append({"effect": m["effect"], "where": m["where"], "feature": m["feature"],
                                 "change": float(m["change"]), "stat": float(m["stat"])})

    def __enter__(self):
        import logging

        self.level = self.logger.level
        self.logger.addHandler(self.handler)
        self.logger.setLevel(logging.DEBUG)
        return self

    def __exit__(self, *exc):
        self.logger.removeHandler(self.handler)
        self.logger.setLevel(self.level)


def _cell(r):
    named = "; ".join(f"{c}: {', '.join(g) or 'no single input'}" for c, g in r["named"].items()) or "nothing explained"
    return named


def _periodic(r) -> list:
    """The channels of a row whose structure left is a spectral line (signature ``periodic``)."""
    return [u.split()[0] for u in r["unexplained"] if u.endswith(" periodic")]


def table(rows, order) -> list:
    """The table of a run's ``rows``: a row per case (the mechanisms in the kinds' ``order``, then
    the clean recordings), then the counts."""
    eff = sorted([r for r in rows if r["kind"] != "clean"], key=lambda r: order.index(r["kind"]))
    clean = sorted([r for r in rows if r["kind"] == "clean"], key=lambda r: r["seed"])
    L = ["| case | size (RMS / noise) | named with confidence | library named with confidence | flexible: "
         "inputs named (keyed-on right?) | share | held-out gain | CPU [s] |", "|---" * 8 + "|"]
    for r in eff:
        conf = r["library_confident"] + [t for t in r["discovered"] if not t.startswith("(partial)")]
        if not r["unexplained"]:  # with structure left, the conclusion says they "may stand in"
            conf += ([r["platform"]] if r["platform"] else []) + r["drifts"]
        g = r["gain"]
        L.append(f"| {r['case']} | {r['size_over_noise']:.1f} (tau{r['size_channel']}) | {'; '.join(conf) or '-'} | "
                 f"{'**' + ', '.join(r['library_confident']) + '**' if r['library_confident'] else '-'} | "
                 f"{_cell(r)} ({'yes' if r['inputs_right'] else 'no'}) | {r['share']:.2f} | "
                 f"{'-' if g is None or not math.isfinite(g) else f'{g:.2f}'} | {r['cpu']:.1f} |")
    for r in clean:
        what = "; ".join(r["library_all"] + r["discovered"] + r["drifts"] + [c for c, _, _ in r["flexible"]])
        L.append(f"| {r['case']} | {r['size_over_noise']:.1f} | {'clean' if r['clean'] else 'NOT CLEAN: ' + what} | "
                 f"- | - | - | - | {r['cpu']:.1f} |")
    n = len(eff)
    if n:
        L += ["", f"library effect named with confidence: {sum(bool(r['library_confident']) for r in eff)}/{n}; "
                  f"flexible stage names the keyed-on inputs: {sum(r['inputs_right'] for r in eff)}/{n}; "
                  f"a channel explained by the flexible stage: {sum(bool(r['named']) for r in eff)}/{n}; "
                  f"a periodic force reported (structure keyed on time): "
                  f"{', '.join(r['case'] for r in eff if _periodic(r)) or 'none'}"]
        L += [f"  {r['case']}: {'; '.join(r.get('periodic') or _periodic(r))}" for r in eff if _periodic(r)]
    if clean:
        L.append(f"clean recordings clean: {sum(r['clean'] for r in clean)}/{len(clean)}")
    L.append(f"diagnosis CPU: median {np.median([r['cpu'] for r in rows]):.1f} s, largest "
             f"{max(r['cpu'] for r in rows):.1f} s")
    return L


def _reached(r) -> list:
    """The rule's rows of a case on effects it judged (not tied before its test)."""
    return [x for x in r.get("rule", []) if not x["tied_already"]]


def sweep_table(rows, order) -> list:
    """Per kind (in the kinds' ``order``) and scale: the cases, the size, a library effect named with confidence, tied (by
    the keyed rule), structure left, "no missing physics found", and the rule's strongest
    statistic against its bar where it was reached (the effect not tied before its test), with the
    largest of the smallest level changes it could see per kind where no product passed
    (cosim.discrepancy.keyed.power; above 1 the effect is tied as too weak to tell) and the product
    the residual leans on whose interval reaches the level (its chi-square less ln n_eff, above the
    look-elsewhere cost: tied as leaning)."""
    eff = [r for r in rows if r["kind"] != "clean"]
    L = ["| kind | scale | cases | size (RMS / noise) | library named with confidence | library tied (by the keyed "
         "rule) | structure left | no missing physics found | rule reached: strongest statistic / bar (kind) |",
         "|---" * 9 + "|"]
    cells = sorted({(r["kind"], r.get("scale", 1.0)) for r in eff}, key=lambda c: (order.index(c[0]), c[1]))
    for kind, scale in cells:
        rs = sorted([r for r in eff if r["kind"] == kind and r.get("scale", 1.0) == scale], key=lambda r: r["seed"])
        conf = [r for r in rs if r["library_confident"]]
        tied_ = [r for r in rs if not r["library_confident"] and r.get("library_tied")]
        by_rule = [r for r in tied_ if any("keyed_elsewhere" in g for g in r["library_tied"].values())]
        stats = []
        for r in rs:
            rule = _reached(r)
            if rule:
                best = max(rule, key=lambda x: x["stat"] - x["bar"])
                weak = max(r.get("power", []), key=lambda x: x["delta"], default=None)
                lean = max(r.get("leaning", []), key=lambda x: x["stat"], default=None)
                stats.append(f"{best['stat']:.1f}/{best['bar']:.1f} ({best['where']}"
                             + (f"; smallest visible change {weak['delta']:.2f}, {weak['where']}" if weak else "")
                             + (f"; leaning {lean['stat']:.1f} ({lean['where']}), change not excluded "
                                f"{lean['change']:.2f}" if lean else "") + ")")
        sizes = [r["size_over_noise"] for r in rs]
        L.append(f"| {kind} | {scale:g} | {len(rs)} | {min(sizes):.1f}-{max(sizes):.1f} | "
                 f"{len(conf)}{' (' + '; '.join(c['case'] + ': ' + ', '.join(c['library_confident']) for c in conf) + ')' if conf else ''} | "
                 f"{len(tied_)} ({len(by_rule)}) | {sum(bool(r['unexplained']) for r in rs)} | "
                 f"{sum(r['conclusion'].startswith('no missing physics') for r in rs)} | {', '.join(stats) or '-'} |")
    clean = [r for r in rows if r["kind"] == "clean"]
    if clean:
        L.append(f"\nclean recordings clean: {sum(r['clean'] for r in clean)}/{len(clean)}; library effects named "
                 f"with confidence over all: {sum(bool(r['library_confident']) for r in eff)}/{len(eff)}")
    return L
