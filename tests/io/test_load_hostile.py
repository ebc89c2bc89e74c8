"""load() of hostile sources: not text, names too long for a path, a device: one ModelFileError that names what
is expected, never Python's TypeError or OSError with a traceback."""

from __future__ import annotations

import os

import pytest

import lagrangian as lg
from lagrangian.errors import ModelFileError


@pytest.mark.parametrize("source, shown", [(b"x", r"bytes b'x'"), (None, "NoneType None"), (3, "int 3"),
                                           (["a.toml"], r"list \['a\.toml'\]")])
def test_a_source_that_is_not_text_or_a_path_is_one_error(source, shown):
    """Before: bytes raised pathlib's TypeError, None and 3 an AttributeError or TypeError."""
    with pytest.raises(ModelFileError, match=r"load\(\) takes the path of a model file or the name of a built-in "
                                             r"example \(text or a pathlib\.Path\), got " + shown
                                             + r"; for example lagrangian\.load\('double-pendulum'\)"):
        lg.load(source)


@pytest.mark.parametrize("name", ["y" * 300 + ".toml", "z" * 5000])
def test_a_name_too_long_for_a_path_is_one_error_with_the_name_cut(name):
    """Before: OSError [Errno 36] File name too long, with a traceback and the whole name."""
    with pytest.raises(ModelFileError) as info:
        lg.load(name)
    text = str(info.value)
    assert len(text) < 400
    assert ("File name too long; check the path" in text) or ("is neither a model file nor a built-in example"
                                                             in text)
    assert name[:77] + "..." in text


@pytest.mark.skipif(not os.path.exists("/dev/null"), reason="needs /dev/null")
def test_a_device_is_not_a_model_file():
    with pytest.raises(ModelFileError, match=r"'/dev/null' is not a regular file \(a device, a pipe or a socket\); "
                                             r"give the path of a \.toml model file"):
        lg.load("/dev/null")
