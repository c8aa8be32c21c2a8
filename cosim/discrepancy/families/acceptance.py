"""What a term of the families (:mod:`.products`) must show to enter the discovery step's search,
beyond what a term of the library of one joint's position and rate must.

* **Its own look-elsewhere count.**  A term of the library pays ``2 ln M_lib`` (M_lib: the
  library's candidates over all channels, as without the families); a term of the families pays
  ``2 ln M`` (M: every candidate, the families' included).  Read as a weighted Bonferroni bound,
  the chance that noise alone makes any library term enter stays what it was, the families' terms
  together add at most the share M_fam / M of it (the false-alarm bound of the whole search is
  less than twice the library's), and adding candidates to the families raises their own cost.
* **Not in the library's trials.**  The tie rule (``discovery.judge_library``) puts each library
  effect on trial against the terms discovered in its place; those searches hold the library's
  terms only (``Search.fam_on`` False), so the library's answer is the one without the families,
  and the families' terms are searched once more on the model that stays, on top of it.  On the
  EMPS drive a damping over the stroke (z qd) in the viscous friction's place fitted the held-out
  part better than the viscous friction with the terms on top of it (whose search had refused
  that term on the held-out part) and withdrew it.
* **On trial again.**  A library effect of one joint that stays after the trials is put on trial
  once more with the families searched on both sides, where the terms in its place hold a family
  term that may withdraw it (:func:`withdrawing`: a load-dependent
  friction, a zone, a level over the stroke, another joint's position or rate): a Coulomb
  friction standing in for a friction zone, a saturation standing in for a cable carrier linking
  two rails, are withdrawn when the terms in their place do better.  A damping over the stroke
  (z qd) or an effort x position term is no such term (a library column times the position): the
  EMPS drive's viscous friction and offset are not put on trial again.
* **Held out.**  The terms of the families a channel's discovered term holds must lower the
  held-out chi-square beyond the library-only selection by more than the threshold plus their
  extra cost (:func:`held_out_keeps`); otherwise the library-only selection is the answer.

``docs/discovery_families.md`` holds what each rule changed on the real recordings and the bench.
"""
from __future__ import annotations

import math
import weakref

from .products import TERMS as FAMILY_TERMS

#: the family terms that may withdraw a library effect (discovery's ``_trials_again``): not the
#: products of a library column with the position (z qd: the viscous friction's column; z tau and
#: tau: the model's own effort), which refine the effect they multiply rather than replace it
WITHDRAWING = ("load", "zone", "stroke_1", "stroke_2", "cross_q", "cross_v")

#: per family term: the index of the column (within the term's columns) that is its own part;
#: the other columns are checked to pay nothing by themselves (a gain of the whole effort)
OWN_PART = {"effortpos": 0}


def is_family(term) -> bool:
    """Is ``term`` ((name, option) or a name) a term of the families?"""
    return (term[0] if isinstance(term, tuple) else term) in FAMILY_TERMS


def split(candidates) -> tuple:
    """(the library's candidates, the families') of a candidate list."""
    lib = [k for k in candidates if not is_family(k)]
    return lib, [k for k in candidates if is_family(k)]


def extra_cost(search) -> float:
    """What a family term pays beyond a library term: 2 ln (M / M_lib), 0 with no family term
    in the search."""
    lib, fam = split(search.candidates())
    if not fam or not lib:
        return 0.0
    return 2.0 * math.log((len(lib) + len(fam)) / len(lib))


def n_library(search) -> int:
    """The library's candidates over all channels: the look-elsewhere count of a library term."""
    return max(1, len(split(search.candidates())[0]) * len(search.channels))


def cost(search, term, threshold: float) -> float:
    """The gain (chi-square in effective samples, after its BIC price) ``term`` must beat to
    enter the search or stay in it, given the library term's ``threshold``."""
    return threshold + (getattr(search, "fam_extra", 0.0) if is_family(term) else 0.0)


#: :func:`searched`'s answers per search (gone with it; a Search is a value): library_only -> candidates
_SEARCHED: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def searched(search, library_only: bool = False) -> list:
    """The candidates a selection searches: the library's, and the families' unless
    ``library_only`` or ``search.fam_on`` is False (the library's trials).  A new list, the
    same for the same search (each bootstrap resample's selection asks)."""
    kept = _SEARCHED.get(search)
    if kept is None:
        kept = _SEARCHED.setdefault(search, {})
    out = kept.get(library_only)
    if out is None:
        lib, fam = split(search.candidates())
        out = kept[library_only] = lib if library_only or not getattr(search, "fam_on", True) else lib + fam
    return list(out)


def own_part(chi2_cols, chi2_full, cand, at, logn, bar) -> bool:
    """Does the own part of ``cand`` (:data:`OWN_PART`) pay ``bar`` plus its BIC price beyond
    the chosen terms with the term's other columns fitted?  ``chi2_cols(cols)``: the chi-square
    with the chosen terms and the columns ``cols`` of ``cand`` (indices of ``at[cand]``);
    ``chi2_full``: with all of them.  True for terms without such a part."""
    k = OWN_PART.get(cand[0])
    if k is None:
        return True
    i = at[cand]
    rest = [j for n, j in enumerate(i) if n != k]
    return chi2_cols(rest) - chi2_full - logn > bar


def held_out_keeps(gain_with, gain_without, threshold: float, search) -> bool:
    """Do the family terms of a channel's selection earn their place on the held-out part:
    the held-out chi-square gain with them (``gain_with``) beyond the library-only selection's
    (``gain_without``) above the threshold plus the families' extra cost?"""
    return gain_with - gain_without > threshold + getattr(search, "fam_extra", 0.0)



def withdrawing(term) -> bool:
    """Does the discovered ``term`` hold a family term that may withdraw a library effect
    (:data:`WITHDRAWING`)?"""
    return any(t in WITHDRAWING for t in term.terms)


def or_library(terms, library, heldout, threshold: float, search, answer=None, refit=None) -> list:
    """``terms`` (holding family terms), or the library-only selection ``library()`` where the
    family terms do not earn their place on the held-out part (:func:`held_out_keeps`;
    ``heldout(terms)[1]``: the held-out chi-square gain of a selection; ``refit(terms)``: the
    library's offset as a term, ``[("constant", 0)]``, where it is refitted beside them, or []).
    ``answer()``: the library-only search's answer on
    this channel (a :class:`DiscoveredTerm` or None; None: not made), whose terms are weighed
    too where they fit the held-out part better than the raw selection: its stability pruning
    and offset refit may leave the terms that stood in for the library's offset
    (:func:`answer_terms`)."""
    lib = library()
    gain = (lambda ts: heldout(ts + (refit(ts) if refit else []))[1])  # noqa: E731
    bar = gain(lib)
    done = answer() if answer is not None else None
    if done is not None:
        bar = max(bar, gain(answer_terms(search, done)))
    return terms if held_out_keeps(gain(terms), bar, threshold, search) else lib


def _no_term():
    """The ``library_result`` of a search whose caller reads family terms only (a library effect
    on trial again, ``discover_all(..., family_only=True)``: :data:`WITHDRAWING` terms in its
    place or nothing): a selection without a family term ends before its fits and bootstrap,
    with no term (about 0.1 s CPU saved per library friction of a 6-PUS, each of whose trials
    again otherwise fitted a Coulomb pair to no use)."""
    return None


def no_term(family_only: bool):
    """:func:`_no_term` for a search whose caller reads family terms only, else None (the
    search's own result)."""
    return _no_term if family_only else None


def answer_terms(search, term) -> list:
    """The (term, option) candidates of a discovered ``term`` (its offset refit as
    ``("constant", 0)``).

    The library's offset fitted before the discovery step takes the part of a missing force
    the recording's mean leaves.  A Coulomb level of one direction (which spans a constant
    while the joint moves, so the offset is not refitted beside it) with a friction zone and a
    level over the stroke can rebuild that offset's share (on the Clavel delta's held-out rotor
    inertia: arm 3, an offset of 2.52 N m kept beside inertia, coulomb_neg, zone and stroke_1),
    where the library-only answer drops the stand-ins and refits the offset to zero.  The
    family terms must beat that answer, not only the raw selection it started from."""
    return [(name, search.option_of(term, name)) for name in term.terms]
