// The mechanism drawn on a canvas from the geometry the server computes (lagrangian.plot._geometry):
// the same rules as `lagrangian animate`. Particles are dots whose area grows with their mass (blocks
// when they slide on a track), rigid bodies disks of radius sqrt(I/m) with a spoke, rods join the
// nodes at constant distance, springs are zigzags, dampers dashpots, fixed points stand on hatched
// blocks. Spatial models are drawn in an axonometric view that the mouse turns; a body in space shows
// its frame's axes (x red, y green, z blue), the link that carries it and its disk; wheels roll on a
// grid, the ground. When the server's framing follows the mechanism (a bicycle riding away), each
// frame is drawn about the framing's centre at that frame.
"use strict";

class LgMechanism {
  constructor(canvas) {
    this.canvas = canvas;
    this.geometry = null;
    this.azimuth = -0.6;   // 3D view angles (radians)
    this.elevation = 0.45;
    this.frame = 0;
    let drag = null;
    canvas.addEventListener("pointerdown", (e) => { if (this.geometry && this.geometry.dim === 3) { drag = [e.clientX, e.clientY]; canvas.setPointerCapture(e.pointerId); } });
    canvas.addEventListener("pointermove", (e) => {
      if (!drag) return;
      this.azimuth -= (e.clientX - drag[0]) * 0.01;
      this.elevation = Math.max(-1.5, Math.min(1.5, this.elevation + (e.clientY - drag[1]) * 0.01));
      drag = [e.clientX, e.clientY];
      this.project(); this.draw(this.frame);
    });
    canvas.addEventListener("pointerup", () => { drag = null; });
  }

  set(geometry) {
    this.geometry = geometry;
    const masses = geometry.nodes.map((n) => n.mass).filter((m) => m > 0);
    this.maxMass = masses.length ? Math.max(...masses) : 1;
    this.project();
  }

  // 2D points of every node in every frame (the 3D ones through the view, about the framing's centre
  // when it follows), the same for the bodies in space (link, axes, disk), and the view's scale.
  project() {
    const g = this.geometry;
    if (!g) return;
    const ca = Math.cos(this.azimuth), sa = Math.sin(this.azimuth), ce = Math.cos(this.elevation), se = Math.sin(this.elevation);
    const base = g.dim === 3
      ? (p) => [ca * p[0] - sa * p[1], se * (sa * p[0] + ca * p[1]) * -1 + ce * p[2]]
      : (p) => [p[0], p[1]];
    const F = g.framing, follow = F.follow;
    this.view = (p, k) => base(follow ? p.map((c, i) => c - F.centre[k][i]) : p);
    this.points = g.positions.map((frame, k) => frame.map((p) => this.view(p, k)));
    const L = g.axis_length;
    this.spatial = g.spatial.map((b) => b.origin.map((o, k) => {
      const r = b.rotation[k], column = (j) => [r[j], r[3 + j], r[6 + j]];
      const link = b.link[k], centre = link[link.length - 1];
      const out = {
        link: link.map((p) => this.view(p, k)),
        axes: [0, 1, 2].map((j) => [o, o.map((c, i) => c + L * column(j)[i])].map((p) => this.view(p, k))),
        disk: null,
      };
      if (b.radius !== null) {
        const u = column((b.axis + 1) % 3), v = column((b.axis + 2) % 3);
        out.disk = [];
        for (let m = 0; m <= LG_DISK_POINTS; m++) {
          const phi = 2 * Math.PI * m / LG_DISK_POINTS, c = Math.cos(phi), s = Math.sin(phi);
          out.disk.push(this.view(centre.map((x, i) => x + b.radius * (c * u[i] + s * v[i])), k));
        }
      }
      return out;
    }));
    let lo = [Infinity, Infinity], hi = [-Infinity, -Infinity];
    const extend = (p) => { for (let k = 0; k < 2; k++) { lo[k] = Math.min(lo[k], p[k]); hi[k] = Math.max(hi[k], p[k]); } };
    for (const frame of this.points) frame.forEach(extend);
    for (const body of this.spatial) for (const d of body) { d.link.forEach(extend); d.axes.forEach((a) => a.forEach(extend)); if (d.disk) d.disk.forEach(extend); }
    this.size = F.size;
    this.radius = {};
    for (const i of g.bodies) {
      const n = g.nodes[i];
      this.radius[i] = n.mass > 0 ? Math.min(Math.sqrt(n.inertia / n.mass), 0.1 * this.size) : 0.05 * this.size;
    }
    this.pad = 0.12 * this.size + Math.max(0, ...Object.values(this.radius));
    this.lo = [lo[0] - this.pad, lo[1] - this.pad];
    this.hi = [hi[0] + this.pad, hi[1] + this.pad];
  }

  // The lines of the ground's grid (z = 0) in the framing's box at frame k, projected; none when the
  // box misses the ground.
  groundLines(k) {
    const g = this.geometry, F = g.framing, c = F.centre[F.follow ? k : 0], step = g.ground.step;
    const lo = c.map((x, i) => x - F.half[i] - this.pad), hi = c.map((x, i) => x + F.half[i] + this.pad);
    if (!(lo[2] <= 0 && 0 <= hi[2])) return [];
    const lines = [];
    for (const axis of [0, 1]) {
      const other = 1 - axis;
      for (let m = Math.ceil(lo[axis] / step - 1e-9); m <= Math.floor(hi[axis] / step + 1e-9); m++) {
        const a = [0, 0, 0], b = [0, 0, 0];
        a[axis] = b[axis] = m * step; a[other] = lo[other]; b[other] = hi[other];
        lines.push([this.view(a, k), this.view(b, k)]);
      }
    }
    return lines;
  }

  frameAt(t) {  // the last frame at or before t
    const times = this.geometry.t;
    let a = 0, b = times.length - 1;
    if (t >= times[b]) return b;
    while (b - a > 1) { const m = (a + b) >> 1; if (times[m] <= t) a = m; else b = m; }
    return a;
  }

  draw(k) {
    const g = this.geometry;
    const { ctx, width, height } = lgFitCanvas(this.canvas);
    ctx.clearRect(0, 0, width, height);
    if (!g) return;
    this.frame = k;
    const spanX = this.hi[0] - this.lo[0], spanY = this.hi[1] - this.lo[1];
    const scale = Math.min(width / spanX, height / spanY);
    const ox = (width - scale * spanX) / 2, oy = (height - scale * spanY) / 2;
    const S = (p) => [ox + (p[0] - this.lo[0]) * scale, height - oy - (p[1] - this.lo[1]) * scale];
    const P = this.points[k];
    const size = this.size;
    const line = (pts, color, w, dash) => {
      ctx.strokeStyle = color; ctx.lineWidth = w; ctx.lineCap = "round"; ctx.lineJoin = "round";
      ctx.beginPath();
      let pen = false;
      for (const p of pts) {
        if (p === null) { pen = false; continue; }
        const [x, y] = S(p);
        if (pen) ctx.lineTo(x, y); else ctx.moveTo(x, y);
        pen = true;
      }
      ctx.stroke();
    };
    if (g.dim === 3 && !g.framing.follow) this.drawAxes(ctx, S);
    if (g.ground) for (const seg of this.groundLines(k)) line(seg, "#b8bcc4", 0.8);
    // tracks and ground
    for (const tr of g.tracks) {
      let a = Infinity, b = -Infinity;
      for (const frame of g.positions) for (const p of frame) {
        const s = (p[0] - tr.point[0]) * tr.direction[0] + (p[1] - tr.point[1]) * tr.direction[1] + (g.dim === 3 ? (p[2] - tr.point[2]) * tr.direction[2] : 0);
        a = Math.min(a, s); b = Math.max(b, s);
      }
      const end = (s) => this.view(tr.point.map((c, i) => c + (s) * tr.direction[i]), k);
      line([end(a - 0.15 * size), end(b + 0.15 * size)], "#999", 1.5);
    }
    const ground = 0.07 * size * scale;
    g.nodes.forEach((n, i) => {
      if (!n.fixed) return;
      const [x, y] = S(P[i]);
      ctx.strokeStyle = "#666"; ctx.lineWidth = 1;
      ctx.strokeRect(x - ground / 2, y - ground / 2, ground, ground);
      ctx.save(); ctx.beginPath(); ctx.rect(x - ground / 2, y - ground / 2, ground, ground); ctx.clip();
      for (let d = -ground; d < ground; d += 5) { ctx.beginPath(); ctx.moveTo(x - ground / 2 + d, y + ground / 2); ctx.lineTo(x - ground / 2 + d + ground, y - ground / 2); ctx.stroke(); }
      ctx.restore();
    });
    for (const [i, j] of g.rods) line([P[i], P[j]], "#404040", 3.5);
    const width2 = 0.04 * size;
    for (const [, i, j] of g.springs) line(lgZigzag(P[i], P[j], width2), "#1f77b4", 1.6);
    for (const [, i, j] of g.dampers) line(lgDashpot(P[i], P[j], width2), "#2ca02c", 1.6);
    for (const body of this.spatial) {
      const d = body[k];
      if (d.link.length > 1) line(d.link, "#404040", 3.5);
      if (d.disk) line(d.disk, "#ff7f0e", 1.8);
      d.axes.forEach((seg, j) => line(seg, LG_AXIS_COLORS[j], 2));
    }
    g.bodies.forEach((i, b) => {
      const [x, y] = S(P[i]), r = this.radius[i] * scale, a = g.angles[k][b];
      ctx.fillStyle = "rgba(255,127,14,0.45)"; ctx.strokeStyle = "#ff7f0e"; ctx.lineWidth = 1.5;
      ctx.beginPath(); ctx.arc(x, y, r, 0, 2 * Math.PI); ctx.fill(); ctx.stroke();
      if (g.dim === 2) { ctx.beginPath(); ctx.moveTo(x, y); ctx.lineTo(x + r * Math.cos(a), y - r * Math.sin(a)); ctx.stroke(); }
    });
    g.nodes.forEach((n, i) => {
      if (n.kind === "end") return;
      const [x, y] = S(P[i]);
      ctx.lineWidth = 1.2; ctx.strokeStyle = "#000";
      if (n.kind === "particle" || n.kind === "body") {
        const d = (7 + 13 * Math.sqrt(n.mass / this.maxMass)) * 1.25;
        ctx.fillStyle = n.kind === "body" ? "#ff7f0e" : "#d62728";
        if (n.slider) { const s = d * 1.6; ctx.fillRect(x - s / 2, y - s / 2, s, s); ctx.strokeRect(x - s / 2, y - s / 2, s, s); }
        else { ctx.beginPath(); ctx.arc(x, y, d / 2, 0, 2 * Math.PI); ctx.fill(); ctx.stroke(); }
      } else if (n.slider) {
        ctx.fillStyle = "#fff"; ctx.fillRect(x - 10, y - 10, 20, 20); ctx.strokeRect(x - 10, y - 10, 20, 20);
      } else {
        ctx.fillStyle = "#fff"; ctx.beginPath(); ctx.arc(x, y, 4, 0, 2 * Math.PI); ctx.fill(); ctx.stroke();
      }
    });
    ctx.fillStyle = "#1a1a1a"; ctx.font = "14px system-ui, sans-serif"; ctx.textAlign = "left"; ctx.textBaseline = "top";
    ctx.fillText(`t = ${g.t[k].toFixed(2)} s`, 10, 8);
    if (g.dim === 3) {
      ctx.fillStyle = "#5b6270"; ctx.font = "12px system-ui, sans-serif";
      ctx.fillText("drag to turn the view" + (g.framing.follow ? "; it follows the mechanism" : ""), 10, 26);
    }
    this.canvas.dataset.frame = String(k);
    this.canvas.dataset.time = String(g.t[k]);
  }

  drawAxes(ctx, S) {  // the world's axes at its origin (a view that does not follow)
    const o = this.view([0, 0, 0], 0), L = 0.25 * this.size;
    ["x", "y", "z"].forEach((name, k) => {
      const e = [0, 0, 0]; e[k] = L;
      const p = this.view(e, 0), [x0, y0] = S(o), [x1, y1] = S(p);
      ctx.strokeStyle = "#b0b4bd"; ctx.lineWidth = 1; ctx.beginPath(); ctx.moveTo(x0, y0); ctx.lineTo(x1, y1); ctx.stroke();
      ctx.fillStyle = "#8a8f98"; ctx.font = "12px system-ui, sans-serif"; ctx.fillText(name, x1 + 3, y1 - 3);
    });
  }
}

// The points of a disk's outline (lagrangian.plot._geometry.DISK_POINTS) and the colours of a body's axes.
const LG_DISK_POINTS = 48;
const LG_AXIS_COLORS = ["#d62728", "#2ca02c", "#1f77b4"];

function lgSub(a, b) { return a.map((v, i) => v - b[i]); }
function lgNormal(u) { return [-u[1], u[0]]; }

function lgZigzag(a, b, width, coils = 7) {
  const d = lgSub(b, a), len = Math.hypot(...d);
  if (len < 1e-12) return [a, b];
  const u = d.map((v) => v / len), n = lgNormal(u), pts = [];
  const s = [0, 0.15];
  for (let k = 1; k < 2 * coils; k++) s.push(0.15 + 0.7 * k / (2 * coils));
  s.push(0.85, 1);
  s.forEach((si, k) => {
    const off = (k >= 2 && k < s.length - 2) ? width * ((k - 2) % 2 === 0 ? 1 : -1) : 0;
    pts.push([a[0] + si * len * u[0] + off * n[0], a[1] + si * len * u[1] + off * n[1]]);
  });
  return pts;
}

function lgDashpot(a, b, width) {
  const d = lgSub(b, a), len = Math.hypot(...d);
  if (len < 1e-12) return [a, b];
  const u = d.map((v) => v / len), n = lgNormal(u);
  const p = (s, o) => [a[0] + s * len * u[0] + o * width * n[0], a[1] + s * len * u[1] + o * width * n[1]];
  return [p(0, 0), p(0.5, 0), null, p(0.5, -0.75), p(0.5, 0.75), null,
          p(0.3, 1), p(0.7, 1), p(0.7, -1), p(0.3, -1), null, p(0.7, 0), p(1, 0)];
}
