"""Small pieces: no module of ``cosim`` over 600 lines, no function or method over 100 lines
(measured with ``ast``: a function from its ``def`` to its last line, docstring included).

The pieces over the limits today are listed with their sizes as ceilings: each may only
shrink (a split takes it off the list), and any other piece over a limit fails.  Classes are
not measured as a whole; their methods are."""
import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MODULE_LINES, FUNCTION_LINES = 600, 100

#: modules over MODULE_LINES today: path -> ceiling [lines]
MODULES = {"cosim/calibration/problems.py": 685, "cosim/core/model.py": 693, "cosim/quattro/cycle_time.py": 715}
#: functions over FUNCTION_LINES today: "path:Class.function" -> ceiling [lines]
FUNCTIONS = {"cosim/calibration/solvers.py:solve": 169, "cosim/discrepancy/blind_sampling.py:sample_effect": 102,
             "cosim/discrepancy/diagnosis.py:diagnose": 218,
             "cosim/discrepancy/discovery_fit.py:discover_channel": 110,
             "cosim/discrepancy/discovery_judgement.py:judge_library": 175,
             "cosim/discrepancy/regressors.py:candidates": 153, "cosim/discrepancy/report.py:markdown": 169,
             "cosim/discrepancy/residuals.py:Pipeline.__init__": 120, "cosim/discrepancy/selection.py:select": 126,
             "cosim/discrepancy/working_set.py:working_set": 103, "cosim/quattro/cycle_time.py:fit_cycle_model": 108}


def sizes(root: Path):
    """``(modules, functions)``: {relative path: lines} of every module and
    {"path:Qualified.name": lines} of every function and method under ``root/cosim``."""
    modules, functions = {}, {}
    for path in sorted((root / "cosim").rglob("*.py")):
        rel = path.relative_to(root).as_posix()
        text = path.read_text()
        modules[rel] = len(text.splitlines())
        stack = [(ast.parse(text), "")]
        while stack:
            node, prefix = stack.pop()
            for child in ast.iter_child_nodes(node):
                if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                    functions[f"{rel}:{prefix}{child.name}"] = child.end_lineno - child.lineno + 1
                    stack.append((child, f"{prefix}{child.name}."))
                elif isinstance(child, ast.ClassDef):
                    stack.append((child, f"{prefix}{child.name}."))
    return modules, functions


def over(measured: dict, limit: int, ceilings: dict) -> list:
    """The pieces over ``limit`` that are not listed, or over their ceiling."""
    return sorted(f"{name}: {n} lines" + (f" (ceiling {ceilings[name]})" if name in ceilings else "")
                  for name, n in measured.items() if n > limit and n > ceilings.get(name, limit))


def test_no_module_and_no_function_grows_over_the_limits():
    modules, functions = sizes(ROOT)
    assert not over(modules, MODULE_LINES, MODULES), over(modules, MODULE_LINES, MODULES)
    assert not over(functions, FUNCTION_LINES, FUNCTIONS), over(functions, FUNCTION_LINES, FUNCTIONS)


def test_the_measure_finds_a_long_function_in_a_class_and_a_long_module(tmp_path):
    pkg = tmp_path / "cosim"
    pkg.mkdir()
    body = "\n".join(f"        x{i} = {i}" for i in range(101))
    (pkg / "long.py").write_text(f"class A:\n    def f(self):\n{body}\n" + "\n" * 600)
    modules, functions = sizes(tmp_path)
    assert functions == {"cosim/long.py:A.f": 102}
    assert modules["cosim/long.py"] == 2 + 101 + 600  # the class and def lines, the body, the blank lines
    assert over(functions, FUNCTION_LINES, {}) == ["cosim/long.py:A.f: 102 lines"]
    assert over(functions, FUNCTION_LINES, {"cosim/long.py:A.f": 102}) == []
    assert over(modules, MODULE_LINES, {}) == [f"cosim/long.py: {modules['cosim/long.py']} lines"]
