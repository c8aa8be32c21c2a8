"""Functions of ``cosim/discrepancy`` do not change their arguments: no item or attribute of a
parameter is assigned, no mutating method (append, update, pop, ...) is called on one, before
the function binds the name to something of its own (a copy).  A part of a parameter (``x =
p.a``, ``for x in p``) counts as the parameter.  The scan reads the source (``ast``); what it
cannot see (a change through an object another call returns) the tests of each step check."""
import ast
import textwrap
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2] / "cosim" / "discrepancy"
MUTATING = {"append", "extend", "update", "pop", "setdefault", "add", "clear", "remove", "insert", "sort",
            "discard", "popitem", "difference_update", "intersection_update", "fill", "resize"}
#: functions still changing an argument, as "path:function": may shrink, not grow
TOLERATED: set = set()


def _root(n):
    while isinstance(n, (ast.Attribute, ast.Subscript)):
        n = n.value
    return n.id if isinstance(n, ast.Name) else None


def _bound_at(fn) -> dict:
    """name -> the first line where the function binds it by plain assignment."""
    out = {}
    for n in ast.walk(fn):
        if isinstance(n, (ast.Assign, ast.AnnAssign)):
            for t in n.targets if isinstance(n, ast.Assign) else [n.target]:
                if isinstance(t, (ast.Name, ast.Tuple, ast.List)):
                    for e in ast.walk(t):
                        if isinstance(e, ast.Name):
                            out[e.id] = min(out.get(e.id, n.lineno), n.lineno)
    return out


def _parts(fn, params) -> set:
    """The parameters and the names bound to a part of one (an alias, a loop over it)."""
    derived = set(params)
    for _ in range(3):
        for n in ast.walk(fn):
            if (isinstance(n, ast.Assign) and len(n.targets) == 1 and isinstance(n.targets[0], ast.Name)
                    and isinstance(n.value, (ast.Attribute, ast.Subscript)) and _root(n.value) in derived):
                derived.add(n.targets[0].id)
            if isinstance(n, (ast.For, ast.comprehension)):
                it = n.iter
                if (isinstance(it, ast.Call) and isinstance(it.func, ast.Attribute)
                        and it.func.attr in ("values", "items")):
                    it = it.func.value
                if not isinstance(it, ast.Call) and _root(it) in derived:
                    derived |= {e.id for e in ast.walk(n.target) if isinstance(e, ast.Name)}
    return derived


def changes(source: str) -> list:
    """``[(function, line, what)]``: the changes of an argument in ``source``."""
    out = []
    for fn in ast.walk(ast.parse(source)):
        if not isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef)):
            continue
        a = fn.args
        params = {x.arg for x in a.posonlyargs + a.args + a.kwonlyargs} - {"self", "cls"}
        names, bound = _parts(fn, params), _bound_at(fn)
        for n in ast.walk(fn):
            hit = None
            if isinstance(n, (ast.Assign, ast.AugAssign, ast.AnnAssign)):
                for t in n.targets if isinstance(n, ast.Assign) else [n.target]:
                    if isinstance(t, (ast.Attribute, ast.Subscript)) and _root(t) in names:
                        hit = t
            elif (isinstance(n, ast.Call) and isinstance(n.func, ast.Attribute) and n.func.attr in MUTATING
                  and _root(n.func.value) in names):
                hit = n.func
            if hit is None:
                continue
            name = _root(hit)
            if name in params and bound.get(name, 10 ** 9) < n.lineno:
                continue  # the name holds the function's own object by then
            out.append((fn.name, n.lineno, ast.unparse(hit)))
    return out


def test_the_scan_finds_planted_changes():
    src = textwrap.dedent('''\
        def f(a, b, c, d, e):
            a.x = 1
            b["k"] = 2
            c.append(3)
            for t in d.values():
                t.y = 4
            part = e.z
            part.update({})

        def g(a, b):
            a = dict(a)
            a["k"] = 1
            b = b + [1]
            return a, b

        def h(a):
            a.pop("k")
            a = dict(a)
            return a
        ''')
    assert [(f, ln) for f, ln, _ in changes(src)] == [("f", 2), ("f", 3), ("f", 4), ("f", 6), ("f", 8), ("h", 17)]


def test_no_function_of_the_discrepancy_engine_changes_its_arguments():
    found = {}
    for p in sorted(ROOT.rglob("*.py")):
        rel = p.relative_to(ROOT).as_posix()
        for fn, line, what in changes(p.read_text()):
            found.setdefault(f"{rel}:{fn}", []).append(f"line {line}: {what}")
    new = {k: v for k, v in found.items() if k not in TOLERATED}
    assert not new, "functions changing their arguments (work on a copy, return the new value): " + "; ".join(
        f"{k} ({', '.join(v)})" for k, v in sorted(new.items()))
    gone = TOLERATED - set(found)
    assert not gone, f"no longer changing an argument: delete from TOLERATED: {sorted(gone)}"
