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


def two_rails(rng, n) -> tuple:
    """(j, k): a rail drawn of ``n`` and another one, k != j (0-based), in this order of draws
    from ``rng`` (every set's seeds are fixed on it)."""
    j = int(rng.integers(n))
    return j, int((j + 1 + rng.integers(n - 1)) % n)


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
    named = {f.channel: list(f.named) for f in told}
    if not told or not any(named.values()):
        return False, max([f.share for f in told], default=0.0), named
    union = set().union(*map(set, named.values()))
    ok = all(set(g) <= key["allowed"] for g in named.values()) and key["need"] <= union
    ok = ok and (not key["any"] or bool(union & key["any"]))
    return ok, max(f.share for f in told), named


#: the quantities a discovered term (cosim.discrepancy.discovery.terms.TERMS) reads of its own joint i,
#: each the group "<quantity> of slider i": q -> position, qd (its sign too) -> rate, qdd ->
#: acceleration, the drive's effort tau -> effort; a constant force reads nothing
OWN_READS = {"constant": (), "spring": ("position",), "quadratic": ("position",), "cubic": ("position",),
             "ripple": ("position",), "step": ("position",), "drag": ("rate",), "viscous_pos": ("rate",),
             "viscous_neg": ("rate",), "viscous_both": ("rate",), "coulomb_pos": ("rate",), "coulomb_neg": ("rate",),
             "coulomb_both": ("rate",), "fading": ("rate",), "inertia": ("acceleration",),
             "load": ("effort", "rate"), "effortpos": ("effort", "position"), "posrate": ("position", "rate"),
             "stroke_1": ("position", "rate"), "stroke_2": ("position", "rate"), "zone": ("position", "rate"),
             "cross_q": (), "cross_v": (), "taut": ("position",)}
#: the quantity a cross term reads of the other joint (its shape's ``force_xj``, 1-based); a
#: one-sided spring (``taut``) reads the difference of the two joints' positions
OTHER_READS = {"cross_q": "position", "cross_v": "rate", "taut": "position"}
#: a platform force's families (cosim.discrepancy.platform_force): a force, wrench or cable reaches
#: the rails through the Jacobian at the pose ("the platform pose"); a drag -c v reads the
#: platform's velocity, which the bench's declarations write as the rails' rates through the
#: Jacobian the pose sets ("rate of slider 1" ... "rate of slider 6" and the pose)
STATIC_FAMILIES = ("force", "wrench", "cable")


def term_groups(term, noun: str = "slider") -> set:
    """The flexible stage's groups a discovered term (``joint`` 1-based, ``terms``, ``shape``: a
    :class:`cosim.discrepancy.discovery.terms.DiscoveredTerm`) reads: per term of ``terms``
    :data:`OWN_READS` of its own joint, and for a cross term (``cross_q``, ``cross_v``)
    :data:`OTHER_READS` of the joint its shape's ``force_xj`` names.  A damper between two joints
    found as a pair (``pair`` set) is ``viscous_both`` and ``cross_v`` on each of its two
    channels: its own rate and the other's.  A term this table does not hold reads "an unknown
    term <name>", a group no declaration allows (the case is refused, not passed silently)."""
    out = set()
    for t in term.terms:
        out |= {f"{q} of {noun} {term.joint}" for q in OWN_READS.get(t, ())}
        if t not in OWN_READS:
            out.add(f"an unknown term {t}")
        if t in OTHER_READS:
            k = next((v for p, v in term.shape.items() if p.endswith(".force_xj")), None)
            out.add(f"an unknown term {t}" if k is None else f"{OTHER_READS[t]} of {noun} {int(k)}")
    return out


def platform_groups(family: str, n: int = 6, noun: str = "slider") -> set:
    """The groups a platform force of ``family`` (``force``, ``wrench``, ``cable``, ``drag`` or a
    static family ``+drag``) reads on every one of the ``n`` channels (:data:`STATIC_FAMILIES`)."""
    parts = family.split("+")
    out = {"the platform pose"}
    if "drag" in parts:
        out |= {f"rate of {noun} {i}" for i in range(1, n + 1)}
    if not all(p in STATIC_FAMILIES or p == "drag" for p in parts):
        out.add(f"an unknown platform force {family}")
    return out


def stage_reads(d, n: int = 6, noun: str = "slider") -> dict:
    """What the diagnosis ``d`` models besides the flexible stage, as the groups it reads per
    joint (1-based, as str: a row's JSON): ``{"confident": {...}, "with_partial": {...}}``.

    ``with_partial``: every discovered term (:func:`term_groups`, on its joint's channel), a
    platform force (:func:`platform_groups`, on every channel) and every drift ("time", on the
    drifting parameter's joint, or on every channel for a parameter of no joint: a drift is the
    library effect's level changing with time; the effect's own inputs are not added, a library
    effect not being a term the discovery writes).  ``confident``: the terms not flagged partial,
    and the platform force and drifts only where no structure is left (beside structure left the
    conclusion says they "may stand in", the bench's rule for what is named with confidence)."""
    from cosim.discrepancy.verdict import _joint

    every = [str(i) for i in range(1, n + 1)]
    out = {"confident": {}, "with_partial": {}}
    settled = not d.unexplained
    for t in d.discovered:
        for v in ("with_partial",) + (("confident",) if not t.partial else ()):
            out[v].setdefault(str(t.joint), set()).update(term_groups(t, noun))
    extra = []
    if d.platform_force:
        extra += [(every, platform_groups(d.platform_force.family, n, noun))]
    for x in d.drifts:
        j = _joint(x.param)
        extra += [(every if j is None else [str(j + 1)], {"time"})]
    for joints, groups in extra:
        for v in ("with_partial",) + (("confident",) if settled else ()):
            for j in joints:
                out[v].setdefault(j, set()).update(groups)
    return {v: {j: sorted(g) for j, g in sorted(per.items())} for v, per in out.items()}


def judge_either(fits, reads, key, joint) -> bool:
    """Are the declared inputs ``key`` modelled by either stage?  The rule: per channel, the union
    of the flexible stage's named groups (its explained channels, as :func:`judge`) and the groups
    the rest of the diagnosis reads there (``reads``: one variant of :func:`stage_reads`, {joint
    (1-based, int or str): groups}); over the case's channels (``joint``: a rail, rails, or None:
    every channel) that union must hold every ``need`` group and one ``any`` group (where any is
    declared) and nothing outside ``allowed``: either stage naming a group outside it refuses
    the case.  Nothing named by either stage: no."""
    on = None if joint is None else set(joint) if isinstance(joint, (list, tuple)) else {joint}
    per = {}
    for f in fits:
        if f.explained and (on is None or f.joint in on):
            per.setdefault(int(f.joint), set()).update(f.named)
    for j, groups in reads.items():
        if on is None or int(j) in on:
            per.setdefault(int(j), set()).update(groups)
    union = set().union(*per.values()) if per else set()
    if not union:
        return False
    return union <= key["allowed"] and key["need"] <= union and (not key["any"] or bool(union & key["any"]))


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


def either_cell(r) -> str:
    """The either-stage judgement of a row (:func:`judge_either`) and what the diagnosis besides
    the flexible stage reads on the case's channels (with partial terms)."""
    if "either_right" not in r:
        return "-"
    yes = lambda v: "yes" if r["either_right"][v] else "no"  # noqa: E731
    joint = r["joint"]
    on = None if joint is None else set(joint) if isinstance(joint, (list, tuple)) else {joint}
    reads = sorted({g for j, gs in r["stage_reads"]["with_partial"].items() if on is None or int(j) in on for g in gs})
    return f"{yes('confident')} / {yes('with_partial')}" + (f" (reads {', '.join(reads)})" if reads else "")


def either_line(eff) -> list:
    """The count of :func:`judge_either`'s rule over the mechanism rows ``eff`` (their
    ``either_right``), one line; none where no row kept the whole diagnosis (a replay of a capture
    made without ``stage_reads``)."""
    kept, n = [r for r in eff if "either_right" in r], len(eff)
    if not kept:
        return []
    return [f"modelled as declared by either stage: {sum(r['either_right']['confident'] for r in kept)}"
            f"/{len(kept)} with the discovery's confident terms, "
            f"{sum(r['either_right']['with_partial'] for r in kept)}/{len(kept)} with its partial ones too"
            + (f" ({n - len(kept)} of {n} rows without the whole diagnosis)" if len(kept) < n else "")]


def _periodic(r) -> list:
    """The channels of a row whose structure left is a spectral line (signature ``periodic``)."""
    return [u.split()[0] for u in r["unexplained"] if u.endswith(" periodic")]


def table(rows, order) -> list:
    """The table of a run's ``rows``: a row per case (the mechanisms in the kinds' ``order``, then
    the clean recordings), then the counts."""
    eff = sorted([r for r in rows if r["kind"] != "clean"], key=lambda r: order.index(r["kind"]))
    clean = sorted([r for r in rows if r["kind"] == "clean"], key=lambda r: r["seed"])
    either = any("either_right" in r for r in eff)  # rows of a run that kept the whole diagnosis
    L = ["| case | size (RMS / noise) | named with confidence | library named with confidence | flexible: "
         "inputs named (keyed-on right?) | share | held-out gain | CPU [s] |"
         + (" either stage: keyed-on right? (confident terms / with partial) |" if either else ""),
         "|---" * (9 if either else 8) + "|"]
    for r in eff:
        # a pair is one term per channel, the same equation on both: stated once
        conf = list(dict.fromkeys(r["library_confident"] + [t for t in r["discovered"] if not t.startswith("(partial)")]))
        if not r["unexplained"]:  # with structure left, the conclusion says they "may stand in"
            conf += ([r["platform"]] if r["platform"] else []) + r["drifts"]
        g = r["gain"]
        L.append(f"| {r['case']} | {r['size_over_noise']:.1f} (tau{r['size_channel']}) | {'; '.join(conf) or '-'} | "
                 f"{'**' + ', '.join(r['library_confident']) + '**' if r['library_confident'] else '-'} | "
                 f"{_cell(r)} ({'yes' if r['inputs_right'] else 'no'}) | {r['share']:.2f} | "
                 f"{'-' if g is None or not math.isfinite(g) else f'{g:.2f}'} | {r['cpu']:.1f} |"
                 + (f" {either_cell(r)} |" if either else ""))
    for r in clean:
        what = "; ".join(r["library_all"] + r["discovered"] + r["drifts"] + [c for c, _, _ in r["flexible"]])
        L.append(f"| {r['case']} | {r['size_over_noise']:.1f} | {'clean' if r['clean'] else 'NOT CLEAN: ' + what} | "
                 f"- | - | - | - | {r['cpu']:.1f} |" + (" - |" if either else ""))
    n = len(eff)
    if n:
        L += ["", f"library effect named with confidence: {sum(bool(r['library_confident']) for r in eff)}/{n}; "
                  f"flexible stage names the keyed-on inputs: {sum(r['inputs_right'] for r in eff)}/{n}; "
                  f"a channel explained by the flexible stage: {sum(bool(r['named']) for r in eff)}/{n}; "
                  f"a periodic force reported (structure keyed on time): "
                  f"{', '.join(r['case'] for r in eff if _periodic(r)) or 'none'}"]
        L += [f"  {r['case']}: {'; '.join(r.get('periodic') or _periodic(r))}" for r in eff if _periodic(r)]
        L += either_line(eff)
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
