"""The playground's web application (Tornado): the page, its static assets and the HTTP API.

Routes (the API is documented in docs/conventions.md):

=======================  =================================================================
``GET /``                the page; ``?example=NAME`` opens it with that built-in example
``GET /static/...``      the page's scripts and style sheet (shipped in the package)
``GET /api/info``        the server's version, limits and what it offers
``GET /api/status``      the worker lanes now: requests running and waiting in each
``GET /api/examples``    ``{name: description}`` of the built-in examples
``GET /api/examples/N``  ``{"name", "text"}``: the model file of example N
``POST /api/derive``     model text -> the JSON of ``lagrangian derive --json``
``POST /api/analysis``   model text -> the report's sections (MathML), [simulation] defaults
``POST /api/equilibria`` ``{"model", "params", "inputs"}`` -> equilibria, modes, as JSON and HTML
``POST /api/simulate``   ``{"model", "t_end", "initial", "inputs", "params", "dt", ...}`` -> the
                         trajectory as JSON (``?format=csv``: the CSV of ``lagrangian simulate``)
``POST /api/report``     model text -> the derivation report (``?format=html|md|tex``)
``POST /api/fmu``        ``{"model", "params", "initial"}`` -> the FMI 2.0 FMU (``export --fmu``)
=======================  =================================================================

Errors of the API are JSON, ``{"errors": [{"line", "key", "message"}, ...]}``: 400 for a bad
request or model, 403 for a foreign Host header or a request from another web page (an ``Origin``
other than the server's own, or ``Sec-Fetch-Site`` saying another site), 404, 405, 413 for a body
over the size limit, 415 for a POST from a web page that is not ``application/json``, 422 for a
computation that fails or runs past the time or memory limit, 503 when overloaded.

The API serves the playground's own page and scripts only: no response carries a CORS permission
(``Access-Control-Allow-*``), so a browser lets no other page read an answer; a request that
another page makes anyway is refused before any work, by its ``Origin`` (browsers send it with
every POST and every cross-site request) and, since such a page can send only "simple" requests
without asking first, by the rule that a POST from a page carries ``Content-Type:
application/json`` (which a browser sends across sites only after a preflight, which gets no
permission). Scripts send no ``Origin``: they may send the model text with any content type.
"""

from __future__ import annotations

import html
import json
import logging
from pathlib import Path
from urllib.parse import urlsplit

import tornado.web

from ._tasks import Reply, errors_reply
from ._workers import WorkerPool

__all__ = ["make_app", "Settings"]

HERE = Path(__file__).resolve().parent
STATIC = HERE / "static"
TEMPLATES = HERE / "templates"
#: The largest request body accepted (bytes): a model file is a few kilobytes.
MAX_BODY = 1024 * 1024
#: A larger body (up to this size) is read and dropped before the 413 answer, so that a client that
#: sends its whole body before reading the answer gets the answer, not a broken connection.
DRAIN_LIMIT = 16 * MAX_BODY
LOOPBACK = ("127.0.0.1", "localhost", "::1", "[::1]")
#: The values of a browser's Sec-Fetch-Site header for a request of the page itself (or typed by the user).
OWN_SITE = ("same-origin", "none")


class Settings:
    """What the handlers share: the worker pool, the limits, and the model the page opens with."""

    def __init__(self, pool: WorkerPool, *, model: str | None = None, max_body: int = MAX_BODY,
                 check_host: bool = True):
        self.pool = pool
        self.model = model
        self.max_body = max_body
        self.check_host = check_host


class _Base(tornado.web.RequestHandler):
    settings_: Settings
    #: An endpoint of the API: answers the server's own page and scripts only (see check_origin).
    api = True

    def initialize(self, settings: Settings):
        self.settings_ = settings

    def prepare(self):
        if self.check_host() and self.api:
            self.check_origin()

    def set_default_headers(self):
        self.set_header("X-Content-Type-Options", "nosniff")
        self.set_header("Referrer-Policy", "no-referrer")
        self.set_header("Cache-Control", "no-store")

    def check_host(self) -> bool:
        """When bound to the loopback address, refuse requests whose Host is not a loopback name:
        a web page elsewhere cannot reach this server through a DNS name that points here."""
        if not self.settings_.check_host:
            return True
        host = self.request.host_name
        if host in LOOPBACK:
            return True
        self.reply(errors_reply(403, [f"this server answers requests for 127.0.0.1 and localhost only, not for "
                                      f"'{host}'; open http://127.0.0.1:{self._port()}/ "
                                      "(or start it with --host to serve other addresses)"]))
        return False

    def check_origin(self) -> bool:
        """Refuse a request that a web page other than the playground's own made (403): its Origin
        header, when it has one, must be this server's origin as the browser addressed it
        (http://HOST:PORT of the request's Host header, which the browser sets: through a tunnel or
        a forwarded port, the address the page was opened at); without one, a Sec-Fetch-Site
        header must not say another site. Scripts send neither."""
        origin = self.request.headers.get("Origin")
        own = self.own_origin()
        if origin is None:
            site = self.request.headers.get("Sec-Fetch-Site", "none").strip().lower()
            if site in OWN_SITE:
                return True
            why = f"the browser says it comes from another site (Sec-Fetch-Site: {site})"
        elif self._same_origin(origin, own):
            return True
        elif origin.strip().lower() == "null":
            why = ("it comes from a page with an opaque origin (Origin: null: a sandboxed frame, a local file or "
                   "a redirect)")
        else:
            why = f"it comes from the web page at {origin[:200]!r} (its Origin header)"
        self.reply(errors_reply(403, [
            f"cross-site request refused: {why}, not from this server's own page at {own}; the playground's API "
            f"answers its own page and scripts only. Open the playground at {own}/ (a script sends its requests "
            "without an Origin header)"]))
        return False

    def own_origin(self) -> str:
        """This server's origin as the request addressed it: http://HOST:PORT (the Host header's)."""
        return f"{self.request.protocol}://{self.request.host.lower()}"

    @staticmethod
    def _same_origin(origin: str, own: str) -> bool:
        def parts(url):
            u = urlsplit(url.strip())
            return u.scheme.lower(), u.hostname, u.port or {"http": 80, "https": 443}.get(u.scheme.lower()), \
                u.path, u.query, u.username, u.password

        try:
            return parts(origin) == parts(own)
        except ValueError:  # not a URL, or a port out of range
            return False

    def _port(self) -> str:
        """The port this server listens on (that of the connection's own end, not the Host header's)."""
        try:
            return str(self.request.connection.stream.socket.getsockname()[1])
        except (AttributeError, OSError, IndexError):
            return "PORT"

    def reply(self, r: Reply) -> None:
        self.set_status(r.status)
        self.set_header("Content-Type", r.content_type)
        for k, v in r.headers.items():
            self.set_header(k, v)
        self.finish(r.body)

    def write_error(self, status_code, **kwargs):
        reason = self._reason or "error"
        if status_code == 405:
            message = f"{self.request.method} is not allowed on {self.request.path}"
        else:
            message = f"{status_code} {reason}"
        self.set_header("Content-Type", "application/json")
        self.finish(json.dumps({"errors": [{"line": None, "key": None, "message": message}]}))


@tornado.web.stream_request_body
class _Api(_Base):
    """A POST endpoint whose body (at most `max_body` bytes) goes to a task in a worker."""

    task = ""
    what = "request"

    def prepare(self):
        self._chunks: list[bytes] = []
        self._size = 0
        self._too_large = False
        super().prepare()
        if self._finished or self.request.method != "POST":
            return
        if "Origin" in self.request.headers and not self.json_body:
            declared = self.request.headers.get("Content-Type", "").split(";")[0].strip()
            said = f"not {declared[:100]!r}" if declared else "but it declares none"
            self.reply(errors_reply(415, [
                f"a request from a web page must send its body as Content-Type: application/json, {said}: the "
                "playground's page does so ({\"model\": \"...\"} for the model text); a script can leave out the "
                "Origin header and send the model text as it is"]))
            return
        length = self.request.headers.get("Content-Length")
        if length is not None and length.isdigit() and int(length) > DRAIN_LIMIT:
            self._refuse_size(int(length))  # not worth reading: answered at once, the connection closed
            return
        self.request.connection.set_max_body_size(DRAIN_LIMIT)

    def _refuse_size(self, size: int) -> None:
        limit = self.settings_.max_body
        self.reply(errors_reply(413, [f"the request body has {size} bytes, more than the limit of {limit} bytes "
                                      f"({limit // 1024} KiB): a model file is a few kilobytes"]))

    def data_received(self, chunk: bytes) -> None:
        self._size += len(chunk)
        if self._size > self.settings_.max_body:
            self._too_large = True
            self._chunks.clear()
        elif not self._too_large:
            self._chunks.append(chunk)

    def args(self) -> tuple:
        return ()

    @property
    def json_body(self) -> bool:
        """The body is declared JSON (``Content-Type: application/json``, parameters aside)."""
        return self.request.headers.get("Content-Type", "").split(";")[0].strip().lower() == "application/json"

    def task_options(self) -> dict:
        """The keyword arguments of the task (the text tasks: whether the body is JSON)."""
        return {}

    async def post(self):
        if self._too_large:
            self._refuse_size(self._size)
            return
        body = b"".join(self._chunks)
        if not body.strip():
            self.reply(errors_reply(400, [self.empty_message]))
            return
        self.reply(await self.settings_.pool.run(self.task, body, *self.args(), what=self.what,
                                                 options=self.task_options()))

    empty_message = "the request body is empty: send the model file's text"


class _TextApi(_Api):
    """An endpoint whose body is the model file's text, or ``{"model": TEXT}`` as JSON."""

    def task_options(self) -> dict:
        return {"json_body": self.json_body}


class DeriveHandler(_TextApi):
    task, what = "derive", "derivation"


class AnalysisHandler(_TextApi):
    task, what = "analysis", "analysis"


class EquilibriaHandler(_Api):
    task, what = "equilibria", "search for equilibria"
    empty_message = 'the request body is empty: send a JSON object {"model": "...", "params": {...}}'


class SimulateHandler(_Api):
    what = "simulation"
    empty_message = 'the request body is empty: send a JSON object {"model": "...", "t_end": 5, ...}'

    @property
    def task(self):
        fmt = self.get_query_argument("format", "json")
        return "simulate_csv" if fmt == "csv" else "simulate"

    async def post(self):
        fmt = self.get_query_argument("format", "json")
        if fmt not in ("json", "csv"):
            self.reply(errors_reply(400, [f"format '{fmt}': choose json (the default) or csv"]))
            return
        await super().post()


class FmuHandler(_Api):
    task, what = "fmu", "FMU export"
    empty_message = 'the request body is empty: send a JSON object {"model": "...", "params": {...}}'


class ReportHandler(_TextApi):
    task, what = "report", "report"

    def args(self):
        return (self.get_query_argument("format", "html"),)


class InfoHandler(_Base):
    def get(self):
        from .._version import __version__
        from ._tasks import MAX_FRAMES, MAX_ROWS

        pool = self.settings_.pool
        memory = None if pool.memory_limit is None else pool.memory_limit // (1024 * 1024)
        self.reply(Reply(200, json.dumps({
            "version": __version__, "workers": pool.size, "time_limit_s": pool.time_limit,
            "memory_limit_mib": memory, "long_workers": pool.long_limit,
            "max_body_bytes": self.settings_.max_body, "max_rows": MAX_ROWS, "max_frames": MAX_FRAMES,
            "model": self.settings_.model}).encode()))


class StatusHandler(_Base):
    """The worker lanes now (:meth:`WorkerPool.state`)."""

    def get(self):
        self.reply(Reply(200, json.dumps(self.settings_.pool.state()).encode()))


class ExamplesHandler(_Base):
    def get(self, name=None):
        from ..examples import example_descriptions, example_source

        if name is None:
            self.reply(Reply(200, json.dumps(example_descriptions()).encode()))
            return
        text = example_source(name)
        if text is None:
            self.reply(errors_reply(404, [unknown_example(name)]))
            return
        self.reply(Reply(200, json.dumps({"name": name, "text": text}).encode()))


def unknown_example(name: str) -> str:
    from .._util import did_you_mean
    from ..examples import example_names

    hint = did_you_mean(name, example_names(), 0.5, sentence=True)
    return (f"there is no built-in example '{name}'.{hint} Choose one in the Examples menu "
            "(pendulum-chain-<n> and spring-mass-damper-chain-<n> take n from 1 to 200).")


class PageHandler(_Base):
    """The page, with the model it opens with: ?example=NAME, else the server's MODEL, else the
    default example. A MODEL file is read anew at each visit, so a reload shows its latest text."""

    DEFAULT = "cart-pendulum"
    api = False  # the page may be linked from anywhere (a lecture's slides); it computes nothing

    def get(self):
        from ..examples import example_source

        example = self.get_query_argument("example", None)
        initial = {"name": None, "text": "", "file": None, "error": None}
        status = 200
        if example is not None:
            text = example_source(example)
            if text is None:
                initial["error"] = unknown_example(example)
                status = 404
            else:
                initial.update(name=example, text=text)
        elif self.settings_.model is not None:
            initial.update(self._served_model())
        else:
            initial.update(name=self.DEFAULT, text=example_source(self.DEFAULT))
        self.set_status(status)
        self.set_header("Content-Type", "text/html; charset=utf-8")
        self.render("index.html", initial_json=_script_json(initial))

    def _served_model(self) -> dict:
        from ..examples import example_source

        model = self.settings_.model
        text = example_source(model)
        if text is not None:
            return {"name": model, "text": text}
        path = Path(model)
        try:
            return {"name": path.stem, "text": path.read_bytes().decode("utf-8-sig"), "file": str(path)}
        except (OSError, UnicodeDecodeError) as exc:
            why = getattr(exc, "strerror", None) or str(exc)
            return {"name": path.stem, "file": str(path),
                    "error": f"cannot read the model file {model}: {why}"}


def _script_json(obj) -> str:
    """JSON safe inside a <script> element."""
    return json.dumps(obj).replace("</", "<\\/").replace("<!--", "<\\!--")


class NotFoundHandler(_Base):
    def prepare(self):
        if self.request.path.startswith("/api/"):
            self.reply(errors_reply(404, [f"no such API endpoint: {self.request.method} {self.request.path}; "
                                          "see GET /api/info and docs/conventions.md"]))
        else:
            self.set_status(404)
            self.set_header("Content-Type", "text/html; charset=utf-8")
            self.finish(f"<!DOCTYPE html><title>Not found</title><p>No page at {html.escape(self.request.path)}. "
                        '<a href="/">Open the playground</a>.</p>')


def make_app(settings: Settings) -> tornado.web.Application:
    """The Tornado application of the playground."""
    logging.getLogger("tornado.access").setLevel(logging.ERROR)
    s = {"settings": settings}
    return tornado.web.Application([
        (r"/", PageHandler, s),
        (r"/api/info", InfoHandler, s),
        (r"/api/status", StatusHandler, s),
        (r"/api/examples", ExamplesHandler, s),
        (r"/api/examples/([A-Za-z0-9_<>-]+)", ExamplesHandler, s),
        (r"/api/derive", DeriveHandler, s),
        (r"/api/analysis", AnalysisHandler, s),
        (r"/api/equilibria", EquilibriaHandler, s),
        (r"/api/simulate", SimulateHandler, s),
        (r"/api/report", ReportHandler, s),
        (r"/api/fmu", FmuHandler, s),
    ], static_path=str(STATIC), template_path=str(TEMPLATES), default_handler_class=NotFoundHandler,
        default_handler_args=s, compress_response=True, autoreload=False, debug=False, serve_traceback=False)
