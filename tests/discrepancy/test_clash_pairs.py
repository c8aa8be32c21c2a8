"""The discovery's clash rule (:func:`cosim.discrepancy.families.products.clash`, and the set of
the candidates it refuses, :func:`~cosim.discrepancy.families.products.clashing`) answered from
the terms kept per search and term equals the rule's definition on every chosen set: a candidate
clashes when it sets a shape parameter of its joint to another value than any chosen term, or is
a zone beside a library friction of the model."""
import itertools

from cosim.discrepancy.families import products


class _Search:
    """The part of a search the rule reads: the joints' parameter names and each term's shape."""

    SHAPES = {("coulomb_pos", 0): {"force_cv": 0.0}, ("coulomb_neg", 0): {"force_cv": 0.0},
              ("fading", 0): {"force_cv": 0.01}, ("fading", 1): {"force_cv": 0.02},
              ("step", 0): {"force_step_q": 0.1, "force_step_w": 0.02},
              ("step", 1): {"force_step_q": 0.2, "force_step_w": 0.02}, ("position", 0): {},
              ("zone", 0): {"force_czone_q": 0.1}}
    cols = dict.fromkeys(SHAPES)

    def name(self, j, key):
        return f"rail[{j + 1}].{key}"

    def shape(self, term, j, option=0):  # on joint 3 the two fadings have one velocity scale
        return {self.name(j, k): (v if j < 2 else round(v, 1)) for k, v in self.SHAPES[(term, option)].items()}


def _defined(search, c, chosen, cand, held=None):
    if cand[0] == "zone" and held and any(search.name(c, k) in held for k in products.ZONE_NOT_BESIDE):
        return True
    a = products._full_shape(search, c, *cand)
    return any(any(k in b and b[k] != v for k, v in a.items()) for b in (products._full_shape(search, c, *t)
                                                                          for t in chosen))


def test_the_pairs_memo_answers_as_the_rule_on_every_chosen_set():
    search, terms = _Search(), list(_Search.SHAPES)
    asked = 0
    for c in (0, 2):
        friction = {search.name(c, "coulomb"): 0.1}
        for held in (None, {}, friction, {search.name(c + 1, "coulomb"): 0.1}):
            for r in (0, 1, 2, 3):
                for chosen in itertools.permutations(terms, r):
                    refused = products.clashing(search, c, list(chosen), held)
                    for cand in terms:
                        want = _defined(search, c, chosen, cand, held)
                        assert products.clash(search, c, list(chosen), cand, held) == want
                        assert products.clashes(refused, cand) == want
                        asked += 1
        assert products.clash(search, c, [], ("zone", 0), friction)
    clashes = [sum(_defined(search, c, [t], u) for t in terms for u in terms) for c in (0, 2)]
    assert asked > 1000 and 0 < clashes[1] < clashes[0] < len(terms) ** 2
