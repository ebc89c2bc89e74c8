"""The C export's <id>_inverse_dynamics(t, q, qd, qdd, u, p, tau) (issue 22): built with -Wall -Wextra
-pedantic -Werror beside a test program, it gives lagrangian.inverse_dynamics's numbers to 1e-12
(a constrained model's: the total tau_a + G^T lambda)."""

from __future__ import annotations

import subprocess

import numpy as np
import pytest

import lagrangian as lg
from lagrangian.export import export_c
from lagrangian.numeric._cbackend import c_compiler

needs_cc = pytest.mark.skipif(c_compiler() is None, reason="no C compiler ($CC, cc or gcc) to build the export")


def _rows(a) -> str:
    return ",\n".join("{" + ", ".join(repr(float(v)) for v in row) + "}" for row in np.atleast_2d(a))


def c_inverse_dynamics(eqs, ident, folder, t, Q, QD, QDD, U) -> np.ndarray:
    """tau from the exported C at the rows of Q, QD, QDD (inputs U), as an array (N, n)."""
    export_c(eqs, folder)
    N, n = Q.shape
    k = max(1, U.shape[1])
    U = U if U.shape[1] else np.zeros((N, 1))
    (folder / "check.c").write_text(f"""#include <stdio.h>
#include "{ident}.h"
int main(void) {{
    const double T[{N}] = {{{", ".join(repr(float(v)) for v in t)}}};
    const double Q[{N}][{n}] = {{{_rows(Q)}}};
    const double QD[{N}][{n}] = {{{_rows(QD)}}};
    const double QDD[{N}][{n}] = {{{_rows(QDD)}}};
    const double U[{N}][{k}] = {{{_rows(U)}}};
    double tau[{n}];
    int r, i;
    for (r = 0; r < {N}; r++) {{
        {ident}_inverse_dynamics(T[r], Q[r], QD[r], QDD[r], U[r], {ident}_parameter_values, tau);
        for (i = 0; i < {n}; i++) printf("%.17g ", tau[i]);
        printf("\\n");
    }}
    return 0;
}}
""")
    build = subprocess.run([*c_compiler().split(), "-std=c99", "-Wall", "-Wextra", "-pedantic", "-Werror", "-O2",
                            "-o", str(folder / "check"), str(folder / "check.c"), str(folder / f"{ident}.c"), "-lm"],
                           capture_output=True, text=True)
    assert build.returncode == 0, build.stderr
    out = subprocess.run([str(folder / "check")], capture_output=True, text=True, check=True).stdout
    return np.array([[float(v) for v in line.split()] for line in out.splitlines()])


@needs_cc
@pytest.mark.subprocess
@pytest.mark.parametrize("name", ["cart-pendulum", "heavy-top"])
def test_c_inverse_dynamics_matches_python(name, tmp_path):
    eqs = lg.derive(lg.load(name))
    rng = np.random.default_rng(11)
    N, n, k = 6, eqs.n, len(eqs.inputs)
    Q, QD, QDD = (rng.uniform(-2, 2, (N, n)) for _ in range(3))
    U = rng.uniform(-1, 1, (N, k))
    t = rng.uniform(0, 1, N)
    tau = c_inverse_dynamics(eqs, name.replace("-", "_"), tmp_path, t, Q, QD, QDD, U)
    inputs = {u.name: U[:, i] for i, u in enumerate(eqs.inputs)}
    expected = lg.inverse_dynamics(eqs, Q, QD, QDD, t=t, inputs=inputs).tau
    np.testing.assert_allclose(tau, expected, rtol=1e-12, atol=1e-12)


@needs_cc
@pytest.mark.subprocess
def test_c_inverse_dynamics_of_a_constrained_model_is_the_total(tmp_path):
    eqs = lg.derive(lg.load("four-bar"))
    traj = lg.simulate(eqs, 0.3, inputs={"tau": "0.3"}, dt=0.05, rtol=1e-11, atol=1e-11)
    nm = lg.compile(eqs, "scipy")
    qdd = np.array([nm.accelerations(t, x, [0.3], nm.parameter_values) for t, x in zip(traj.t, traj.x)])
    Q, QD = traj.x[:, :3], traj.x[:, 3:]
    U = np.full((len(traj.t), 1), 0.1)
    tau = c_inverse_dynamics(eqs, "four_bar", tmp_path, traj.t, Q, QD, qdd, U)
    expected = lg.inverse_dynamics(eqs, Q, QD, qdd, t=traj.t, inputs={"tau": 0.1})
    np.testing.assert_allclose(tau, expected.total, rtol=1e-12, atol=1e-12)
    assert np.abs(expected.tau[:, 0] - 0.2).max() < 1e-9  # 0.3 drives the motion, 0.1 is given: 0.2 more
    header = (tmp_path / "four_bar.h").read_text()
    assert "void four_bar_inverse_dynamics(double t, const double *q, const double *qd, const double *qdd" in header
    assert "tau_a + G^T lambda" in header
