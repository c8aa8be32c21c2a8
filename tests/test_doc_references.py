"""Every reference to a documentation page in the code and the docs points to something that
exists: the page (``docs/robots.md``), and the section when one is named
(``docs/robots.md, Mobility``, ``docs/fmu.md "Controller FMUs and SSP"``): a heading of that
page, or a bold title opening a paragraph, that contains the name."""
import re
import subprocess
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
PAGE = re.compile(r"docs/((?:records/)?[A-Za-z0-9_]+\.md)")
# docs/X.md, Section)   docs/X.md, "Section"   docs/X.md "Section"
SECTION = re.compile(r"docs/((?:records/)?[A-Za-z0-9_]+\.md)(?:,\s*\"([^\"\n]+)\"|\s+\"([^\"\n]+)\"|,\s*([A-Z][A-Za-z -]*?)\s*\))")


def _tracked():
    files = subprocess.run(["git", "ls-files"], cwd=REPO, capture_output=True, text=True, check=True).stdout.split()
    for f in files:
        if f == "tests/test_doc_references.py":  # its own patterns are examples, not references
            continue
        p = REPO / f
        if p.suffix in {".py", ".md", ".cpp", ".h", ".hpp", ".c", ".toml", ".txt", ".in", ".sh"} and p.is_file():
            yield f, p.read_text(errors="replace")


def _titles(page: Path) -> list:
    text = re.sub(r"^```.*?^```", "", page.read_text(), flags=re.M | re.S)  # no code blocks
    return [t.lower() for t in re.findall(r"^#+\s+(.*)$", text, flags=re.M) + re.findall(r"^\*\*([^*]+)\*\*", text, flags=re.M)]


def references():
    for f, text in _tracked():
        # a reference may wrap over two lines in a comment or a docstring
        flat = re.sub(r"\s*\n\s*(?:#|//|\*)?\s*", " ", text)
        for m in PAGE.finditer(text):
            yield f, m.group(1), None
        for m in SECTION.finditer(flat):
            yield f, m.group(1), next(g for g in m.groups()[1:] if g)


def test_the_check_finds_the_references_it_is_meant_to_check():
    found = {(page, sec) for _, page, sec in references() if sec}
    assert ("robots.md", "Mobility") in found          # the description reader's message
    assert ("fmu.md", "Controller FMUs and SSP") in found
    assert ("discrepancy.md", "errors in variables") in found


def test_every_documentation_reference_resolves():
    bad = []
    for f, page, sec in references():
        p = REPO / "docs" / page
        if not p.exists():
            bad.append(f"{f}: docs/{page} does not exist")
        elif sec and not any(sec.lower() in t for t in _titles(p)):
            bad.append(f"{f}: docs/{page} has no section {sec!r}")
    assert not bad, "\n".join(sorted(set(bad)))
