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
"""

from __future__ import annotations

import functools
import math
from collections.abc import Iterable

import symengine as se
import sympy
from sympy.printing.str import StrPrinter

__all__ = ["readable", "trigonometric_polynomial", "expanded_terms_bound", "text", "MAX_TERMS"]

#: The budget: expressions whose expansion may exceed this many terms are left as derived.
MAX_TERMS = 5000

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
    terms = _rewritten(expr, max_terms)
    if not isinstance(terms, dict):
        return terms
    state_names = state if isinstance(state, frozenset) else frozenset(str(s) for s in state)
    collect_names = frozenset(str(s) for s in collect_on)
    return _grouped(terms, state_names, collect_names)


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


def _rewritten(expr, max_terms: int):
    """The expanded terms of `expr` {monomial: coefficient} with the identities applied, or, over
    the budget (or not convertible to SymEngine), `expr` in SymPy as it is."""
    try:
        e = se.sympify(expr)
    except (TypeError, ValueError, RuntimeError):
        return sympy.sympify(expr)
    if expanded_terms_bound(e, max_terms) > max_terms:
        return e._sympy_()
    terms = _terms(se.expand(e))
    _apply_identities(terms)
    return terms


def expanded_terms_bound(expr, limit: int | None = None) -> int:
    """An upper bound of the number of terms of ``expand(expr)``, from its tree (each shared
    subexpression visited once): a sum adds, a product multiplies, a power (a + b + ...)**k
    counts the monomials of degree k. Stops counting past `limit` (then returns more than it)."""
    memo: dict = {}
    cap = math.inf if limit is None else limit + 1

    def bound(e) -> int:
        k = memo.get(e)
        if k is not None:
            return k
        if e.is_Add:
            k = 0
            for a in e.args:
                k += bound(a)
                if k >= cap:
                    break
        elif e.is_Mul:
            k = 1
            for a in e.args:
                k *= bound(a)
                if k >= cap:
                    break
        elif e.is_Pow:
            base, exp = e.args
            kb = bound(base)
            if exp.is_Integer and int(exp) > 1 and kb > 1:
                n = int(exp)
                # the number of monomials of degree n in kb terms, without building a huge integer
                k = math.comb(kb + n - 1, n) if kb < 10_000 and n < 1000 else int(cap)
            else:
                k = kb if exp.is_Integer and int(exp) == 1 else 1
        else:
            k = 1
        k = min(k, cap) if cap != math.inf else k
        memo[e] = k
        return k

    return int(bound(se.sympify(expr)))


# ----------------------------------------------------------------------------- the terms
def _terms(expanded) -> dict:
    """{monomial: coefficient} of an expanded SymEngine expression; a monomial is a frozenset of
    (base, exponent) pairs, the coefficient a SymEngine number."""
    out: dict = {}
    for term in (expanded.args if expanded.is_Add else (expanded,)):
        coef, mono = _split(term)
        _add(out, mono, coef)
    return out


def _split(term):
    """(number, monomial) of one product; a sum left in it (under a root or in a denominator) is
    itself written with the identities."""
    coef = se.Integer(1)
    powers: dict = {}
    for f in (term.args if term.is_Mul else (term,)):
        if f.is_Number:
            coef = coef * f
            continue
        base, exp = f.args if f.is_Pow else (f, se.Integer(1))
        if base.is_Add:
            base = _compact(base)
        powers[base] = powers.get(base, 0) + exp
    return coef, frozenset(powers.items())


def _compact(e):
    """An expanded sum with the identities applied, as a SymEngine expression."""
    terms = _terms(e)
    _apply_identities(terms)
    return se.Add(*(c * se.Mul(*(b ** x for b, x in mono)) for mono, c in terms.items()))


def _add(terms: dict, mono: frozenset, coef) -> None:
    total = terms.get(mono, 0) + coef
    if total == 0:
        terms.pop(mono, None)
    else:
        terms[mono] = total


def _times(mono: frozenset, factor) -> tuple:
    """(number, monomial) of mono * factor, factor a product of powers (as SymEngine builds it)."""
    coef, extra = _split(factor)
    if not extra:
        return coef, mono
    powers = dict(mono)
    for base, exp in extra:
        powers[base] = powers.get(base, 0) + exp
    return coef, frozenset((b, x) for b, x in powers.items() if x != 0)


def _shift(mono: frozenset, remove: dict, add: dict) -> frozenset | None:
    """mono / prod(remove) * prod(add), or None when mono does not contain `remove`."""
    powers = dict(mono)
    for base, exp in remove.items():
        have = powers.get(base)
        if have is None or not have.is_Integer or int(have) < exp:
            return None
        if have == exp:
            del powers[base]
        else:
            powers[base] = have - exp
    for base, exp in add.items():
        powers[base] = powers.get(base, 0) + exp
    return frozenset(powers.items())


# ------------------------------------------------------------------------ the identities
def _apply_identities(terms: dict) -> None:
    """Apply the identities of the module docstring until none applies (each one removes a term)."""
    changed = True
    while changed:
        changed = False
        for mono in list(terms):
            if mono in terms and _rewrite_one(terms, mono):
                changed = True


def _trig(mono: frozenset) -> list:
    """[(kind, argument, exponent)] of the sin and cos factors of a monomial (integer powers)."""
    out = []
    for base, exp in mono:
        if exp.is_Integer and isinstance(base, (se.sin, se.cos)):
            out.append((type(base), base.args[0], int(exp)))
    return out


def _rewrite_one(terms: dict, mono: frozenset) -> bool:
    """Try every identity on the term `mono` with its partner terms; True if one applied."""
    c = terms[mono]
    trig = _trig(mono)
    sin, cos = se.sin, se.cos
    for kind, x, k in trig:
        if k >= 2:  # sin^2 + cos^2 = 1, and 1 - sin^2 = cos^2
            other = cos if kind is sin else sin
            pair = _shift(mono, {kind(x): 2}, {other(x): 2})
            if pair is not None and terms.get(pair) == c:
                rest = _shift(mono, {kind(x): 2}, {})
                return _replace(terms, (mono, pair), c, rest, se.Integer(1))
            rest = _shift(mono, {kind(x): 2}, {})
            if terms.get(rest) == -c:
                return _replace(terms, (mono, rest), -c, rest, other(x) ** 2)
    for i, (kind1, x, _) in enumerate(trig):
        for kind2, y, _ in trig[i + 1:]:
            if x == y:
                continue
            f1, f2 = kind1(x), kind2(y)
            if kind1 is kind2:  # sin x sin y with cos x cos y, or cos x cos y with sin x sin y
                other = cos if kind1 is sin else sin
                pair = _shift(mono, {f1: 1, f2: 1}, {other(x): 1, other(y): 1})
                if pair is None:
                    continue
                d = terms.get(pair)
                if d is None:
                    continue
                rest = _shift(mono, {f1: 1, f2: 1}, {})
                if d == c:  # c (sin x sin y + cos x cos y) = c cos(x - y)
                    return _replace(terms, (mono, pair), c, rest, cos(_sum(x, -y)))
                if d == -c:  # c (cos x cos y - sin x sin y) = c cos(x + y)
                    return _replace(terms, (mono, pair), c if kind1 is cos else -c, rest, cos(_sum(x, y)))
            else:  # sin x cos y with cos x sin y
                if kind1 is cos:
                    x, y = y, x  # now the term holds sin(x) cos(y)
                pair = _shift(mono, {sin(x): 1, cos(y): 1}, {cos(x): 1, sin(y): 1})
                if pair is None:
                    continue
                d = terms.get(pair)
                rest = _shift(mono, {sin(x): 1, cos(y): 1}, {})
                if d == -c:  # c (sin x cos y - cos x sin y) = c sin(x - y)
                    return _replace(terms, (mono, pair), c, rest, sin(_sum(x, -y)))
                if d == c:  # c (sin x cos y + cos x sin y) = c sin(x + y)
                    return _replace(terms, (mono, pair), c, rest, sin(_sum(x, y)))
    return False


def _sum(x, y):
    """x + y, expanded: the argument of a new sine or cosine (so that equal angles are one key)."""
    return se.expand(x + y)


def _replace(terms: dict, old: tuple, coef, rest: frozenset, factor) -> bool:
    for m in old:
        del terms[m]
    k, mono = _times(rest, factor)
    if k != 0:
        _add(terms, mono, coef * k)
    return True


# -------------------------------------------------------------------------- Fourier form
def _fourier(terms: dict, max_terms: int) -> dict | None:
    """The terms with each product of sines and cosines (integer powers) written as a sum of
    sines and cosines of sums of the arguments; None when that would exceed `max_terms` terms."""
    out: dict = {}
    for mono, c in terms.items():
        series = {_ONE: se.Integer(1)}  # {frozenset holding one sin or cos, or none: coefficient}
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


_ONE = frozenset()
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
        collected, varying, params = [], [], []
        for base, exp in mono:
            if base.is_Symbol and str(base) in collect_on:
                collected.append((base, exp))
            elif _is_state(base, state):
                varying.append((base, exp))
            else:
                params.append((base, exp))
        by_state = groups.setdefault(frozenset(collected), {})
        by_state.setdefault(frozenset(varying), []).append((coef, frozenset(params)))
    out = []
    for collected, by_state in groups.items():
        if len(by_state) == 1:
            (varying, poly), = by_state.items()
            out.append(_factored(poly, _factors(collected) + _factors(varying)))
        else:
            parts = [_factored(poly, _factors(varying)) for varying, poly in by_state.items()]
            out.append(sympy.Mul(*_factors(collected), sympy.Add(*parts)))
    return sympy.Add(*out)


@functools.lru_cache(maxsize=8192)
def _is_state(base, state: frozenset) -> bool:
    if base.is_Symbol:
        return str(base) in state
    return any(str(s) in state for s in base.free_symbols)


def _factored(poly: list, factors: list) -> sympy.Expr:
    """sum(coef * monomial) of parameters times `factors` (SymPy), written as
    content * common parameters * (the rest) * factors, in one product (so that SymPy does not
    distribute a number over the sum)."""
    if len(poly) == 1:
        coef, mono = poly[0]
        return sympy.Mul(_to_sympy(coef), *_factors(mono), *factors)
    common = _common_powers([m for _, m in poly])
    content = _content([c for c, _ in poly])
    inner = []
    for coef, mono in poly:
        rest = [(b, x - common[b]) if b in common else (b, x) for b, x in mono]
        inner.append(sympy.Mul(_to_sympy(coef / content), *_factors(p for p in rest if p[1] != 0)))
    return sympy.Mul(_to_sympy(content), *_factors(common.items()), sympy.Add(*inner), *factors)


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
    denominator (1 when the denominators differ), negative when every coefficient is."""
    if not all(c.is_Rational for c in coefs):
        return se.Integer(1)
    nums, dens = zip(*(c.get_num_den() for c in coefs))
    g = se.Integer(math.gcd(*(abs(int(n)) for n in nums)))
    content = g / dens[0] if all(d == dens[0] for d in dens) else se.Integer(1)
    return -content if all(c.is_negative for c in coefs) else content


# ------------------------------------------------------------------------- to SymPy
_TRIG = {se.sin: (sympy.sin, -1), se.cos: (sympy.cos, 1)}


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
            func, parity = trig
            return parity * func(arg, evaluate=False) if flipped else func(arg, evaluate=False)
    return e._sympy_() if isinstance(e, se.Basic) else sympy.sympify(e)


@functools.lru_cache(maxsize=8192)
def _oriented(arg) -> tuple:
    """(SymPy's canonical form of the argument a of sin(a), cos(a), and whether it is -a), or
    (None, False) when SymPy's sin and cos would do more than extract a minus sign."""
    a = _to_sympy(arg)
    if not _plain(a):
        return None, False
    return (-a, True) if a.could_extract_minus_sign() else (a, False)


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


# ------------------------------------------------------------------------------ text
class _Printer(StrPrinter):
    """``sympy.sstr``, with the text of each function printed once: the same few hundred
    sin(theta_i - theta_j) recur in every entry of a chain's equations, and printing their
    arguments was half the time of printing the equations."""

    def __init__(self):
        super().__init__()
        self._functions: dict = {}

    def _print_Function(self, expr) -> str:
        out = self._functions.get(expr)
        if out is None:
            if len(self._functions) > 8192:
                self._functions.clear()
            out = self._functions[expr] = super()._print_Function(expr)
        return out


_PRINTER = _Printer()


def text(expr) -> str:
    """`expr` as ``sympy.sstr`` prints it (the same string), faster for many entries."""
    return _PRINTER.doprint(expr)
