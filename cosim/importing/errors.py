"""The one error of an import: what is wrong, in which file, with which variable or field."""
from __future__ import annotations

from ..errors import ImportFailure  # noqa: F401 - its home is cosim.errors
