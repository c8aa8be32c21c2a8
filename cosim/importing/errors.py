"""The one error of an import: what is wrong, in which file, with which variable or field."""
from __future__ import annotations

from ..errors import InputError


class ImportFailure(InputError):
    """A source file or a map that cannot be imported.

    The message is one line: the file, then the variable (of the source) or the field (of
    the map) and the recording column it feeds, then what is wrong.  The CLI prints it and
    exits with status 2.
    """

    def __init__(self, path, message, variable=None, column=None, field=None):
        where = str(path)
        if field is not None:
            where += f", field {field}"
        if variable is not None:
            where += f", variable {variable!r}"
        if column is not None:
            where += f" (column {column})"
        super().__init__(f"{where}: {message}")
        self.path, self.variable, self.column, self.field = path, variable, column, field
