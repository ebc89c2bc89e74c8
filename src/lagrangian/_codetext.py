"""The one way for names and free text into generated code.

Every generator (the numba module and the C of the backends, the C export and its CMakeLists.txt,
the FMU's C and XML, the Modelica model) takes the names and the free text of a model from here,
and from nowhere else:

- :func:`local_name` maps a model symbol (a coordinate, velocity, parameter, input, time) to the
  identifier that holds it in generated code: ``v_<name>``. No generator defines a name that
  starts with ``v_``, and no language keyword, library function or macro does, so a parameter
  named ``E``, ``pow``, ``NAN`` or ``main`` is that parameter and nothing else.
- :func:`module_identifier` maps a model's name to the identifier of an exported module (the C
  prefix ``<id>_rhs`` and its files ``<id>.c``, the FMU's ``modelIdentifier``, the Modelica class):
  letters, digits and ``_`` only, and never one of the target's reserved names (``main``, ``fmu``,
  ``math``, ``Real``, a keyword, a standard header, ...), which get the suffix ``_model``.
- :func:`comment_text` writes free text (a model's name or description, a constraint's
  expression) in the only form that may enter a comment or a docstring: printable ASCII without
  the characters that could close or continue a comment or string in any target (``*/``, ``\\``
  and a newline, ``\"\"\"``, ``#``, ``?`` for trigraphs, ``$``, ``@``, quotes), each other
  character replaced by ``_``, and cut to :data:`COMMENT_MAX` characters.
- :func:`c_string`, :func:`modelica_string` and :func:`xml_attribute` write text as a string
  literal of their language, escaped so that it cannot end early.

Identifiers follow one rule, :data:`IDENTIFIER` (ASCII letters, digits and ``_``, not starting
with a digit): :func:`check_identifier` refuses any other name before it can reach a generator.
"""

from __future__ import annotations

import keyword
import re

__all__ = ["IDENTIFIER", "COMMENT_MAX", "check_identifier", "local_name", "module_identifier", "comment_text",
           "c_string", "c_strings", "modelica_string", "xml_attribute", "plot_text", "without_controls", "RESERVED",
           "toml_string"]

#: The one rule for a name that enters generated code.
IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")
#: Free text in a comment is cut to this many characters.
COMMENT_MAX = 120

# the characters free text keeps in a comment: none of them can end or continue a comment or a
# string in Python, C, CMake, Modelica or XML, or form a C trigraph or a CMake variable reference
_SAFE = frozenset("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789 _-+=.,:;()<>!^~|&%")

_C_KEYWORDS = frozenset("""auto break case char const continue default do double else enum extern float for goto if
inline int long register restrict return short signed sizeof static struct switch typedef union unsigned void volatile
while _Alignas _Alignof _Atomic _Bool _Complex _Generic _Imaginary _Noreturn _Static_assert _Thread_local bool true
false alignas alignof static_assert thread_local nullptr typeof constexpr asm fortran""".split())
# C's standard headers (an exported <id>.h must not shadow <math.h>) and the files an export writes
_C_FILES = frozenset("""assert complex ctype errno fenv float inttypes iso646 limits locale math setjmp signal stdalign
stdarg stdatomic stdbool stddef stdint stdio stdlib stdnoreturn string tgmath threads time uchar wchar wctype main fmu
cmakelists modeldescription fmi2functions fmi2functiontypes fmi2typesplatform""".split())
_MODELICA = frozenset("""algorithm and annotation block break class connect connector constant constrainedby der
discrete each else elseif elsewhen encapsulated end enumeration equation expandable extends external false final flow
for function if import impure in initial inner input loop model not operator or outer output package parameter partial
protected public pure record redeclare replaceable return stream then true type when while within time pi StateSelect
Real Integer Boolean String Modelica ModelicaServices Complex ExternalObject abs sign sqrt sin cos tan asin acos atan
atan2 sinh cosh tanh exp log log10 div mod rem ceil floor integer min max sum product noEvent smooth sample pre edge
change reinit delay cardinality homotopy semiLinear inStream actualStream getInstanceName terminal assert size ndims
scalar vector matrix zeros ones fill linspace transpose cross skew identity diagonal""".split())

#: The names each target reserves for itself (compared without case for the C targets, whose
#: files may land on a case-insensitive file system).
RESERVED = {
    "c": _C_KEYWORDS | _C_FILES,
    "modelica": _MODELICA,
    "python": frozenset(keyword.kwlist) | frozenset(keyword.softkwlist),
}


def check_identifier(name: object, what: str = "name") -> str:
    """`name` itself when it follows :data:`IDENTIFIER`; else ValueError saying the rule."""
    if not isinstance(name, str) or not IDENTIFIER.match(name):
        raise ValueError(f"{what} {name!r} cannot enter generated code: a name there is ASCII letters, digits and "
                         "'_', not starting with a digit (for example 'theta1')")
    return name


def local_name(name: str) -> str:
    """The identifier of the model symbol `name` in generated code: ``v_<name>``."""
    return "v_" + check_identifier(name, "the symbol")


def module_identifier(name: str, target: str = "c") -> str:
    """The identifier of a module generated from the model named `name` (free text) for `target`
    ("c": the C export, its files and the FMU; "modelica": a class, CamelCase): its letters and
    digits, every other character as ``_`` (C, the ends stripped) or words capitalized (Modelica),
    ``m_``/``M`` before a leading
    digit, ``model``/``Model`` when nothing is left, and the suffix ``_model``/``Model`` when the
    result is one of the target's reserved names (``main``, ``math``, ``fmu``, ``Real``, ...)."""
    words = re.findall(r"[A-Za-z0-9]+", name if isinstance(name, str) else "")
    if target == "modelica":
        ident = "".join(w[:1].upper() + w[1:] for w in words) or "Model"
        ident = "M" + ident if ident[0].isdigit() else ident
        return ident + "Model" if ident in RESERVED["modelica"] else ident
    ident = re.sub(r"\W", "_", name if isinstance(name, str) else "", flags=re.ASCII).strip("_") or "model"
    ident = "m_" + ident if ident[0].isdigit() else ident
    low = ident.lower()
    if low in RESERVED["c"] or low.startswith("fmi"):
        ident += "_model"
    return ident


def without_controls(text: object) -> str:
    """`text` with every control character (a newline, a NUL, DEL) as a space."""
    return "".join(" " if (ord(c) < 32 or ord(c) == 127) else c for c in str(text))


def comment_text(text: object, limit: int = COMMENT_MAX) -> str:
    """`text` as it may stand in a comment or docstring of any target: printable ASCII of a safe
    set only (every other character, a newline and a NUL included, becomes ``_``), runs of
    whitespace as one space, at most `limit` characters (the cut marked by ``...``)."""
    text = " ".join(str(text).split())
    out = "".join(c if c in _SAFE else "_" for c in text)
    return out if len(out) <= limit else out[:limit - 3] + "..."


def c_string(text: str) -> str:
    """A C string literal of `text` (UTF-8): printable ASCII but ``"``, ``\\`` and ``?`` as
    themselves, every other byte as a three-digit octal escape (which cannot run on)."""
    out = []
    for b in str(text).encode("utf-8", "replace"):
        c = chr(b)
        out.append(c if (32 <= b < 127 and c not in '"\\?') else f"\\{b:03o}")
    return '"' + "".join(out) + '"'


def c_strings(texts) -> str:
    """The initializer of a C array of strings: `texts` as :func:`c_string` literals, or ``0``
    for none (C has no empty initializer)."""
    return ", ".join(c_string(t) for t in texts) or "0"


def modelica_string(text: str) -> str:
    """A Modelica string literal of `text`: ``\\`` and ``"`` escaped, control characters (a newline,
    a NUL) as spaces."""
    text = without_controls(text)
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def toml_string(text: object) -> str:
    """A TOML basic string of `text` (a model file written by lagrangian): ``"`` and ``\\`` escaped, the
    control characters TOML does not allow raw (all below U+0020 and DEL) as ``\\uXXXX``, a lone surrogate
    (no Unicode scalar value: neither TOML nor UTF-8 holds it) as U+FFFD; every other character as itself
    (JSON's ``\\ud83d\\ude00`` pairs are not TOML)."""
    out = []
    for c in str(text):
        o = ord(c)
        if c in '"\\':
            out.append("\\" + c)
        elif o < 32 or o == 127:
            out.append(f"\\u{o:04x}")
        elif 0xD800 <= o <= 0xDFFF:
            out.append("\ufffd")
        else:
            out.append(c)
    return '"' + "".join(out) + '"'


def plot_text(text: object) -> str:
    """`text` as Matplotlib shows it literally: ``$`` escaped (no mathtext parsed from a model's
    name), control characters as spaces."""
    return without_controls(text).replace("$", "\\$")


_XML_INVALID = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\ufffe\uffff\ud800-\udfff]")


def xml_attribute(text: str) -> str:
    """An XML attribute value of `text`, quoted: the characters XML 1.0 cannot hold (NUL and the
    other control characters) as spaces, then &, <, >, quotes and newlines escaped."""
    return _quoteattr(_XML_INVALID.sub(" ", str(text)))


def _quoteattr(data: str) -> str:
    """``xml.sax.saxutils.quoteattr(data)``, written out: that module imports urllib.request and with it
    ssl (65 ms at every start of a process that generates code: the bicycle's report and steady)."""
    for char, entity in (("&", "&amp;"), (">", "&gt;"), ("<", "&lt;"), ("\n", "&#10;"), ("\r", "&#13;"),
                         ("\t", "&#9;")):
        data = data.replace(char, entity)
    if '"' not in data:
        return f'"{data}"'
    if "'" not in data:
        return f"'{data}'"
    return '"' + data.replace('"', "&quot;") + '"'
