"""URDF mistakes: each ends ``cosim urdf`` with exit code 2 and one line naming the file, the
line and the element (tests/cli/test_mistakes.py style), and ``Model("arm.urdf")`` raises an
``InputError`` with the same message."""
import contextlib
import io
import re

import pytest

from cosim.cli.main import main
from cosim.core import Model
from cosim.errors import InputError

HEAD = '<?xml version="1.0"?>\n<robot name="two">\n  <link name="base"/>\n'
LINK = ('  <link name="{n}">\n    <inertial>\n      <mass value="{m}"/>\n'
        '      <inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/>\n    </inertial>\n  </link>\n')
JOINT = ('  <joint name="{n}" type="{t}">\n    <parent link="{p}"/>\n    <child link="{c}"/>\n'
         '    <axis xyz="0 0 1"/>\n    <limit lower="-1" upper="1"/>\n  </joint>\n')


def _arm(links=(("l1", 1.0), ("l2", 1.0)), joints=(("j1", "revolute", "base", "l1"), ("j2", "revolute", "l1", "l2")),
         extra=""):
    return (HEAD + "".join(LINK.format(n=n, m=m) for n, m in links)
            + "".join(JOINT.format(n=n, t=t, p=p, c=c) for n, t, p, c in joints) + extra + "</robot>\n")


# name: (URDF text, the line and element the message must name, a word of its reason)
CASES = {
    "missing inertial": (_arm(extra='  <link name="l3"/>\n' + JOINT.format(n="j3", t="revolute", p="l2", c="l3")),
                         (28, '<link name="l3">'), "<inertial> is missing"),
    "joint without parent": (_arm().replace('    <parent link="l1"/>\n', ""), (22, '<joint name="j2">'),
                             "<parent link=...> is missing"),
    "loop": (_arm(extra=JOINT.format(n="j3", t="revolute", p="l2", c="l1")), (28, '<joint name="j3">'), "loop"),
    "non-positive mass": (_arm(links=(("l1", 1.0), ("l2", 0.0))), (12, "<mass>"), "must be > 0"),
    "negative mass": (_arm(links=(("l1", -2.0), ("l2", 1.0))), (6, "<mass>"), "must be > 0"),
    "unknown joint type": (_arm(joints=(("j1", "revolute", "base", "l1"), ("j2", "hinge", "l1", "l2"))),
                           (22, '<joint name="j2">'), "not a URDF joint type"),
    "floating joint": (_arm(joints=(("j1", "floating", "base", "l1"), ("j2", "revolute", "l1", "l2"))),
                       (16, '<joint name="j1">'), "not read"),
    "parent not a link": (_arm().replace('<parent link="l1"/>', '<parent link="l9"/>'), (23, "<parent>"),
                          "is not a <link>"),
    "branching tree": (_arm(links=(("l1", 1.0), ("l2", 1.0), ("l3", 1.0)),
                            joints=(("j1", "revolute", "base", "l1"), ("j2", "revolute", "l1", "l2"),
                                    ("j3", "revolute", "l1", "l3"))), (34, '<joint name="j3">'), "branches"),
    "not XML": (_arm().replace("</joint>", "</joint", 1), (22, None), "not well-formed"),
}


def _run(argv):
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(argv)
    return code, err.getvalue()


@pytest.mark.parametrize("case", sorted(CASES))
def test_urdf_mistake_is_one_line_exit_2(case, tmp_path):
    text, (line, element), reason = CASES[case]
    path = tmp_path / "arm.urdf"
    path.write_text(text)
    code, err = _run(["urdf", str(path)])
    assert code == 2, err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    assert err.startswith(f"cosim urdf: error: {path}:{line}: "), err
    if element:
        assert f": {element}: " in err, err
    assert reason in err, err
    with pytest.raises(InputError, match=re.escape(f"{path}:{line}: ")):
        Model(str(path))


def test_good_two_link_arm_reads(tmp_path):
    """The corpus's base arm is valid: the mistakes above are the only thing wrong."""
    path = tmp_path / "arm.urdf"
    path.write_text(_arm())
    out = tmp_path / "arm.toml"
    code, err = _run(["urdf", str(path), "--out", str(out)])
    assert code == 0, err
    assert Model(str(out)).facts.pose_names == ("j1", "j2")
