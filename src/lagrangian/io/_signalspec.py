"""The text of a measured signal taken from a CSV file, ``@FILE.csv[:COLUMN][:cubic][:hold]``: one
parser for the command line's ``--input F=@data.csv:acc`` and the model file's ``[simulation]
inputs = { F = "@data.csv:acc" }``, and the file's reference that the model keeps (the numeric layer
reads the CSV into a ``lagrangian.Signal`` when it simulates)."""

from __future__ import annotations

from dataclasses import dataclass

_QUALIFIERS = {"linear": "interpolation", "cubic": "interpolation", "hold": "extrapolation"}


def split_signal_spec(name: str, text: str) -> tuple[str, str, dict[str, str]]:
    """(path, column, options) of ``@FILE.csv[:COLUMN][:cubic][:hold]`` (`text` starts with '@'): the
    column defaults to the input's `name`; options holds interpolation and extrapolation when given.
    The path is '' when none is given (the caller says so in its own words)."""
    parts = text[1:].split(":")
    options: dict[str, str] = {}
    while len(parts) > 1 and parts[-1].strip().lower() in _QUALIFIERS:
        word = parts.pop().strip().lower()
        options[_QUALIFIERS[word]] = word
    column = name
    if len(parts) > 1 and not (len(parts) == 2 and len(parts[0]) == 1):  # C:\data.csv is a path
        column = parts.pop().strip()
    return ":".join(parts).strip(), column, options


@dataclass(frozen=True)
class SignalFile:
    """A model file's input read from a CSV column: the resolved path, the column, the options, and
    where the model file named it (``model.toml: simulation.inputs.F``, for the errors)."""

    path: str
    column: str
    interpolation: str = "linear"
    extrapolation: str = "error"
    where: str = ""
    text: str = ""

    def __str__(self) -> str:
        return self.text or f"@{self.path}:{self.column}"
