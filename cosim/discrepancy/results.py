"""What a diagnosis finds, as documented dataclasses (fields with units), for
:class:`cosim.discrepancy.Diagnosis`.

Each also reads like the nested dictionaries of earlier releases (``e["key"]``,
``e["params"][name]["value"]``, ``e.get("derived")``) so existing scripts keep working;
new code should use the attributes.  ``to_dict()`` gives the plain form (JSON).
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, field, fields


class Record:
    """Read access by key as well as by attribute (the earlier dictionary form)."""

    def __getitem__(self, key):
        if key not in self.keys():
            raise KeyError(key)
        return getattr(self, key)

    def get(self, key, default=None):
        return getattr(self, key) if key in self.keys() else default

    def keys(self) -> list:
        return [f.name for f in fields(self)]

    def __contains__(self, key) -> bool:
        return key in self.keys()

    def items(self):
        return [(k, getattr(self, k)) for k in self.keys()]

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass
class ParamEstimate(Record):
    """One fitted core parameter: ``value`` and ``nominal`` in ``unit``, ``ci95`` the half
    width of its 95 % interval (same unit)."""

    value: float
    ci95: float
    nominal: float
    unit: str


@dataclass
class Alternative(Record):
    """A look-alike of a found effect: the best fit of another group in its place.

    ``delta_bic`` (its BIC minus the selected model's; < 2 is a tie), ``delta_chi2`` (the fit
    apart from the parameter penalty; < 2 is the same physics on this recording),
    ``extra_params`` (how many more parameters it has), ``correlation`` (of the two
    signatures), ``related`` (declared look-alikes in the library), ``collinear`` (both selected, and one
    column on this recording: a tie), ``statement`` (the
    sentence of the report, with the motion that would separate them)."""

    group: str
    effect: str
    name: str
    delta_bic: float
    delta_chi2: float
    extra_params: int
    correlation: float
    related: bool
    statement: str = ""
    collinear: bool = False


@dataclass
class FoundEffect(Record):
    """One effect the diagnosis selected.

    ``key`` (library key, e.g. ``"coulomb"``), ``name`` and ``title`` (for people),
    ``group`` (its label), ``joint`` (1-based, None for a global effect), ``family``
    (``"effort"``, ``"kinematic"`` or ``"both"``), ``params`` (core parameter ->
    :class:`ParamEstimate`), ``delta_bic`` (when it entered), ``importance`` (chi-square
    increase when removed), ``plant`` (where the core and the FMUs model it),
    ``lookalikes`` (:class:`Alternative`, best first), ``derived`` (quantities besides the
    core parameters: a tilt angle in degrees, a payload offset in mm...)."""

    key: str
    name: str
    group: str
    title: str
    joint: int | None
    family: str
    params: dict
    delta_bic: float
    importance: float
    plant: str
    lookalikes: list = field(default_factory=list)
    derived: dict = field(default_factory=dict)


@dataclass
class Structure(Record):
    """Structure left in a residual channel after the selected model.

    ``channel`` (e.g. ``"tau3"``), ``joint`` (1-based), ``signature`` (what it is keyed on:
    ``"command_sign"``, ``"velocity_sign"``, ``"position"``, ``"velocity"``,
    ``"acceleration"``, ``"offset"``, ``"pose"``, ``"low_speed"``, ``"periodic"``: spectral lines,
    :mod:`.lines`), ``keyed_on`` (in words), ``closest`` (library effects
    of that kind), ``chi2`` (explained, in independent samples), ``rms`` (of the structured
    part) and ``noise`` (the residual's own high-frequency noise), in the channel's unit;
    ``lines``: for ``"periodic"``, the lines as ``(frequency [Hz], amplitude)``, strongest first."""

    channel: str
    joint: int
    signature: str
    keyed_on: str
    closest: list
    chi2: float
    rms: float
    noise: float
    lines: list = field(default_factory=list)
