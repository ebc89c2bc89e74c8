"""The playground's HTTP API, against the real server (`lagrangian serve`, one for this module): the
same results as the library and the CLI, every error a user can hit as a JSON body with the CLI's
message, and a server that stays up and responsive through bad models, runaway requests and a
crashed worker."""

from __future__ import annotations

import json
import os
import re
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

import lagrangian as lg
from lagrangian.examples import example_descriptions, example_source
from lagrangian.io import loads_model
from lagrangian.errors import ModelFileError

from serve_support import Server, alive, wait_until

OSCILLATOR = ('name = "osc"\ncoordinates = ["x"]\n\n[parameters]\nm = 1.0\nk = 4.0\n\n'
              '[energy]\nT = "m*x_dot**2/2"\nV = "k*x**2/2"\n')
#: docs/model-files.md's file with three mistakes
BAD = ('coordinates = ["q1", "q2"]\n\n[parameters]\nm = "2"\ng = 9.81\n\n[energy]\n'
       'T = "1/2*m*q1_dot**2 + 1/2*m*q2_dot**2"\nV = "m*g*q3 + 1/2*k*q1_dot**2"\nD = "c*"\n')


@pytest.fixture(scope="module")
def server():
    s = Server(workers=2, time_limit=60)
    yield s
    code, out, err = s.stop()
    assert code == 0 and "lagrangian serve: stopped" in out, (code, out, err)
    assert "Traceback" not in err, err


# ------------------------------------------------------------------ derive
@pytest.mark.slow
@pytest.mark.subprocess
def test_derive_returns_the_json_of_derive_json(server):
    text = example_source("cart-pendulum")
    status, headers, body = server.request("POST", "/api/derive", text)
    assert status == 200 and headers["Content-Type"] == "application/json"
    cli = subprocess.run([sys.executable, "-m", "lagrangian", "derive", "cart-pendulum", "--json"],
                         capture_output=True, text=True, check=True).stdout
    assert body.decode() == cli  # the same bytes as `lagrangian derive --json`
    assert json.loads(body)["mass_matrix"] == [["M1 + M2", "-L*M2*sin(q2)"], ["-L*M2*sin(q2)", "L**2*M2"]]


@pytest.mark.subprocess
def test_derive_reports_every_problem_at_its_line_with_the_cli_message(server):
    status, data = server.post_json("/api/derive", BAD)
    assert status == 400
    with pytest.raises(ModelFileError) as exc:
        loads_model(BAD)
    assert data == {"errors": [{"line": p.line, "key": p.key, "message": p.message} for p in exc.value.problems]}
    lines = [(e["line"], e["key"]) for e in data["errors"]]
    assert lines == [(4, "parameters.m"), (9, "energy.V"), (10, "energy.D")]
    assert data["errors"][0]["message"] == ("expected a number, got the string '2'; "
                                            "write m = 2 (a number, without quotes)")
    assert data["errors"][1]["message"].startswith("unknown names 'q3' (did you mean 'q2'?), "
                                                   "'k' in the expression at position 5")
    assert data["errors"][2]["message"].startswith("malformed expression at position 2: missing operand after '*'")


@pytest.mark.parametrize("body, message", [
    (b"", "the request body is empty: send the model file's text"),
    (b"\xff\xfe not text", "the request body is not UTF-8 text (the byte at offset 0 cannot be decoded)"),
    (b"coordinates = [", "line 1"),
])
@pytest.mark.subprocess
def test_derive_refuses_bodies_that_are_not_model_files(server, body, message):
    status, data = server.post_json("/api/derive", body)
    assert status == 400
    assert message in data["errors"][0]["message"] or data["errors"][0]["line"] == 1, data


@pytest.mark.subprocess
def test_a_body_over_the_size_limit_is_refused_with_413(server):
    status, data = server.post_json("/api/derive", "#" * (1024 * 1024 + 10))
    assert status == 413
    assert data["errors"][0]["message"] == ("the request body has 1048586 bytes, more than the limit of 1048576 bytes "
                                            "(1024 KiB): a model file is a few kilobytes")
    try:  # a body over 16 MiB is not even read: answered 413 at once and the connection closed
        status, headers, body = server.request("POST", "/api/derive", "#" * (20 * 1024 * 1024))
        assert status == 413 and b"the request body has 20971520 bytes" in body
    except (BrokenPipeError, ConnectionResetError):
        pass  # the client was still sending when the server closed
    assert server.request("GET", "/api/info")[0] == 200  # still serving


@pytest.mark.subprocess
def test_a_foreign_host_header_is_refused(server):
    status, data = server.post_json("/api/derive", OSCILLATOR, headers={"Host": "evil.example:80"})
    assert status == 403
    assert data["errors"][0]["message"] == ("this server answers requests for 127.0.0.1 and localhost only, not for "
                                            f"'evil.example'; open http://127.0.0.1:{server.port}/ (or start it with "
                                            "--host to serve other addresses)")  # this server's port, not the Host's
    assert server.post_json("/api/derive", OSCILLATOR, headers={"Host": f"localhost:{server.port}"})[0] == 200


# ------------------------------------------------------------------ requests of other web pages
def _refusal(server, why, own=None):
    own = own or f"http://127.0.0.1:{server.port}"
    return (f"cross-site request refused: {why}, not from this server's own page at {own}; the playground's API "
            f"answers its own page and scripts only. Open the playground at {own}/ (a script sends its requests "
            "without an Origin header)")


def _no_cors(headers):
    assert not [k for k in headers if k.lower().startswith("access-control-")], headers


@pytest.mark.parametrize("origin, why", [
    ("http://evil.example", "it comes from the web page at 'http://evil.example' (its Origin header)"),
    ("null", "it comes from a page with an opaque origin "
             "(Origin: null: a sandboxed frame, a local file or a redirect)"),
    ("http://localhost:{port}", "it comes from the web page at 'http://localhost:{port}' (its Origin header)"),
    ("http://127.0.0.1:{other}", "it comes from the web page at 'http://127.0.0.1:{other}' (its Origin header)"),
    ("https://127.0.0.1:{port}", "it comes from the web page at 'https://127.0.0.1:{port}' (its Origin header)"),
    ("http://127.0.0.1:{port}/x", "it comes from the web page at 'http://127.0.0.1:{port}/x' (its Origin header)"),
])
@pytest.mark.subprocess
def test_a_request_from_another_web_page_is_refused_before_any_work(server, origin, why):
    """A page elsewhere (another site, a sandboxed frame, another port of this machine, the other
    loopback name) gets 403 for any API request, JSON or not, and no CORS permission."""
    values = {"port": server.port, "other": server.port + 1}
    origin, why = origin.format(**values), why.format(**values)
    for method, path, body, headers in [
            ("POST", "/api/simulate", {"model": OSCILLATOR, "t_end": 1}, {"Content-Type": "application/json"}),
            ("POST", "/api/derive", OSCILLATOR, {"Content-Type": "text/plain"}),  # a "simple" request
            ("GET", "/api/examples", None, {})]:
        status, got, data = server.request(method, path, body, headers={"Origin": origin, **headers})
        assert status == 403 and json.loads(data)["errors"][0]["message"] == _refusal(server, why), (path, data)
        _no_cors(got)


@pytest.mark.subprocess
@pytest.mark.slow
def test_the_page_s_own_origin_is_served_by_the_name_it_was_opened_with(server):
    """The page's own requests (Origin = http://HOST:PORT as the browser addressed the server: any
    loopback name, a port forwarded by a tunnel) are answered, JSON bodies for every endpoint:
    {"model": TEXT} where the text is taken."""
    raw = server.request("POST", "/api/derive", OSCILLATOR)[2]
    for host in ("127.0.0.1", "localhost", "[::1]"):
        own = {"Host": f"{host}:{server.port}", "Origin": f"http://{host}:{server.port}",
               "Content-Type": "application/json; charset=utf-8"}
        status, headers, body = server.request("POST", "/api/derive", {"model": OSCILLATOR}, headers=own)
        assert status == 200 and body == raw, body[:300]  # the bytes of the text sent as it is
        _no_cors(headers)
    tunnel = {"Host": "localhost:9000", "Origin": "http://localhost:9000", "Content-Type": "application/json"}
    assert server.request("POST", "/api/derive", {"model": OSCILLATOR}, headers=tunnel)[2] == raw  # ssh -L 9000:...
    own = {"Origin": f"http://127.0.0.1:{server.port}", "Content-Type": "application/json"}
    status, data = server.post_json("/api/simulate", {"model": OSCILLATOR, "t_end": 1, "dt": 0.5}, headers=own)
    assert status == 200 and data["columns"]["t"] == [0.0, 0.5, 1.0]
    status, headers, body = server.request("POST", "/api/report?format=md", {"model": example_source("mck")},
                                           headers=own)
    assert status == 200 and body.decode() == lg.report("mck").render("md")
    status, data = server.post_json("/api/analysis", {"model": OSCILLATOR}, headers=own)
    assert status == 200 and data["coordinates"] == ["x"]
    status, data = server.post_json("/api/derive", OSCILLATOR, headers=own)  # declared JSON, sent as text
    assert status == 400 and data["errors"][0]["message"] == (
        "the request body is not valid JSON (Expecting value at line 1, column 1): send an object such as "
        "{\"model\": \"coordinates = [\\\"x\\\"] ...\"} (or send the model file's text itself with another "
        "Content-Type, such as text/plain)")
    status, data = server.post_json("/api/derive", {"text": OSCILLATOR}, headers=own)
    assert status == 400 and [e["message"] for e in data["errors"]] == [
        "unknown field 'text'; the fields are model",
        "the field 'model' is missing: give the model-file text, {\"model\": \"coordinates = [\\\"x\\\"] ...\"}"]


@pytest.mark.parametrize("content_type, said", [("text/plain", "not 'text/plain'"),
                                                ("application/x-www-form-urlencoded",
                                                 "not 'application/x-www-form-urlencoded'"),
                                                (None, "but it declares none")])
@pytest.mark.subprocess
def test_a_post_from_a_page_must_be_json(server, content_type, said):
    """From a page (Origin present, its own), a body that is not application/json is refused with 415:
    the forms a page elsewhere could send without a preflight never reach a worker."""
    headers = {"Origin": f"http://127.0.0.1:{server.port}"}
    if content_type:
        headers["Content-Type"] = content_type
    status, got, data = server.request("POST", "/api/simulate", {"model": OSCILLATOR, "t_end": 1}, headers=headers)
    assert status == 415 and json.loads(data)["errors"][0]["message"] == (
        f"a request from a web page must send its body as Content-Type: application/json, {said}: the playground's "
        "page does so ({\"model\": \"...\"} for the model text); a script can leave out the Origin header and send "
        "the model text as it is")
    _no_cors(got)


@pytest.mark.subprocess
def test_scripts_without_an_origin_send_the_model_text_as_they_like(server):
    """curl --data-binary (form-urlencoded), text/plain, or no content type: as documented."""
    raw = server.request("POST", "/api/derive", OSCILLATOR)[2]
    for content_type in ("text/plain", "application/x-www-form-urlencoded", "application/toml"):
        status, headers, body = server.request("POST", "/api/derive", OSCILLATOR,
                                               headers={"Content-Type": content_type})
        assert status == 200 and body == raw
        _no_cors(headers)
    status, data = server.post_json("/api/simulate", {"model": OSCILLATOR, "t_end": 1, "dt": 0.5},
                                    headers={"Content-Type": "application/x-www-form-urlencoded"})
    assert status == 200 and data["columns"]["t"] == [0.0, 0.5, 1.0]


@pytest.mark.subprocess
def test_a_preflight_gets_no_permission(server):
    status, headers, data = server.request("OPTIONS", "/api/simulate", headers={
        "Origin": "http://evil.example", "Access-Control-Request-Method": "POST",
        "Access-Control-Request-Headers": "content-type"})
    assert status == 403 and json.loads(data)["errors"][0]["message"] == _refusal(
        server, "it comes from the web page at 'http://evil.example' (its Origin header)")
    _no_cors(headers)
    status, headers, data = server.request("OPTIONS", "/api/simulate")
    assert status == 405 and json.loads(data)["errors"][0]["message"] == "OPTIONS is not allowed on /api/simulate"
    _no_cors(headers)


@pytest.mark.subprocess
def test_a_browser_request_marked_cross_site_is_refused_without_an_origin(server):
    status, headers, data = server.request("POST", "/api/derive", OSCILLATOR, headers={"Sec-Fetch-Site": "cross-site"})
    assert status == 403 and json.loads(data)["errors"][0]["message"] == _refusal(
        server, "the browser says it comes from another site (Sec-Fetch-Site: cross-site)")
    assert server.request("POST", "/api/derive", OSCILLATOR, headers={"Sec-Fetch-Site": "same-origin"})[0] == 200


@pytest.mark.subprocess
def test_the_page_itself_may_be_linked_from_anywhere(server):
    """A link on a lecture's slides opens the page (it computes nothing); its API calls are its own."""
    status, headers, body = server.request("GET", "/?example=mck", headers={"Sec-Fetch-Site": "cross-site"})
    assert status == 200 and b'"name": "mck"' in body
    _no_cors(headers)


@pytest.mark.subprocess
def test_unknown_endpoints_and_methods_answer_json(server):
    status, data = server.post_json("/api/solve", OSCILLATOR)
    assert status == 404 and data["errors"][0]["message"].startswith("no such API endpoint: POST /api/solve")
    status, headers, body = server.request("GET", "/api/derive")
    assert status == 405 and json.loads(body)["errors"][0]["message"] == "GET is not allowed on /api/derive"


# ------------------------------------------------------------------ simulate
def _simulate_body(**kw):
    return {"model": example_source("cart-pendulum"), "t_end": 2.0, "dt": 0.05, "initial": {"q2": "pi/3"},
            "inputs": {"F": "0.5*sin(3*t)"}, "params": {"M1": 2.0}, **kw}


@pytest.mark.subprocess
def test_simulate_returns_the_trajectory_of_simulate(server):
    status, data = server.post_json("/api/simulate", _simulate_body(initial={"q2": 1.0, "q2_dot": -0.5}))
    assert status == 200
    traj = lg.simulate(lg.derive(lg.load("cart-pendulum")), 2.0, {"q2": 1.0, "q2_dot": -0.5}, dt=0.05,
                       inputs={"F": "0.5*sin(3*t)"}, params={"M1": 2.0})
    assert data["names"] == list(traj.columns) == ["t", "q1", "q2", "q1_dot", "q2_dot", "F", "energy"]
    for name in traj.columns:
        assert data["columns"][name] == traj[name].tolist()
    assert data["parameters"]["M1"] == 2.0 and data["energy_name"] == "energy"
    g = data["geometry"]
    assert [n["name"] for n in g["nodes"]] == ["cart", "pendulum", "pendulum pivot"]
    assert len(g["positions"]) == len(g["t"]) == 41 and len(g["positions"][0]) == 3
    # the pendulum's bob is where the model puts it: (q1 + L cos q2, L + L sin q2)
    q1, q2 = data["columns"]["q1"][20], data["columns"]["q2"][20]
    assert g["positions"][20][1] == pytest.approx([q1 + __import__("math").cos(q2), 1 + __import__("math").sin(q2)])


@pytest.mark.subprocess
def test_simulate_takes_a_feedback_law_as_simulate_does(server):
    """An input may be a law of the state (here a saturated LQR with a switch), as on the command
    line; a comparison outside where is refused with the CLI's message."""
    law = "where(abs(q2 - pi/2) < 1, clip(q1 - 41.9*(q2 - pi/2) + 2.56*q1_dot - 11.7*q2_dot, -6, 6), 0)"
    status, data = server.post_json("/api/simulate", _simulate_body(initial={"q2": 1.3}, inputs={"F": law},
                                                                    t_end=10.0, params={}))
    assert status == 200, data
    traj = lg.simulate(lg.derive(lg.load("cart-pendulum")), 10.0, {"q2": 1.3}, dt=0.05, inputs={"F": law})
    for name in traj.columns:
        assert data["columns"][name] == traj[name].tolist()
    assert abs(data["columns"]["q2"][-1] - 1.5707963) < 1e-2
    status, data = server.post_json("/api/simulate", _simulate_body(inputs={"F": "5*(q1 > 0)"}))
    assert status == 400
    assert data["errors"][0]["key"] == "inputs.F"
    assert data["errors"][0]["message"].startswith("the condition 'q1 > 0' is true or false, not a number: use it as "
                                                   "the condition of where(q1 > 0, a, b)")


@pytest.mark.subprocess
def test_simulate_refuses_a_model_that_names_a_file_on_the_server(server, tmp_path):
    (tmp_path / "data.csv").write_text("t,F\n0,1\n10,1\n")
    text = (OSCILLATOR.replace('coordinates = ["x"]', 'coordinates = ["x"]\ninputs = ["F"]')
            + '\n[simulation]\ninputs = { F = "@data.csv:F" }\n')
    for endpoint, body in (("/api/simulate", {"model": text, "t_end": 1}), ("/api/derive", text)):
        status, data = server.post_json(endpoint, body)
        assert status == 400, (endpoint, data)
        [e] = data["errors"]
        assert e["key"] == "simulation.inputs.F"
        assert e["message"].startswith("a model sent to the playground cannot read files on the server; "
                                       "'@data.csv:F' names a CSV file: give F as an expression of t")


@pytest.mark.slow
@pytest.mark.subprocess
def test_simulate_csv_is_the_csv_of_lagrangian_simulate(server, tmp_path):
    status, headers, body = server.request("POST", "/api/simulate?format=csv", _simulate_body())
    assert status == 200 and headers["Content-Type"].startswith("text/csv")
    assert headers["Content-Disposition"] == 'attachment; filename="cart-pendulum.csv"'
    out = tmp_path / "out.csv"
    subprocess.run([sys.executable, "-m", "lagrangian", "simulate", "cart-pendulum", "--t-end", "2", "--dt", "0.05",
                    "--initial", "q2=pi/3", "--input", "F=0.5*sin(3*t)", "--param", "M1=2", "-o", str(out)],
                   check=True, capture_output=True)
    assert body.decode() == out.read_text()


@pytest.mark.subprocess
@pytest.mark.slow
def test_simulate_draws_bodies_in_space_and_follows_a_rolling_disk(server):
    """The page's canvas gets what `lagrangian animate` draws: each body's frame (origin, rotation)
    and link at every frame, the axes' length, the ground under the wheel, and the framing that
    follows the disk (its centre at each frame: the disk's centre of mass)."""
    import numpy as np

    from lagrangian.plot._geometry import grid_step, scene_of

    status, data = server.post_json("/api/simulate", {"model": example_source("rolling-disk"), "t_end": 4.0,
                                                      "dt": 0.05})
    assert status == 200, data
    g = data["geometry"]
    traj = lg.simulate(lg.load("rolling-disk"), 4.0, dt=0.05)
    scene = scene_of(lg.load("rolling-disk"))
    ((disk, drawing),) = zip(scene.spatial, scene.body_drawings(traj.t, traj.q, g["axis_length"]))
    (body,) = g["spatial"]
    assert (body["name"], body["frame"], body["radius"], body["axis"]) == (disk.name, disk.frame, 0.3, 1)
    np.testing.assert_allclose(body["origin"], drawing.origin, atol=2e-9)
    np.testing.assert_allclose(np.reshape(body["rotation"], (-1, 3, 3)), drawing.rotation, atol=2e-9)
    np.testing.assert_allclose(body["link"], drawing.link, atol=2e-9)
    R = np.reshape(body["rotation"], (-1, 3, 3))
    np.testing.assert_allclose(R @ np.swapaxes(R, 1, 2), np.broadcast_to(np.eye(3), R.shape), atol=1e-8)
    assert g["axis_length"] == pytest.approx(0.2 * 0.6)  # a fifth of the disk's diameter
    f = g["framing"]
    assert f["follow"] and len(f["centre"]) == len(g["t"]) == 81
    P = np.array(g["positions"])
    i = [n["name"] for n in g["nodes"]].index("coin")
    np.testing.assert_allclose(f["centre"], P[:, i], atol=1e-8)  # the only mass: the coin
    assert g["ground"]["step"] == grid_step(2 * (max(f["half"][:2]) + 0.12 * f["size"]))
    status, top = server.post_json("/api/simulate", {"model": example_source("heavy-top"), "t_end": 0.5})
    assert status == 200 and not top["geometry"]["framing"]["follow"]
    assert len(top["geometry"]["framing"]["centre"]) == 1 and top["geometry"]["ground"] is None


@pytest.mark.slow
@pytest.mark.subprocess
def test_a_closed_loop_simulates_from_the_values_the_page_sends(server):
    """The analysis says which initial values a simulation takes as given (the four-bar's crank
    angle and speed; its other angles are guesses that the loop corrects), and sent so, the
    trajectory is simulate's default one; sending every angle, as a page that knew nothing of the
    constraints would, gets the library's message about the loop."""
    status, a = server.post_json("/api/analysis", example_source("four-bar"))
    assert status == 200 and a["given"] == ["th1", "th1_dot"]
    body = {"model": example_source("four-bar"), "t_end": 1.0, "dt": 0.05, "initial": {"th1": 1.2, "th1_dot": 4.0}}
    status, data = server.post_json("/api/simulate", body)
    assert status == 200, data
    traj = lg.simulate(lg.load("four-bar"), 1.0, dt=0.05)
    for name in ("th1", "th2", "th3", "lambda_loop_x"):
        assert data["columns"][name] == pytest.approx(traj[name].tolist(), abs=1e-12)
    status, data = server.post_json("/api/simulate", dict(body, initial={"th1": 1.2, "th2": 0.2, "th3": 1.4}))
    assert status == 400
    assert data["errors"][0]["message"].startswith("the initial coordinates do not meet constraint 'loop_x'")


@pytest.mark.subprocess
def test_a_model_with_energies_only_simulates_and_says_why_it_is_not_drawn(server):
    status, data = server.post_json("/api/simulate", {"model": OSCILLATOR, "t_end": 1, "initial": {"x": 1}})
    assert status == 200 and data["geometry"] is None
    assert data["not_drawable"].startswith("model 'osc' cannot be drawn: it is described by its energies")
    assert data["columns"]["x"][-1] == pytest.approx(__import__("math").cos(2.0), abs=1e-7)


@pytest.mark.parametrize("body, status, message", [
    ("not json", 400, "the request body is not valid JSON (Expecting value at line 1, column 1)"),
    ([1, 2], 400, "the request body must be a JSON object with the fields model, t_end"),
    ({"t_end": 1}, 400, "the field 'model' is missing"),
    ({"model": 3}, 400, "the field 'model' must be the model file's text (a string), got int"),
    ({"model": OSCILLATOR, "t_ned": 1}, 400, "unknown field 't_ned' (did you mean 't_end'?)"),
    ({"model": OSCILLATOR, "t_end": -1}, 400, "t_end: expected a positive number, got -1.0"),
    ({"model": OSCILLATOR, "t_end": "soon"}, 400, "t_end: 'soon' is not a number"),
    ({"model": OSCILLATOR, "initial": [1]}, 400, "initial: expected an object {name: value}, got [1]"),
    ({"model": OSCILLATOR, "initial": {"x": True}}, 400, "initial.x: expected a number, got true"),
    ({"model": OSCILLATOR, "initial": {"y": 1}, "t_end": 1}, 400, "'y'"),
    ({"model": OSCILLATOR, "params": {"kk": 1}, "t_end": 1}, 400, "'kk'"),
    ({"model": OSCILLATOR, "inputs": {"F": [1]}, "t_end": 1}, 400, "inputs.F: expected an expression of t"),
    ({"model": OSCILLATOR, "method": "Euler", "t_end": 1}, 400, "unknown method 'Euler'"),
    ({"model": OSCILLATOR, "t_end": 1000, "dt": 0.001}, 400,
     "the simulation would output 1000001 rows (t_end / dt + 1), more than the limit of 100000 per request"),
    ({"model": OSCILLATOR}, 400, "t_end is needed"),
    ({"model": BAD, "t_end": 1}, 400, "expected a number, got the string '2'"),
])
@pytest.mark.subprocess
def test_simulate_errors(server, body, status, message):
    got, data = server.post_json("/api/simulate", body)
    assert got == status, data
    assert any(message in e["message"] for e in data["errors"]), data


@pytest.mark.subprocess
def test_every_problem_of_a_request_is_reported_at_once(server):
    body = {"model": OSCILLATOR, "t_ned": 1, "t_end": -1, "dt": "soon", "initial": {"x": True, "x_dot": [1]},
            "inputs": {"F": [1]}, "method": 3}
    status, data = server.post_json("/api/simulate", body)
    assert status == 400
    assert [e["message"].split(":")[0] for e in data["errors"]] == [
        "unknown field 't_ned' (did you mean 't_end'?); the fields are model, t_end, initial, inputs, params, dt, "
        "rtol, atol, method", "t_end", "dt", "initial.x", "initial.x_dot", "inputs.F", "method",
        "'F' is not an input of the model; the choices are none"], data
    assert data["errors"][5]["message"].startswith("inputs.F: expected an expression of t, the coordinates and "
                                                   "velocities (a string such as")
    status, data = server.post_json("/api/fmu", {"model": OSCILLATOR, "params": {"m": "heavy", "k": None},
                                                 "initial": 3})
    assert status == 400 and [e["message"] for e in data["errors"]] == [
        "params.m: 'heavy' is not a number (unknown name 'heavy'); write e.g. 0.5 or pi/2",
        "params.k: expected a number, got null", "initial: expected an object {name: value}, got 3"], data


@pytest.mark.parametrize("path, body", [("/api/derive", "cart-pendulum\n"),
                                        ("/api/simulate", {"model": "pendulum-chain-3", "t_end": 1})])
@pytest.mark.subprocess
def test_an_example_s_name_instead_of_its_text_says_how_to_get_the_text(server, path, body):
    status, data = server.post_json(path, body)
    name = "cart-pendulum" if path == "/api/derive" else "pendulum-chain-3"
    assert status == 400 and data["errors"] == [{"line": None, "key": None, "message": (
        f"'{name}' is the name of a built-in example, not a model file's text: send its text "
        f"(GET /api/examples/{name} gives it, as {{\"name\", \"text\"}})")}]


@pytest.mark.subprocess
def test_a_simulation_that_reaches_a_singular_mass_matrix_is_a_422_with_the_diagnosis(server):
    status, data = server.post_json("/api/simulate", {"model": example_source("cart-pendulum-massless"), "t_end": 5})
    assert status == 422
    message = data["errors"][0]["message"]
    assert message.startswith("the mass matrix became singular at t = 0.549")
    assert "det M = L**2*M**2*cos(q2)**2" in message


@pytest.mark.subprocess
def test_simulate_format_must_be_json_or_csv(server):
    status, data = server.post_json("/api/simulate?format=xml", _simulate_body())
    assert status == 400 and data["errors"][0]["message"] == "format 'xml': choose json (the default) or csv"


# ------------------------------------------------------------------ analysis, equilibria, report
@pytest.mark.subprocess
def test_analysis_gives_the_reports_sections_as_mathml(server):
    status, data = server.post_json("/api/analysis", example_source("double-pendulum"))
    assert status == 200
    keys = [s["key"] for s in data["sections"]]
    assert keys == [s.key for s in lg.report("double-pendulum", equilibria=False).sections]
    equations = next(s for s in data["sections"] if s["key"] == "equations")
    assert equations["title"] == "8. Lagrange's equations" and equations["html"].count("<math") >= 2
    assert data["simulation"] == {"t_end": 20.0, "dt": 0.01, "initial": {"theta1": 2.0, "theta2": 2.5}}
    assert data["drawable"] and data["parameters"] == {"m1": 1.0, "m2": 1.0, "l1": 1.0, "l2": 1.0, "g": 9.81}


@pytest.mark.slow
@pytest.mark.subprocess
def test_equilibria_with_slider_values_and_the_modes_of_the_stable_ones(server):
    status, data = server.post_json("/api/equilibria", {"model": example_source("rotating-pendulum"),
                                                        "params": {"Omega": 6.0}})
    assert status == 200
    found = lg.equilibria(lg.derive(lg.load("rotating-pendulum")), params={"Omega": 6.0})
    assert data["equilibria"] == [e.to_dict() for e in found]
    assert [e["stable"] for e in data["equilibria"]] == [True, False, True, False]
    stable = found[0]
    assert data["modes"][0] == lg.modes(stable.linear_model).to_dict() and data["modes"][1] is None
    assert "acos" not in data["html"] and "<math" in data["html"] and "exists when g &lt;= Omega**2*l" in data["html"]
    assert data["html"].count("Modes about equilibrium") == 2


@pytest.mark.subprocess
def test_a_model_without_equilibrium_says_why(server):
    status, data = server.post_json("/api/equilibria", {"model": example_source("kepler")})
    assert status == 200 and data["equilibria"] == []
    assert "There is no equilibrium" in data["html"] and "SymPy finds no solution" in data["html"]


@pytest.mark.parametrize("fmt", ["html", "md", "tex"])
@pytest.mark.subprocess
def test_report_is_the_cli_report(server, fmt):
    status, headers, body = server.request("POST", f"/api/report?format={fmt}", example_source("mck"))
    assert status == 200
    assert headers["Content-Disposition"] == f'attachment; filename="mck.{fmt}"'
    assert body.decode() == lg.report("mck").render(fmt)  # what `lagrangian report mck -o mck.FMT` writes


@pytest.mark.subprocess
def test_report_format_is_checked(server):
    status, data = server.post_json("/api/report?format=pdf", OSCILLATOR)
    assert status == 400 and data["errors"][0]["message"] == "format 'pdf': choose html, md or tex"


@pytest.mark.subprocess
def test_fmu_is_the_exported_fmu_with_the_sliders_values_as_start_values(server):
    import io
    import shutil as sh
    import xml.etree.ElementTree as ET
    import zipfile

    status, headers, body = server.request("POST", "/api/fmu", {"model": example_source("cart-pendulum"),
                                                                "params": {"M1": 2.0}, "initial": {"q2": 1.25}})
    assert status == 200 and headers["Content-Type"] == "application/zip"
    assert headers["Content-Disposition"] == 'attachment; filename="cart-pendulum.fmu"'
    archive = zipfile.ZipFile(io.BytesIO(body))
    root = ET.fromstring(archive.read("modelDescription.xml"))
    assert root.get("fmiVersion") == "2.0" and root.get("modelName") == "cart-pendulum"
    starts = {v.get("name"): v[0].get("start") for v in root.iter("ScalarVariable")}
    assert float(starts["M1"]) == 2.0 and float(starts["q2"]) == 1.25 and float(starts["M2"]) == 0.5
    assert "sources/fmu.c" in archive.namelist()
    if sh.which("cc") or sh.which("gcc"):
        assert "binaries/linux64/cart_pendulum.so" in archive.namelist() or "X-Lagrangian-Warnings" in headers
    status, data = server.post_json("/api/fmu", {"model": BAD})
    assert status == 400 and data["errors"][0]["message"].startswith("expected a number, got the string '2'")
    status, data = server.post_json("/api/fmu", {"model": OSCILLATOR, "params": {"k": "x"}})
    assert status == 400 and data["errors"][0]["message"].startswith("params.k: 'x' is not a number")


# ------------------------------------------------------------------ the page and the examples
@pytest.mark.subprocess
def test_examples(server):
    status, headers, body = server.request("GET", "/api/examples")
    assert status == 200 and json.loads(body) == example_descriptions()
    status, headers, body = server.request("GET", "/api/examples/pendulum-chain-3")
    assert json.loads(body) == {"name": "pendulum-chain-3", "text": example_source("pendulum-chain-3")}
    status, data = server.request("GET", "/api/examples/double-pendulm")[0], json.loads(
        server.request("GET", "/api/examples/double-pendulm")[2])
    assert status == 404
    assert data["errors"][0]["message"].startswith("there is no built-in example 'double-pendulm'. Did you mean "
                                                   "'double-pendulum'?")


@pytest.mark.subprocess
def test_the_page_opens_with_an_example_and_ships_its_assets(server):
    status, headers, body = server.request("GET", "/?example=mck")
    page = body.decode()
    assert status == 200 and headers["Content-Type"].startswith("text/html")
    initial = json.loads(page.split('<script id="initial" type="application/json">')[1].split("</script>")[0])
    assert initial["name"] == "mck" and initial["text"] == example_source("mck")
    assert "http" not in page.replace("http://www.w3.org", "")  # nothing fetched from elsewhere
    for asset in ("playground.js", "editor.js", "plots.js", "mechanism.js", "playground.css"):
        path = page.split(f"/static/{asset}")[1].split('"')[0]
        status, headers, body = server.request("GET", f"/static/{asset}{path}")
        assert status == 200 and len(body) > 1000
        assert b"https://" not in body and b"http://" not in body.replace(b"http://www.w3.org", b"")
    status, headers, body = server.request("GET", "/?example=nope")
    assert status == 404 and b"there is no built-in example 'nope'." in body


@pytest.mark.subprocess
def test_info_says_the_limits(server):
    status, headers, body = server.request("GET", "/api/info")
    assert json.loads(body) == {"version": lg.__version__, "workers": 2, "time_limit_s": 60.0,
                                "memory_limit_mib": 2048, "long_workers": 1, "max_body_bytes": 1048576,
                                "max_rows": 100000, "max_frames": 4000, "model": None}


# ------------------------------------------------------------------ robustness
@pytest.mark.slow
@pytest.mark.subprocess
def test_the_server_answers_while_workers_are_busy(server):
    slow = {"model": example_source("double-pendulum"), "t_end": 20, "dt": 0.01, "method": "RK45", "rtol": 1e-11,
            "atol": 1e-11}
    done = {}
    thread = threading.Thread(target=lambda: done.update(r=server.post_json("/api/simulate", slow)))
    thread.start()
    # the simulation holds a worker (the server's /api/status says so), then the rest is answered on the other
    assert wait_until(lambda: server.status()["running"]["long"] == 1, 60), server.status()
    start = time.monotonic()
    assert server.request("GET", "/api/info")[0] == 200
    assert server.request("GET", "/?example=mck")[0] == 200
    assert server.post_json("/api/derive", OSCILLATOR)[0] == 200  # on the other worker
    assert time.monotonic() - start < 5 and "r" not in done
    thread.join()
    assert done["r"][0] == 200


@pytest.mark.slow
@pytest.mark.subprocess
def test_a_runaway_request_is_stopped_at_the_time_limit_and_a_crash_is_survived():
    s = Server(workers=1, time_limit=3)
    try:
        assert s.post_json("/api/derive", OSCILLATOR)[0] == 200
        before = s.worker_pids()
        slow = {"model": example_source("double-pendulum"), "t_end": 5000, "dt": 1, "method": "RK45", "rtol": 1e-12,
                "atol": 1e-12}
        start = time.monotonic()
        status, data = s.post_json("/api/simulate", slow)
        assert status == 422 and time.monotonic() - start < 30
        assert data["errors"][0]["message"].startswith(
            "the simulation took longer than the limit of 3 s per request and was stopped: make the model or the "
            "simulation smaller")
        assert s.post_json("/api/derive", OSCILLATOR)[0] == 200  # a new worker took its place
        after = s.worker_pids()
        assert len(after) == 1 and after != before
        # a worker killed in the middle of a request (a crash): that request fails, the server goes on
        result = {}
        thread = threading.Thread(target=lambda: result.update(r=s.post_json("/api/simulate", slow)))
        thread.start()
        assert wait_until(lambda: s.status()["running"]["long"] == 1, 30), s.status()  # in the worker now
        os.kill(after[0], signal.SIGKILL)
        thread.join()
        status, data = result["r"]
        assert status == 500
        assert "stopped unexpectedly (signal 9)" in data["errors"][0]["message"]
        assert s.post_json("/api/derive", OSCILLATOR)[0] == 200
    finally:
        code, out, err = s.stop()
    assert code == 0 and "Traceback" not in err
    assert wait_until(lambda: not s.worker_pids(), 10)


@pytest.mark.slow
@pytest.mark.subprocess
def test_a_request_past_the_memory_limit_is_a_422_and_the_server_goes_on():
    """The worker's data segment is capped (RLIMIT_DATA) at its footprint plus --memory-limit: a
    simulation whose output (99,901 rows of 41 columns, about 470 MB as JSON) does not fit in 256 MiB
    is refused with a message, its worker replaced, and the next request answered."""
    s = Server("--memory-limit", "256", workers=1, time_limit=120)
    try:
        assert json.loads(s.request("GET", "/api/info")[2])["memory_limit_mib"] == 256
        before = wait_until(s.worker_pids, 10)
        status, data = s.post_json("/api/simulate", {"model": example_source("spring-mass-damper-chain-20"),
                                                     "t_end": 99.9, "dt": 0.001})
        assert status == 422, data
        assert data["errors"][0]["message"] == (
            "the simulation needed more memory than the limit of 256 MiB per request and was stopped: make the "
            "model or the simulation smaller (fewer output rows: a larger dt or a shorter t_end), or start the "
            "server with a larger --memory-limit")
        assert s.status()["replaced"] == 1
        status, data = s.post_json("/api/simulate", {"model": OSCILLATOR, "t_end": 1, "dt": 0.5})
        assert status == 200 and data["columns"]["t"] == [0.0, 0.5, 1.0]
        assert s.worker_pids() != before
    finally:
        code, out, err = s.stop()
    assert code == 0 and "Traceback" not in err, err


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads the processes in /proc")
@pytest.mark.slow
@pytest.mark.subprocess
def test_a_time_out_ends_the_compiler_and_removes_the_request_s_temporary_files(tmp_path):
    """/api/fmu runs the C compiler ($CC: here a stand-in that writes into its temporary folder, starts
    a child and waits); when the request's time is up, the worker, the compiler and its child are
    killed and the request's temporary folder (TMPDIR of the worker and the compiler) is removed."""
    temp, marks = tmp_path / "tmp", tmp_path / "marks"
    temp.mkdir()
    marks.mkdir()
    cc = tmp_path / "slow-cc"
    cc.write_text(f'#!/bin/sh\necho $$ > "{marks}/cc.pid"\nmktemp -d "$TMPDIR/cc-XXXXXX" > "{marks}/cc.tmp"\n'
                  f'sleep 600 &\necho $! > "{marks}/child.pid"\nwait\n')
    cc.chmod(0o755)
    s = Server(workers=1, time_limit=3, env={"CC": str(cc), "TMPDIR": str(temp)})
    try:
        status, data = s.post_json("/api/fmu", {"model": OSCILLATOR})
        assert status == 422 and data["errors"][0]["message"].startswith(
            "the FMU export took longer than the limit of 3 s per request and was stopped")
        pids = [int((marks / f"{name}.pid").read_text()) for name in ("cc", "child")]
        made = Path((marks / "cc.tmp").read_text().strip())
        assert made.parent.parent == temp and made.parent.name.startswith("lagrangian-request-")
        assert wait_until(lambda: not any(alive(p) for p in pids), 10), pids  # no compiler left running
        assert list(temp.iterdir()) == []  # the request's folder, the compiler's files in it, removed
        assert s.post_json("/api/derive", OSCILLATOR)[0] == 200
        assert list(temp.iterdir()) == []  # every request's folder goes when it ends
        temp.rmdir()  # no temporary folder for a request: refused before any work
        status, data = s.post_json("/api/derive", OSCILLATOR)
        assert status == 503 and data["errors"][0]["message"] == (
            f"the server cannot create a temporary folder for the derivation in {temp} (No such file or directory): "
            "check that this folder exists, is writable and has free space, or start the server with TMPDIR set to "
            "another folder")
    finally:
        code, out, err = s.stop()
    assert code == 0 and "Traceback" not in err, err


@pytest.mark.slow
@pytest.mark.subprocess
def test_slow_requests_leave_a_worker_to_short_ones():
    """Two workers: simulations take at most one, so that with two slow simulations in flight (one
    running, one waiting: the server's /api/status says so) a derivation is answered at once."""
    s = Server(workers=2, time_limit=600)
    slow = {"model": example_source("double-pendulum"), "t_end": 5000, "dt": 1, "method": "RK45", "rtol": 1e-12,
            "atol": 1e-12}
    results = []

    def send():
        try:
            results.append(s.post_json("/api/simulate", slow)[0])
        except OSError as exc:  # the server stopped under it, at the end of the test
            results.append(type(exc).__name__)

    threads = [threading.Thread(target=send) for _ in range(2)]
    try:
        assert s.status() == {"workers": 2, "long_limit": 1, "running": {"short": 0, "long": 0},
                              "waiting": {"short": 0, "long": 0}, "replaced": 0}
        for t in threads:
            t.start()
        busy = {"short": 0, "long": 1}, {"short": 0, "long": 1}
        assert wait_until(lambda: (s.status()["running"], s.status()["waiting"]) == busy, 60), s.status()
        for _ in range(3):
            status, headers, body = s.request("POST", "/api/derive", OSCILLATOR)
            assert status == 200 and json.loads(body)["coordinates"] == ["x"]
        state = s.status()
        assert (state["running"], state["waiting"]) == busy and not results  # both simulations still in flight
    finally:
        code, out, err = s.stop()
        for t in threads:
            t.join(60)
    assert code == 0 and "Traceback" not in err, err


def test_the_lanes_serve_in_order_of_arrival_and_keep_a_worker_for_short_requests():
    """The pool's queue without processes (two stand-in workers): long requests hold at most one of
    two workers, a short one takes the other at once, a freed worker goes to the oldest request its
    lane lets run, a cancelled wait gives nothing away, and past max_waiting a request gets a 503."""
    import asyncio

    from lagrangian.serve._workers import WorkerPool

    async def scenario():
        pool = WorkerPool(2, time_limit=1, max_waiting=3)
        pool._idle = ["w1", "w2"]
        first = await pool._acquire("long")
        second = asyncio.ensure_future(pool._acquire("long"))
        cancelled = asyncio.ensure_future(pool._acquire("long"))
        await asyncio.sleep(0)
        assert not second.done() and pool.state()["waiting"] == {"short": 0, "long": 2}
        short = await pool._acquire("short")  # behind two long ones, served at once
        assert {first, short} == {"w1", "w2"}
        assert pool.state()["running"] == {"short": 1, "long": 1}
        later_short = asyncio.ensure_future(pool._acquire("short"))
        await asyncio.sleep(0)
        busy = await pool.run("derive", b"x", what="derivation")  # three waiting: no room for a fourth
        assert busy.status == 503 and json.loads(busy.body)["errors"][0]["message"] == (
            "the server is busy: 3 requests are waiting; try again in a moment")
        cancelled.cancel()
        await asyncio.sleep(0)
        pool._release(short, "short")  # the long lane is full: the short one behind goes first
        assert await later_short == short and not second.done()
        pool._release(first, "long")
        assert await second == first
        assert pool.state()["running"] == {"short": 1, "long": 1}
        assert pool.state()["waiting"] == {"short": 0, "long": 0}

    asyncio.run(scenario())


# ------------------------------------------------------------------ the command
@pytest.mark.slow
@pytest.mark.subprocess
def test_serve_stops_cleanly_on_ctrl_c_and_takes_its_workers_along():
    s = Server("double-pendulum", workers=1)
    assert s.first_line == f"lagrangian serve: the playground is at {s.url} (press Ctrl-C to stop)\n"
    assert s.url.startswith("http://127.0.0.1:")
    page = s.request("GET", "/")[2].decode()
    assert '"name": "double-pendulum"' in page
    pids = wait_until(s.worker_pids, 10)
    code, out, err = s.stop(signal.SIGINT)
    assert code == 0 and out == "lagrangian serve: stopped\n" and err == ""
    assert not any(os.path.exists(f"/proc/{p}") and open(f"/proc/{p}/stat").read().split()[2] != "Z" for p in pids)


@pytest.mark.skipif(os.name != "posix", reason="the stand-in browser is a shell script")
@pytest.mark.slow
@pytest.mark.subprocess
def test_serve_opens_the_page_in_the_browser_unless_told_not_to(tmp_path):
    """Without --no-browser the page opens in the default browser (Python's webbrowser, which
    honours $BROWSER: here a script that writes down the address it was given)."""
    opened = tmp_path / "opened.txt"
    browser = tmp_path / "browser.sh"
    browser.write_text(f'#!/bin/sh\nprintf "%s" "$1" > "{opened}"\n')
    browser.chmod(0o755)
    env = dict(os.environ, BROWSER=str(browser), PYTHONUNBUFFERED="1")
    process = subprocess.Popen([sys.executable, "-m", "lagrangian", "serve", "--port", "0", "--workers", "1"],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    try:
        first = process.stdout.readline()
        url = first.split(" the playground is at ", 1)[1].split(" ", 1)[0]
        assert wait_until(lambda: opened.exists() and opened.read_text(), 30) == url
    finally:
        process.send_signal(signal.SIGINT)
        out, err = process.communicate(timeout=60)
    assert process.returncode == 0 and out == "lagrangian serve: stopped\n" and "Traceback" not in err


@pytest.mark.slow
@pytest.mark.subprocess
def test_serve_reads_a_model_file_anew_at_each_visit(tmp_path):
    path = tmp_path / "osc.toml"
    path.write_text(OSCILLATOR)
    s = Server(str(path), workers=1)
    try:
        first = s.request("GET", "/")[2].decode()
        assert '"file": "' + str(path) in first and "k = 4.0" in first
        path.write_text(OSCILLATOR.replace("k = 4.0", "k = 9.0"))
        assert "k = 9.0" in s.request("GET", "/")[2].decode()
        assert json.loads(s.request("GET", "/api/info")[2])["model"] == str(path)
    finally:
        s.stop()


@pytest.mark.parametrize("argv, message", [
    (["nope-model"], "lagrangian serve: error: 'nope-model' is neither a model file nor a built-in example."),
    (["missing.toml"], "lagrangian serve: error: missing.toml: no such model file 'missing.toml': check the path"),
    (["--port", "70000"], "lagrangian serve: error: --port must be at most 65535, got 70000; for example --port 8800"),
    (["--workers", "0"], "lagrangian serve: error: --workers must be at least 1, got 0; for example --workers 2"),
    (["--time-limit", "0"], "lagrangian serve: error: --time-limit must be a positive number, got 0; for example "
                            "--time-limit 30"),
    (["--memory-limit", "0"], "lagrangian serve: error: --memory-limit must be at least 64, got 0; for example "
                              "--memory-limit 2048"),
])
@pytest.mark.slow
@pytest.mark.subprocess
def test_serve_errors(argv, message, tmp_path):
    run = subprocess.run([sys.executable, "-m", "lagrangian", "serve", "--no-browser", *argv], capture_output=True,
                         text=True, timeout=60, cwd=tmp_path)
    assert run.returncode == 2 and run.stderr.startswith(message), run.stderr
    assert "Traceback" not in run.stderr


@pytest.mark.parametrize("kwargs, message", [
    ({"port": 70000}, "--port 70000: expected a port number from 1 to 65535 (or 0 for a free one)"),
    ({"time_limit": 0}, "--time-limit 0: expected a positive number of seconds"),
    ({"memory_limit": 0}, "--memory-limit 0: expected a positive number of MiB (default 2048)"),
    ({"workers": 0}, "--workers 0: expected at least 1"),
])
def test_serve_run_checks_its_arguments_before_listening(kwargs, message):
    """lagrangian.serve.run, the Python entry of the command, refuses what the CLI's options refuse."""
    from lagrangian.serve import run

    with pytest.raises(lg.errors.ModelError, match=re.escape(message)):
        run(open_browser=False, **kwargs)


@pytest.mark.slow
@pytest.mark.subprocess
def test_a_port_in_use_is_an_error_that_says_what_to_do():
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        run = subprocess.run([sys.executable, "-m", "lagrangian", "serve", "--no-browser", "--port", str(port)],
                             capture_output=True, text=True, timeout=60)
    assert run.returncode == 2
    assert run.stderr == (f"lagrangian serve: error: port {port} on 127.0.0.1 is in use (another `lagrangian "
                          "serve`?): choose another with --port, or --port 0 for a free one\n")


@pytest.mark.slow
@pytest.mark.subprocess
def test_another_host_needs_saying_so_and_prints_a_warning():
    s = Server("--host", "0.0.0.0", workers=1)
    try:
        assert len(s.lines) == 2
        assert s.lines[0].startswith("lagrangian serve: warning: serving on 0.0.0.0, reachable from other machines")
        assert s.lines[1].startswith("lagrangian serve: the playground is at http://0.0.0.0:")
    finally:
        s.stop()


# ------------------------------------------------------------------ measured signals (issue 21, Part 0)
DRIVEN = OSCILLATOR.replace('coordinates = ["x"]', 'coordinates = ["x"]\ninputs = ["F"]') + '\n[forces]\nx = "F"\n'


@pytest.mark.subprocess
def test_simulate_takes_a_measured_signal_as_data(server):
    """The browser reads the user's CSV and sends the table: the playground simulates it as
    lg.Signal does (never a file on the server), cubic as well as linear."""
    import numpy as np

    t = np.linspace(0.0, 2.0, 41)
    force = np.sin(3 * t) + 0.1 * t**2
    for interpolation in ("linear", "cubic"):
        signal = {"t": t.tolist(), "values": force.tolist(), "interpolation": interpolation}
        status, data = server.post_json("/api/simulate", {"model": DRIVEN, "t_end": 2.0, "dt": 0.1,
                                                          "initial": {"x": 0.5}, "inputs": {"F": signal}})
        assert status == 200, data
        traj = lg.simulate(lg.derive(loads_model(DRIVEN)), 2.0, {"x": 0.5}, dt=0.1,
                           inputs={"F": lg.Signal(t, force, interpolation)})
        assert data["columns"]["x"] == traj["x"].tolist()
        assert data["columns"]["F"] == pytest.approx(traj["F"].tolist(), abs=1e-12)
        assert data["output_names"] == []


@pytest.mark.parametrize("signal, message", [
    ({"t": [0, 1], "value": [1, 2]}, "inputs.F: unknown key 'value' (did you mean 'values'?); a measured signal "
                                     "has the keys t, values, interpolation, extrapolation"),
    ({"t": [0, 1], "values": "1,2"}, "inputs.F.values: expected a list of numbers, got \"1,2\""),
    ({"t": [0, True], "values": [1, 2]}, "inputs.F.t: expected a list of numbers, got [0, true]"),
    ({"t": [0, 1]}, "inputs.F.values: expected a list of numbers, got null"),
    ({"t": [1, 0], "values": [1, 2]}, "inputs.F: signal 'F': times must increase strictly"),
    ({"t": [0, 1], "values": [1, 2, 3]}, "inputs.F: signal 'F': 2 times but 3 values"),
    ({"t": [0, 1], "values": [1, 2], "interpolation": "spline"},
     "inputs.F: signal 'F': unknown interpolation 'spline'"),
    ({"t": [0, 1], "values": [1, 2], "extrapolation": 0}, "inputs.F.extrapolation: expected a string, got 0"),
    ({"t": [0] * 100_001, "values": [0]}, "inputs.F.t: 100001 samples, more than the limit of 100000 per request"),
])
def test_a_bad_measured_signal_is_refused_with_one_clear_message(signal, message):
    from lagrangian.serve._tasks import BadRequest, simulate_request

    with pytest.raises(BadRequest) as exc:
        simulate_request(json.dumps({"model": DRIVEN, "t_end": 1.0, "inputs": {"F": signal}}).encode())
    assert any(m.startswith(message) for m in exc.value.messages), exc.value.messages


@pytest.mark.subprocess
def test_a_run_beyond_the_signal_is_refused_by_the_playground(server):
    status, data = server.post_json("/api/simulate", {"model": DRIVEN, "t_end": 5.0,
                                                      "inputs": {"F": {"t": [0, 1, 2], "values": [0, 1, 0]}}})
    assert status == 400, data
    assert "F" in data["errors"][0]["message"] and "hold" in data["errors"][0]["message"], data
