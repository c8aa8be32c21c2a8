"""The import graph of the ``cosim`` package, read from the source with ``ast``: every
module, the layer it belongs to, the import cycles and the imports that go up a layer.

    .venv/bin/python scripts/import_graph.py            # the layers, the figures, each problem
    .venv/bin/python scripts/import_graph.py --write    # the same, and the graph in docs/architecture.md

Every ``import`` statement counts, at the top of a module or inside a function (a function's
import still ties the two modules together: it only moves the moment of the import).  A
module may import modules of its own layer and of the layers below; the layers, lowest
first, are :data:`LAYERS`.  ``tests/test_architecture.py`` fails on a cycle, an upward
import, a module in no layer, or a graph in docs/architecture.md that is not this script's.
"""
from __future__ import annotations

import argparse
import ast
import functools
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
PACKAGE = REPO / "cosim"
DOC = REPO / "docs" / "architecture.md"
BEGIN, END = "<!-- import graph: scripts/import_graph.py --write -->", "<!-- end of the import graph -->"

#: The layers, lowest first: (name, what it holds, module prefixes).  A module belongs to the
#: layer of its longest matching prefix (a prefix names a module or a package and everything in
#: it; the root package ``cosim``, whose ``__init__`` imports nothing, names itself only).
LAYERS = [
    ("binding", "the C declarations, the public exceptions and the core's Python face",
     ["cosim._native", "cosim.errors", "cosim.core", "cosim",
      # robot files in other formats read into descriptions for the core (Model("arm.urdf"))
      "cosim.robots"]),
    ("basics", "what the loop and every capability use: recordings, trajectories, controllers, the FMU wrapper",
     ["cosim.jsonable", "cosim.recording_io", "cosim.recording", "cosim.run_record", "cosim.trajectories",
      "cosim.simulate", "cosim.controllers", "cosim.fmu", "cosim._fmu_build", "cosim.fourbar", "cosim.indices", "cosim.parasitic", "cosim.plots",
      "cosim.injection",
      # exciting trajectories: a leaf (it imports nothing of cosim) that scenarios and calibration use too
      "cosim.discrepancy.excitation"]),
    ("loop", "plants, the one closed loop, scenarios and their SSP export",
     ["cosim.plants", "cosim.closed_loop", "cosim.master", "cosim.scenario", "cosim.ssp"]),
    ("capabilities", "one subpackage per family of work over the loop",
     ["cosim.calibration", "cosim.quattro", "cosim.discrepancy", "cosim.importing", "cosim.report",
      "cosim.identification"]),
    ("sweeps", "many runs of any capability on a Dask cluster", ["cosim.sweep"]),
    ("interface", "the cosim command and the python -m entry points",
     ["cosim.cli", "cosim.__main__", "cosim.sweep.__main__"]),
]

#: Cycles tolerated, each the set of its modules (the check passes them; the figures count
#: them).  Empty: the test holds the package to no cycle at all.
ALLOWED_CYCLES: list[frozenset] = []


def modules(package: Path = PACKAGE) -> dict:
    """{dotted module name: path} of every module of the package (a package is its ``__init__``)."""
    out = {}
    for p in sorted(package.rglob("*.py")):
        parts = list(p.relative_to(package.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = p
    return out


@functools.lru_cache(maxsize=None)
def _tree(path: Path, mtime: float) -> ast.Module:
    return ast.parse(path.read_text(), str(path))


def _parse(path: Path) -> ast.Module:
    return _tree(path, path.stat().st_mtime)


def _known(name: str, mods: dict) -> str:
    """The module ``name`` is, or the innermost package holding it (``from pkg import func``)."""
    while name and name not in mods:
        name = name.rpartition(".")[0]
    return name


def imports(mods: dict | None = None) -> dict:
    """{module: {imported module: first line}} over every import statement of the package."""
    mods = modules() if mods is None else mods
    root = next(iter(mods)).split(".")[0]
    graph = {}
    for name, path in mods.items():
        pkg = name if path.name == "__init__.py" else name.rpartition(".")[0]
        out = {}
        for node in ast.walk(_parse(path)):
            targets = []
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    base = pkg.split(".")[: len(pkg.split(".")) - (node.level - 1)]
                    full = ".".join(base + ([node.module] if node.module else []))
                else:
                    full = node.module or ""
                # `from pkg import mod` imports the module pkg.mod; `from mod import func`, mod
                targets = [f"{full}.{a.name}" if f"{full}.{a.name}" in mods else full for a in node.names]
            for t in targets:
                if t == root or t.startswith(root + "."):
                    t = _known(t, mods)
                    if t != name:
                        out.setdefault(t, node.lineno)
        graph[name] = out
    return graph


def dynamic_imports(mods: dict | None = None) -> list:
    """(module, line) of every ``importlib.import_module`` or ``__import__`` call whose argument
    names the package itself (a constant or f-string starting with its name): an import this
    graph cannot follow (a user's module named by a sweep spec, an argument, is not one)."""
    mods = modules() if mods is None else mods
    root = next(iter(mods)).split(".")[0]
    out = []
    for name, path in mods.items():
        for node in ast.walk(_parse(path)):
            if not (isinstance(node, ast.Call) and node.args):
                continue
            f = node.func
            called = f.attr if isinstance(f, ast.Attribute) else getattr(f, "id", "")
            if called not in ("import_module", "__import__"):
                continue
            a = node.args[0]
            first = a.values[0] if isinstance(a, ast.JoinedStr) and a.values else a
            if isinstance(first, ast.Constant) and isinstance(first.value, str) and \
                    (first.value == root or first.value.startswith(root + ".") or first.value.startswith(".")):
                out.append((name, node.lineno))
    return out


def layer_of(module: str) -> int | None:
    """Index in :data:`LAYERS` of the module's layer (None: in no layer)."""
    best, where = -1, None
    for i, (_, _, prefixes) in enumerate(LAYERS):
        for p in prefixes:
            if (module == p or ("." in p and module.startswith(p + "."))) and len(p) > best:
                best, where = len(p), i
    return where


def cycles(graph: dict) -> list:
    """The strongly connected components of more than one module (Tarjan), each sorted."""
    index, low, stack, on, out = {}, {}, [], set(), []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
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

    sys.setrecursionlimit(max(1000, 10 * len(graph)))
    for v in sorted(graph):
        if v not in index:
            visit(v)
    return sorted(out)


def upward(graph: dict, mods: dict) -> list:
    """(module, line, imported module, its layer, the imported one's layer) of every import of a higher layer."""
    out = []
    for a, targets in sorted(graph.items()):
        for b, line in sorted(targets.items()):
            la, lb = layer_of(a), layer_of(b)
            if la is not None and lb is not None and lb > la:
                out.append((a, line, b, LAYERS[la][0], LAYERS[lb][0]))
    return out


def check(graph: dict | None = None, mods: dict | None = None) -> dict:
    """The figures and every problem: {"modules", "imports", "cycles", "upward", "unplaced"}."""
    mods = modules() if mods is None else mods
    graph = imports(mods) if graph is None else graph
    every = cycles(graph)
    return {"modules": len(mods), "imports": sum(len(t) for t in graph.values()),
            "cycles": [c for c in every if frozenset(c) not in ALLOWED_CYCLES],
            "tolerated": [c for c in every if frozenset(c) in ALLOWED_CYCLES],
            "upward": upward(graph, mods), "unplaced": sorted(m for m in mods if layer_of(m) is None),
            "dynamic": dynamic_imports(mods)}


def _group(module: str) -> str:
    """The node a module is drawn in: its subpackage (cosim.core, cosim.cli, ...) or itself
    (a top-level module, or a module placed in another layer than its subpackage)."""
    group = ".".join(module.split(".")[:2])
    return group if layer_of(group) == layer_of(module) else module


def mermaid(graph: dict) -> str:
    """The graph between subpackages and top-level modules, one subgraph per layer, as a mermaid flowchart."""
    nodes = sorted({_group(m) for m in graph}, key=lambda n: (layer_of(n) or 0, n))
    ident = {n: n.replace("cosim.", "").replace(".", "_").strip("_") or "cosim" for n in nodes}
    ident = {n: i if list(ident.values()).count(i) == 1 else n.replace(".", "_") for n, i in ident.items()}
    label = {n: n.replace("cosim.", "", 1) + ("/" if any(m.startswith(n + ".") for m in graph) else "") for n in nodes}
    lines = ["```mermaid", "flowchart BT"]
    for i, (name, what, _) in enumerate(LAYERS):
        members = [n for n in nodes if layer_of(n) == i and n != "cosim"]
        if not members:
            continue
        lines.append(f'  subgraph L{i}["{i}. {name}: {what}"]')
        lines += [f'    {ident[n]}["{label[n]}"]' for n in members]
        lines.append("  end")
    edges = sorted({(_group(a), _group(b)) for a, t in graph.items() for b in t
                    if _group(a) != _group(b) and "cosim" not in (_group(a), _group(b))})
    lines += [f"  {ident[a]} --> {ident[b]}" for a, b in edges]
    lines.append("```")
    return "\n".join(lines)


def doc_block(graph: dict, result: dict) -> str:
    """The text between the markers of docs/architecture.md."""
    tolerated = "".join(f" (and, tolerated while it is being removed, {' <-> '.join(c)})" for c in result["tolerated"])
    layers = "\n".join(f"{i}. **{name}**: {what} (`{'`, `'.join(p)}`)" for i, (name, what, p) in enumerate(LAYERS))
    return (f"{BEGIN}\n{layers}\n\n{mermaid(graph)}\n\n"
            f"{result['modules']} modules, {result['imports']} imports between them: "
            f"{len(result['cycles'])} import cycles{tolerated}, {len(result['upward'])} imports from a lower "
            f"layer to a higher one.\n{END}")


def write_doc(text: str, block: str) -> str:
    """``text`` with the block between the markers replaced (or appended)."""
    if BEGIN in text:
        head, rest = text.split(BEGIN, 1)
        return head + block + rest.split(END, 1)[1]
    return text.rstrip("\n") + "\n\n" + block + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--write", action="store_true", help="write the graph into docs/architecture.md")
    args = ap.parse_args(argv)
    mods = modules()
    graph = imports(mods)
    r = check(graph, mods)
    for i, (name, _, _) in enumerate(LAYERS):
        members = [m for m in mods if layer_of(m) == i]
        print(f"{i}. {name:<13} {len(members):3d} modules")
    print(f"{r['modules']} modules, {r['imports']} imports: {len(r['cycles'])} import cycles "
          f"(+ {len(r['tolerated'])} tolerated), "
          f"{len(r['upward'])} upward imports, {len(r['unplaced'])} modules in no layer")
    for c in r["cycles"]:
        print("cycle:", " <-> ".join(c))
    for c in r["tolerated"]:
        print("cycle tolerated (ALLOWED_CYCLES):", " <-> ".join(c))
    for a, line, b, la, lb in r["upward"]:
        print(f"upward: {a} (line {line}, {la}) imports {b} ({lb})")
    for m in r["unplaced"]:
        print(f"in no layer: {m} (add it to LAYERS)")
    for m, line in r["dynamic"]:
        print(f"dynamic import of the package: {m} line {line} (import it by name: the graph cannot see it)")
    if args.write:
        DOC.write_text(write_doc(DOC.read_text(), doc_block(graph, r)))
        print(f"wrote the graph into {DOC.relative_to(REPO)}")
    return 1 if r["cycles"] or r["upward"] or r["unplaced"] or r["dynamic"] else 0


if __name__ == "__main__":
    sys.exit(main())
