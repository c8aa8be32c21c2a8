"""Leg kinds are whole traits: no code of the core branches on a leg's kind outside the kind
files (``c_core/src/description/kind_*.cpp`` and ``joint_kind.hpp``), and the description
code stays in small pieces (modules under 600 lines, functions under 100).

A branch on the kind is any of: the enum the kinds once were (``Joint::rail``), a comparison
of a leg's or a robot's ``joint`` or kind with a kind (``l.joint == ...``,
``== &rail_leg()``), a comparison of a leg type's name or a kind's name with a literal
(``type->name == "PUS"``, ``prefix() == ...``), a ``switch`` on a leg's joint or kind, a
``dynamic_cast`` or ``typeid`` on a kind.  What a robot is made of (``Structure``: legs,
a single axis, a serial chain) chooses its class in the loader and is not a leg kind.
"""
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SRC = ROOT / "c_core" / "src"
DESCRIPTION = SRC / "description"

_KINDS = r"(?:rail|arm|strut|rail_revolute|revolute_strut)_leg|(?:prismatic|revolute)_axis"
_TYPES = r"PUS|PSS|P\(SS\)2|PRR|RUS|RSS|R\(SS\)2|RRR|UPS|SPS|PRS|RPS|P|R"
KIND_BRANCH = re.compile(
    r"\bJoint::"
    r"|(?:\.|->)\s*joint\s*(?:==|!=)"
    r"|(?:==|!=)\s*&?\s*(?:" + _KINDS + r")\(\)"
    r"|&?\b(?:" + _KINDS + r")\(\)\s*(?:==|!=)"
    r"|\b(?:name|type|prefix|noun|what)(?:\(\))?\)?\s*(?:==|!=)\s*(?:std::string\()?\"(?:" + _TYPES + r"|rail|arm|strut)\""
    r"|\"(?:" + _TYPES + r"|rail|arm|strut)\"\s*(?:==|!=)"
    r"|\bstrcmp\s*\([^;]*\"(?:" + _TYPES + r"|rail|arm|strut)\""
    r"|\bswitch\s*\([^)]*(?:\bjoint\b|->leg\b|->axis\b|\bmotion\(\))"
    r"|\bdynamic_cast\s*<[^>]*(?:Kind|Motion)"
    r"|\btypeid\s*\("
)


def _is_kind_file(path: Path) -> bool:
    return path.parent == DESCRIPTION and (path.name.startswith("kind_") or path.name == "joint_kind.hpp")


def _strip(text: str) -> str:
    """The code without comments (lines kept), string literals kept."""
    text = re.sub(r"/\*.*?\*/", lambda m: "\n" * m.group(0).count("\n"), text, flags=re.S)
    return re.sub(r"//[^\n]*", "", text)


def kind_branches(text: str) -> list[tuple[int, str]]:
    """(line, code) of each branch on a leg kind in C++ source text."""
    out = []
    for k, line in enumerate(_strip(text).splitlines(), 1):
        if KIND_BRANCH.search(line):
            out.append((k, line.strip()))
    return out


def test_the_check_finds_branches_on_the_kind():
    planted = [
        "  if (l.joint == Joint::arm) t1 = 0;",
        "  if (l.type->leg == &strut_leg()) return;",
        "  const bool s = &rail_leg() != l.type->leg;",
        "  if (type->name == std::string(\"PUS\")) x = 1;",
        "  if (std::string(l.kind->prefix()) == \"rail\") x = 1;",
        "  switch (l.joint) { default: break; }",
        "  if (dynamic_cast<const LegMotion*>(k)) x = 1;",
        "  if (strcmp(t->name, \"RPS\") == 0) x = 1;",
    ]
    for code in planted:
        assert kind_branches(code), code
    allowed = [
        "  l.kind->grad(l, P, lg, at);",
        "  if (desc.structure == Structure::axis) r = make_axis();",
        "  for (const JointLimit& L : limits_) g[k++] = q_[L.joint];",
        "  if (v->kind != toml::Value::Bool) fail();",
        "  switch (kind) {",
        "  if (std::strcmp(m->robot->name(), \"quattro\") != 0) return;",
        "  // if (l.joint == Joint::arm) in a comment",
    ]
    for code in allowed:
        assert not kind_branches(code), code


def test_no_branch_on_the_leg_kind_outside_the_kind_files():
    found = []
    for path in sorted(SRC.rglob("*")):
        if path.suffix not in (".cpp", ".hpp", ".h", ".c") or _is_kind_file(path):
            continue
        for line, code in kind_branches(path.read_text()):
            found.append(f"{path.relative_to(ROOT)}:{line}: {code}")
    assert not found, "branches on the leg kind outside the kind files:\n" + "\n".join(found)


def function_lengths(text: str) -> list[tuple[int, int]]:
    """(first line, number of lines) of each function body in C++ source text, lambdas and
    local classes counted with the function they are in."""
    code = _strip(text)
    code = re.sub(r'"(?:\\.|[^"\\\n])*"', '""', code)
    code = re.sub(r"'(?:\\.|[^'\\\n])*'", "''", code)
    out, stack, line = [], [], 1
    for i, ch in enumerate(code):
        if ch == "\n":
            line += 1
        elif ch == "{":
            head = re.split(r"[;{}]", code[max(0, i - 400):i])[-1]
            in_function = any(f for f, _ in stack)
            starts = (not in_function and re.search(r"\)[\w\s:&*<>,()]*$", head) is not None
                      and not re.match(r"\s*(?:if|for|while|switch|catch|do)\b", head)
                      and not re.search(r"(?:^|\s)(?:namespace|struct|class|enum|union)\b", head)
                      and not re.search(r"=\s*$", head))
            stack.append((starts, line))
        elif ch == "}" and stack:
            starts, first = stack.pop()
            if starts:
                out.append((first, line - first + 1))
    return out


def test_the_length_check_counts_a_function_and_not_a_table():
    text = "namespace a {\nconst int t[] = {\n 1,\n 2};\nint f(int x) {\n  if (x) {\n    return 1;\n  }\n" \
           "  return 0;\n}\nstruct S {\n  int g() const override { return 2; }\n};\n}\n"
    assert function_lengths(text) == [(5, 6), (12, 1)]


def test_the_description_code_is_in_small_pieces():
    for name in ("described_robot.cpp", "description.cpp"):
        n = len((DESCRIPTION / name).read_text().splitlines())
        assert n <= 600, f"{name} has {n} lines (at most 600)"
    long = []
    for path in sorted(DESCRIPTION.glob("*.[ch]pp")):
        for first, n in function_lengths(path.read_text()):
            if n > 100:
                long.append(f"{path.name}:{first}: {n} lines")
    assert not long, "functions over 100 lines:\n" + "\n".join(long)
