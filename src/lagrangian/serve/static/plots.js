// Line plots on a canvas: time histories with axes, ticks, a legend and a cursor at the animation's time.
"use strict";

const LG_COLORS = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f",
                   "#bcbd22", "#17becf"];

// Ticks at 1, 2 or 5 times a power of ten, about `count` of them across [lo, hi].
function lgTicks(lo, hi, count) {
  const span = hi - lo;
  if (!(span > 0)) return [lo];
  const raw = span / count, power = Math.pow(10, Math.floor(Math.log10(raw)));
  const step = [1, 2, 5, 10].map((m) => m * power).find((s) => s >= raw);
  const out = [];
  for (let v = Math.ceil(lo / step) * step; v <= hi + step * 1e-9; v += step) out.push(Math.abs(v) < step * 1e-9 ? 0 : v);
  return out;
}

function lgTickText(v) {
  const a = Math.abs(v);
  return (a !== 0 && (a < 1e-3 || a >= 1e5)) ? v.toExponential(1) : String(+v.toPrecision(6));
}

// Fit a canvas's drawing buffer to its displayed size (sharp on high-density screens).
function lgFitCanvas(canvas) {
  const ratio = window.devicePixelRatio || 1, rect = canvas.getBoundingClientRect();
  const w = Math.max(1, Math.round(rect.width * ratio)), h = Math.max(1, Math.round(rect.height * ratio));
  if (rect.width > 0 && (canvas.width !== w || canvas.height !== h)) { canvas.width = w; canvas.height = h; }
  const ctx = canvas.getContext("2d");
  const scale = rect.width > 0 ? canvas.width / rect.width : 1;
  ctx.setTransform(scale, 0, 0, scale, 0, 0);
  return { ctx, width: rect.width > 0 ? rect.width : canvas.width, height: rect.height > 0 ? rect.height : canvas.height };
}

class LgPlot {
  constructor(canvas) {
    this.canvas = canvas;
    this.data = null;
  }

  // series: [{name, values}], t: times; title: string; minSpan: the least height of the y range, as a
  // fraction of the largest |value| (a conserved energy's round-off is then drawn as the flat line it is)
  set(t, series, title, minSpan = 0) {
    this.data = { t, series, title };
    let lo = Infinity, hi = -Infinity;
    for (const s of series) for (const v of s.values) { if (v < lo) lo = v; if (v > hi) hi = v; }
    const least = Math.max(minSpan * Math.max(Math.abs(lo), Math.abs(hi), 1), 1e-9);
    if (!(hi - lo >= least)) { const mid = isFinite(lo) ? (lo + hi) / 2 : 0; lo = mid - least / 2; hi = mid + least / 2; }
    const pad = (hi - lo) * 0.06;
    this.yRange = [lo - pad, hi + pad];
    this.draw(null);
  }

  clear(message) {
    this.data = null;
    const { ctx, width, height } = lgFitCanvas(this.canvas);
    ctx.clearRect(0, 0, width, height);
    if (message) {
      ctx.fillStyle = "#5b6270";
      ctx.font = "13px system-ui, sans-serif";
      ctx.fillText(message, 12, 24);
    }
  }

  draw(cursorT) {
    if (!this.data) return;
    const { t, series, title } = this.data;
    const { ctx, width, height } = lgFitCanvas(this.canvas);
    const left = 58, right = 10, top = 24, bottom = 30;
    const w = width - left - right, h = height - top - bottom;
    const t0 = t[0], t1 = t[t.length - 1] > t0 ? t[t.length - 1] : t0 + 1;
    const [y0, y1] = this.yRange;
    const X = (v) => left + (v - t0) / (t1 - t0) * w, Y = (v) => top + (1 - (v - y0) / (y1 - y0)) * h;
    ctx.clearRect(0, 0, width, height);
    ctx.font = "11px system-ui, sans-serif";
    ctx.strokeStyle = "#e3e5ea"; ctx.fillStyle = "#5b6270"; ctx.lineWidth = 1;
    ctx.textAlign = "right"; ctx.textBaseline = "middle";
    for (const v of lgTicks(y0, y1, 5)) {
      ctx.beginPath(); ctx.moveTo(left, Y(v)); ctx.lineTo(left + w, Y(v)); ctx.stroke();
      ctx.fillText(lgTickText(v), left - 5, Y(v));
    }
    ctx.textAlign = "center"; ctx.textBaseline = "top";
    for (const v of lgTicks(t0, t1, 6)) {
      ctx.beginPath(); ctx.moveTo(X(v), top); ctx.lineTo(X(v), top + h); ctx.stroke();
      ctx.fillText(lgTickText(v), X(v), top + h + 4);
    }
    ctx.fillText("t (s)", left + w - 12, top + h + 16);
    ctx.strokeStyle = "#9aa0ab"; ctx.strokeRect(left, top, w, h);
    ctx.save();
    ctx.beginPath(); ctx.rect(left, top, w, h); ctx.clip();
    series.forEach((s, k) => {
      ctx.strokeStyle = LG_COLORS[k % LG_COLORS.length]; ctx.lineWidth = 1.6;
      ctx.beginPath();
      const stride = Math.max(1, Math.floor(t.length / (4 * w)));
      for (let i = 0; i < t.length; i += stride) {
        const x = X(t[i]), y = Y(s.values[i]);
        if (i === 0) ctx.moveTo(x, y); else ctx.lineTo(x, y);
      }
      ctx.stroke();
    });
    if (cursorT != null) {
      ctx.strokeStyle = "rgba(57,73,171,0.7)"; ctx.lineWidth = 1;
      ctx.beginPath(); ctx.moveTo(X(cursorT), top); ctx.lineTo(X(cursorT), top + h); ctx.stroke();
    }
    ctx.restore();
    ctx.textAlign = "left"; ctx.textBaseline = "alphabetic"; ctx.font = "12px system-ui, sans-serif";
    ctx.fillStyle = "#1a1a1a";
    ctx.fillText(title, left, 15);
    let x = left + ctx.measureText(title).width + 14;
    series.forEach((s, k) => {
      ctx.fillStyle = LG_COLORS[k % LG_COLORS.length];
      ctx.fillRect(x, 8, 12, 3);
      ctx.fillStyle = "#1a1a1a";
      ctx.fillText(s.name, x + 16, 15);
      x += 26 + ctx.measureText(s.name).width;
    });
  }
}
