"""Where no family fits: a flexible model of what is left, then its dependence (docs/flexible.md).

* :mod:`.stage`: the stage itself (one channel's fit, every channel's, the black-box force);
* :mod:`.columns`: the stage's inputs (the columns its trees are given) and their groups;
* :mod:`.cv`: cross-validation over blocks in time, the single-input screen, the staged tree growth;
* :mod:`.select`: which inputs are named (causes before consequences);
* :mod:`.beside`: what stands beside a force's inputs without being one (time, a copy beside the pose, a fitted limit's part);
* :mod:`.across`: what the channels say together (the pose on one channel alone, a kind of input on one channel alone);
* :mod:`.backfit`: the fitted model's parameters re-adjusted beside the trees;
* :mod:`.oblique`: the platform pose and the rates projected on the direction of a linear fit of the residual, per fold;
* :mod:`.motion`: the commanded platform's acceleration through a resonance fitted per fold (a body carried on a spring);
* :mod:`.rival`: a discovered equation against the stage's fit of the residual before it (named with confidence or partial);
* :mod:`.report`: the stage's statements, figure and Markdown;
* :mod:`.cases`: forces no term family covers, simulated with their truth (the stage's test cases).
"""
from .stage import (  # noqa: F401 (the stage's public names)
    Dependence,
    FlexibleFit,
    black_box_force,
    figure,
    flexible_stage,
    inputs,
    markdown,
    reported,
    sentence,
    statement,
)
