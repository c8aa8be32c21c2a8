"""Share of numeric test files that name or use an independent oracle (a heuristic): python scripts/oracle_share.py . [-v]

numeric: the file compares numbers (approx, assert_allclose, assert_array_equal,
assert_array_almost_equal, assert_almost_equal, isclose, allclose).
oracle: the file says "oracle" / "closed form" / "analytic solution", uses another library
for expected values (scipy, sympy, mpmath, hashlib, itertools, numpy.linalg, np.polyfit/polyval,
np.fft, np.trapz), or cites a published source (a citation "Author [et al.|and Author] YEAR",
"Table N", "Fig. N", "published", "datasheet", "thesis").
"""
import re
import sys
from pathlib import Path

root = Path(sys.argv[1])
NUMERIC = re.compile(r"approx\(|assert_allclose|assert_array_equal|assert_array_almost_equal|assert_almost_equal|"
                     r"isclose\(|allclose\(")
ORACLE = re.compile(r"oracle|closed[- ]form|analytic(al)? solution|\bscipy\b|\bsympy\b|\bmpmath\b|\bhashlib\b|"
                    r"\bitertools\b|np\.linalg\.|numpy\.linalg|np\.polyfit|np\.polyval|np\.fft|np\.trapz|"
                    r"\bpublished\b|\bdatasheet\b|\bthesis\b|\bTable \d|\bFig\. ?\d", re.I)
CITATION = re.compile(r"\b[A-Z][a-z]+(-[A-Z][a-z]+)?( et al\.?| and [A-Z][a-z]+)?,? (19|20)\d\d\b")
num, orc, rows = 0, 0, []
for f in sorted(root.glob("tests/**/test_*.py")):
    t = f.read_text()
    if not NUMERIC.search(t):
        continue
    num += 1
    hit = bool(ORACLE.search(t) or CITATION.search(t))
    orc += hit
    rows.append((hit, str(f.relative_to(root))))
if "-v" in sys.argv:
    for h, f in rows:
        print("oracle " if h else "NONE   ", f)
print(f"{orc} of {num} numeric test files ({100 * orc / num:.0f} %)")
