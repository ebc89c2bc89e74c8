// The model-file editor: a textarea over a highlighted copy of its text (TOML, and the expression
// syntax inside strings), a gutter of line numbers, and problems marked at their lines.
"use strict";

const LG_FUNCTIONS = new Set(["sin", "cos", "tan", "asin", "acos", "atan", "atan2", "sinh", "cosh", "tanh",
                              "exp", "log", "sqrt", "abs", "sign", "pi",
                              // and those of inputs and events (feedback laws): saturations and switches
                              "min", "max", "clip", "where", "and", "or", "not"]);

function lgEscape(text) {
  return text.replace(/&/g, "&amp;").replace(/</g, "&lt;").replace(/>/g, "&gt;").replace(/"/g, "&quot;");
}

function lgSpan(cls, text) {
  return `<span class="${cls}">${lgEscape(text)}</span>`;
}

// An expression inside a string: numbers, the allowed functions, names and operators.
function lgHighlightExpression(text) {
  const re = /([0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)|([A-Za-z_][A-Za-z0-9_]*)|(\*\*|<=|>=|[-+*/^(),<>])|(\s+|.)/g;
  let out = "", m;
  while ((m = re.exec(text)) !== null) {
    if (m[1]) out += lgSpan("tok-number", m[1]);
    else if (m[2]) out += lgSpan(LG_FUNCTIONS.has(m[2]) ? "tok-func" : "tok-name", m[2]);
    else if (m[3]) out += lgSpan("tok-op", m[3]);
    else out += lgEscape(m[4]);
  }
  return out;
}

// One line of TOML as HTML.
function lgHighlightLine(line) {
  const header = /^(\s*)(\[\[?[^\]]*\]\]?)(.*)$/.exec(line);
  if (header && !/=/.test(header[2])) {
    return lgEscape(header[1]) + lgSpan("tok-table", header[2]) + lgHighlightValue(header[3]);
  }
  const key = /^(\s*)([A-Za-z0-9_."'-]+)(\s*=)(.*)$/.exec(line);
  if (key) return lgEscape(key[1]) + lgSpan("tok-key", key[2]) + lgEscape(key[3]) + lgHighlightValue(key[4]);
  return lgHighlightValue(line);
}

// Values: strings (with their expressions), numbers, booleans, comments, punctuation.
function lgHighlightValue(text) {
  let out = "", i = 0;
  while (i < text.length) {
    const c = text[i];
    if (c === "#") { out += lgSpan("tok-comment", text.slice(i)); break; }
    if (c === '"' || c === "'") {
      let j = i + 1;
      while (j < text.length && text[j] !== c) j += (text[j] === "\\" && c === '"') ? 2 : 1;
      const inner = text.slice(i + 1, Math.min(j, text.length));
      out += `<span class="tok-string">${lgEscape(c)}${lgHighlightExpression(inner)}${j < text.length ? lgEscape(c) : ""}</span>`;
      i = j + 1;
      continue;
    }
    const rest = text.slice(i);
    const num = /^[-+]?(?:[0-9][0-9_]*\.?[0-9_]*|\.[0-9]+)(?:[eE][-+]?[0-9]+)?/.exec(rest);
    if (num && (i === 0 || /[\s=,\[{]/.test(text[i - 1]))) { out += lgSpan("tok-number", num[0]); i += num[0].length; continue; }
    const word = /^(true|false|inf|nan)\b/.exec(rest);
    if (word) { out += lgSpan("tok-bool", word[0]); i += word[0].length; continue; }
    const name = /^[A-Za-z_][A-Za-z0-9_-]*/.exec(rest);
    if (name) { out += lgSpan("tok-key", name[0]); i += name[0].length; continue; }
    out += lgEscape(c);
    i += 1;
  }
  return out;
}

class LgEditor {
  constructor(textarea, highlight, gutter, onChange) {
    this.textarea = textarea;
    this.highlight = highlight;
    this.gutter = gutter;
    this.onChange = onChange;
    this.errors = new Map();  // line -> [messages]
    textarea.addEventListener("input", () => { this.render(); this.onChange(this.text); });
    textarea.addEventListener("scroll", () => this.syncScroll());
    textarea.addEventListener("keydown", (e) => {
      if (e.key === "Tab" && !e.ctrlKey && !e.metaKey && !e.altKey) {  // indent, do not leave the editor
        e.preventDefault();
        document.execCommand("insertText", false, "  ");
      }
    });
  }

  get text() { return this.textarea.value; }

  set text(value) {
    this.textarea.value = value;
    this.textarea.scrollTop = 0;
    this.render();
  }

  setErrors(errors) {
    this.errors = new Map();
    for (const e of errors) {
      if (e.line == null) continue;
      if (!this.errors.has(e.line)) this.errors.set(e.line, []);
      this.errors.get(e.line).push(e.message);
    }
    this.render();
  }

  render() {
    const lines = this.textarea.value.split("\n");
    const html = [], numbers = [];
    lines.forEach((line, k) => {
      const n = k + 1, messages = this.errors.get(n);
      if (messages) {
        const first = messages[0].split("\n")[0];
        const short = first.length > 90 ? first.slice(0, 87) + "…" : first;
        html.push(`<span class="line error" data-line="${n}" data-message="${lgEscape(short)}">${lgHighlightLine(line)}</span>`);
        numbers.push(`<div class="error" data-line="${n}" title="${lgEscape(messages.join("\n\n"))}">${n}</div>`);
      } else {
        html.push(`<span class="line" data-line="${n}">${lgHighlightLine(line)}</span>`);
        numbers.push(`<div data-line="${n}">${n}</div>`);
      }
    });
    this.highlight.innerHTML = html.join("\n") + "\n";
    this.gutter.innerHTML = numbers.join("");
    this.syncScroll();
  }

  syncScroll() {
    this.highlight.scrollTop = this.textarea.scrollTop;
    this.highlight.scrollLeft = this.textarea.scrollLeft;
    this.gutter.scrollTop = this.textarea.scrollTop;
  }

  goToLine(n) {
    const lines = this.textarea.value.split("\n");
    let start = 0;
    for (let k = 0; k < n - 1 && k < lines.length; k++) start += lines[k].length + 1;
    const end = start + (lines[n - 1] || "").length;
    this.textarea.focus();
    this.textarea.setSelectionRange(start, end);
    const lineHeight = 20;
    this.textarea.scrollTop = Math.max(0, (n - 3) * lineHeight);
    this.syncScroll();
  }
}
