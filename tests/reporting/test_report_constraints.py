"""The derivation report of constrained models and of models with frames and bodies in space: the
constraints (g = 0, G, the multipliers, G^T lambda, G q_ddot = c) and the equations with their
constraint forces as steps, the frames' rotations as elementary rotations with the angular
velocities derived from them, and the sections that read differently with multipliers (state
equations, mass-matrix diagnosis, equilibria) saying so. Every report builds in its three formats."""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET

import pytest
import sympy

import lagrangian as lg
from lagrangian.cli import main
from lagrangian.model._frames import angular_velocity, elementary
from lagrangian.model._kinematics import Kinematics
from lagrangian.reporting import Math, Paragraph, Table

S = sympy.Symbol
x, y, xd, yd, xdd, ydd, lam, m, g, l = (S(n) for n in ("x", "y", "x_dot", "y_dot", "x_ddot", "y_ddot", "lambda_rod",
                                                       "m", "g", "l"))
r = sympy.sqrt(x**2 + y**2)


def same(a, b) -> bool:
    a = a if isinstance(a, sympy.MatrixBase) else sympy.Matrix([a])
    b = b if isinstance(b, sympy.MatrixBase) else sympy.Matrix([b])
    return a.shape == b.shape and all(sympy.simplify(p - q) == 0 for p, q in zip(a, b))


def text_of(section) -> str:
    return "\n".join(b.text() for b in section.blocks if isinstance(b, Paragraph))


def builds(rep) -> dict:
    """The three formats, with every MathML element well-formed XML."""
    pages = {"html": rep.to_html(), "md": rep.to_markdown(), "tex": rep.to_latex()}
    for m_ in re.findall(r"<math\b.*?</math>", pages["html"], re.S):
        ET.fromstring(m_)
    assert "\\begin{document}" in pages["tex"] and "\\end{document}" in pages["tex"]
    return pages


@pytest.fixture(scope="module")
def pendulum():
    return lg.report("cartesian-pendulum")


# ----------------------------------------------------------------------------- the Cartesian pendulum
@pytest.mark.slow
def test_a_constrained_report_has_a_constraints_section_and_numbers_its_sections_in_order(pendulum):
    assert [s.key for s in pendulum.sections] == [
        "bodies", "coordinates", "kinematics", "energies", "dissipation", "forces", "constraints", "lagrangian",
        "equations", "matrix-form", "state-form", "singularities", "equilibria"]
    assert [s.title.split(". ")[0] for s in pendulum.sections] == [str(i) for i in range(1, 14)]
    assert pendulum.section("constraints").title == "7. Constraints"
    assert text_of(pendulum.section("coordinates")).startswith(
        "2 generalized coordinates, complete but not independent: 1 holonomic constraint relates them")


def test_the_constraints_section_derives_g_G_lambda_the_constraint_forces_and_c(pendulum):
    eq = lg.derive(lg.load("cartesian-pendulum"))
    rod = pendulum.math("constraint[rod]")
    assert rod.rhs == 0 and same(rod.lhs, l - r)
    assert same(pendulum.expression("constraint-jacobian"), sympy.Matrix([[-x / r, -y / r]]))
    assert pendulum.expression("multipliers") == sympy.Matrix([lam])
    assert same(pendulum.expression("constraint-forces"), sympy.Matrix([-lam * x / r, -lam * y / r]))
    assert sympy.sstr(pendulum.math("constraint-forces").lhs) == "G^T*lambda"
    assert same(pendulum.expression("c"), eq.constraint_acceleration)
    text = text_of(pendulum.section("constraints"))
    assert "Constraint rod, holonomic, multiplier lambda_rod:" in text
    assert "the constraints read G*q_ddot = c, with c = -dw/dq*q_dot + -dw/dt:" in text
    assert "at velocity level the constraints read G*q_dot + b = 0" in text


def test_each_lagrange_equation_gains_its_constraint_force(pendulum):
    generic = pendulum.section("equations").blocks[0].text()
    assert "= Q_i + Sum(G_ki*lambda_k, (k, 1, m))" in generic
    for q, qd, Gi, expected in ((x, xd, -x / r, m * xdd + lam * x / r), (y, yd, -y / r, m * ydd + m * g + lam * y / r)):
        law = pendulum.math(f"lagrange[{q.name}]")
        assert sympy.sstr(law.rhs[1]).startswith("(G^T*lambda)_")
        assert same(pendulum.expression(f"constraint-force[{q.name}]"), lam * Gi)
        eq_ = pendulum.math(f"equation[{q.name}]")
        assert eq_.rhs == 0 and same(eq_.lhs, expected)
        # the steps add up: d/dt dL/dq_dot - dL/dq - Q - (G^T lambda)_i = E_i
        i = 1 if q == x else 2
        pieces = (pendulum.expression(f"d/dt dL/d{qd.name}") - pendulum.expression(f"dL/d{q.name}")
                  - pendulum.expression(f"Q_{i}") - pendulum.expression(f"constraint-force[{q.name}]"))
        assert same(pieces, expected)


def test_the_matrix_form_with_multipliers_and_the_saddle_point_system(pendulum):
    sides = lambda key: tuple(  # noqa: E731
        " + ".join(map(sympy.sstr, s)) if isinstance(s, tuple) else sympy.sstr(s)
        for s in (pendulum.math(key).lhs, pendulum.math(key).rhs))
    assert sides("matrix-form") == ("M*q_ddot + C*q_dot + dV/dq", "Q + G^T*lambda")
    assert sides("matrix-form-constraints") == ("G*q_ddot", "c")
    assert sides("constrained-form") == ("M*q_ddot", "f + G^T*lambda")
    saddle = pendulum.math("saddle-point")
    assert saddle.rhs == sympy.ImmutableMatrix([S("f"), S("c")])
    assert sympy.sstr(saddle.lhs).replace("\n", "").replace(" ", "") == \
        "Matrix([[M,G^T],[G,0]])*Matrix([[q_ddot],[-lambda]])"
    assert same(pendulum.expression("G"), sympy.Matrix([0, g * m]))  # dV/dq, shown as such
    assert sympy.sstr(pendulum.math("G").lhs) == "dV/dq"
    assert same(pendulum.expression("f"), sympy.Matrix([0, -g * m]))
    md = builds(pendulum)["md"]
    assert r"M \ddot{q} = f + G^{T} \lambda" in md and r"G \ddot{q} = c" in md


def test_sections_that_read_differently_with_multipliers_say_so(pendulum):
    state = text_of(pendulum.section("state-form"))
    assert "with q_ddot (and lambda) from the saddle-point system" in state and "q_ddot" not in pendulum.keys()
    assert "projects the state back onto the constraints after every step" in state
    assert pendulum.expression("x_dot") == sympy.Matrix([S("q_dot"), S("q_ddot")])  # not M^-1 f
    diagnosis = pendulum.section("singularities")
    assert diagnosis.title == "12. Mass matrix and constraints diagnosis"
    assert "the saddle-point matrix [M, G^T; G, 0] rather than M alone" in text_of(diagnosis)
    assert "G has full rank at every configuration: det(G G^T) does not vanish." in text_of(diagnosis)
    assert pendulum.expression("det G G^T") == 1  # G is a unit vector
    assert ("It is conserved: L does not depend on t explicitly, D = 0 and Q = 0, and the constraints do no work "
            "(they do not depend on t).") in text_of(pendulum.section("lagrangian"))


def test_the_equilibria_section_gives_the_multipliers(pendulum):
    section = pendulum.section("equilibria")
    assert "f + G^T*lambda = 0 and g = 0, solved for q and the multipliers" in text_of(section)
    (table,) = [b for b in section.blocks if isinstance(b, Table)]
    assert table.header == ("", "configuration", "multipliers", "stability", "eigenvalues")
    bottom, top = table.rows
    assert sympy.sstr(bottom[1]) == "(Eq(x, 0), Eq(y, -l))" and sympy.sstr(bottom[2]) == "Eq(lambda_rod, g*m)"
    assert bottom[3] == "stable" and top[3] == "unstable" and sympy.sstr(top[2]) == "Eq(lambda_rod, -g*m)"


# ----------------------------------------------------------------------------- the four-bar
@pytest.mark.slow
def test_four_bar_report_shows_its_loop_its_independent_crank_and_its_equilibria():
    rep = lg.report("four-bar")
    eq = lg.derive(lg.load("four-bar"))
    builds(rep)
    assert same(rep.expression("constraint-jacobian"), eq.constraint_jacobian)
    assert same(rep.math("constraint[loop_y]").lhs, sympy.sympify("a*sin(th1) + b*sin(th2) - c*sin(th3)"))
    assert "The independent coordinates ([simulation] independent): th1; the constraints fix the others." in \
        text_of(rep.section("constraints"))
    for q, E in zip(eq.coordinates, eq.equations):
        assert same(rep.math(f"equation[{q.name}]").lhs, E)
    th1 = S("th1")
    assert same(rep.expression("constraint-force[th1]"),
                -S("a") * S("lambda_loop_x") * sympy.sin(th1) + S("a") * S("lambda_loop_y") * sympy.cos(th1))
    a, b, c = S("a"), S("b"), S("c")
    th2, th3 = S("th2"), S("th3")
    assert same(rep.expression("det G G^T"), a**2 * b**2 * sympy.sin(th1 - th2) ** 2
                + a**2 * c**2 * sympy.sin(th1 - th3) ** 2 + b**2 * c**2 * sympy.sin(th2 - th3) ** 2)
    assert "Dead points of th1 ([simulation] independent): none found on the constraints" in \
        text_of(rep.section("singularities"))
    (table,) = [b for b in rep.section("equilibria").blocks if isinstance(b, Table)]
    assert [row[3] for row in table.rows] == ["stable", "stable", "unstable", "unstable"]
    assert "there may be others" in text_of(rep.section("equilibria"))


@pytest.mark.slow
def test_a_velocity_constraint_is_shown_and_its_equilibria_are_not_invented():
    knife = lg.Model("knife", coordinates=["x", "y", "phi"], parameters={"m": 1.0, "J": 0.1})
    knife.add_energy(T="m*(x_dot**2 + y_dot**2)/2 + J*phi_dot**2/2")
    knife.add_velocity_constraint("x_dot*sin(phi) - y_dot*cos(phi)", name="blade")
    rep = lg.report(knife)
    builds(rep)
    phi = S("phi")
    assert same(rep.math("constraint[blade]").lhs, S("x_dot") * sympy.sin(phi) - S("y_dot") * sympy.cos(phi))
    assert "Constraint blade, velocity (nonholonomic), multiplier lambda_blade:" in text_of(rep.section("constraints"))
    assert same(rep.expression("constraint-jacobian"), sympy.Matrix([[sympy.sin(phi), -sympy.cos(phi), 0]]))
    assert "1 velocity constraint restrict their velocities to 2 free combinations" in \
        text_of(rep.section("coordinates"))
    (table,) = [b for b in rep.section("equilibria").blocks if hasattr(b, "rows")]  # no force: at rest anywhere
    assert [row[3] for row in table.rows] == ["marginally stable (non-isolated: any phi)"]


# ----------------------------------------------------------------------------- frames and bodies in space
@pytest.mark.slow
def test_heavy_top_report_derives_its_frame_rotation_and_angular_velocity():
    rep = lg.report("heavy-top", equilibria=False)
    builds(rep)
    phi, theta, psi = S("phi"), S("theta"), S("psi")
    R = elementary((0, 0, 1), phi) * elementary((1, 0, 0), theta) * elementary((0, 0, 1), psi)
    assert same(rep.expression("rotation[body]"), R)
    (product,) = [p for b in rep.section("bodies").blocks if isinstance(b, Paragraph)
                  for p in b.parts if isinstance(p, Math) and sympy.sstr(p.lhs) == "R_body"]
    assert sympy.sstr(product.rhs) == "R_z(phi)*R_x(theta)*R_z(psi)"
    assert rep.expression("origin[body]") == sympy.Matrix([0, 0, 0])
    # omega: one term per elementary rotation, carried into the body's axes by the rotations after it
    pd, td, sd = S("phi_dot"), S("theta_dot"), S("psi_dot")
    terms = rep.math("omega-terms[body]").rhs
    assert len(terms) == 3
    assert same(terms[0], sympy.Matrix([pd * sympy.sin(theta) * sympy.sin(psi), pd * sympy.sin(theta) * sympy.cos(psi),
                                        pd * sympy.cos(theta)]))
    assert same(terms[1], sympy.Matrix([td * sympy.cos(psi), -td * sympy.sin(psi), 0]))
    assert same(terms[2], sympy.Matrix([0, 0, sd]))
    total = terms[0] + terms[1] + terms[2]
    assert same(rep.expression("frame-omega[body]"), total)
    # the same omega as the derivation uses (R^T dR/dt), and the body's in section 3
    model = lg.load("heavy-top")
    kin = Kinematics(model.q, [])
    derived = sympy.Matrix([sympy.sympify(str(w)) for w in angular_velocity(model.frames["body"].factors, kin)])
    assert same(total, derived) and same(rep.expression("omega[top]"), total)
    Rdot = R.applyfunc(lambda e: sum(e.diff(q) * v for q, v in ((phi, pd), (theta, td), (psi, sd))))
    W = (R.T * Rdot).applyfunc(sympy.simplify)
    assert same(total, sympy.Matrix([W[2, 1], W[0, 2], W[1, 0]]))
    assert "Frame body, in frame world: its rotation R_body = R_z(phi)*R_x(theta)*R_z(psi):" in \
        text_of(rep.section("bodies"))
    assert "Gravity, of magnitude g, along (0, 0, -1)" in text_of(rep.section("kinematics"))


def test_chained_frames_compose_their_rotations_origins_and_angular_velocities():
    model = lg.Model("gimbal", coordinates=["a", "b"], parameters={"m": 1.0, "h": 0.5, "d": 0.2})
    model.add_frame("yoke", origin=(0, 0, "h"), rotation=[("z", "a")])
    model.add_frame("ring", parent="yoke", origin=("d", 0, 0), rotation=[("x", "b")])
    model.add_rigid_body("m", (1, 2, 3), frame="ring", name="rotor")
    rep = lg.report(model, equilibria=False)
    builds(rep)
    a, b, h, d = S("a"), S("b"), S("h"), S("d")
    assert same(rep.expression("rotation[ring]"), elementary((1, 0, 0), b))  # relative to its parent
    assert same(rep.expression("origin[ring]"), sympy.Matrix([d * sympy.cos(a), d * sympy.sin(a), h]))
    ad, bd = S("a_dot"), S("b_dot")
    assert same(rep.expression("frame-omega[yoke]"), sympy.Matrix([0, 0, ad]))
    assert same(rep.expression("frame-omega[ring]"), sympy.Matrix([bd, ad * sympy.sin(b), ad * sympy.cos(b)]))
    assert same(rep.expression("omega[rotor]"), rep.expression("frame-omega[ring]"))


@pytest.mark.slow
def test_the_report_command_writes_constrained_reports(tmp_path, capsys):
    out = tmp_path / "four-bar.html"
    assert main(["report", "four-bar", "-o", str(out), "--no-equilibria"]) == 0
    page = out.read_text()
    assert "7. Constraints" in page and "Equilibria and stability" not in page
    assert main(["report", "spherical-pendulum-3d", "-o", "-", "--format", "md", "--no-equilibria"]) == 0
    assert "## 7. Constraints" in capsys.readouterr().out


@pytest.mark.parametrize("name", ["cartesian-pendulum", "four-bar", "heavy-top"])
@pytest.mark.slow
@pytest.mark.subprocess
def test_the_latex_of_constrained_and_spatial_reports_compiles(name, tmp_path):
    import shutil
    import subprocess

    tex = lg.report(name, equilibria=False).to_latex()
    assert tex.isascii() and tex.count("\\[") == tex.count("\\]")
    latex = shutil.which("pdflatex")
    if latex is None:
        pytest.skip("pdflatex is not installed (apt-get install texlive-latex-base): the .tex was checked "
                    "but not compiled")
    (tmp_path / "r.tex").write_text(tex)
    run = subprocess.run([latex, "-interaction=nonstopmode", "-halt-on-error", "r.tex"], cwd=tmp_path,
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stdout[-3000:]
