"""readable(expr): the compact form in which equations are shown, by targeted rewrites.

The derivation's expressions are correct but unreadable: the mass matrix entry of two links of a
chain comes out as ``m*(2*l**2*sin(q1)*sin(q2) + 2*l**2*cos(q1)*cos(q2))/2``. SymPy's general
simplifiers (``trigsimp``) find the readable ``l**2*m*cos(q1 - q2)`` but take seconds per entry.
Here the expression is expanded (in SymEngine) into a dictionary {monomial: coefficient}, each
monomial a product of powers of symbols and functions, and only these exact identities are
applied, each of which merges two terms into one (so the rewriting ends, in at most as many steps
as there are terms):

    c*m*sin(x)*sin(y) + c*m*cos(x)*cos(y)  ->  c*m*cos(x - y)     (and - c*m*cos(x)*cos(y): -c*m*cos(x + y))
    c*m*sin(x)*cos(y) - c*m*cos(x)*sin(y)  ->  c*m*sin(x - y)     (and + c*m*cos(x)*sin(y):  c*m*sin(x + y))
    c*m*sin(x)**2 + c*m*cos(x)**2          ->  c*m
    c*m - c*m*sin(x)**2                    ->  c*m*cos(x)**2      (and - c*m*cos(x)**2: c*m*sin(x)**2)

(m any monomial, c a number). The terms are then grouped: by the monomial of the symbols to
collect on (accelerations and velocities for equations), then by the part that depends on the
state (coordinates, velocities, time, inputs, and the functions of them such as sin(q1)), and the
parameter polynomial of each group is written with its common factor taken out, so that the
entry (0, 1) of a chain's mass matrix reads ``l1*l2*(m2 + m3 + ... + m10)*cos(q1 - q2)``.

A budget bounds the work: an expression whose expansion could have more than `max_terms` terms
(estimated from its tree, before expanding) is returned as derived.

Also here: :func:`trigonometric_polynomial`, the shorter of that form and the Fourier form (for
det M), and :func:`text`, ``sympy.sstr`` for many entries.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Iterable

import symengine as se
import sympy
from sympy.core.exprtools import decompose_power
from sympy.core.mul import _args_sortkey
from sympy.core.sorting import default_sort_key
from sympy.sets.sets import FiniteSet
from sympy.printing.precedence import PRECEDENCE, precedence
from sympy.printing.str import StrPrinter

__all__ = ["readable", "readable_many", "trigonometric_polynomial", "expanded_terms_bound", "text", "MAX_TERMS"]

#: The budget: expressions whose expansion may exceed this many terms are left as derived.
MAX_TERMS = 5000

_ADD, _MUL, _POW, _UNIT = se.Add, se.Mul, se.Pow, se.Integer(1)
_COMPOUND = (_ADD, _MUL, _POW)


def readable(expr, *, state: Iterable = (), collect_on: Iterable = (), max_terms: int = MAX_TERMS) -> sympy.Expr:
    """The compact readable form of `expr`, mathematically equal to it (a SymPy expression).

    Parameters
    ----------
    expr : SymEngine or SymPy expression
    state : iterable of symbols (or a frozenset of their names)
        The symbols that vary (coordinates, velocities, accelerations, time, inputs); the others
        are parameters, whose common factors are taken out of each group of terms.
    collect_on : iterable of symbols
        Terms with the same monomial in these symbols are grouped, as ``sympy.collect`` does
        (the accelerations and velocities, for equations).
    max_terms : int
        The budget: when the expansion of `expr` could have more terms than this, `expr` is
        returned as it is (converted to SymPy).
    """
    return readable_many((expr,), state=state, collect_on=collect_on, max_terms=max_terms)[0]


def readable_many(exprs: Iterable, *, state: Iterable = (), collect_on: Iterable = (),
                  max_terms: int = MAX_TERMS, bounds: dict | None = None) -> list[sympy.Expr]:
    """:func:`readable` of each of `exprs`, the budget's count of their common subexpressions
    (the entries of M and f share many) done once; `bounds`: that count's memo, for `max_terms`
    (see :func:`expanded_terms_bound`), shared with other calls."""
    state_names = state if isinstance(state, frozenset) else frozenset(str(s) for s in state)
    collect_names = frozenset(str(s) for s in collect_on)
    bounds = {} if bounds is None else bounds
    out = []
    for expr in exprs:
        terms = _rewritten(expr, max_terms, bounds)
        out.append(_grouped(terms, state_names, collect_names) if isinstance(terms, dict) else terms)
    return out


def trigonometric_polynomial(expr, *, max_terms: int = MAX_TERMS) -> sympy.Expr:
    """`expr` as the shorter of two equal sums, in one group with its common factor taken out:
    the readable form's terms, or the Fourier form, where every product of sines and cosines is
    a sum of sines and cosines of sums of their arguments (sin(x)*sin(y) = (cos(x - y) -
    cos(x + y))/2, ...), unique for a trigonometric polynomial. For determinants: that of a
    three-link chain's mass matrix is ``-l**6*m**3*(2*cos(2*theta1 - 2*theta2) + ... - 5)/2`` in
    the Fourier form, and the cart-pendulum's ``L**2*M2*(M1 + M2*cos(q2)**2)`` in the other."""
    terms = _rewritten(expr, max_terms)
    if not isinstance(terms, dict):
        return terms
    fourier = _fourier(terms, max_terms)
    if fourier is not None and len(fourier) < len(terms):
        terms = fourier
    return _grouped(terms, frozenset(), frozenset())


def _rewritten(expr, max_terms: int, bounds: dict | None = None):
    """The expanded terms of `expr` {monomial: coefficient} with the identities applied, or, over
    the budget (or not convertible to SymEngine), `expr` in SymPy as it is. `bounds` keeps the
    counts of subexpressions for the next call with the same `max_terms`."""
    try:
        e = se.sympify(expr)
    except (TypeError, ValueError, RuntimeError):
        return sympy.sympify(expr)
    if expanded_terms_bound(e, max_terms, bounds) > max_terms:
        return _as_derived(e)
    terms = _terms(se.expand(e))
    _apply_identities(terms)
    return terms


#: The expressions left as derived (over the budget): {id of the SymPy object: (it, the SymEngine
#: original)}, so that :func:`text` prints them with SymEngine's printer (C++, a hundred times
#: faster than SymPy's on the bicycle's entries: megabytes). Bounded; entries are replaced.
_DERIVED: dict = {}


def _as_derived(e) -> sympy.Expr:
    out = e._sympy_()
    if len(_DERIVED) >= 4096:
        _DERIVED.clear()
    _DERIVED[id(out)] = (out, e)
    return out


def expanded_terms_bound(expr, limit: int | None = None, memo: dict | None = None) -> int:
    """An upper bound of the number of terms of ``expand(expr)``, from its tree (each shared
    subexpression visited once): a sum adds, a product multiplies, a power (a + b + ...)**k
    counts the monomials of degree k. Stops counting past `limit` (then returns more than it).
    `memo` ({subexpression: count}, for one `limit`) is read and filled."""
    memo = {} if memo is None else memo
    cap = math.inf if limit is None else limit + 1

    def bound(e) -> int:
        kind = type(e)
        if kind not in _COMPOUND:  # a symbol, number or function: one term
            return 1
        k = memo.get(e)
        if k is not None:
            return k
        if kind is _ADD:  # (the atoms among the arguments counted here, without a call: most are)
            k = 0
            for a in e.args:
                k += bound(a) if type(a) in _COMPOUND else 1
                if k >= cap:
                    break
        elif kind is _MUL:
            k = 1
            for a in e.args:
                if type(a) in _COMPOUND:
                    k *= bound(a)
                    if k >= cap:
                        break
        elif kind is _POW:
            base, exp = e.args
            kb = bound(base)
            if exp.is_Integer and int(exp) > 1 and kb > 1:
                n = int(exp)
                # the number of monomials of degree n in kb terms, without building a huge integer
                k = math.comb(kb + n - 1, n) if kb < 10_000 and n < 1000 else int(cap)
            else:
                k = kb if exp.is_Integer and int(exp) == 1 else 1
        k = min(k, cap) if cap != math.inf else k
        memo[e] = k
        return k

    return int(bound(se.sympify(expr)))


# ----------------------------------------------------------------------------- the terms
def _terms(expanded) -> dict:
    """{monomial: coefficient} of an expanded SymEngine expression; a monomial is a frozenset of
    (base, exponent) pairs, the coefficient a SymEngine number."""
    out: dict = {}
    for term in (expanded.args if type(expanded) is _ADD else (expanded,)):
        coef, mono = _split(term)
        _add(out, mono, coef)
    return out


def _split(term):
    """(number, monomial) of one product; a sum left in it (under a root or in a denominator) is
    itself written with the identities."""
    coef = _UNIT
    powers: dict = {}
    for f in (term.args if type(term) is _MUL else (term,)):
        if type(f) is _POW:
            base, exp = f.args
        elif isinstance(f, se.Number):
            coef = f if coef is _UNIT else coef * f
            continue
        else:
            base, exp = f, _UNIT
        if type(base) is _ADD:
            base = _compact(base)
        have = powers.get(base)
        powers[base] = exp if have is None else have + exp
    return coef, frozenset(powers.items())


def _compact(e):
    """An expanded sum with the identities applied, as a SymEngine expression."""
    terms = _terms(e)
    _apply_identities(terms)
    return se.Add(*(c * se.Mul(*(b ** x for b, x in mono)) for mono, c in terms.items()))


def _add(terms: dict, mono: frozenset, coef) -> None:
    have = terms.get(mono)
    if have is None:
        terms[mono] = coef
        return
    total = have + coef
    if total == 0:
        del terms[mono]
    else:
        terms[mono] = total


def _times(mono: frozenset, factor) -> tuple:
    """(number, monomial) of mono * factor, factor a product of powers (as SymEngine builds it)."""
    coef, extra = _split(factor)
    if not extra:
        return coef, mono
    powers = dict(mono)
    for base, exp in extra:
        have = powers.get(base)
        powers[base] = exp if have is None else have + exp
    return coef, frozenset((b, x) for b, x in powers.items() if x != 0)


def _shift(mono: frozenset, remove: dict, add: dict) -> frozenset | None:
    """mono / prod(remove) * prod(add), or None when mono does not contain `remove`."""
    powers = dict(mono)
    for base, exp in remove.items():
        have = powers.get(base)
        if have is None or not have.is_Integer:
            return None
        left = int(have) - exp
        if left < 0:
            return None
        if left == 0:
            del powers[base]
        else:
            powers[base] = _INTEGERS[left] if left < len(_INTEGERS) else se.Integer(left)
    for base, exp in add.items():
        have = powers.get(base)
        if have is not None:
            powers[base] = have + exp
        else:
            powers[base] = _INTEGERS[exp] if type(exp) is int else exp
    return frozenset(powers.items())


_INTEGERS = tuple(se.Integer(k) for k in range(16))
_ONE = _INTEGERS[1]


# ------------------------------------------------------------------------ the identities
def _apply_identities(terms: dict) -> None:
    """Apply the identities of the module docstring until none applies (each one removes a term).

    Every term is tried once; then only the terms a rewrite produced, and those with a squared
    sine or cosine (whose partner in 1 - sin^2 = cos^2, the term without it, may be new)."""
    pending = list(terms)
    while pending:
        produced = []
        for mono in pending:
            if mono in terms:
                new = _rewrite_one(terms, mono)
                if new is not None:
                    produced.append(new)
        if not produced:
            return
        pending = [m for m in produced if m in terms] + [m for m in terms if _has_square(m)]


_SIN_COS = (se.sin, se.cos)


def _has_square(mono: frozenset) -> bool:
    return any(type(b) in _SIN_COS and x.is_Integer and int(x) >= 2 for b, x in mono)


def _trig(mono: frozenset) -> list:
    """[(base, is_sin, exponent)] of the sin and cos factors of a monomial (integer powers)."""
    out = []
    for base, exp in mono:
        kind = type(base)
        if kind in _SIN_COS and exp.is_Integer:
            out.append((base, kind is se.sin, int(exp)))
    return out


@functools.lru_cache(maxsize=8192)
def _partner(base):
    """cos(x) for sin(x), sin(x) for cos(x)."""
    x = base.args[0]
    return se.cos(x) if type(base) is se.sin else se.sin(x)


def _rewrite_one(terms: dict, mono: frozenset):
    """Try every identity on the term `mono` with its partner terms; the monomial it produced (or
    an empty tuple when the result cancelled) if one applied, else None."""
    c = terms[mono]
    trig = _trig(mono)
    for base, is_sin, k in trig:
        if k >= 2:  # sin^2 + cos^2 = 1, and 1 - sin^2 = cos^2
            other = _partner(base)
            rest = _shift(mono, {base: 2}, {})
            pair = _shift(rest, {}, {other: 2})
            if terms.get(pair) == c:
                return _replace(terms, (mono, pair), c, rest, _UNIT)
            if terms.get(rest) == -c:
                return _replace(terms, (mono, rest), -c, rest, other ** 2)
    bases = None
    for i, (b1, sin1, k1) in enumerate(trig):
        for b2, sin2, k2 in trig[i + 1:]:
            x, y = b1.args[0], b2.args[0]
            if x == y:
                continue
            # the partner: each of the two factors replaced by the other function of its angle (where both
            # are first powers and neither partner is a factor, the same monomial as _shift's, by set operations)
            p1, p2 = _partner(b1), _partner(b2)
            if bases is None:
                bases = {b for b, _ in mono}
            if k1 == 1 and k2 == 1 and p1 not in bases and p2 not in bases:
                pair = mono.difference(((b1, _ONE), (b2, _ONE))).union(((p1, _ONE), (p2, _ONE)))
            else:
                pair = _shift(mono, {b1: 1, b2: 1}, {p1: 1, p2: 1})
            d = None if pair is None else terms.get(pair)
            if d is None or (d != c and d != -c):
                continue
            rest = _shift(mono, {b1: 1, b2: 1}, {})
            if sin1 == sin2:  # sin x sin y with cos x cos y
                if d == c:  # c (sin x sin y + cos x cos y) = c cos(x - y)
                    return _replace(terms, (mono, pair), c, rest, se.cos(_sum(x, -y)))
                # c (cos x cos y - sin x sin y) = c cos(x + y)
                return _replace(terms, (mono, pair), -c if sin1 else c, rest, se.cos(_sum(x, y)))
            if not sin1:
                x, y = y, x  # now the term holds sin(x) cos(y), its partner cos(x) sin(y)
            if d == -c:  # c (sin x cos y - cos x sin y) = c sin(x - y)
                return _replace(terms, (mono, pair), c, rest, se.sin(_sum(x, -y)))
            # c (sin x cos y + cos x sin y) = c sin(x + y)
            return _replace(terms, (mono, pair), c, rest, se.sin(_sum(x, y)))
    return None


def _sum(x, y):
    """x + y, expanded: the argument of a new sine or cosine (so that equal angles are one key)."""
    return se.expand(x + y)


def _replace(terms: dict, old: tuple, coef, rest: frozenset, factor):
    """Remove the terms `old`, add coef * rest * factor; the monomial added (() if none)."""
    for m in old:
        del terms[m]
    k, mono = _times(rest, factor)
    if k == 0:
        return ()
    _add(terms, mono, coef * k)
    return mono


# -------------------------------------------------------------------------- Fourier form
def _fourier(terms: dict, max_terms: int) -> dict | None:
    """The terms with each product of sines and cosines (integer powers) written as a sum of
    sines and cosines of sums of the arguments; None when that would exceed `max_terms` terms."""
    out: dict = {}
    for mono, c in terms.items():
        series = {_NO_TRIG: _UNIT}  # {frozenset holding one sin or cos, or none: coefficient}
        rest = []
        for base, exp in mono:
            if exp.is_Integer and int(exp) > 0 and isinstance(base, (se.sin, se.cos)):
                for _ in range(int(exp)):
                    series = _times_trig(series, base)
                    if len(series) > max_terms:
                        return None
            else:
                rest.append((base, exp))
        rest = frozenset(rest)
        for atom, k in series.items():
            _add(out, _shift(rest, {}, dict(atom)) if atom else rest, c * k)
        if len(out) > max_terms:
            return None
    return out


_NO_TRIG = frozenset()
_HALF = se.Rational(1, 2)


def _times_trig(series: dict, f) -> dict:
    """The Fourier series `series` times sin(b) or cos(b), by the product-to-sum formulas."""
    out: dict = {}
    b = f.args[0]
    f_is_sin = isinstance(f, se.sin)
    for atom, k in series.items():
        if not atom:
            pieces = ((k, f),)
        else:
            (g, _), = atom
            a = g.args[0]
            if isinstance(g, se.sin):
                pieces = (((k * _HALF, se.cos(_sum(a, -b))), (-k * _HALF, se.cos(_sum(a, b)))) if f_is_sin
                          else ((k * _HALF, se.sin(_sum(a, b))), (k * _HALF, se.sin(_sum(a, -b)))))
            else:
                pieces = (((k * _HALF, se.sin(_sum(a, b))), (-k * _HALF, se.sin(_sum(a, -b)))) if f_is_sin
                          else ((k * _HALF, se.cos(_sum(a, -b))), (k * _HALF, se.cos(_sum(a, b)))))
        for coef, value in pieces:
            number, mono = _split(value)
            if number != 0:
                _add(out, mono, coef * number)
    return out


# ----------------------------------------------------------------------------- grouping
def _grouped(terms: dict, state: frozenset, collect_on: frozenset) -> sympy.Expr:
    """The terms as one SymPy expression, grouped on `collect_on`, then on the state part, each
    group's parameter polynomial with its common factor taken out."""
    groups: dict = {}
    for mono, coef in terms.items():
        parts: tuple = ([], [], [])  # collected, varying, parameters
        for factor in mono:
            parts[_role(factor[0], state, collect_on)].append(factor)
        collected, varying, params = parts
        by_state = groups.setdefault(frozenset(collected), {})
        by_state.setdefault(frozenset(varying), []).append((coef, frozenset(params)))
    out = []
    for collected, by_state in groups.items():
        if len(by_state) == 1:
            (varying, poly), = by_state.items()
            out.append(_factored(poly, _factors(collected) + _factors(varying)))
        else:
            parts = [_factored(poly, _factors(varying)) for varying, poly in by_state.items()]
            out.append(_mul(_ONE_SYMPY, [*_factors(collected), _add_sympy(parts)]))
    return _add_sympy(out)


@functools.lru_cache(maxsize=8192)
def _role(base, state: frozenset, collect_on: frozenset) -> int:
    """0: a symbol to collect on; 1: a factor that varies (depends on the state); 2: a parameter."""
    if base.is_Symbol:
        name = str(base)
        return 0 if name in collect_on else 1 if name in state else 2
    return 1 if any(str(s) in state for s in base.free_symbols) else 2


def _factored(poly: list, factors: list) -> sympy.Expr:
    """sum(coef * monomial) of parameters times `factors` (SymPy), written as
    content * common parameters * (the rest) * factors, in one product (so that SymPy does not
    distribute a number over the sum)."""
    if len(poly) == 1:
        coef, mono = poly[0]
        return _mul(_to_sympy(coef), [*_factors(mono), *factors])
    common = _common_powers([m for _, m in poly])
    content = _content([c for c, _ in poly])
    inner = []
    for coef, mono in poly:
        rest = [(b, x - common[b]) if b in common else (b, x) for b, x in mono]
        inner.append(_mul(_to_sympy(coef / content), _factors(p for p in rest if p[1] != 0)))
    total = _add_sympy(inner)
    if total.could_extract_minus_sign():  # (I1 - I3), not (-I1 + I3)
        content, total = -content, -total
    return _mul(_to_sympy(content), [*_factors(common.items()), total, *factors])


def _common_powers(monos: list) -> dict:
    """{base: the least exponent} of the bases with a positive integer power in every monomial."""
    first = {b: x for b, x in monos[0] if x.is_Integer and int(x) > 0}
    for mono in monos[1:]:
        powers = dict(mono)
        first = {b: min(x, powers[b], key=int) for b, x in first.items()
                 if b in powers and powers[b].is_Integer and int(powers[b]) > 0}
        if not first:
            break
    return first


def _content(coefs: list):
    """The common numerical factor taken out of a group: the gcd of the numerators over the common
    denominator (1 when the denominators differ), negative when every coefficient is (and when
    SymPy would extract a minus sign from the sum left, see `_factored`)."""
    if not all(c.is_Rational for c in coefs):
        return _UNIT
    nums, dens = zip(*(c.get_num_den() for c in coefs))
    g = se.Integer(math.gcd(*(abs(int(n)) for n in nums)))
    content = g / dens[0] if all(d == dens[0] for d in dens) else _UNIT
    return -content if all(c.is_negative for c in coefs) else content


# ------------------------------------------------------------------------- to SymPy
_TRIG = {se.sin: (sympy.sin, True), se.cos: (sympy.cos, False)}  # the function, whether it is odd


@functools.lru_cache(maxsize=8192)
def _to_sympy(e) -> sympy.Expr:
    """A SymEngine atom, function or number as SymPy (cached: the same few recur in every entry).

    sin and cos of a sum of symbol terms (the angle differences) are built without SymPy's
    evaluation, which would only flip the sign of the argument (sin is odd, cos even) and costs
    half a millisecond each, as the same canonical object."""
    trig = _TRIG.get(type(e))
    if trig is not None:
        arg, flipped = _oriented(e.args[0])
        if arg is not None:
            func, odd = trig
            value = _unevaluated(func, arg)
            return _mul(_MINUS_ONE, [value]) if flipped and odd else value
    return e._sympy_() if isinstance(e, se.Basic) else sympy.sympify(e)


_ONE_ARGUMENT = FiniteSet(1)


def _unevaluated(func, arg) -> sympy.Expr:
    """``func(arg, evaluate=False)`` for sin or cos: the object SymPy's Application.__new__ makes
    (its arguments, and nargs = {1}), without its checks (a third of the cost of a new entry)."""
    obj = sympy.Basic.__new__(func, arg)
    obj.nargs = _ONE_ARGUMENT
    return obj


@functools.lru_cache(maxsize=8192)
def _oriented(arg) -> tuple:
    """(SymPy's canonical form of the argument a of sin(a), cos(a), and whether it is -a), or
    (None, False) when SymPy's sin and cos would do more than extract a minus sign."""
    linear = _linear(arg)
    if linear is not None:  # a sum of rational multiples of symbols: built directly
        flipped = _extracts_minus(linear)
        if flipped:
            linear = [(symbol, -c) for symbol, c in linear]
        terms = [_mul(_to_sympy(c), [_to_sympy(symbol)]) for symbol, c in linear]
        if len(terms) == 1:
            return terms[0], flipped
        return sympy.Add._from_args(sorted(terms, key=_args_sortkey)), flipped
    a = _to_sympy(arg)
    if not _plain(a):
        return None, False
    return (-a, True) if a.could_extract_minus_sign() else (a, False)


def _linear(arg) -> list | None:
    """[(symbol, rational coefficient)] of a SymEngine sum of rational multiples of distinct
    symbols, or None."""
    out = []
    for t in (arg.args if type(arg) is _ADD else (arg,)):
        if type(t) is se.Symbol:
            out.append((t, _UNIT))
        elif type(t) is _MUL and len(t.args) == 2 and t.args[0].is_Rational and type(t.args[1]) is se.Symbol:
            out.append((t.args[1], t.args[0]))
        else:
            return None
    return out


def _extracts_minus(linear: list) -> bool:
    """SymPy's ``could_extract_minus_sign()`` of the sum of rational multiples of symbols
    [(symbol, coefficient)], without its sort keys (the slow part): the sign is extracted when
    more terms have a minus sign than not, and, when as many, if the term of the first symbol by
    name has one."""
    negative = sum(1 for _, c in linear if c.is_negative)
    if 2 * negative != len(linear):
        return 2 * negative > len(linear)
    return min(linear, key=lambda sc: sc[0].name)[1].is_negative


def _plain(arg: sympy.Expr) -> bool:
    """A symbol or a sum of (rational multiples of) products of symbols: no pi, no I, no number,
    nothing that SymPy's sin and cos evaluate."""
    for term in sympy.Add.make_args(arg):
        for f in sympy.Mul.make_args(term):
            if not (f.is_Symbol or (f.is_Rational and not f.is_zero) or (f.is_Pow and f.base.is_Symbol)):
                return False
        if term.is_number:
            return False
    return True


@functools.lru_cache(maxsize=8192)
def _power(base, exp) -> sympy.Expr:
    b = _to_sympy(base)
    return b if exp == 1 else sympy.Pow(b, _to_sympy(exp))


def _factors(powers) -> list:
    return [_power(b, x) for b, x in powers]


_ONE_SYMPY, _MINUS_ONE, _ZERO = sympy.S.One, sympy.S.NegativeOne, sympy.S.Zero


def _mul(coef: sympy.Expr, factors: list) -> sympy.Expr:
    """``sympy.Mul(coef, *factors)``. When the factors are symbols, functions, their integer powers
    and sums, with distinct bases, and `coef` a nonzero rational, SymPy's flattening would only
    sort them (in its canonical order) after the coefficient, and that is done here directly,
    ten times faster; anything else goes through ``sympy.Mul``."""
    if not factors or not coef.is_Rational or coef.is_zero:
        return sympy.Mul(coef, *factors)
    plain = []
    for f in factors:  # -sin(x): the sign goes to the coefficient
        if f.is_Mul and len(f.args) == 2 and f.args[0] is _MINUS_ONE:
            coef, f = -coef, f.args[1]
        if not _plain_factor(f):
            return sympy.Mul(coef, *plain, f, *factors[len(plain) + 1:])
        plain.append(f)
    factors = plain
    if len(factors) == 1 and factors[0].is_Add and coef is not _ONE_SYMPY:
        return sympy.Mul(coef, factors[0])
    if len(factors) == 1 and coef is _ONE_SYMPY:
        return factors[0]
    args = sorted(factors, key=_args_sortkey)
    if coef is not _ONE_SYMPY:
        args.insert(0, coef)
    return sympy.Mul._from_args(args, True)


def _add_sympy(terms: list) -> sympy.Expr:
    """``sympy.Add(*terms)``. When the terms are products, symbols or functions that do not combine
    (no two with the same part besides the number: the groups of `_grouped` and the monomials of
    `_factored`), SymPy's flattening would only sort them, and that is done here directly."""
    if len(terms) < 2 or any(t.is_Add or t.is_Number for t in terms):
        return sympy.Add(*terms)
    parts = {t.as_coeff_Mul()[1] for t in terms}
    if len(parts) != len(terms):
        return sympy.Add(*terms)
    return sympy.Add._from_args(sorted(terms, key=_args_sortkey), True)


def times(expr: sympy.Expr, coef: sympy.Expr, extra: list) -> sympy.Expr:
    """``sympy.Mul(coef, expr, *extra)`` (`coef` a rational, `extra` symbols or their powers with
    bases not among the factors of `expr`: the velocities times an entry of M), built by `_mul`
    without SymPy's flattening where it would only sort the factors."""
    c, factors = expr.as_coeff_mul()
    if not c.is_Rational or c.is_zero or any(f.is_Number for f in factors):
        return sympy.Mul(coef, expr, *extra)
    return _mul(c * coef, [*factors, *extra])


def plus(terms: list) -> sympy.Expr:
    """``sympy.Add(*terms)``: sums among them opened, zeros left out, then `_add_sympy`."""
    flat = [t for term in terms for t in sympy.Add.make_args(term) if t is not _ZERO]
    return _add_sympy(flat) if flat else sympy.S.Zero


def negated(expr: sympy.Expr) -> list:
    """The terms of ``-expr`` (SymPy's negation of each term of the sum)."""
    return [-t for t in sympy.Add.make_args(expr)]


def _plain_factor(f) -> bool:
    """A symbol, sum, function or an integer power of a symbol or function."""
    if f.is_Symbol or f.is_Add or f.is_Function:
        return True
    return f.is_Pow and f.exp.is_Integer and (f.base.is_Symbol or f.base.is_Function)


# ------------------------------------------------------------------------------ text
class _Printer(StrPrinter):
    """``sympy.sstr``, the same string, faster for the equations' many entries.

    The text of each function is printed once: the same few hundred sin(theta_i - theta_j) recur
    in every entry of a chain's equations. Sums and products whose terms are products of a rational
    number and factors that are not numbers (symbols, functions of symbols, their positive powers,
    sums: the readable forms) are printed here directly, each distinct factor's text, sort key and
    power decomposition computed once: SymPy's ``_print_Add`` orders the terms by ``as_terms``
    (``complex()`` of every coefficient, a power decomposition of every factor) and its
    ``_print_Mul`` sorts the factors by ``sort_key`` and asks ``could_extract_minus_sign`` (which
    negates the product) and ``precedence`` of each; together three quarters of printing the
    equations of a chain. Anything else (numbers among the factors, a denominator other than the
    coefficient's, an unevaluated product, non-commutative factors) goes to SymPy's printer."""

    def __init__(self):
        super().__init__()
        self._functions: dict = {}
        self._factors: dict = {}  # factor -> (its text in a product, its sort key), or None: not plain
        self._powers: dict = {}  # factor -> (base, exponent) as sympy's decompose_power gives them
        self._keys: dict = {}  # base -> default_sort_key(base)
        self._complex: dict = {}  # rational -> complex(rational)

    def _print_Function(self, expr) -> str:
        out = self._functions.get(expr)
        if out is None:
            if len(self._functions) > 8192:
                self._functions.clear()
            out = self._functions[expr] = super()._print_Function(expr)
        return out

    def _factor(self, f):
        """(text of `f` as a factor of a product, its sort key), or None when `f` is not a plain
        factor: a symbol, a function, a sum (parenthesized), or a positive rational power of one
        of these, with at least one free symbol and commutative."""
        info = self._factors.get(f, False)
        if info is not False:
            return info
        base = f.base if f.is_Pow else f
        plain = (f.is_commutative and (base.is_Symbol or base.is_Function or base.is_Add) and not base.is_number
                 and (not f.is_Pow or (f.exp.is_Rational and f.exp.is_positive))
                 and (f.is_Add or precedence(f) > _MUL_PRECEDENCE))  # never parenthesized in a product
        if not plain:
            info = None
        elif f.is_Add:
            info = (f"({self._print(f)})", f.sort_key())
        else:
            info = (self._print(f), f.sort_key())
        if len(self._factors) > 8192:
            self._factors.clear()
        self._factors[f] = info
        return info

    def _coefficient(self, expr):
        """(the rational coefficient, the other factors) of a product or a single factor, or None
        when SymPy's printing of it is not the plain one (see the class docstring)."""
        if expr.is_Mul:
            args = expr.args
            first = args[0]
            if first.is_Number:
                if not first.is_Rational or first is _ONE_SYMPY:
                    return None
                return first, args[1:]
            return _ONE_SYMPY, args
        return _ONE_SYMPY, (expr,)

    def _print_Mul(self, expr) -> str:
        split = self._coefficient(expr)
        if split is None:
            return super()._print_Mul(expr)
        c, rest = split
        infos = []
        for f in rest:
            info = self._factor(f)
            if info is None:
                return super()._print_Mul(expr)
            infos.append(info)
        sign = ""
        if c.is_negative:
            sign, c = "-", -c
        a = [] if c.p == 1 else [str(c.p)]
        a += [text for text, _ in sorted(infos, key=lambda info: info[1])] if len(infos) > 1 else [infos[0][0]]
        out = sign + "*".join(a)
        return out if c.q == 1 else f"{out}/{c.q}"

    def _power(self, f):
        """sympy's ``decompose_power(f)``, once per factor."""
        out = self._powers.get(f)
        if out is None:
            if len(self._powers) > 8192:
                self._powers.clear()
            out = self._powers[f] = decompose_power(f)
        return out

    def _sort_key(self, base):
        out = self._keys.get(base)
        if out is None:
            if len(self._keys) > 8192:
                self._keys.clear()
            out = self._keys[base] = default_sort_key(base)
        return out

    def _print_Add(self, expr, order=None) -> str:
        if order is not None or self.order is not None:
            return super()._print_Add(expr, order=order)
        # the terms in the order of Expr.as_ordered_terms() (as_terms and _parse_order's key, for
        # order=None: lex), with the plain terms only
        terms = []
        gens: set = set()
        for term in expr.args:
            split = self._coefficient(term)
            if split is None:
                return super()._print_Add(expr, order=order)
            c, rest = split
            powers = {}
            for f in rest:
                if self._factor(f) is None:
                    return super()._print_Add(expr, order=order)
                base, e = self._power(f)
                powers[base] = e
                gens.add(base)
            z = self._complex.get(c)
            if z is None:
                z = self._complex[c] = complex(c)
            terms.append((term, powers, z))
        index = {g: i for i, g in enumerate(sorted(gens, key=self._sort_key))}
        keyed = []
        for term, powers, z in terms:
            monom = [0] * len(index)
            for base, e in powers.items():
                monom[index[base]] = -e
            keyed.append(((tuple(monom), (), ((bool(z.imag), z.imag), (z.real, z.imag))), term))
        keyed.sort(key=lambda kt: kt[0])
        parts = []
        for _, term in keyed:
            t = self._print(term)
            if t.startswith("-"):
                parts.extend(("-", t[1:]))
            else:
                parts.extend(("+", t))
        sign = parts.pop(0)
        return ("" if sign == "+" else sign) + " ".join(parts)


_MUL_PRECEDENCE = PRECEDENCE["Mul"]
_PRINTER = _Printer()


def text(expr) -> str:
    """`expr` as ``sympy.sstr`` prints it (the same string), faster for many entries; an expression
    left as derived by :func:`readable` (over its budget) as SymEngine prints it (SymPy syntax too:
    the same expression, its terms in SymEngine's order)."""
    derived = _DERIVED.get(id(expr))
    if derived is not None and derived[0] is expr:
        return str(derived[1])
    return _PRINTER.doprint(expr)
