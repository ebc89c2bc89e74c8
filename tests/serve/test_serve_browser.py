"""The playground as a user drives it: the real server (`lagrangian serve`) and a real headless
Chromium (Debian's `chromium`, driven by Selenium through Debian's `chromedriver`). Load an example,
see the equations the API derives, edit the model and see them change, see an error appear at its
line with the CLI's message, run a simulation with a slider moved, see the animation play, and
download the CSV, which is simulate's. Skipped, saying why, where the browser or its driver is
missing."""

from __future__ import annotations

import base64
import json
import shutil
import time

import pytest

import lagrangian as lg
from lagrangian.errors import ModelFileError
from lagrangian.examples import example_source
from lagrangian.io import loads_model

from serve_support import Server

webdriver = pytest.importorskip("selenium.webdriver", reason="Selenium is not installed (the `test` extra: "
                                "python -m pip install -e \".[test]\"): the playground's browser tests need it")
from selenium.webdriver.common.by import By  # noqa: E402
from selenium.webdriver.common.keys import Keys  # noqa: E402
from selenium.webdriver.support.ui import WebDriverWait  # noqa: E402

FLAGS = ["--headless=new", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
         "--disable-component-update", "--disable-sync", "--no-first-run", "--window-size=1400,900"]
WAIT = 90  # seconds: the first simulation of a model compiles it (longer on a machine's first use)


def _program(*names):
    return next((shutil.which(n) for n in names if shutil.which(n)), None)


@pytest.fixture(scope="module")
def server():
    s = Server(workers=2)
    yield s
    s.stop()


@pytest.fixture(scope="module")
def browser(tmp_path_factory):
    chromium = _program("chromium", "chromium-browser", "google-chrome")
    driver_path = _program("chromedriver")
    if chromium is None or driver_path is None:
        pytest.skip("no chromium and chromedriver on this machine (Debian: apt-get install chromium "
                    "chromium-driver): the playground's browser tests need them")
    from selenium.webdriver.chrome.service import Service

    downloads = tmp_path_factory.mktemp("downloads")
    options = webdriver.ChromeOptions()
    options.binary_location = chromium
    for flag in FLAGS:
        options.add_argument(flag)
    options.add_argument(f"--user-data-dir={tmp_path_factory.mktemp('profile')}")
    options.add_experimental_option("prefs", {"download.default_directory": str(downloads),
                                              "download.prompt_for_download": False})
    driver = webdriver.Chrome(service=Service(driver_path), options=options)
    driver.execute_cdp_cmd("Browser.setDownloadBehavior", {"behavior": "allow", "downloadPath": str(downloads)})
    driver.downloads = downloads
    yield driver
    driver.quit()


def wait(driver, condition, timeout=WAIT):
    return WebDriverWait(driver, timeout, poll_frequency=0.1).until(lambda d: condition())


def js(driver, script, *args):
    return driver.execute_script(script, *args)


def ready(driver) -> bool:
    """Nothing is running (derivation, analysis, equilibria, simulation) and the model is valid."""
    return js(driver, "return window.lagrangianPlayground && window.lagrangianPlayground.state.busy.size === 0 "
                      "&& document.getElementById('check-state').textContent === 'valid' "
                      "&& window.lagrangianPlayground.state.simulation !== null")


def text_equations(driver):
    return json.loads(js(driver, "return document.getElementById('equations-text').dataset.equations || 'null'"))


def api_equations(server, text):
    status, data = server.post_json("/api/derive", text)
    assert status == 200, data
    return data["equations"]


def editor_text(driver):
    return js(driver, "return document.getElementById('source').value")


def put_caret(driver, line: int, column: int | None = None):
    """The caret at the end of `line` (1-based), or at `column` (0-based) of it."""
    js(driver, """const ta = document.getElementById('source'), lines = ta.value.split('\\n');
        let pos = 0; for (let k = 0; k < arguments[0] - 1; k++) pos += lines[k].length + 1;
        pos += arguments[1] === null ? lines[arguments[0] - 1].length : arguments[1];
        ta.focus(); ta.setSelectionRange(pos, pos);""", line, column)


def line_of(text: str, needle: str) -> int:
    return next(k for k, line in enumerate(text.splitlines(), start=1) if needle in line)


@pytest.fixture(scope="module")
def page(server, browser):
    """The page with the double pendulum loaded, derived and simulated."""
    browser.get(server.url + "?example=double-pendulum")
    wait(browser, lambda: ready(browser))
    return browser


@pytest.mark.slow
@pytest.mark.browser
@pytest.mark.subprocess
def test_an_example_opens_derived_with_the_apis_equations_as_mathematics(page, server):
    assert editor_text(page) == example_source("double-pendulum")
    assert text_equations(page) == api_equations(server, example_source("double-pendulum"))
    page.find_element(By.CSS_SELECTOR, '.tabs button[data-tab="equations"]').click()
    boxes = js(page, "return [...document.querySelectorAll("
                     "'#equations-math section[data-key=equations] div.math math')]"
                     ".map(m => m.getBoundingClientRect().height)")
    assert len(boxes) >= 2 and min(boxes) > 10  # Chromium lays out the MathML
    page.find_element(By.CSS_SELECTOR, '.tabs button[data-tab="diagnosis"]').click()
    assert "det M" in page.find_element(By.ID, "diagnosis-math").text
    page.find_element(By.CSS_SELECTOR, '.tabs button[data-tab="equilibria"]').click()
    assert page.find_element(By.ID, "equilibria-math").text.count("unstable") == 3
    page.find_element(By.CSS_SELECTOR, '.tabs button[data-tab="motion"]').click()


@pytest.mark.slow
@pytest.mark.browser
@pytest.mark.subprocess
def test_editing_the_model_changes_the_equations(page, server):
    before = text_equations(page)
    line = line_of(editor_text(page), 'g = "g"')
    put_caret(page, line)
    page.switch_to.active_element.send_keys(Keys.BACKSPACE, '*3"')  # g = "g*3"
    wait(page, lambda: text_equations(page) != before and ready(page))
    text = editor_text(page)
    assert 'g = "g*3"' in text.splitlines()[line - 1]
    after = text_equations(page)
    assert after == api_equations(server, text)
    assert "3*g" in after[0] and "3*g" not in before[0]
    page.find_element(By.CSS_SELECTOR, '.tabs button[data-tab="equations"]').click()
    assert "3" in page.find_element(By.CSS_SELECTOR, "#equations-math section[data-key=equations]").text
    page.find_element(By.CSS_SELECTOR, '.tabs button[data-tab="motion"]').click()


@pytest.mark.slow
@pytest.mark.browser
@pytest.mark.subprocess
def test_an_error_appears_at_its_line_with_the_clis_message(page, server):
    line = line_of(editor_text(page), 'mass = "m2"')
    put_caret(page, line, len('mass = "m2'))
    page.switch_to.active_element.send_keys("*")  # mass = "m2*"
    wait(page, lambda: js(page, f"return document.querySelector('#gutter div[data-line=\"{line}\"]')"
                                ".classList.contains('error')"))
    text = editor_text(page)
    with pytest.raises(ModelFileError) as exc:
        loads_model(text)
    (problem,) = exc.value.problems
    assert problem.line == line and problem.message.startswith("malformed expression at position 3: missing operand")
    items = page.find_elements(By.CSS_SELECTOR, "#errors li")
    assert [li.text for li in items] == [f"line {line} [{problem.key}]: {problem.message}"]
    marked = js(page, "return [...document.querySelectorAll('#highlight .line.error')].map(e => +e.dataset.line)")
    assert marked == [line]
    assert "1 problem" in page.find_element(By.ID, "check-state").text
    page.switch_to.active_element.send_keys(Keys.BACKSPACE)  # fixed again
    wait(page, lambda: ready(page) and not page.find_elements(By.CSS_SELECTOR, "#errors li"))
    assert not js(page, "return document.querySelectorAll('#gutter div.error').length")


def canvas_png(driver) -> bytes:
    return base64.b64decode(js(driver, "return document.getElementById('mechanism').toDataURL('image/png')")
                            .split(",", 1)[1])


@pytest.mark.slow
@pytest.mark.browser
@pytest.mark.subprocess
def test_a_slider_runs_a_new_simulation_and_the_animation_plays(page, server):
    old = js(page, "return window.lagrangianPlayground.state.simulation.columns.theta1[0]")
    js(page, "const box = document.getElementById('value-theta1'); box.value = '0.75';"
             "box.dispatchEvent(new Event('change'));")
    wait(page, lambda: ready(page) and js(
        page, "return window.lagrangianPlayground.state.simulation.columns.theta1[0]") == 0.75)
    assert old != 0.75
    request = js(page, "return window.lagrangianPlayground.state.lastRequest")
    assert request["initial"]["theta1"] == 0.75 and request["model"] == editor_text(page)
    status, data = server.post_json("/api/simulate", request)
    shown = js(page, "return window.lagrangianPlayground.state.simulation")
    assert status == 200 and shown["columns"] == data["columns"]  # the page shows what the API returns
    # the animation plays: the frame and the picture change as time goes on
    frames, pictures = set(), set()

    def played() -> bool:  # seen, not slept on: three frames and three pictures, however loaded the machine
        frames.add(js(page, "return document.getElementById('mechanism').dataset.frame"))
        pictures.add(canvas_png(page))
        return len(frames) >= 3 and len(pictures) >= 3

    wait(page, played)
    assert len(frames) >= 3 and len(pictures) >= 3
    # paused, it stays; the time slider moves it
    page.find_element(By.ID, "play").click()
    time.sleep(0.2)
    still = js(page, "return document.getElementById('mechanism').dataset.frame")
    time.sleep(0.5)
    assert js(page, "return document.getElementById('mechanism').dataset.frame") == still
    js(page, "const s = document.getElementById('scrub'); s.value = '100'; s.dispatchEvent(new Event('input'));")
    assert float(js(page, "return document.getElementById('mechanism').dataset.time")) == data["geometry"]["t"][100]
    assert page.find_element(By.ID, "time-label").text == f"t = {data['geometry']['t'][100]:.2f} s"
    page.find_element(By.ID, "play").click()


@pytest.mark.browser
@pytest.mark.subprocess
@pytest.mark.slow
def test_the_downloaded_csv_is_simulates(page, server):
    for old in page.downloads.iterdir():
        old.unlink()
    page.find_element(By.ID, "download-csv").click()
    path = page.downloads / "double-pendulum.csv"
    wait(page, lambda: path.exists() and path.stat().st_size > 0, 30)
    request = js(page, "return window.lagrangianPlayground.state.lastRequest")
    traj = lg.simulate(lg.derive(loads_model(request["model"])), request["t_end"], request["initial"],
                       params=request["params"], dt=request["dt"])
    assert path.read_text() == traj.to_csv()


@pytest.mark.slow
@pytest.mark.browser
@pytest.mark.subprocess
def test_the_fmu_downloads_with_the_sliders_values(page):
    import xml.etree.ElementTree as ET
    import zipfile

    page.find_element(By.ID, "download-fmu").click()
    path = page.downloads / "double-pendulum.fmu"
    wait(page, lambda: path.exists() and path.stat().st_size > 0 and zipfile.is_zipfile(path), 60)
    root = ET.fromstring(zipfile.ZipFile(path).read("modelDescription.xml"))
    starts = {v.get("name"): float(v[0].get("start")) for v in root.iter("ScalarVariable") if v[0].get("start")}
    assert starts["theta1"] == 0.75  # the slider's value, set above


@pytest.mark.browser
@pytest.mark.subprocess
def test_the_file_is_highlighted_and_the_states_and_energy_plotted(page):
    """The editor's highlighting (the expressions' functions, feedback laws' included) and the
    three plots drawn in their first color (the coordinates', the velocities', the energy's)."""
    funcs = js(page, "return [...document.querySelectorAll('#highlight .tok-func')].map(e => e.textContent)")
    assert {"sin", "cos"} <= set(funcs)
    assert js(page, "return document.querySelectorAll('#highlight .tok-table').length") >= 3
    law = js(page, "return lgHighlightExpression('where(q1 > 0, clip(-3*q1_dot, -1, 1), 0)')")
    assert '<span class="tok-func">where</span>' in law and '<span class="tok-func">clip</span>' in law
    assert '<span class="tok-op">&gt;</span>' in law
    drawn = js(page, """return ['plot-q', 'plot-qdot', 'plot-energy'].map((id) => {
        const c = document.getElementById(id), d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
        let n = 0;
        for (let i = 0; i < d.length; i += 4)
          if (Math.abs(d[i] - 31) < 40 && Math.abs(d[i + 1] - 119) < 40 && Math.abs(d[i + 2] - 180) < 40
              && d[i + 3] > 128) n++;
        return n; });""")
    assert min(drawn) > 100, drawn


@pytest.mark.slow
@pytest.mark.browser
@pytest.mark.subprocess
def test_the_model_file_and_the_report_download(page, server):
    for old in page.downloads.iterdir():
        old.unlink()
    page.find_element(By.ID, "download-model").click()
    toml = page.downloads / "double-pendulum.toml"
    wait(page, lambda: toml.exists() and toml.stat().st_size > 0, 30)
    assert toml.read_text() == editor_text(page)
    page.find_element(By.ID, "download-report-md").click()
    md = page.downloads / "double-pendulum.md"
    wait(page, lambda: md.exists() and md.stat().st_size > 0, 60)
    status, _, body = server.request("POST", "/api/report?format=md", editor_text(page))
    assert status == 200 and md.read_bytes() == body


@pytest.mark.browser
@pytest.mark.subprocess
def test_an_unknown_example_says_so(server, browser):
    browser.get(server.url + "?example=double-pendulm")
    wait(browser, lambda: browser.find_elements(By.CSS_SELECTOR, "#errors li"))
    assert browser.find_element(By.CSS_SELECTOR, "#errors li").text.startswith(
        "there is no built-in example 'double-pendulm'. Did you mean 'double-pendulum'?")


def colour_counts(driver, colours) -> list[int]:
    """How many pixels of the mechanism's canvas are near each (r, g, b) colour."""
    return js(driver, """const c = document.getElementById('mechanism'), d = c.getContext('2d')
          .getImageData(0, 0, c.width, c.height).data;
        return arguments[0].map(([r, g, b]) => { let n = 0;
          for (let i = 0; i < d.length; i += 4)
            if (Math.abs(d[i] - r) < 30 && Math.abs(d[i + 1] - g) < 30 && Math.abs(d[i + 2] - b) < 30
                && d[i + 3] > 128) n++;
          return n; });""", colours)


ORANGE, RED, GREEN, BLUE, GROUND = (255, 127, 14), (214, 39, 40), (44, 160, 44), (31, 119, 180), (184, 188, 196)


@pytest.mark.slow
@pytest.mark.browser
@pytest.mark.subprocess
def test_a_body_in_space_is_drawn_and_the_view_follows_it(server, browser):
    """The rolling disk: its rim (orange), its frame's axes (red, green, blue) and the ground's grid;
    it rolls about 4 m away in 10 s, and the view follows it, so at the end it is as large as at
    the start."""
    browser.get(server.url + "?example=rolling-disk")
    wait(browser, lambda: ready(browser))
    assert js(browser, "return window.lagrangianPlayground.mechanism.geometry.framing.follow") is True
    browser.find_element(By.ID, "play").click()  # pause
    counts = []
    for end in (False, True):
        js(browser, "const s = document.getElementById('scrub'); s.value = arguments[0] ? s.max : '0';"
                    "s.dispatchEvent(new Event('input'));", end)
        counts.append(colour_counts(browser, [ORANGE, RED, GREEN, BLUE, GROUND]))
    start, last = counts
    assert min(start) > 20 and min(last) > 20, counts
    assert 0.5 < last[0] / start[0] < 2, counts
    browser.find_element(By.ID, "play").click()


@pytest.mark.slow
@pytest.mark.browser
@pytest.mark.subprocess
def test_a_closed_loop_simulates_with_the_dependent_values_completed(server, browser):
    """The four-bar: the page sends the crank's angle and speed (the given values), the loop
    completes the other angles, and their boxes show the completed values, in grey; moving the
    crank's slider sends its new value and keeps the others completed."""
    browser.get(server.url + "?example=four-bar")
    wait(browser, lambda: ready(browser))
    request = js(browser, "return window.lagrangianPlayground.state.lastRequest")
    assert set(request["initial"]) == {"th1", "th1_dot"}
    traj = lg.simulate(lg.load("four-bar"), 5.0)
    shown = float(browser.find_element(By.ID, "value-th2").get_attribute("value"))
    assert shown == pytest.approx(traj["th2"][0], rel=1e-5)
    computed = js(browser, "return [...document.querySelectorAll('#sliders .slider.computed label')]"
                           ".map((l) => l.textContent)")
    assert "th2" in computed and "th3" in computed and "th1" not in computed and "th1_dot" not in computed
    js(browser, "const box = document.getElementById('value-th1'); box.value = '0.9';"
                "box.dispatchEvent(new Event('change'));")
    wait(browser, lambda: ready(browser) and js(
        browser, "return window.lagrangianPlayground.state.lastRequest.initial.th1") == 0.9)
    assert set(js(browser, "return window.lagrangianPlayground.state.lastRequest.initial")) == {"th1", "th1_dot"}
    moved = lg.simulate(lg.load("four-bar"), 5.0, initial={"th1": 0.9, "th1_dot": 4.0})
    assert float(browser.find_element(By.ID, "value-th3").get_attribute("value")) == pytest.approx(
        moved["th3"][0], rel=1e-5)


@pytest.mark.slow
@pytest.mark.browser
@pytest.mark.subprocess
def test_a_measured_signal_from_a_csv_drives_the_simulation(server, browser, tmp_path):
    """Issue 21, Part 0: the user picks a CSV for the cart's force; the page reads it in the browser,
    sends the table as numbers (the server reads no file), and the motion is lg.Signal's."""
    import numpy as np

    t = np.linspace(0.0, 10.0, 201)
    force = 0.8 * np.sin(2.0 * t)
    csv = tmp_path / "push.csv"
    csv.write_text("time,F\n" + "".join(f"{float(a)!r},{float(b)!r}\n" for a, b in zip(t, force)))
    browser.get(server.url + "?example=cart-pendulum")
    wait(browser, lambda: ready(browser))
    js(browser, "document.getElementById('signal-F').hidden = false")
    browser.find_element(By.ID, "signal-F").send_keys(str(csv))
    wait(browser, lambda: ready(browser) and isinstance(
        js(browser, "return window.lagrangianPlayground.state.lastRequest.inputs.F"), dict))
    request = js(browser, "return window.lagrangianPlayground.state.lastRequest")
    assert request["inputs"]["F"]["t"] == t.tolist() and request["inputs"]["F"]["values"] == force.tolist()
    assert browser.find_element(By.ID, "input-F").get_attribute("value") == "@push.csv:F (201 samples, linear)"
    traj = lg.simulate(lg.derive(loads_model(request["model"])), request["t_end"], request["initial"],
                       params=request["params"], dt=request["dt"], inputs={"F": lg.Signal(t, force)})
    shown = js(browser, "return window.lagrangianPlayground.state.simulation.columns.q1")
    assert shown == traj["q1"].tolist()
    bad = tmp_path / "bad.csv"
    bad.write_text("time,F\n0,1\n1,oops\n2,3\n")
    browser.find_element(By.ID, "signal-F").send_keys(str(bad))
    wait(browser, lambda: "bad.csv: row 3: expected 2 numbers, got '1,oops'"
         in browser.find_element(By.ID, "sim-info").text)
