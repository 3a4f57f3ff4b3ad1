// tmakit's solution page: the measurement model of the point kinds, in the page.
//
// Mirrors tmakit.measurements (bearing atan2(dE, dN); range |p|; frequency f0 (1 - rdot / c)
// with the carrier f0 eliminated by weighted least squares at the solution shown, as the
// variable projection of the maximum likelihood eliminates it) and the WGS-84 East-North-Up
// frame of tmakit.geodesy, so that the stacked dots and chi-square of a dragged solution are
// the ones Python gives for it.  Called once per page with the page's Bokeh models.
function tmaSolutionPage(a) {
  "use strict";
  const cfg = a.config;
  const rows = a.rows.data;
  const n = rows.t.length;
  const TWO_PI = 2 * Math.PI;
  // WGS-84
  const A = 6378137.0, F = 1 / 298.257223563, E2 = F * (2 - F);
  const rad = Math.PI / 180;

  function ecef(latDeg, lonDeg, h) {
    const la = latDeg * rad, lo = lonDeg * rad;
    const s = Math.sin(la), c = Math.cos(la);
    const N = A / Math.sqrt(1 - E2 * s * s);
    return [(N + h) * c * Math.cos(lo), (N + h) * c * Math.sin(lo), (N * (1 - E2) + h) * s];
  }
  const O = cfg.origin;  // [lat, lon, alt] or null
  const o = O ? ecef(O[0], O[1], O[2]) : null;
  const sla = O ? Math.sin(O[0] * rad) : 0, cla = O ? Math.cos(O[0] * rad) : 1;
  const slo = O ? Math.sin(O[1] * rad) : 0, clo = O ? Math.cos(O[1] * rad) : 1;

  function enuOf(latDeg, lonDeg, h) {
    const p = ecef(latDeg, lonDeg, h);
    const dx = p[0] - o[0], dy = p[1] - o[1], dz = p[2] - o[2];
    return [-slo * dx + clo * dy,
            -sla * clo * dx - sla * slo * dy + cla * dz,
            cla * clo * dx + cla * slo * dy + sla * dz];
  }
  function geodeticOf(e, nn, u) {
    const x = o[0] - slo * e - sla * clo * nn + cla * clo * u;
    const y = o[1] + clo * e - sla * slo * nn + cla * slo * u;
    const z = o[2] + cla * nn + sla * u;
    const lon = Math.atan2(y, x), p = Math.hypot(x, y);
    let lat = Math.atan2(z, p * (1 - E2)), h = 0;
    for (let k = 0; k < 6; k++) {
      const s = Math.sin(lat), N = A / Math.sqrt(1 - E2 * s * s);
      h = p / Math.cos(lat) - N;
      lat = Math.atan2(z, p * (1 - E2 * N / (N + h)));
    }
    return [lat / rad, lon / rad, h];
  }
  // Map coordinates: (lon, lat) of the point at (east, north, up = 0), as tmakit's MapFrame;
  // without an origin, East and North in km.
  function toMap(e, nn) {
    if (!O) return [e / 1000, nn / 1000];
    const g = geodeticOf(e, nn, 0);
    return [g[1], g[0]];
  }
  function fromMap(x, y) {
    if (!O) return [x * 1000, y * 1000];
    let h = O[2], enu = null;
    for (let k = 0; k < 4; k++) {  // the height at which up = 0 (MapFrame's plane)
      enu = enuOf(y, x, h);
      h -= enu[2];
    }
    return [enu[0], enu[1]];
  }

  // The residuals (in sigma) and chi-square of the rows at a state [x y z vx vy vz] at tref.
  const z = new Float64Array(n);
  const refs = cfg.carrier_ref, nt = refs.length;  // one carrier per tonal
  const sAA = new Float64Array(nt), sAU = new Float64Array(nt), delta = new Float64Array(nt);
  const carrier = new Array(nt).fill(NaN);
  function residuals(s) {
    const t = rows.t, kind = rows.kind, val = rows.value, sig = rows.sigma, tonal = rows.tonal;
    const se = rows.se, sn = rows.sn, su = rows.su, sve = rows.sve, svn = rows.svn,
          svu = rows.svu;
    const c = cfg.c;
    sAA.fill(0);
    sAU.fill(0);
    const small = new Float64Array(n);
    for (let i = 0; i < n; i++) {
      const dt = t[i] - cfg.ref_time;
      const dx = s[0] + s[3] * dt - se[i], dy = s[1] + s[4] * dt - sn[i],
            dz = s[2] + s[5] * dt - su[i];
      const k = kind[i];
      if (k === 0) {  // bearing, clockwise from North
        let r = val[i] - Math.atan2(dx, dy);
        if (r > Math.PI) r -= TWO_PI; else if (r <= -Math.PI) r += TWO_PI;
        z[i] = r / sig[i];
      } else if (k === 1) {  // range
        z[i] = (val[i] - Math.sqrt(dx * dx + dy * dy + dz * dz)) / sig[i];
      } else if (k === 2) {  // frequency: f = f0 (1 + small), small = -rdot / c
        const rng = Math.sqrt(dx * dx + dy * dy + dz * dz);
        const rdot = (dx * (s[3] - sve[i]) + dy * (s[4] - svn[i]) + dz * (s[5] - svu[i])) / rng;
        small[i] = -rdot / c;
        const w = 1 / (sig[i] * sig[i]), av = 1 + small[i], g = tonal[i], ref = refs[g];
        const u = (val[i] - ref) - ref * small[i];  // formed about the reference carrier
        sAA[g] += w * av * av;
        sAU[g] += w * av * u;
      } else {
        z[i] = NaN;
      }
    }
    for (let g = 0; g < nt; g++) {
      delta[g] = sAA[g] > 0 ? sAU[g] / sAA[g] : 0;
      carrier[g] = sAA[g] > 0 ? refs[g] + delta[g] : NaN;
    }
    let chi2 = 0;
    for (let i = 0; i < n; i++) {
      if (kind[i] === 2) {
        const g = tonal[i], ref = refs[g];
        z[i] = ((val[i] - ref) - ref * small[i] - delta[g] * (1 + small[i])) / sig[i];
      }
      chi2 += z[i] * z[i];
    }
    return chi2;
  }

  const stats = document.getElementById("tma-stats");
  const ml = cfg.ml.slice();
  const cur = ml.slice();
  const tau = cfg.tau;  // s: the velocity handle sits at position + velocity * tau
  let chi2 = NaN, busy = false, last = null;
  const timings = [];

  function handleXY() {
    const p = toMap(cur[0], cur[1]);
    if (!cfg.moving) return [[p[0]], [p[1]]];
    const q = toMap(cur[0] + cur[3] * tau, cur[1] + cur[4] * tau);
    return [[p[0], q[0]], [p[1], q[1]]];
  }
  function placeHandles() {
    const xy = handleXY();
    a.handles.data = {x: xy[0], y: xy[1], m: ["square", "circle"].slice(0, xy[0].length)};
    last = [xy[0].slice(), xy[1].slice()];  // (the tool edits the source's arrays in place)
    a.stick.data = {x: xy[0], y: xy[1]};
  }

  function fmt(v, d) { return Number.isFinite(v) ? v.toFixed(d) : "—"; }
  function words() {
    const course = (Math.atan2(cur[3], cur[4]) / rad + 360) % 360;
    const speed = Math.hypot(cur[3], cur[4]);
    const g = O ? geodeticOf(cur[0], cur[1], 0) : null;
    let s = "<b>χ² " + fmt(chi2, 1) + "</b> on " + cfg.n_used + " rows (ML solution: " +
      fmt(cfg.ml_chi2, 1) + "; χ²/dof " + fmt(chi2 / cfg.dof, 2) + ")<br>";
    s += "at " + cfg.ref_label + ": " + (g ? "lat " + fmt(g[0], 5) + "°, lon " + fmt(g[1], 5) +
      "°" : "E " + fmt(cur[0] / 1000, 3) + " km, N " + fmt(cur[1] / 1000, 3) + " km");
    if (cfg.moving) {
      s += ", course " + fmt(course, 1) + "°, speed " + fmt(speed, 2) + " m/s (" +
        fmt(speed / 0.514444, 1) + " kn)";
    }
    const f0 = carrier.filter(Number.isFinite).map((f) => fmt(f, 3));
    if (f0.length) s += ", f0 " + f0.join(", ") + " Hz";
    const per = [];
    for (const k of cfg.kinds) {
      let ss = 0, m = 0, out = 0;
      for (let i = 0; i < n; i++) {
        if (rows.kind[i] === k.code) { ss += z[i] * z[i]; m++; if (Math.abs(z[i]) > 3) out++; }
      }
      per.push(k.name + " RMS " + fmt(Math.sqrt(ss / m), 2) + " σ, " + out + " beyond 3σ");
    }
    return s + "<br>" + per.join("; ");
  }

  // a.dots: one source per kind and series ({kind, source, renderer}, and on a large panel a
  // light_source of every few dots drawn instead while the mouse drags); a.ranges[kind]: its
  // y range.  `light`: a drag's update (the light dots; all of them once the drag stops).
  function roundUp(v) {
    const p = Math.pow(10, Math.floor(Math.log10(v)));
    return v <= p ? p : v <= 2 * p ? 2 * p : v <= 5 * p ? 5 * p : 10 * p;
  }
  let lightShown = false;
  // Each update is timed to the end of the repaint of every plot it changed (Bokeh's
  // `repainted`): `waiting` holds the plots not yet repainted, `open` the updates they close.
  const plots = Bokeh.index.select(a.figures);
  const waiting = new Set(), open = [];
  for (const v of plots) {
    v.repainted.connect(() => {
      waiting.delete(v);
      if (waiting.size > 0) return;
      const now = performance.now();
      for (const r of open.splice(0)) { r.painted_ms = now - r.t0; delete r.t0; timings.push(r); }
    });
  }
  function update(since, light) {
    const tStart = performance.now();
    const t0 = since === undefined ? tStart : since;
    chi2 = residuals(cur);
    const tModel = performance.now();
    const big = {};
    for (const d of a.dots) {  // the stacked dots
      const src = light && d.light_source ? d.light_source : d.source;
      if (d.light_source && lightShown !== Boolean(light)) {
        d.renderer.visible = !light;
        d.light_renderer.visible = Boolean(light);
      }
      const idx = src.data.row, zz = src.data.z;
      let m = big[d.kind] || 4;
      for (let j = 0; j < idx.length; j++) {
        zz[j] = z[idx[j]];
        const v = Math.abs(zz[j]) * 1.1;
        if (v > m) m = v;
      }
      big[d.kind] = m;
      src.change.emit();
    }
    lightShown = Boolean(light);
    for (const kind in big) {  // a new scale only when the dots leave it or shrink well inside
      const yr = a.ranges[kind];
      if (big[kind] > yr.end || big[kind] < 0.4 * yr.end) {
        const end = Math.max(4, roundUp(big[kind]));  // 1, 2 or 5 times a power of ten
        yr.setv({start: -end, end: end});
      }
    }
    const tDots = performance.now();
    const tt = a.track.data.t, tx = a.track.data.x, ty = a.track.data.y;
    for (let j = 0; j < tt.length; j++) {
      const dt = tt[j] - cfg.ref_time;
      const p = toMap(cur[0] + cur[3] * dt, cur[1] + cur[4] * dt);
      tx[j] = p[0]; ty[j] = p[1];
    }
    a.track.change.emit();
    const tTrack = performance.now();
    stats.innerHTML = words();  // numbers and fixed words only
    const t1 = performance.now();
    for (const v of plots) waiting.add(v);
    open.push({t0: t0, input_ms: tStart - t0, model_ms: tModel - tStart, dots_ms: tDots - tModel,
               track_ms: tTrack - tDots, stats_ms: t1 - tTrack, compute_ms: t1 - tStart,
               drag: Boolean(light)});
  }

  // A drag of the handles (Bokeh's PointDrawTool edits their data in place): the solution,
  // its dots and chi-square follow at once (Chromium delivers a drag's moves once a frame),
  // drawn at the next frame.
  let idle = null, pointerAt = -Infinity;
  const DRAG_STOP_MS = 200;
  document.addEventListener("pointermove", (e) => { pointerAt = e.timeStamp; },
                            {capture: true, passive: true});
  function onHandles() {
    if (busy || !cfg.draggable) return;
    const now = performance.now();  // timed from the mouse event that moved the handle
    const moved = now - pointerAt < 1000 ? Math.min(pointerAt, now) : now;
    const d = a.handles.data;
    if (d.x.length !== last[0].length) { busy = true; placeHandles(); busy = false; return; }
    busy = true;
    try {
      if (d.x[0] !== last[0][0] || d.y[0] !== last[1][0]) {
        const en = fromMap(d.x[0], d.y[0]);
        cur[0] = en[0]; cur[1] = en[1];
      } else if (cfg.moving && (d.x[1] !== last[0][1] || d.y[1] !== last[1][1])) {
        const en = fromMap(d.x[1], d.y[1]);
        cur[3] = (en[0] - cur[0]) / tau; cur[4] = (en[1] - cur[1]) / tau;
      } else {
        return;
      }
      const xy = handleXY();
      for (let j = 0; j < xy[0].length; j++) { d.x[j] = xy[0][j]; d.y[j] = xy[1][j]; }
      last = [xy[0].slice(), xy[1].slice()];
      a.stick.data = {x: xy[0], y: xy[1]};
      update(moved, true);
      clearTimeout(idle);  // every dot again once the drag has stopped
      idle = setTimeout(() => { idle = null; update(); }, DRAG_STOP_MS);
    } finally {
      busy = false;
    }
  }

  function setState(s) {
    for (let j = 0; j < 6; j++) cur[j] = s[j];
    busy = true; placeHandles(); busy = false;
    update();
  }

  const api = {
    ready: true,
    onHandles: onHandles,
    // whether an update is still to come or to be drawn
    pending: () => idle !== null || open.length > 0,
    reset: () => { if (cfg.draggable) setState(ml); },
    // for scripted use and tests: move the solution at the reference time by (dE, dN) m and
    // its velocity by (dvE, dvN) m/s
    moveBy: (de, dn, dve, dvn) => cfg.draggable && setState([cur[0] + de, cur[1] + dn, cur[2],
                                            cur[3] + (dve || 0), cur[4] + (dvn || 0), cur[5]]),
    state: () => cur.slice(),
    residuals: () => Array.from(z),
    // the residuals drawn, per row of the set (NaN for a row not drawn)
    shown: () => {
      const out = new Array(n).fill(NaN);
      for (const d of a.dots) {
        const dd = d.source.data;
        for (let j = 0; j < dd.row.length; j++) out[dd.row[j]] = dd.z[j];
      }
      return out;
    },
    chi2: () => chi2,
    carrier: () => (nt === 1 ? carrier[0] : carrier.slice()),  // Hz, one per tonal
    timings: timings,
    toMap: toMap,
    fromMap: fromMap,
  };
  // The handles and the dots are drawn from Python at the ML solution (the same numbers);
  // only the words are made here.
  document.getElementById("tma-reset").addEventListener("click", api.reset);
  last = [a.handles.data.x.slice(), a.handles.data.y.slice()];
  if (cfg.draggable) { chi2 = residuals(cur); stats.innerHTML = words(); }
  api.readyAt = performance.now();
  requestAnimationFrame(() => { api.paintedAt = performance.now(); });
  return api;
}
