"""Sizes of the project's modules and functions: lines per source file and per function.

The roots measured: the Python package ``cosim/``, the core ``c_core/src/`` and the FMU layer
``fmu/`` (its C files, the generator's C++).

Python functions are read with ``ast`` (``def`` line to last line, decorators excluded).
C and C++ functions are found by a brace-matching scanner: comments, string and character
literals (raw strings too) and preprocessor lines are blanked first, then every ``{`` at
file, namespace, ``extern "C"`` or class level is classified as a function body (a header with
a parameter list and no ``=`` outside it), a scope (namespace, class, struct, enum, extern) or
an initialiser (member initialisers ``x_{a}``, ``= {...}`` tables). A function's length runs
from the first line of its header to its closing brace; lambdas and local classes count in the
function that contains them; lambdas assigned at namespace level are not measured.

Run ``python scripts/code_sizes.py [--max-module N] [--max-function N]`` to list what is over
the limits (600 and 100 by default).
"""
from __future__ import annotations

import ast
import re
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
ROOTS = ("cosim", "c_core/src", "fmu")
C_SUFFIXES = (".c", ".cc", ".cpp", ".h", ".hpp")
MAX_MODULE = 600
MAX_FUNCTION = 100


def blank_c(text: str) -> str:
    """The text with comments, literals and preprocessor lines replaced by spaces (newlines kept)."""
    out = []
    i, n = 0, len(text)
    line_start = True
    while i < n:
        c = text[i]
        if line_start and c == "#":
            j = i
            while j < n and (text[j] != "\n" or text[j - 1] == "\\"):
                j += 1
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
            continue
        if c == "\n":
            line_start = True
            out.append(c)
            i += 1
            continue
        if not c.isspace():
            line_start = False
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            out.append(" " * (j - i))
            i = j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
        elif c == "R" and text.startswith('R"', i) and (i == 0 or not (text[i - 1].isalnum() or text[i - 1] == "_")):
            m = re.match(r'R"([^()\\ ]{0,16})\(', text[i:])
            if not m:
                out.append(c)
                i += 1
                continue
            end = text.find(")" + m.group(1) + '"', i + m.end())
            j = n if end < 0 else end + len(m.group(1)) + 2
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
        elif c in "\"'":
            if c == "'" and i > 0 and text[i - 1].isalnum() and i + 1 < n and text[i + 1].isalnum():
                out.append(" ")  # a digit separator: 1'000'000
                i += 1
                continue
            j = i + 1
            while j < n and text[j] != c and text[j] != "\n":
                j += 2 if text[j] == "\\" else 1
            j = min(j + 1, n)
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
        else:
            out.append(c)
            i += 1
    return "".join(out)


_SCOPE = re.compile(r"^(?:template\s*<.*>\s*)?(?:namespace|class|struct|union|enum|extern)\b", re.S)
_NAME = re.compile(r"(~?[A-Za-z_]\w*(?:\s*<[^<>;{}]*>)?(?:\s*::\s*~?[A-Za-z_]\w*(?:\s*<[^<>;{}]*>)?)*"
                   r"|operator\s*[^\s(]+(?:\s*\(\s*\))?)\s*$")


def _depth0(header: str) -> str:
    """The header with everything inside parentheses removed."""
    out, depth = [], 0
    for ch in header:
        if ch == "(":
            depth += 1
            out.append("(") if depth == 1 else None
        elif ch == ")":
            depth -= 1
            out.append(")") if depth == 0 else None
        elif depth == 0:
            out.append(ch)
    return "".join(out)


def _kind(header: str) -> str:
    """'function', 'scope' or 'init' for the brace that follows ``header``."""
    h = header.strip()
    flat = _depth0(re.sub(r"\boperator\s*(?:\(\s*\)|[^\s(]+)", "operator", h))
    if _SCOPE.match(h) and "(" not in flat.split("{")[0].replace("alignas(", ""):
        return "scope"
    if "(" not in flat or "=" in flat.split("(")[0] or re.search(r"=\s*(?:\[|\{|$)", flat):
        return "scope" if _SCOPE.match(h) else "init"
    tail = flat[flat.rfind(")") + 1:]
    if re.search(r"\)\s*:", flat) and re.search(r"[A-Za-z_]\w*\s*$", tail) and \
            not re.search(r"\b(?:const|noexcept|override|final|mutable|try)\s*$", tail) and "->" not in tail:
        return "init"  # a member initialiser x_{a} after the constructor's ':'
    return "function"


def _match(text: str, i: int) -> int:
    """Index of the brace closing the one at ``i``."""
    depth = 0
    for j in range(i, len(text)):
        if text[j] == "{":
            depth += 1
        elif text[j] == "}":
            depth -= 1
            if depth == 0:
                return j
    return len(text) - 1


def c_functions(text: str) -> list[tuple[str, int, int]]:
    """(name, first line, line count) of every function defined in C/C++ source ``text``."""
    s = blank_c(text)
    found = []
    header_start = 0
    i = 0
    pending_init = None  # header start kept across member-initialiser braces
    while i < len(s):
        c = s[i]
        if c in ";}":
            header_start, pending_init = i + 1, None
        elif c == "{":
            start = pending_init if pending_init is not None else header_start
            header = s[start:i]
            kind = _kind(header)
            if kind == "scope":
                header_start, pending_init = i + 1, None
            elif kind == "init":
                end = _match(s, i)
                pending_init = start if re.search(r"\)\s*:", _depth0(header)) else None
                if pending_init is None:
                    header_start = end + 1
                i = end + 1
                continue
            else:
                end = _match(s, i)
                first = start + (len(header) - len(header.lstrip()))
                line0 = s.count("\n", 0, first) + 1
                line1 = s.count("\n", 0, end) + 1
                head = _depth0(header)
                m = _NAME.search(head[:head.find("(")].rstrip()) if "(" in head else None
                name = re.sub(r"\s+", "", m.group(1)) if m else "?"
                found.append((name, line0, line1 - line0 + 1))
                header_start, pending_init = end + 1, None
                i = end + 1
                continue
        i += 1
    return found


def py_functions(text: str) -> list[tuple[str, int, int]]:
    """(qualified name, first line, line count) of every Python function, methods as Class.name."""
    out = []

    def visit(node, prefix):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                out.append((prefix + child.name, child.lineno, child.end_lineno - child.lineno + 1))
                visit(child, prefix + child.name + ".")
            elif isinstance(child, ast.ClassDef):
                visit(child, prefix + child.name + ".")
            else:
                visit(child, prefix)

    visit(ast.parse(text), "")
    return out


def source_files(repo: Path = REPO, roots=ROOTS) -> list[Path]:
    files = []
    for root in roots:
        for p in sorted((repo / root).rglob("*")):
            if p.is_file() and (p.suffix == ".py" or p.suffix in C_SUFFIXES):
                files.append(p)
    return files


def measure(repo: Path = REPO, roots=ROOTS):
    """({file: lines}, {(file, function): lines}) for every source file under ``roots``."""
    modules, functions = {}, {}
    for p in source_files(repo, roots):
        rel = p.relative_to(repo).as_posix()
        text = p.read_text(encoding="utf-8", errors="replace")
        modules[rel] = text.count("\n") + (0 if text.endswith("\n") or not text else 1)
        fns = py_functions(text) if p.suffix == ".py" else c_functions(text)
        for name, _line, length in fns:
            key = (rel, name)
            functions[key] = max(length, functions.get(key, 0))  # overloads: the longest
    return modules, functions


def over(repo: Path = REPO, roots=ROOTS, max_module=MAX_MODULE, max_function=MAX_FUNCTION):
    """({file: lines}, {'file:function': lines}) of what is over the limits."""
    modules, functions = measure(repo, roots)
    big_modules = {f: n for f, n in modules.items() if n > max_module}
    big_functions = {f"{f}:{name}": n for (f, name), n in functions.items() if n > max_function}
    return big_modules, big_functions


def main(argv=None) -> int:
    import argparse
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--max-module", type=int, default=MAX_MODULE)
    ap.add_argument("--max-function", type=int, default=MAX_FUNCTION)
    ap.add_argument("roots", nargs="*", default=list(ROOTS))
    a = ap.parse_args(argv)
    mods, fns = over(REPO, a.roots, a.max_module, a.max_function)
    for f, n in sorted(mods.items(), key=lambda kv: -kv[1]):
        print(f"module   {n:5d}  {f}")
    for f, n in sorted(fns.items(), key=lambda kv: -kv[1]):
        print(f"function {n:5d}  {f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
