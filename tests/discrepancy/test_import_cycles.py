"""No import cycle among the modules of cosim/ (read from the source with ast, nothing imported).

At module level (what runs on import, ``if TYPE_CHECKING`` blocks included) no module of
cosim/ may reach itself; inside cosim/discrepancy not even through an import in a function
body, so that its layers (fit state, regressors, noise, fitting, selection, inference,
engine, diagnosis) read in one order.
"""
import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2] / "cosim"


def _modules(root: Path) -> dict:
    """Dotted module name -> (file, is a package's __init__)."""
    out = {}
    for f in root.rglob("*.py"):
        parts = list(f.relative_to(root.parent).with_suffix("").parts)
        is_pkg = parts[-1] == "__init__"
        out[".".join(parts[:-1] if is_pkg else parts)] = (f, is_pkg)
    return out


def _module_level(tree):
    """The statements that run on import: all but the bodies of functions and classes' methods."""
    stack, out = list(tree.body), []
    while stack:
        n = stack.pop()
        if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
            continue
        out.append(n)
        stack.extend(ast.iter_child_nodes(n))
    return out


def import_graph(root: Path, function_level: bool) -> dict:
    """Module -> the modules of the same package it imports."""
    mods = _modules(root)
    graph = {}
    for name, (f, is_pkg) in mods.items():
        tree = ast.parse(f.read_text(), str(f))
        here = name.split(".") if is_pkg else name.split(".")[:-1]
        targets = set()
        for n in (ast.walk(tree) if function_level else _module_level(tree)):
            if isinstance(n, ast.Import):
                targets |= {a.name for a in n.names}
            elif isinstance(n, ast.ImportFrom):
                base = ".".join(here[:len(here) - n.level + 1] + ([n.module] if n.module else [])) if n.level \
                    else n.module
                # ``from . import x``: x may be a module of the package
                targets |= {f"{base}.{a.name}" if f"{base}.{a.name}" in mods else base for a in n.names}
        edges = set()
        for t in targets:
            while t and t not in mods:
                t = t.rpartition(".")[0]
            if t and t != name:
                edges.add(t)
        graph[name] = edges
    return graph


def cycles(graph: dict) -> list:
    """The strongly connected components of more than one module (Tarjan), each sorted."""
    index, low, stack, on, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def test_the_check_finds_a_cycle(tmp_path):
    """A package whose modules import each other (one in a function, one under
    TYPE_CHECKING) is reported; without the function-level import it is not."""
    pkg = tmp_path / "pkg"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "sub" / "__init__.py").write_text("from .a import f\n")
    (pkg / "sub" / "a.py").write_text("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from .b import g\n"
                                      "def f():\n    return 1\n")
    (pkg / "sub" / "b.py").write_text("def g():\n    from ..sub import a\n    return a\n")
    (pkg / "c.py").write_text("from .sub import b\n")
    assert cycles(import_graph(pkg, function_level=True)) == [["pkg.sub.a", "pkg.sub.b"]]
    assert cycles(import_graph(pkg, function_level=False)) == []


def test_no_import_cycle_on_import_in_cosim():
    assert cycles(import_graph(ROOT, function_level=False)) == []


def test_no_import_cycle_at_all_in_the_discrepancy_engine():
    graph = import_graph(ROOT, function_level=True)
    sub = {m: {t for t in e if t.startswith("cosim.discrepancy")} for m, e in graph.items()
           if m.startswith("cosim.discrepancy")}
    assert cycles(sub) == []
