"""Code generation: the model's M, f, energy and Lagrangian parts as common-subexpression-
eliminated Python (for numba) or C source, written to a cache directory under a name made from the
hash of the exact generated source (see :func:`source_key`), so that a second process finds the
module (and numba its compiled machine code) and compiles nothing, and two models whose code
differs never share an entry. Names and free text enter the code only through
lagrangian._codetext.

The cache directory is ``$LAGRANGIAN_CACHE_DIR`` or ``~/.cache/lagrangian``.
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import re
import sys
from pathlib import Path

import symengine as se

from .._codetext import comment_text, local_name
from ..equations import Equations
from ..io._files import write_atomically
from ._kernels import SINGULAR_RATIO as SINGULAR

__all__ = ["cache_dir", "source_key", "fingerprint", "store", "cached_module", "model_module", "numba_source",
           "c_source", "large_model",
           "load_module", "Unsupported",
           "GENERATOR_VERSION"]

#: Changes whenever the generated code changes, so that old cache entries are not reused.
GENERATOR_VERSION = "35"

_PY_FUNCS = {
    "sin": "math.sin", "cos": "math.cos", "tan": "math.tan", "asin": "math.asin", "acos": "math.acos",
    "atan": "math.atan", "atan2": "math.atan2", "sinh": "math.sinh", "cosh": "math.cosh",
    "tanh": "math.tanh", "asinh": "math.asinh", "acosh": "math.acosh", "atanh": "math.atanh",
    "exp": "math.exp", "log": "math.log", "sqrt": "math.sqrt", "abs": "abs", "sign": "_sign",
    "Heaviside": "_heaviside", "floor": "math.floor", "ceiling": "math.ceil", "max": "max",
    "min": "min", "pi": "math.pi", "E": "math.e", "lg_step": "_step",
}
#: Functions that C writes otherwise: lg_step(a) (1 for a > 0, else 0: see _steps) as (double)!signbit(a)
#: (1 at +0 too, where the pieces it joins agree: the one-sided springs' forces are continuous).
_C_SPECIAL = {"lg_step": "(double)!signbit"}
_C_FUNCS = {
    "sin", "cos", "tan", "asin", "acos", "atan", "atan2", "sinh", "cosh", "tanh", "asinh", "acosh",
    "atanh", "exp", "log", "sqrt", "fabs", "pow", "floor", "ceil", "fmax", "fmin",
}
_TOKEN = re.compile(r"(\d+\.?\d*(?:[eE][-+]?\d+)?)|([^\W\d]\w*)")


class Unsupported(Exception):
    """An expression the code generator cannot translate (the caller falls back to SciPy)."""


def cache_dir() -> Path:
    """$LAGRANGIAN_CACHE_DIR or ~/.cache/lagrangian (created when missing)."""
    path = Path(os.environ.get("LAGRANGIAN_CACHE_DIR") or Path.home() / ".cache" / "lagrangian")
    path.mkdir(parents=True, exist_ok=True)
    return path


def _names(equations: Equations):
    core = equations.core
    return ([core.t.name], [s.name for s in (*core.q, *core.qd)], [u.name for u in equations.inputs],
            [p.name for p in equations.parameters])


def source_key(source: str, *salt: str) -> str:
    """The cache key of a generated module: the hash of its exact source, the generator's version
    and `salt` (the compiler and its flags, numba's version). Two models whose generated code
    differs in any character (a name in a comment included) never share an entry."""
    h = hashlib.sha256()
    h.update("|".join((GENERATOR_VERSION, *salt)).encode())
    h.update(b"\0")
    h.update(source.encode("utf-8"))
    return h.hexdigest()[:32]


def fingerprint(equations: Equations, *salt: str) -> str:
    """A hash of what the generators read of `equations` (the expressions, the names, the model's
    name) and of `salt` (the FMU's GUID is made from it; :func:`model_module` finds a cached
    module by it)."""
    core = equations.core
    h = hashlib.sha256()
    h.update(repr((GENERATOR_VERSION, _names(equations), equations.model.name, salt)).encode())
    parts = (*core.M, *core.f, core.L, core.D, *core.Q, *core.p, *core.g, *core.w, *core.c)
    if _tree_size(parts, SHARED_FROM) > SHARED_FROM:  # printed as trees: past 1e12 characters at 20 rods
        h.update(b"shared\0")
        for line in _shared_text(parts):
            h.update(line.encode())
            h.update(b"|")
    else:
        for e in parts:
            h.update(str(e).encode())
            h.update(b"|")
    if core.G is not None:
        h.update(str(list(core.G)).encode())
    return h.hexdigest()[:24]


def _symbols(equations: Equations):
    """(symbol, accessor) pairs: t, x[i], u[i], p[i]."""
    core = equations.core
    out = [(se.Symbol(core.t.name), "t")]
    out += [(s, f"x[{i}]") for i, s in enumerate((*core.q, *core.qd))]
    out += [(se.Symbol(u.name), f"u[{i}]") for i, u in enumerate(equations.inputs)]
    out += [(se.Symbol(p.name), f"p[{i}]") for i, p in enumerate(equations.parameters)]
    return out


class _Printer:
    """Prints CSE'd SymEngine expressions in the target language, the model's symbols as their
    local names (``v_<name>``, from lagrangian._codetext.local_name).

    The symbols are replaced by placeholders (``__lg_s<k>``) before printing, so that the printed
    text holds no name of the user's: a token of it is a placeholder, a temporary or a function
    or constant of the language (a parameter named ``E`` or ``pow`` cannot be read as Euler's
    number or C's pow, and cannot meet SymEngine's CSE names ``x0``, ``x1``, ...)."""

    def __init__(self, equations: Equations, lang: str):
        self.lang = lang
        self.locals = []  # (local name, accessor, model name)
        self.placeholders: dict = {}  # model symbol -> placeholder symbol
        self.rename: dict[str, str] = {}  # placeholder name -> local name
        for k, (sym, acc) in enumerate(_symbols(equations)):
            local = local_name(sym.name)
            self.locals.append((local, acc, sym.name))
            placeholder = se.Symbol(f"__lg_s{k}")
            self.placeholders[sym] = placeholder
            self.rename[placeholder.name] = local

    def _hide(self, exprs: list) -> list:
        """`exprs` with the model's symbols replaced by their placeholders (and Piecewise of one
        threshold as steps, see :func:`_steps`)."""
        return [_steps(se.sympify(e).xreplace(self.placeholders)) for e in exprs]

    def _translate(self, text: str, temps: dict[str, str]) -> str:
        def sub(m):
            if m.group(1):
                number = m.group(1)
                # an integer past 15 digits as a double: C truncates a literal past long long's range
                # (99999999999999999999 gave wrong numbers) and numba cannot type one past int64
                return repr(float(number)) if number.isdigit() and len(number) > 15 else number
            name = m.group(2)
            if name in temps:
                return temps[name]
            if name in self.rename:
                return self.rename[name]
            if self.lang == "py":
                if name in _PY_FUNCS:
                    return _PY_FUNCS[name]
            elif name in _C_FUNCS:
                return name
            elif name in _C_SPECIAL:
                return _C_SPECIAL[name]
            raise Unsupported(f"'{name}' in a generated expression")
        return _TOKEN.sub(sub, text)

    def trig_block(self, exprs: list, indent: str = "    ", lanes: bool = False, first=None) -> tuple:
        """:meth:`block` of `exprs` with their sin and cos computed first, a pair at a time by
        `sn{k}, cs{k} = _sincos(base k)` (see _split_trig); returns (statements, outputs, the
        number of bases). `lanes`: by the polynomial alone, each argument named b{k}. With `first`
        (see :meth:`block`): (the sin and cos and the statements the `first` outputs need, the other
        statements, the outputs, the number of bases)."""
        shared = None
        if _tree_size(exprs, SHARED_FROM) > SHARED_FROM:  # one statement per shared node (see _shared)
            bases, *shared = self._shared(exprs, trig=True)
        else:
            bases, exprs = _split_trig(self._hide(exprs))
        lines, names = [], {}
        for k, b in enumerate(bases):
            text = self._translate(self._str(b), {})
            if lanes:
                lines += [f"{indent}b{k} = {text}", f"{indent}sn{k}, cs{k} = _sincos_poly(b{k})"]
            else:
                lines.append(f"{indent}sn{k}, cs{k} = _sincos({text})")
            names.update({f"__lg_sn{k}": f"sn{k}", f"__lg_cs{k}": f"cs{k}"})
        if first is not None:
            early, late, outputs = self.block(exprs, indent, first=first, names=names, hidden=True, cse=shared)
            return lines + early, late, outputs, len(bases)
        more, outputs = self.block(exprs, indent, names=names, hidden=True, cse=shared)
        return lines + more, outputs, len(bases)

    def block(self, exprs: list, indent: str = "    ", first=None, names: dict | None = None,
              hidden: bool = False, cse=None):
        """(statements defining the common subexpressions, the output expressions); with `first`,
        (the statements the first `first` outputs need (or the outputs whose indices `first` lists),
        the other statements, the outputs).
        `names`: more symbols' names (those of :meth:`trig_block`); `hidden`: `exprs` hold
        placeholders already; `cse`: (replacements, reduced expressions) made already (:meth:`_shared`)."""
        if cse is not None:
            reps, reduced = cse
        elif not hidden and _tree_size(exprs, SHARED_FROM) > SHARED_FROM:
            _, reps, reduced = self._shared(exprs, trig=False)
        else:
            reps, reduced = se.cse(exprs if hidden else self._hide(exprs))
        temps: dict[str, str] = dict(names or {})
        lines = []
        for k, (sym, expr) in enumerate(reps):
            name = f"c{k}"
            text = self._translate(self._str(expr), temps)
            temps[sym.name] = name
            lines.append(f"{indent}{'double ' if self.lang == 'c' else ''}{name} = {text}"
                         f"{';' if self.lang == 'c' else ''}")
        outputs = [self._translate(self._str(e), temps) for e in reduced]
        if first is None:
            return lines, outputs
        # the common subexpressions the first `first` outputs need, and the others
        needed: set = set()
        for e in (reduced[:first] if isinstance(first, int) else [reduced[k] for k in first]):
            needed |= set(e.free_symbols)
        for sym, expr in reversed(reps):
            if sym in needed:
                needed |= set(expr.free_symbols)
        early = [line for (sym, _), line in zip(reps, lines) if sym in needed]
        late = [line for (sym, _), line in zip(reps, lines) if sym not in needed]
        return early, late, outputs

    def _shared(self, exprs: list, trig: bool) -> tuple[list, list, list]:
        """(bases, replacements, reduced): what :meth:`trig_block` (`trig`) or :meth:`block` make of
        `exprs` by :func:`_split_trig`, :meth:`_hide` and SymEngine's cse, made in one walk over the
        expressions' shared subexpressions instead, for expressions far larger written out as trees
        than they are (SHARED_FROM): each subexpression used more than once (by two expressions or
        two larger subexpressions) becomes one statement, the others are written where they are used.
        SymEngine's cse of a spatial chain's M and f grows about 4x per rod (65 s at 8 rods), and
        xreplace's copies of a shared subexpression are equal without being the same object (sets of
        them compare whole trees): here every set and dict holds the derived expressions themselves."""
        order, uses = _post_order(exprs)
        inner: dict = {}  # node -> whether it holds a sin or cos
        for e in order:
            inner[e] = any(inner[a] or isinstance(a, (se.sin, se.cos)) for a in e.args)
        calls = [e for e in order if isinstance(e, (se.sin, se.cos)) and not inner[e]] if trig else []
        hidden = {c: c.args[0].xreplace(self.placeholders) for c in calls}
        bases, rep = _trig_bases(sorted(set(hidden.values()), key=str)) if calls else ([], {})
        new: dict = {}
        reps: list = []
        for e in order:
            args = e.args
            if not args:
                out = self.placeholders.get(e, e)
            elif e in hidden:
                out = rep[(se.sin if isinstance(e, se.sin) else se.cos)(hidden[e])]
            else:
                parts = [new[a] for a in args]
                if isinstance(e, se.Piecewise):
                    out = _steps(e.xreplace(dict(zip(args, parts))))
                else:
                    try:
                        out = e.func(*parts)
                    except (AttributeError, TypeError):  # a relation (no func)
                        out = e.xreplace(dict(zip(args, parts)))
            if uses[e] > 1 and out.args and not isinstance(out, _BOOLEAN):  # (a condition stays in its Piecewise)
                name = se.Symbol(f"__lg_d{len(reps)}")
                reps.append((name, out))
                out = name
            new[e] = out
        return bases, reps, [new[e] for e in exprs]

    def _str(self, e) -> str:
        if self.lang == "c":
            text = se.ccode(e)
            if re.search(r"\b(NAN|INFINITY)\b", text):
                raise Unsupported("a non-finite constant")
            return text
        return str(e)  # a name that is not the model's (I, oo, nan) is refused by _translate

    def unpack(self, indent: str = "    ", lanes: bool = False) -> list[str]:
        """Statements naming t, x, u and p; `lanes`: of lane k, from lane-major arrays."""
        end = ";" if self.lang == "c" else ""
        decl = "double " if self.lang == "c" else ""
        if lanes:
            lane = lambda acc: "t[k]" if acc == "t" else re.sub(r"\[(\d+)\]", r"[\1 * L + k]", acc)  # noqa: E731
            return [f"{indent}{local} = {lane(acc)}" for local, acc, _ in self.locals]
        return [f"{indent}{decl}{local} = {acc}{end}" for local, acc, _ in self.locals]


_STEP = se.Function("lg_step")
_BOOLEAN = type(se.true).__mro__[2]  # symengine's Boolean: relations, And, Or, true, false


def _atoms(exprs, *types) -> set:
    """The subexpressions of `exprs` of the given types, each shared subexpression visited once
    (SymEngine's atoms() walks the tree: exponential in the depth of a spatial chain's positions)."""
    seen, found, stack = set(), set(), list(exprs)
    while stack:
        e = stack.pop()
        if e in seen:
            continue
        seen.add(e)
        if isinstance(e, types):
            found.add(e)
        stack.extend(e.args)
    return found


def _tree_size(exprs, bound: int) -> int:
    """The number of nodes of `exprs` written out as trees (each shared subexpression counted
    every time it occurs), computed over the shared ones once; stops counting past `bound`."""
    size: dict = {}
    total = 0
    for root in exprs:
        stack = [(root, False)]
        while stack:
            e, ready = stack.pop()
            if e in size:
                continue
            if ready:
                size[e] = min(1 + sum(size[a] for a in e.args), bound + 1)
            else:
                stack.append((e, True))
                stack.extend((a, False) for a in e.args if a not in size)
        total += size[root]
        if total > bound:
            break
    return total


#: Expressions that written out as trees would have more nodes than this are generated by one walk
#: over their shared subexpressions (:meth:`_Printer._shared`), the others by SymEngine's cse (which
#: also finds common parts of sums and products): the examples, the Panda (1.2e6 nodes) and chains
#: of up to 4 rods in space (3.8e6) as before; 5 rods: 2.1e7, 20 rods: past 1e12.
SHARED_FROM = 10_000_000


def large_model(equations: Equations) -> bool:
    """Whether M and f of `equations` written out as trees pass SHARED_FROM nodes (spatial chains of 5 rods and
    more; not the examples, the Panda nor 4 rods): then c_source writes the split form, and compile's backend "auto"
    takes C where a compiler is present (numba's compile of such a module grows faster than linearly with its
    functions' size: the 8-rod chain 165 s, 12 rods past 15 min; C's split form: gcc -O1 about 10 s at 8 rods)."""
    from ._cache import cached

    core = equations.core
    return cached(equations, ("large_model", SHARED_FROM),  # (the bicycle's 13 ms once)
                  lambda: _tree_size((*core.M, *core.f), SHARED_FROM) > SHARED_FROM)


def _post_order(exprs) -> tuple[list, dict]:
    """(each distinct subexpression of `exprs`, children before parents; node -> the number of
    distinct larger subexpressions that hold it, plus the times it is one of `exprs`)."""
    uses: dict = {}
    order: list = []
    seen: set = set()
    for e in exprs:
        uses[e] = uses.get(e, 0) + 1
    stack = [(e, False) for e in reversed(exprs)]
    while stack:
        e, ready = stack.pop()
        if ready:
            order.append(e)
            continue
        if e in seen:
            continue
        seen.add(e)
        stack.append((e, True))
        args = e.args
        for a in args:
            uses[a] = uses.get(a, 0) + 1
        stack.extend((a, False) for a in reversed(args) if a not in seen)
    return order, uses


def _shared_text(exprs):
    """`exprs` written as a list of their distinct subexpressions, children first, each as its kind and
    the positions of its arguments in the list (a leaf as itself), then the positions of `exprs`: the
    same text exactly for the same expressions, in a size of their shared form (str() writes trees)."""
    order, _ = _post_order(exprs)
    index: dict = {}
    for k, e in enumerate(order):
        index[e] = k
        args = e.args
        if not args:
            yield f"{type(e).__name__}:{e}"
        else:
            kind = type(e).__name__ + (f":{e.get_name()}" if isinstance(e, se.FunctionSymbol) else "")
            yield f"{kind}(" + ",".join(str(index[a]) for a in args) + ")"
    yield "roots(" + ",".join(str(index[e]) for e in exprs) + ")"


def _steps(e):
    """`e` with each Piecewise((a, lhs < rhs), (b, True)) written b + (a - b) lg_step(rhs - lhs)
    (lg_step(x) = 1 for x > 0, else 0), which every target language computes: the one-sided
    springs' potentials and forces (model/_elements.Spring) are such Piecewise. Other Piecewise are
    left as they are (the code generator then refuses them: the SciPy path evaluates them). Each
    shared subexpression is rewritten once; a subexpression without Piecewise is kept as it is."""
    if not e.args or not _atoms([e], se.Piecewise):
        return e
    memo: dict = {}  # subexpression -> its rewriting, or None where it is kept as it is

    def rewrite(e):
        if e in memo:
            return memo[e]
        out = None
        if isinstance(e, se.Piecewise):
            args = e.args
            if len(args) == 4 and args[3] == se.true and isinstance(args[1], se.StrictLessThan):
                lhs, rhs = args[1].args
                a, b = kept(args[0]), kept(args[2])
                out = b + (a - b) * _STEP(kept(rhs) - kept(lhs))
        elif e.args:
            args = e.args
            new = [rewrite(a) for a in args]
            if any(n is not None for n in new):
                out = e.func(*[a if n is None else n for a, n in zip(args, new)])
        memo[e] = out
        return out

    def kept(e):
        out = rewrite(e)
        return e if out is None else out

    return kept(e)


def _header(equations: Equations) -> str:
    t, x, u, p = _names(equations)
    return (f"Generated by lagrangian for the model '{comment_text(equations.model.name)}'. Do not edit.\n\n"
            f"Arguments, in this order, of every function below:\n"
            f"    t : float, time\n"
            f"    x : float64[{len(x)}], the state [{', '.join(x)}]\n"
            f"    u : float64[{len(u)}], the inputs [{', '.join(u)}]\n"
            f"    p : float64[{len(p)}], the parameters [{', '.join(p)}]\n")


#: Models whose M and f print shorter than this (characters) are generated from the simplified
#: forms of Equations.mass_matrix and .forcing (trigonometric identities applied): a double
#: pendulum's forcing shrinks six-fold; larger models are generated as derived.
SIMPLIFY_MAX_CHARS = 20000


def _mass_and_forcing(equations: Equations):
    core = equations.core
    n = equations.n
    M = [[core.M[i, j] for j in range(n)] for i in range(n)]
    f = list(core.f)
    # every node prints at least one character: past the bound in nodes, the text is too (and
    # printing a deep chain's expressions as trees would take minutes)
    parts = (*core.M, *f)
    if (_tree_size(parts, SIMPLIFY_MAX_CHARS) <= SIMPLIFY_MAX_CHARS
            and sum(len(str(e)) for e in parts) <= SIMPLIFY_MAX_CHARS):
        import sympy

        from ..model._kinematics import to_sympy

        Ms, fs = equations.mass_matrix, equations.forcing
        calls = lambda exprs: len(set().union(*(e.atoms(sympy.Function) for e in exprs)))  # noqa: E731
        # simplifying turns sin(q1) cos(q2) - ... into sin(q1 - q2): fewer operations, but one
        # trigonometric call per pair of coordinates; keep it when it needs no more calls
        if calls([*Ms, *fs]) <= calls([to_sympy(e) for e in (*core.M, *core.f)]):
            M = [[se.sympify(Ms[i, j]) for j in range(n)] for i in range(n)]
            f = [se.sympify(e) for e in fs]
    return M, f


def _model_parts(equations: Equations, part: str = "main"):
    core = equations.core
    n = equations.n
    Ms, fs = _mass_and_forcing(equations)
    Mlow = [Ms[i][j] for i in range(n) for j in range(i + 1)]
    if part != "main":
        F = [core.L.diff(qi) - core.D.diff(vi) + Qi for qi, vi, Qi in zip(core.q, core.qd, core.Q)]
        return Mlow, fs, None, list(core.p), F
    h = sum((v * pi for v, pi in zip(core.qd, core.p)), se.Integer(0)) - core.L
    return Mlow, fs, h, None, None


#: sin and cos of arguments up to this size are evaluated by the generated module's own
#: polynomial (_sincos_poly: both at once, and vectorizable), beyond it by libm.
SINCOS_BOUND = 1e5
#: pi/2 in three parts: its first 33 bits, the next 33 bits, the rest rounded (Cody and Waite).
PIO2_PARTS = (1.5707963267341256, 6.077100506303966e-11, 2.0222662487959506e-21)


def _prelude() -> str:
    text = _PRELUDE.replace("@BOUND@", repr(SINCOS_BOUND)).replace("@TWO_OVER_PI@", repr(0.6366197723675814))
    for k, part in enumerate(PIO2_PARTS, 1):
        text = text.replace(f"@PIO2_{k}@", repr(part))
    return text


def _split_trig(exprs: list) -> tuple[list, list]:
    """(bases, exprs'): sin and cos in `exprs` (of arguments free of sin and cos) replaced by the
    symbols __lg_sn{k} and __lg_cs{k} of (sin, cos) of the arguments `bases`, one (sin, cos) pair
    per base. An argument +-a +- b of two symbols is expanded by the addition theorems into the
    pairs of a and b, when that needs fewer pairs (a chain's sin(q1 - q2), cos(q1 - q3), ...
    then cost one pair per coordinate, not one per pair of coordinates)."""
    calls = {c for c in _atoms(exprs, se.sin, se.cos) if not _atoms(c.args, se.sin, se.cos)}
    args = sorted({c.args[0] for c in calls}, key=str)
    bases, rep = _trig_bases(args)
    return bases, ([e.subs(rep) for e in exprs] if rep else list(exprs))


def _trig_bases(args: list) -> tuple[list, dict]:
    """(bases, {sin(a): S, cos(a): C} for each argument a of `args`) for :func:`_split_trig`."""
    def pair(a):  # ((c1, s1), (c2, s2)) for a = c1 s1 + c2 s2, c = +-1, s symbols; or None
        if not (a.is_Add and len(a.args) == 2):
            return None
        out = []
        for term in a.args:
            if term.is_Symbol:
                out.append((1, term))
            elif term.is_Mul and len(term.args) == 2 and term.args[0] == -1 and term.args[1].is_Symbol:
                out.append((-1, term.args[1]))
            else:
                return None
        return out

    split = {a: pair(a) for a in args}
    expanded = {a for a in args if split[a] is None} | {s for a in args if split[a] for _, s in split[a]}
    bases = sorted(expanded, key=str) if len(expanded) < len(args) else args
    sym = {b: (se.Symbol(f"__lg_sn{k}"), se.Symbol(f"__lg_cs{k}")) for k, b in enumerate(bases)}
    rep = {}
    for a in args:
        if a in sym:
            S, C = sym[a]
        else:
            (c1, s1), (c2, s2) = split[a]
            S1, C1 = sym[s1][0] * c1, sym[s1][1]
            S2, C2 = sym[s2][0] * c2, sym[s2][1]
            S, C = S1 * C2 + C1 * S2, C1 * C2 - S1 * S2
        rep[se.sin(a)] = S
        rep[se.cos(a)] = C
    return bases, rep


_PRELUDE = """
import math

import numpy as np
from numba import carray, cfunc, njit, types

_P = types.CPointer(types.float64)
_SIG_VOID = types.void(types.float64, _P, _P, _P, _P, _P)
_SIG_DOUBLE = types.float64(types.float64, _P, _P, _P)
_SIG_RHS = types.float64(types.float64, _P, _P, _P, _P, _P)
_SIG_LANES = types.float64(_P, _P, _P, _P, _P, _P, types.int64)


@njit(cache=True)
def _sign(a):
    return 1.0 if a > 0.0 else (-1.0 if a < 0.0 else 0.0)


@njit(cache=True)
def _heaviside(a):
    return 1.0 if a > 0.0 else (0.5 if a == 0.0 else 0.0)


@njit(cache=True)
def _step(a):
    return 1.0 if a > 0.0 else 0.0


@njit(cache=True, inline="always", error_model="numpy")
def _sincos_poly(a):
    \"\"\"(sin a, cos a) for |a| <= @BOUND@, within 2 ulp, without a branch (so that a loop
    over lanes vectorizes): a = k pi/2 + r with pi/2 in three parts of 33, 33 and 53 bits (k pi/2
    exact for |k| < 2**20), then the Taylor series of sin and cos on |r| <= pi/4 (truncation
    below 1e-19), in Estrin's scheme (a short chain of dependent operations).\"\"\"
    k = math.floor(a * @TWO_OVER_PI@ + 0.5)
    r = ((a - k * @PIO2_1@) - k * @PIO2_2@) - k * @PIO2_3@
    z = r * r
    z2 = z * z
    z4 = z2 * z2
    s = r + r * z * ((-1 / 6 + z * (1 / 120)) + z2 * (-1 / 5040 + z * (1 / 362880)) + z4 * (
        (-1 / 39916800 + z * (1 / 6227020800)) + z2 * (-1 / 1307674368000 + z * (1 / 355687428096000))))
    c = 1.0 + z * ((-0.5 + z * (1 / 24)) + z2 * (-1 / 720 + z * (1 / 40320)) + z4 * (
        (-1 / 3628800 + z * (1 / 479001600)) + z2 * (-1 / 87178291200 + z * (1 / 20922789888000))))
    q = np.int64(k) & 3
    odd = (q & 1) == 1
    sa = c if odd else s
    ca = s if odd else c
    sa = -sa if (q & 2) == 2 else sa
    ca = -ca if ((q + 1) & 2) == 2 else ca
    return sa, ca


@njit(cache=True, inline="always")
def _sincos(a):
    \"\"\"(sin a, cos a): _sincos_poly where it holds, libm beyond (and for inf and NaN).\"\"\"
    if abs(a) <= @BOUND@:
        return _sincos_poly(a)
    return math.sin(a), math.cos(a)
"""


_SOLVE_LOOP = """

@njit(cache=True)
def _solve_loop(work, x, dx):
    \"\"\"The LDL^T solve of rhs with loops (n = @N@): M (lower triangle, row-major) in work[:n*n],
    f in work[n*n:n*n+n], D in work[n*n+n:].\"\"\"
    n = @N@
    o = n * n
    r = 1.0
    for j in range(n):
        d = work[j * n + j]
        for k in range(j):
            d -= work[j * n + k] * work[j * n + k] * work[o + n + k]
        if not (d > 0.0 and d < math.inf):
            return 0.0
        r = min(r, d / work[j * n + j])
        work[o + n + j] = d
        inv = 1.0 / d
        for i in range(j + 1, n):
            s = work[i * n + j]
            for k in range(j):
                s -= work[i * n + k] * work[j * n + k] * work[o + n + k]
            work[i * n + j] = s * inv
    if r <= @SINGULAR@:
        return r
    for i in range(n):
        if not math.isfinite(work[o + i]):
            return -1.0
    for i in range(n):
        s = work[o + i]
        for k in range(i):
            s -= work[i * n + k] * dx[n + k]
        dx[n + i] = s
    for i in range(n - 1, -1, -1):
        s = dx[n + i] / work[o + n + i]
        for k in range(i + 1, n):
            s -= work[k * n + i] * dx[n + k]
        dx[n + i] = s
    for i in range(n):
        dx[i] = x[n + i]
    return r
"""


def _cfunc_head(name: str, sig: str, outs: tuple, n: int, nu: int, npar: int, doc: str) -> list[str]:
    args = ", ".join(["t", "x_", "u_", "p_", *[f"{o}_" for o, _ in outs]])
    lines = ["", "", f"@cfunc({sig}, cache=True)", f"def {name}({args}):", f'    """{doc}"""',
             f"    x = carray(x_, ({2 * n},))"]
    if nu:
        lines.append(f"    u = carray(u_, ({nu},))")
    if npar:
        lines.append(f"    p = carray(p_, ({npar},))")
    lines += [f"    {o} = carray({o}_, ({size},))" for o, size in outs]
    return lines


#: Largest n whose LDL^T solve is written out statement by statement; larger models use loops.
UNROLL_MAX = 12


def _ldl(n: int, lang: str, M, f, indent: str = "    ", part: str = "both") -> list[str]:
    """Statements solving M q_ddot = f by LDL^T, written out (n <= UNROLL_MAX): `M(i, j)` and
    `f(i)` name the entries (lower triangle); q_ddot goes to dx[n:], q_dot = x[n:] to dx[:n].
    The function returns the inertia measure min_j D_j / M_jj, 0.0 when M is not positive
    definite, -1.0 when f is not finite."""
    c = lang == "c"
    dbl, end = ("double ", ";") if c else ("", "")
    fin = "isfinite" if c else "math.isfinite"
    out = []
    def st(text):
        out.append(f"{indent}{text}{end}")
    for j in range(n):
        terms = "".join(f" - l{j}_{k} * l{j}_{k} * d{k}" for k in range(j))
        st(f"{dbl}d{j} = {M(j, j)}{terms}")
        if c:
            out.append(f"{indent}if (!(d{j} > 0.0 && d{j} < INFINITY)) return 0.0;")
        else:
            out.append(f"{indent}if not (d{j} > 0.0 and d{j} < math.inf):")
            out.append(f"{indent}    return 0.0")
        st(f"{dbl}i{j} = 1.0 / d{j}")
        for i in range(j + 1, n):
            terms = "".join(f" - l{i}_{k} * l{j}_{k} * d{k}" for k in range(j))
            st(f"{dbl}l{i}_{j} = ({M(i, j)}{terms}) * i{j}")
    st(f"{dbl}r = 1.0")  # d0 / M00 = 1
    for j in range(1, n):
        if c:
            st(f"r = fmin(r, d{j} / ({M(j, j)}))")
        else:
            st(f"r = min(r, d{j} / ({M(j, j)}))")
    if c:
        out.append(f"{indent}if (r <= {SINGULAR!r}) return r;")
    else:
        out.append(f"{indent}if r <= {SINGULAR!r}:")
        out.append(f"{indent}    return r")
    factor, out = out, []
    if c:
        out.append(f"{indent}if (!{fin}({' + '.join(f(i) for i in range(n))})) return -1.0;")
    else:
        out.append(f"{indent}if not {fin}({' + '.join(f(i) for i in range(n))}):")
        out.append(f"{indent}    return -1.0")
    for i in range(n):  # L z = f
        terms = "".join(f" - l{i}_{k} * z{k}" for k in range(i))
        st(f"{dbl}z{i} = {f(i)}{terms}")
    for i in range(n - 1, -1, -1):  # L^T a = D^-1 z
        terms = "".join(f" - l{k}_{i} * a{k}" for k in range(i + 1, n))
        st(f"{dbl}a{i} = z{i} * i{i}{terms}")
    for i in range(n):
        st(f"dx[{n + i}] = a{i}")
        st(f"dx[{i}] = x[{n + i}]")
    st("return r")
    return {"both": factor + out, "factor": factor, "solve": out}[part]


def numba_source(equations: Equations, part: str = "main") -> str:
    """The numba module of `equations`: ``rhs`` and ``energy`` (part "main"), or
    ``mass_forcing`` and ``lagrange_parts`` (part "variational", generated on first use), as
    cfuncs for the kernels of _kernels.py."""
    n = equations.n
    nu, npar = len(equations.inputs), len(equations.parameters)
    Mlow, f, h, pm, F = _model_parts(equations, part)
    pr = _Printer(equations, "py")
    out = ['"""' + _header(equations) + '"""', _prelude(), f"N = {n}", f"NU = {nu}", f"NPAR = {npar}"]
    if n > UNROLL_MAX and part == "main" and not equations.is_constrained:
        out.append(_SOLVE_LOOP.replace("@N@", str(n)).replace("@SINGULAR@", repr(SINGULAR)))
    if part == "main" and equations.is_constrained:
        from ._codegen_constrained import constrained_main

        out += constrained_main(equations)
    elif part == "main":
        out += _cfunc_head("rhs", "_SIG_RHS", (("dx", 2 * n), ("work", n * n + 2 * n)), n, nu, npar,
                           "dx = [q_dot, q_ddot]; returns the inertia measure of M (min_j D_j / M_jj of "
                           "its LDL^T factorization: 0 when singular) or -1.0 when f is not finite.")
        out += pr.unpack()
        # (factorizing M before computing f, to overlap the divisions with the forcing's work,
        # measured 8% slower for a double pendulum: the order is sin and cos, common
        # subexpressions, M, f)
        lines, exprs, _ = pr.trig_block(Mlow + f)
        out += lines
        out += _rhs_values(n, exprs)
        if n <= UNROLL_MAX:
            out += _ldl(n, "py", lambda i, j: f"m{i}_{j}", lambda i: f"f{i}")
        else:
            out.append("    return _solve_loop(work, x, dx)")
    if part == "main":
        out += _cfunc_head("energy", "_SIG_DOUBLE", (), n, nu, npar,
                           "The Jacobi integral h = q_dot . dL/dq_dot - L (the energy T* + V when T* = T2).")
        out += pr.unpack()
        # sin and cos a pair at a time, as the rhs (_sincos: the same values to 2 ulp): the output stage
        # evaluates the energy at every output (a 20 s double pendulum's 2001: 82 -> 56 us of its run)
        lines, exprs, _ = pr.trig_block([h])
        out += lines + [f"    return {exprs[0]}"]
        if n <= ENERGY_ROWS_MAX:
            out += _energy_rows(equations, pr, h)
    elif part.startswith("lanes"):
        out += _rhs_lanes(equations, pr, Mlow, f, int(part[5:]))
    else:
        out += _cfunc_head("mass_forcing", "_SIG_VOID", (("M", n * n), ("f", n)), n, nu, npar,
                           "M (row-major n x n) and f with M q_ddot = f.")
        out += pr.unpack()
        lines, exprs = pr.block(Mlow + f)
        out += lines
        out += _stores(n, exprs, ("M", "f"))
        out += _cfunc_head("lagrange_parts", "_SIG_VOID", (("pm", n), ("F", n)), n, nu, npar,
                           "pm = dL/dq_dot and F = dL/dq - dD/dq_dot + Q.")
        out += pr.unpack()
        lines, exprs = pr.block(pm + F)
        out += lines
        out += _stores(n, exprs, ("pm", "F"))
    return "\n".join(out) + "\n"


#: The largest model (coordinates) whose main module has energy_rows (the output stage's energy, vectorized
#: over the output rows: a 20 s double pendulum's 2001 rows 58 -> 11 us; a larger model's energy is a small
#: part of its run, and would only lengthen its one compilation).
ENERGY_ROWS_MAX = 6


def _energy_rows(equations: Equations, pr: _Printer, h) -> list[str]:
    """The cfunc energy_rows: the Jacobi integral h at `count` output rows at once, written as one loop
    over the rows with no branch in it, so that numba vectorizes it (SIMD across the rows); the same
    operations as the energy's, in the same order (the same numbers: no contraction into fused
    multiply-adds), with sin and cos by the polynomial alone, so that a row where an argument of sin or
    cos exceeds SINCOS_BOUND is NaN: the kernels evaluate that row by energy. A plain function: compiled
    (a cfunc, numba's cache) only where the model's runs need it (_fast.EnergyRows), so that a new model's
    first compile is its rhs and energy alone."""
    n = equations.n
    nu, npar = len(equations.inputs), len(equations.parameters)
    ind = " " * 8
    out = ["", "", "#: energy_rows is compiled when first asked for, not on import (numeric/_fast.py, EnergyRows):",
           '#: cfunc(ENERGY_ROWS_SIGNATURE, cache=True, error_model="numpy")(energy_rows)',
           "ENERGY_ROWS_SIGNATURE = types.void(_P, _P, _P, _P, _P, types.int64)", "", "",
           "def energy_rows(t_, x_, u_, p_, e_, count):",
           f'    """e[k] = the Jacobi integral at row k: t[k], x[k * {2 * n} + i]'
           + (f", u[k * {nu} + i]" if nu else "") + " (row-major, as",
           "    the output arrays) and p; NaN where an argument of sin or cos exceeds the polynomial's bound",
           f'    ({SINCOS_BOUND!r}: evaluate that row by energy)."""',
           "    t = carray(t_, (count,))", f"    x = carray(x_, (count * {2 * n},))", "    e = carray(e_, (count,))"]
    if nu:
        out.append(f"    u = carray(u_, (count * {nu},))")
    if npar:
        out.append(f"    p = carray(p_, ({npar},))")
    row = {"x": 2 * n, "u": nu}
    inner = []
    for local, acc, _ in pr.locals:  # the parameters before the loop, the row's t, x and u in it
        if acc.startswith("p["):
            out.append(f"    {local} = {acc}")
        else:
            inner.append(f"{ind}{local} = " + ("t[k]" if acc == "t" else re.sub(
                r"^([xu])\[(\d+)\]$", lambda m: f"{m[1]}[k * {row[m[1]]} + {m[2]}]", acc)))
    out.append("    for k in range(count):")
    lines, exprs, nbases = pr.trig_block([h], ind, lanes=True)
    out += inner + lines
    if nbases:
        big = ", ".join(f"abs(b{k})" for k in range(nbases)) + (", 0.0" if nbases == 1 else "")
        out.append(f"{ind}e[k] = ({exprs[0]}) if max({big}) <= {SINCOS_BOUND!r} else math.nan")
    else:
        out.append(f"{ind}e[k] = {exprs[0]}")
    return out


def _rhs_lanes(equations: Equations, pr: _Printer, Mlow: list, f: list, lanes: int) -> list[str]:
    """The cfunc rhs_lanes: rhs for L states at once, written as one loop over the lanes with no
    branch and no reduction in it, so that numba vectorizes it (SIMD across the lanes)."""
    n = equations.n
    nu, npar = len(equations.inputs), len(equations.parameters)
    ind = " " * 8
    out = ["", "", '@cfunc(_SIG_LANES, cache=True, error_model="numpy", fastmath={"contract"})',
           "def rhs_lanes(t_, x_, u_, p_, dx_, work_, lanes):",
           '    """rhs of L states at once: t[k] the time of lane k, the other arrays lane-major (x[i * L',
           "    + k]: component i of lane k; u and p likewise; work: 2 L). Returns the smallest inertia",
           "    measure of the lanes' M, or -1.0 when f is not finite or an argument of sin or cos exceeds",
           f'    {SINCOS_BOUND!r} in a lane."""',
           f"    L = {lanes}  # the argument lanes must be this: a constant, so that the loop vectorizes",
           "    t = carray(t_, (L,))", f"    x = carray(x_, ({2 * n} * L,))", f"    dx = carray(dx_, ({2 * n} * L,))",
           "    work = carray(work_, (2 * L,))"]
    if nu:
        out.append(f"    u = carray(u_, ({nu} * L,))")
    if npar:
        out.append(f"    p = carray(p_, ({npar} * L,))")
    out.append("    for k in range(L):")
    out += pr.unpack(ind, lanes=True)
    lines, exprs, nbases = pr.trig_block(Mlow + f, ind, lanes=True)
    out += lines
    out += [line.replace("    ", ind, 1) for line in _rhs_values(n, exprs)]
    m = lambda i, j: f"m{i}_{j}"  # noqa: E731
    for j in range(n):  # LDL^T, as _ldl, without its branches
        out.append(f"{ind}d{j} = {m(j, j)}" + "".join(f" - l{j}_{k} * l{j}_{k} * d{k}" for k in range(j)))
        out.append(f"{ind}i{j} = 1.0 / d{j}")
        for i in range(j + 1, n):
            terms = "".join(f" - l{i}_{k} * l{j}_{k} * d{k}" for k in range(j))
            out.append(f"{ind}l{i}_{j} = ({m(i, j)}{terms}) * i{j}")
    out.append(f"{ind}r = 1.0 if d0 > 0.0 else 0.0")
    out += [f"{ind}r = min(r, d{j} / {m(j, j)} if {m(j, j)} > 0.0 else 0.0)" for j in range(1, n)]
    for i in range(n):
        out.append(f"{ind}z{i} = f{i}" + "".join(f" - l{i}_{k} * z{k}" for k in range(i)))
    for i in range(n - 1, -1, -1):
        out.append(f"{ind}a{i} = z{i} * i{i}" + "".join(f" - l{k}_{i} * a{k}" for k in range(i + 1, n)))
    for i in range(n):
        out += [f"{ind}dx[{n + i} * L + k] = a{i}", f"{ind}dx[{i} * L + k] = x[{n + i} * L + k]"]
    if nbases:
        big = ", ".join(f"abs(b{k})" for k in range(nbases)) + (", 0.0" if nbases == 1 else "")
        out.append(f"{ind}work[k] = r if max({big}) <= {SINCOS_BOUND!r} else -2.0")
    else:
        out.append(f"{ind}work[k] = r")
    out += [f"{ind}work[L + k] = {' + '.join(f'a{i}' for i in range(n))}",
            "    r = 1.0", "    s = 0.0", "    for k in range(L):", "        r = min(r, work[k])",
            "        s += work[L + k]", "    if r < -1.0 or not math.isfinite(s):", "        return -1.0",
            "    return r"]
    return out


#: The C functions' declarations (cffi cdef): the same signatures as the numba cfuncs.
C_DECLARATIONS = """
double lg_rhs(double t, double *x, double *u, double *p, double *dx, double *work);
double lg_energy(double t, double *x, double *u, double *p);
void lg_mass_forcing(double t, double *x, double *u, double *p, double *M, double *f);
void lg_lagrange_parts(double t, double *x, double *u, double *p, double *pm, double *F);
"""

_C_SOLVE_LOOP = """
static double lg_solve_loop(int n, double *work, const double *x, double *dx) {
    /* LDL^T with loops: M (lower triangle, row-major) in work[0:n*n], f in work[n*n:n*n+n],
       D in work[n*n+n:n*n+2n]. */
    int o = n * n, i, j, k;
    double r = 1.0, d, s, inv;
    for (j = 0; j < n; j++) {
        d = work[j * n + j];
        for (k = 0; k < j; k++) d -= work[j * n + k] * work[j * n + k] * work[o + n + k];
        if (!(d > 0.0 && d < INFINITY)) return 0.0;
        r = fmin(r, d / work[j * n + j]);
        work[o + n + j] = d;
        inv = 1.0 / d;
        for (i = j + 1; i < n; i++) {
            s = work[i * n + j];
            for (k = 0; k < j; k++) s -= work[i * n + k] * work[j * n + k] * work[o + n + k];
            work[i * n + j] = s * inv;
        }
    }
    if (r <= @SINGULAR@) return r;
    for (i = 0; i < n; i++) if (!isfinite(work[o + i])) return -1.0;
    for (i = 0; i < n; i++) {
        s = work[o + i];
        for (k = 0; k < i; k++) s -= work[i * n + k] * dx[n + k];
        dx[n + i] = s;
    }
    for (i = n - 1; i >= 0; i--) {
        s = dx[n + i] / work[o + n + i];
        for (k = i + 1; k < n; k++) s -= work[k * n + i] * dx[n + k];
        dx[n + i] = s;
    }
    for (i = 0; i < n; i++) dx[i] = x[n + i];
    return r;
}
"""


#: The functions c_source writes (all four, unless told otherwise: see its `functions`).
C_FUNCTIONS = ("rhs", "mass_forcing", "energy", "lagrange_parts")


def c_source(equations: Equations, prefix: str = "lg_", storage: str = "", quiet: bool = False,
             functions: tuple[str, ...] = C_FUNCTIONS) -> str:
    """C source of `equations`' functions, with the signatures of C_DECLARATIONS (the same as the
    numba cfuncs): lg_rhs, lg_energy, lg_mass_forcing (M row-major, n x n), lg_lagrange_parts.

    For lagrangian.export: `prefix` replaces "lg_" in the functions' names, `storage` is put
    before each definition ("static "), and `quiet` marks the unpacked arguments as used
    ((void)v_t;), and the arguments a model may not read (u without inputs, p without
    parameters), so that -Wall -Wextra stays silent.

    A large model (:func:`large_model`) is written in the split form
    (:func:`_c_split_source`), where `functions` (some of C_FUNCTIONS) names the functions written: the C
    backend compiles lg_lagrange_parts (the variational integrator's, far the largest of a spatial chain)
    only when it is first used. Smaller models are written as before, all four functions."""
    n = equations.n
    Mlow, f, h, _, _ = _model_parts(equations)
    pr = _Printer(equations, "c")
    loop = _C_SOLVE_LOOP.replace("@SINGULAR@", repr(SINGULAR)).replace("lg_solve_loop", f"{prefix}solve_loop")
    head = ("/* " + _header(equations) + "*/\n#include <math.h>\n"
            + (loop if n > UNROLL_MAX else "") + "\n")
    mf = pr.block(Mlow + f)
    if large_model(equations):
        return _c_split_source(equations, pr, mf, h, head, prefix, storage, quiet, functions)
    _, _, _, pm, F = _model_parts(equations, "variational")

    def unpack() -> list[str]:
        lines = pr.unpack()
        if quiet:
            lines.append("    " + " ".join(["(void)u;", "(void)p;", *(f"(void){local};" for local, _, _ in pr.locals)]))
        return lines

    body = [f"{storage}double {prefix}rhs(double t, double *x, double *u, double *p, double *dx, double *work) {{"]
    body += unpack()
    lines, exprs = mf
    body += lines
    body += _rhs_values(n, exprs, "double ", ";")
    if n <= UNROLL_MAX:
        body += (["    (void)work;"] if quiet else []) + _ldl(n, "c", lambda i, j: f"m{i}_{j}", lambda i: f"f{i}")
    else:
        body.append(f"    return {prefix}solve_loop({n}, work, x, dx);")
    body += ["}", "", f"{storage}void {prefix}mass_forcing(double t, double *x, double *u, double *p, double *M, "
             "double *f) {"]
    body += unpack()
    body += lines
    body += _stores(n, exprs, ("M", "f"), ";")
    body += ["}", "", f"{storage}double {prefix}energy(double t, double *x, double *u, double *p) {{"]
    body += unpack()
    lines, exprs = pr.block([h])
    body += lines + [f"    return {exprs[0]};", "}", ""]
    body += [f"{storage}void {prefix}lagrange_parts(double t, double *x, double *u, double *p, double *pm, "
             "double *F) {"]
    body += unpack()
    lines, exprs = pr.block(pm + F)
    body += lines
    body += _stores(n, exprs, ("pm", "F"), ";")
    body += ["}", ""]
    return head + "\n".join(body)


#: The split form's helpers hold at most this many statements each: gcc's time grows faster than linearly with a
#: function's length. The 8-rod spatial chain's rhs, mass_forcing and energy (9000 statements, 1.1 MB), gcc -O1
#: CPU by helper size 100, 500, 2000: 9.5, 12.6, 18.5 s (-O2 at 500: 52 s, 3.3 GB); one rhs 9.5 us each.
C_HELPER_STATEMENTS = 200
_C_TEMP = re.compile(r"\bc(\d+)\b")
_C_STATEMENT = re.compile(r"^ *double (c\d+) = (.*);$")


def _c_split(pr: _Printer, block: tuple, name: str, prefix: str, unpack: list[str]) -> tuple[list[str], list[str], int]:
    """(the definitions of the helpers, the statements calling them, the work size) of `block` (:meth:`_Printer.block`'s
    statements and outputs) in static helpers `<prefix><name>_<k>(t, x, u, p, w)` of at most C_HELPER_STATEMENTS
    statements each, the outputs stored in w[0], w[1], ... in order. A value used only in its own helper stays a local
    there; one used by a later helper goes through w[], after the outputs. `unpack`: the statements naming t, x, u and
    p (from lagrangian._codetext.local_name, as everywhere: no name of the model's reaches the C text raw)."""
    lines, outputs = block
    texts = []
    for line in lines:
        m = _C_STATEMENT.match(line)
        if m is None or m.group(1) != f"c{len(texts)}":  # (the printer's own statements, in order)
            raise AssertionError(f"unexpected generated statement {line[:80]!r}")
        texts.append(m.group(2))
    first = len(texts)
    texts += outputs  # output i is statement first + i
    size = C_HELPER_STATEMENTS
    part = lambda k: min(k, first - 1) // size if first else 0  # noqa: E731  (the outputs go with the last part)
    slots = {first + i: i for i in range(len(outputs))}
    uses = [[int(m) for m in _C_TEMP.findall(text)] for text in texts]
    for k, used in enumerate(uses):
        for j in used:
            if j not in slots and part(j) != part(k):
                slots[j] = len(slots)
    helpers, calls = [], []
    for h in range(part(len(texts) - 1) + 1):
        fname = f"{prefix}{name}_{h}"
        calls.append(f"    {fname}(t, x, u, p, w);")
        helpers += [f"static void {fname}(double t, double *x, double *u, double *p, double *w) {{", *unpack]
        for k in (k for k in range(len(texts)) if part(k) == h):
            text = _C_TEMP.sub(lambda m: f"c{m[1]}" if part(int(m[1])) == h else f"w[{slots[int(m[1])]}]", texts[k])
            if k >= first:
                helpers.append(f"    w[{slots[k]}] = {text};")
            else:
                helpers.append(f"    double c{k} = {text};")
                if k in slots:
                    helpers.append(f"    w[{slots[k]}] = c{k};")
        helpers += ["}", ""]
    return helpers, calls, max(1, len(slots))


def _c_split_source(equations: Equations, pr: _Printer, mf: tuple, h, head: str, prefix: str, storage: str,
                    quiet: bool, functions: tuple[str, ...]) -> str:
    """c_source of a large model: each statement list written once (M and f: for lg_rhs and lg_mass_forcing both), in
    static helper functions of at most C_HELPER_STATEMENTS statements (:func:`_c_split`) that pass their values
    through a work array on the stack; only the functions named in `functions`. The 20-rod spatial chain's M, f and
    energy: 1.9 MB of C where the four functions written out were 29 MB (its lg_lagrange_parts alone 26 MB)."""
    n = equations.n
    unpack = pr.unpack()
    if quiet:
        unpack.append("    " + " ".join(["(void)t;", "(void)x;", "(void)u;", "(void)p;", "(void)w;",
                                         *(f"(void){local};" for local, _, _ in pr.locals)]))
    sig = "double t, double *x, double *u, double *p"
    body = []
    if "rhs" in functions or "mass_forcing" in functions:
        helpers, calls, size = _c_split(pr, mf, "mf", prefix, unpack)
        body += helpers
        outs = [f"w[{k}]" for k in range(n * (n + 1) // 2 + n)]
        if "rhs" in functions:
            body += [f"{storage}double {prefix}rhs({sig}, double *dx, double *work) {{",
                     *_c_work(size, calls, "return -1.0;")]
            body += _rhs_values(n, outs, "double ", ";")
            if n > UNROLL_MAX:
                body += [f"    double r = {prefix}solve_loop({n}, work, x, dx);"]
            else:  # (the unrolled solve returns from several places: the values leave w first)
                body += (["    (void)work;"] if quiet else [])
                if size > C_STACK_VALUES:
                    body.append("    free(w);")
                body += _ldl(n, "c", lambda i, j: f"m{i}_{j}", lambda i: f"f{i}")
            if n > UNROLL_MAX:
                body += (["    free(w);"] if size > C_STACK_VALUES else []) + ["    return r;"]
            body += ["}", ""]
        if "mass_forcing" in functions:
            body += [f"{storage}void {prefix}mass_forcing({sig}, double *M, double *f) {{",
                     *_c_work(size, calls, f"{{ for (int i = 0; i < {n * n}; i++) M[i] = NAN; "
                                           f"for (int i = 0; i < {n}; i++) f[i] = NAN; return; }}")]
            body += _stores(n, outs, ("M", "f"), ";")
            body += (["    free(w);"] if size > C_STACK_VALUES else []) + ["}", ""]
    if "energy" in functions:
        helpers, calls, size = _c_split(pr, pr.block([h]), "energy", prefix, unpack)
        body += helpers + [f"{storage}double {prefix}energy({sig}) {{", *_c_work(size, calls, "return NAN;"),
                           "    double e = w[0];", *(["    free(w);"] if size > C_STACK_VALUES else []),
                           "    return e;", "}", ""]
    if "lagrange_parts" in functions:
        _, _, _, pm, F = _model_parts(equations, "variational")
        helpers, calls, size = _c_split(pr, pr.block(pm + F), "lagrange_parts", prefix, unpack)
        body += helpers + [f"{storage}void {prefix}lagrange_parts({sig}, double *pm, double *F) {{",
                           *_c_work(size, calls, f"{{ for (int i = 0; i < {n}; i++) pm[i] = F[i] = NAN; return; }}")]
        body += _stores(n, [f"w[{k}]" for k in range(2 * n)], ("pm", "F"), ";")
        body += (["    free(w);"] if size > C_STACK_VALUES else []) + ["}", ""]
    return head.replace("#include <math.h>\n", "#include <math.h>\n#include <stdlib.h>\n", 1) + "\n".join(body)


#: A split function's work array is on the stack up to this many values (64 KB), else on the heap.
C_STACK_VALUES = 8192


def _c_work(size: int, calls: list[str], fail: str) -> list[str]:
    """The statements making the work array w of `size` values (on the stack, or from malloc past C_STACK_VALUES:
    the caller frees it; `fail` runs where malloc fails) and calling the helpers that fill it."""
    if size <= C_STACK_VALUES:
        return [f"    double w[{size}];", *calls]
    return [f"    double *w = (double *)malloc({size} * sizeof(double));", f"    if (w == 0) {fail}", *calls]


def _rhs_values(n: int, exprs, decl: str = "", end: str = "") -> list[str]:
    """Lines naming M's lower triangle and f for the unrolled solve (m{i}_{j}, f{i}), or storing
    them in work[] for the loop solve (n > UNROLL_MAX); `decl` and `end` make them C."""
    out, k = [], 0
    for i in range(n):
        for j in range(i + 1):
            out.append(f"    {decl}m{i}_{j} = {exprs[k]}{end}" if n <= UNROLL_MAX
                       else f"    work[{i * n + j}] = {exprs[k]}{end}")
            k += 1
    for i in range(n):
        out.append(f"    {decl}f{i} = {exprs[k + i]}{end}" if n <= UNROLL_MAX
                   else f"    work[{n * n + i}] = {exprs[k + i]}{end}")
    return out


def _stores(n: int, exprs, names: tuple[str, str], end: str = "") -> list[str]:
    """Lines storing into two output arrays: ("M", "f"), exprs = M's lower triangle then f (M
    filled symmetric, row-major); or ("pm", "F"), exprs = n values each."""
    first, second = names
    out, k = [], 0
    if first == "M":
        for i in range(n):
            for j in range(i + 1):
                out.append(f"    M[{i * n + j}] = {exprs[k]}{end}")
                if i != j:
                    out.append(f"    M[{j * n + i}] = M[{i * n + j}]{end}")
                k += 1
    else:
        out += [f"    {first}[{i}] = {e}{end}" for i, e in enumerate(exprs[:n])]
        k = n
    out += [f"    {second}[{i}] = {e}{end}" for i, e in enumerate(exprs[k:])]
    return out


def store(path: Path, text: str) -> None:
    """Make the cache entry `path` hold exactly `text`: written when missing or different (a
    truncated, broken or tampered entry is replaced, never reused), atomically and with the
    user's umask (lagrangian.io._files.write_atomically: another process may be reading it)."""
    try:
        if path.read_bytes() == text.encode("utf-8"):
            return
    except OSError:
        pass
    write_atomically(path, text)


def _numba_key(source: str) -> str:
    import numba

    return source_key(source, "numba", numba.__version__, sys.version)


def cached_module(source: str, prefix: str = "lagrangian"):
    """(path, key, module): the Python module of `source`, stored in the cache under the hash of
    its exact text (see :func:`source_key`) after it passed a check (it compiles), and imported.
    A module that fails to import is removed from the cache, so that the next call builds it
    again."""
    compile(source, "<generated>", "exec")  # a syntax check; nothing runs
    key = _numba_key(source)
    path = cache_dir() / f"{prefix}_{key}.py"
    store(path, source)
    return path, key, _import_or_remove(path, f"{prefix}_generated_{key}")


def _import_or_remove(path: Path, name: str):
    try:
        return load_module(path, name)
    except BaseException:
        path.unlink(missing_ok=True)
        raise


def model_module(equations: Equations, part: str):
    """(path, key, module) of the numba module `part` of `equations` (:func:`numba_source`).

    The module is stored under the hash of its exact source (:func:`cached_module`). So that a
    second process need not generate the source to find it (seconds for a large model), an
    index entry named by :func:`fingerprint` (everything the generator reads, the model's name
    included) gives that hash; the module is used only when its file still hashes to it (an
    entry changed on disk is generated and written again, never imported)."""
    folder = cache_dir()
    index = folder / f"lagrangian_index_{fingerprint(equations, 'numba-' + part)}.txt"
    try:
        key = index.read_text().strip()
        path = folder / f"lagrangian_{key}.py"
        if re.fullmatch(r"[0-9a-f]{32}", key) and _numba_key(path.read_text(encoding="utf-8")) == key:
            return path, key, _import_or_remove(path, f"lagrangian_generated_{key}")
    except (OSError, UnicodeDecodeError):
        pass
    path, key, module = cached_module(numba_source(equations, part))
    store(index, key)
    return path, key, module


def load_module(path: Path, name: str):
    """Import the generated module at `path` (once per process)."""
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        del sys.modules[name]
        raise
    return module
