"""Input and output: model files (a safe expression parser and one-pass checks), loading by name."""

from __future__ import annotations

import os
import re
from pathlib import Path

from .._util import did_you_mean
from ..errors import ModelFileError, Problem
from ..model._expr import parse_expression

__all__ = ["load", "parse_expression", "load_model_file", "loads_model"]


def load_model_file(path):
    from ._modelfile import load_model_file as _load

    return _load(path)


def loads_model(text: str, *, source: str = "<string>"):
    from ._modelfile import loads_model as _loads

    return _loads(text, source=source)


def load(source: str | os.PathLike):
    """A Model from a built-in example name (``"cart-pendulum"``, ``"pendulum-chain-5"``) or the
    path of a TOML model file.

    Raises
    ------
    ModelFileError
        The file has problems (all of them are listed), or there is no such file or example.
    """
    from ..examples import example_names, example_source

    text = None
    if isinstance(source, str) and not source.endswith(".toml") and os.sep not in source:
        text = example_source(source)
        if text is not None:
            return loads_model(text, source=f"<example {source}>")
    path = Path(source)
    if path.exists() or str(source).endswith(".toml") or os.sep in str(source):
        return load_model_file(path)
    family = re.match(r"(pendulum-chain|spring-mass-damper-chain)-(-?[0-9]+)\Z", str(source))
    if family:
        raise ModelFileError([Problem(
            f"'{source}': a {family.group(1)} has 1 to 200 elements; choose n in that range, "
            f"e.g. {family.group(1)}-5")])
    extra = did_you_mean(source, example_names(), 0.5, sentence=True)
    raise ModelFileError([Problem(
        f"'{source}' is neither a model file nor a built-in example.{extra} "
        "Run `lagrangian examples` to list the examples, or give the path of a .toml model file.")])
