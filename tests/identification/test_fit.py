"""lg.fit: parameter identification by multiple shooting on exact sensitivities.

Synthetic data come from lagrangian.simulate (DOP853, tolerances 1e-11) at known parameters, plus
Gaussian noise of a known level; the fit integrates by its own Runge-Kutta steps, so the two paths
are independent. Every expected number is a true parameter (or a combination of them) and the
fit's own confidence interval.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

import lagrangian as lg
from lagrangian.identification import FitResult, fit
from lagrangian.identification._fit import _Problem, _Setup, _guess_states
from lagrangian.identification._sensitivity import Sensitivities


def pendulum(c=0.1, l=0.5):
    m = lg.Model("pendulum")
    th = m.coordinate("theta")
    mass, ll, g, cc = m.parameter("m", 1.0), m.parameter("l", l), m.parameter("g", 9.81), m.parameter("c", c)
    m.add_particle(mass, (ll * lg.sin(th), -ll * lg.cos(th)), name="bob")
    m.add_gravity(g)
    m.add_energy(D=cc * lg.dot(th) ** 2 / 2)
    return lg.derive(m)


@pytest.fixture(scope="module")
def pend():
    return pendulum()


@pytest.fixture(scope="module")
def pend_run(pend):
    return lg.simulate(pend, 5.0, initial={"theta": 1.0}, dt=0.02, rtol=1e-11, atol=1e-11)


def noisy(tr, names, sigma, seed):
    rng = np.random.default_rng(seed)
    return {"t": tr.t, **{n: tr[n] + sigma * rng.standard_normal(len(tr.t)) for n in names}}


def test_sensitivities_match_finite_differences(pend, pend_run):
    """The assembled Jacobian (forward sensitivities through the saddle-point form) against central
    differences of the residuals, in every node state and parameter."""
    data = noisy(pend_run, ["theta"], 0.01, 0)
    s = _Setup(pend, data, ["l", "c"], {"l": 0.6, "c": 0.2}, None, None, 0.01, None, 5)
    sens = Sensitivities.build(pend, s.fitted, s.exprs)
    X = _guess_states(s, sens)
    nodes = np.array([X[e][a] for e, a, _ in s.rows])
    pr = _Problem(s, sens, np.ones(2, bool), substeps=4)
    pr.set_nodes(nodes)
    pr.defect_weight = 10.0
    z = pr.pack(nodes, s.values)
    _, J, _ = pr.evaluate(z)
    fd = np.empty_like(J)
    for i in range(len(z)):
        h = 1e-6 * max(1.0, abs(z[i]))
        zp, zm = z.copy(), z.copy()
        zp[i] += h
        zm[i] -= h
        fd[:, i] = (pr.evaluate(zp, False)[0] - pr.evaluate(zm, False)[0]) / (2 * h)
    assert np.max(np.abs(J - fd)) <= 1e-6 * np.max(np.abs(J))


def test_sensitivities_of_a_constrained_model_match_finite_differences():
    """The four-bar: the saddle-point solve with the loop constraints G, the derivatives of G, c and
    of the constraint residuals at the nodes in b (a length inside the constraints) and mb, and the
    coordinates th2, th3 (not measured) found from th1 through the constraints."""
    eqs = lg.derive(lg.load("four-bar"))
    tr = lg.simulate(eqs, 0.3, initial={"th1": 1.2, "th1_dot": 4.0}, dt=0.01, rtol=1e-11, atol=1e-11,
                     inputs={"tau": 0.0})
    data = noisy(tr, ["th1"], 0.002, 12)
    s = _Setup(eqs, data, ["mb", "b"], {"mb": 1.5, "b": 0.62}, None, None, 0.002, {"tau": 0.3}, 3)
    sens = Sensitivities.build(eqs, s.fitted, s.exprs)
    X = _guess_states(s, sens)
    assert abs(X[0][0, 1] - tr["th2"][0]) < 0.05  # th2 from th1 and the loop
    nodes = np.array([X[e][a] for e, a, _ in s.rows])
    pr = _Problem(s, sens, np.ones(2, bool), substeps=2)
    pr.set_nodes(nodes)
    pr.defect_weight = 10.0
    z = pr.pack(nodes, s.values)
    _, J, _ = pr.evaluate(z)
    fd = np.empty_like(J)
    for i in range(len(z)):
        h = 1e-6 * max(1.0, abs(z[i]))
        zp, zm = z.copy(), z.copy()
        zp[i] += h
        zm[i] -= h
        fd[:, i] = (pr.evaluate(zp, False)[0] - pr.evaluate(zm, False)[0]) / (2 * h)
    assert np.max(np.abs(J - fd)) <= 1e-6 * np.max(np.abs(J))


def test_damped_pendulum(pend, pend_run):
    r = fit(pend, noisy(pend_run, ["theta"], 0.01, 1), ["l", "c"], guess={"l": 0.8, "c": 0.3})
    assert isinstance(r, FitResult) and r.success
    for p, true in (("l", 0.5), ("c", 0.1)):
        lo, hi = r.intervals[p]
        assert lo <= true <= hi
        assert abs(r[p] - true) < 5 * r.standard_errors[p]
    assert r.standard_errors["l"] < 1e-3 and r.standard_errors["c"] < 2e-3
    assert r.noise_estimated and abs(r.noise["theta"] - 0.01) < 2e-3
    assert r.rank == 2 and r.not_identifiable == ()
    assert abs(r.initial_states[0]["theta"] - 1.0) < 0.01
    assert r.max_defect < 1e-8
    json.dumps(r.to_dict())
    with pytest.raises(AttributeError):
        r.cost = 0.0  # frozen


def test_positions_measured(pend, pend_run):
    """A camera's view: only the bob's position (bob.x, bob.y); theta is found from them."""
    rng = np.random.default_rng(2)
    th = pend_run["theta"]
    data = {"t": pend_run.t, "bob.x": 0.5 * np.sin(th) + 0.005 * rng.standard_normal(th.size),
            "bob.y": -0.5 * np.cos(th) + 0.005 * rng.standard_normal(th.size)}
    r = fit(pend, data, ["l", "c"], guess={"l": 0.7, "c": 0.3}, noise=0.005)
    assert not r.noise_estimated
    for p, true in (("l", 0.5), ("c", 0.1)):
        lo, hi = r.intervals[p]
        assert lo <= true <= hi, (p, r.intervals[p])
    assert set(r.fitted[0]) == {"bob.x", "bob.y"}
    assert np.sqrt(np.mean(r.residuals[0]["bob.x"] ** 2)) == pytest.approx(0.005, rel=0.2)


def test_not_identifiable_named_not_fitted(pend, pend_run):
    """theta'' = -(g/l) sin(theta) - c/(m l^2) theta': with g known, l is determined and m, c only as
    c/m. m is named and held, c is fitted given m, and c/m is reported with its value."""
    r = fit(pend, noisy(pend_run, ["theta"], 0.01, 3), ["m", "l", "c"], guess={"m": 2.0, "l": 0.8, "c": 0.3})
    assert r.not_identifiable == ("m",)
    assert "m" not in r.estimates and r.held["m"] == 2.0
    assert "structurally" in r.held_reasons["m"]
    assert r.parameters == ("l", "c")
    (text, (value, se)), = r.combinations.items()
    assert text == "c/m"
    assert abs(value - 0.1) < 4 * se
    assert r.estimates["c"] == pytest.approx(2.0 * value)
    assert "not identifiable" in r.text() and "c/m" in r.text()
    assert r.to_dict()["not_identifiable"]["m"]["held_at"] == 2.0


@pytest.mark.slow
def test_coverage_across_seeds(pend, pend_run):
    """The 95 % intervals cover the true values at about the stated rate: over 10 seeds and two
    parameters (20 chances), at least 16 (a binomial(20, 0.95) is below 16 with probability 0.3 %),
    with the noise level given and estimated."""
    for noise in (0.02, None):  # given (normal quantile), estimated (Student's t)
        covered = 0
        for seed in range(10):
            r = fit(pend, noisy(pend_run, ["theta"], 0.02, 100 + seed), ["l", "c"], guess={"l": 0.6, "c": 0.2},
                    noise=noise)
            covered += sum(r.intervals[p][0] <= true <= r.intervals[p][1] for p, true in (("l", 0.5), ("c", 0.1)))
        assert covered >= 16, (noise, covered)


def mass_spring_damper(F=True):
    inputs = ["F"] if F else []
    m = lg.Model("msd", coordinates=["x"], parameters={"m": 2.0, "c": 0.6, "k": 30.0}, inputs=inputs,
                 T="m*x_dot**2/2", V="k*x**2/2", D="c*x_dot**2/2", Q={"x": "F"} if F else None)
    return lg.derive(m)


def test_forced_mass_spring_damper_input_measured():
    """m x'' + c x' + k x = F with F a measured column (the input signal, interpolated): m, c and k
    all determined (the input fixes the scale that free decay leaves open)."""
    eqs = mass_spring_damper()
    t = np.linspace(0, 6, 601)
    F = np.sin(3.0 * t) + 0.5 * np.sin(7.3 * t)
    tr = lg.simulate(eqs, 6.0, initial={"x": 0.05}, dt=0.01, rtol=1e-11, atol=1e-11,
                     inputs={"F": lg.Signal(t, F)})
    rng = np.random.default_rng(4)
    data = {"t": tr.t, "x": tr["x"] + 1e-4 * rng.standard_normal(t.size), "F": F}
    r = fit(eqs, data, ["m", "c", "k"], guess={"m": 1.0, "c": 1.0, "k": 20.0})
    assert r.not_identifiable == ()
    for p, true in (("m", 2.0), ("c", 0.6), ("k", 30.0)):
        lo, hi = r.intervals[p]
        assert lo <= true <= hi, (p, r.intervals[p])
        assert r.standard_errors[p] < 0.02 * true


def test_free_decay_mass_and_damper_trade_off():
    """Without the input: x'' = -(k/m) x - (c/m) x', so only c/m and k/m are determined."""
    eqs = mass_spring_damper(F=False)
    tr = lg.simulate(eqs, 6.0, initial={"x": 0.05}, dt=0.02, rtol=1e-11, atol=1e-11)
    r = fit(eqs, noisy(tr, ["x"], 1e-4, 5), ["m", "c", "k"], guess={"m": 1.0, "c": 1.0, "k": 20.0})
    assert r.not_identifiable == ("m",)
    values = {k.replace(" ", ""): v for k, (v, _) in r.combinations.items()}
    assert values["c/m"] == pytest.approx(0.3, rel=1e-2)
    assert values["k/m"] == pytest.approx(15.0, rel=1e-3)


def test_several_experiments_and_given_initial(pend):
    """Two experiments from other initial states; the first's initial state given (held)."""
    runs = [lg.simulate(pend, 3.0, initial={"theta": a}, dt=0.02, rtol=1e-11, atol=1e-11) for a in (0.4, 1.2)]
    data = [noisy(tr, ["theta"], 0.01, 6 + i) for i, tr in enumerate(runs)]
    r = fit(pend, data, ["l", "c"], guess={"l": 0.7, "c": 0.2}, initial=[{"theta": 0.4, "theta_dot": 0.0}, {}],
            noise=0.01)
    assert r.initial_states[0] == {"theta": 0.4, "theta_dot": 0.0}
    assert abs(r.initial_states[1]["theta"] - 1.2) < 0.02
    for p, true in (("l", 0.5), ("c", 0.1)):
        assert r.intervals[p][0] <= true <= r.intervals[p][1]
    assert len(r.fitted) == 2 and r.intervals_per_experiment == (15, 15)


@pytest.mark.slow
def test_four_bar_constrained():
    """A closed chain: three coordinates, two loop constraints, the crank's angle measured; the
    coupler's mass fitted (the constraints hold at the nodes)."""
    eqs = lg.derive(lg.load("four-bar"))
    init = {"th1": 1.2, "th1_dot": 4.0}
    tr = lg.simulate(eqs, 2.0, initial=init, dt=0.01, rtol=1e-11, atol=1e-11, inputs={"tau": 0.0})
    r = fit(eqs, noisy(tr, ["th1"], 0.002, 7), ["mb"], guess={"mb": 2.0}, inputs={"tau": 0.0}, noise=0.002)
    lo, hi = r.intervals["mb"]
    assert lo <= 1.2 <= hi and r.standard_errors["mb"] < 0.05
    assert r.max_defect < 1e-6


@pytest.mark.slow
def test_chaotic_double_pendulum_20s_poor_guess():
    """20 s of a chaotic double pendulum (single shooting's sensitivities grow like e^(20 lambda)),
    a first guess 30 % and 100 % off: multiple shooting with the defect continuation finds the truth."""
    eqs = lg.derive(lg.load("double-pendulum"))
    tr = lg.simulate(eqs, 20.0, initial={"theta1": 2.0, "theta2": 2.5}, dt=0.02, rtol=1e-12, atol=1e-12)
    r = fit(eqs, noisy(tr, ["theta1", "theta2"], 0.01, 8), ["l1", "l2", "m2"], guess={"l1": 1.3, "l2": 0.7, "m2": 2.0})
    assert r.success
    for p in ("l1", "l2", "m2"):
        assert r.intervals[p][0] <= 1.0 <= r.intervals[p][1], (p, r.intervals[p])
    assert r.noise["theta1"] == pytest.approx(0.01, rel=0.1)


def test_bounds(pend, pend_run):
    r = fit(pend, noisy(pend_run, ["theta"], 0.01, 9), ["l", "c"], guess={"l": 0.8, "c": 0.3},
            bounds={"c": (0.2, 1.0)})
    assert r["c"] == pytest.approx(0.2, abs=1e-6)  # the truth (0.1) is outside: held at the bound


def test_nothing_determined_is_an_error():
    """With c = 0 the swing says nothing of m (it enters only as c/(m l^2)): a fit of m alone is
    refused with the reason."""
    eqs = pendulum(c=0.0)
    tr = lg.simulate(eqs, 2.0, initial={"theta": 0.5}, dt=0.02, rtol=1e-10, atol=1e-10)
    with pytest.raises(lg.ModelError, match=r"none of m can be determined by these data \(m is not identifiable "
                                            r"structurally\); fit other parameters or measure more"):
        fit(eqs, noisy(tr, ["theta"], 0.01, 11), ["m"])


def test_numeric_rank_alone_holds_what_the_data_leave_open(pend, pend_run, monkeypatch):
    """Without the structural analysis the singular values of the sensitivity find the same: m and c
    move together (c/m), one of them is held, said to be so by the data."""
    import lagrangian.identification._fit as fitmod

    monkeypatch.setattr(fitmod, "_structural", lambda eqs, setup: (None, "the structural analysis is off"))
    r = fit(pend, noisy(pend_run, ["theta"], 0.01, 3), ["m", "l", "c"], guess={"m": 2.0, "l": 0.8, "c": 0.3})
    (held, why), = r.held_reasons.items()
    assert held in ("m", "c") and why == "numerically (by the data)"
    kept = "c" if held == "m" else "m"
    ratio = r[kept] / r.held[held] if kept == "c" else r.held[held] / r[kept]
    assert ratio == pytest.approx(0.1, abs=0.003)  # c/m
    assert r.combinations == {} and "the structural analysis is off" in r.text()
