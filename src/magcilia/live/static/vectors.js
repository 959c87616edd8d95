/* magcilia dashboard: the views of force vectors (a 3-axis sensor, an array of cilia).
 *
 * dashboard.js hands over the version-2 frames (header: 7 numbers and the number of cilia C;
 * then the column time and, per cilium, Fx, Fy, σx, σy in display units and the flag bits).
 * Shown: a polar view of the chosen cilium's force (the tip of its vector over the last seconds,
 * its σ ellipse, the span's circle), Fx and Fy with their σ bands and |F| over the window, and for
 * an array a map of the cilia at their places on the board (an arrow each, coloured by |F|;
 * click one to choose it). window.magciliaVectors is the interface; window.magcilia.vectors holds
 * the newest vector of every cilium ([fx, fy], display units; null without a value) and
 * window.magcilia.chosen the chosen cilium's index.
 */
(function () {
  "use strict";

  const HEADER = 8;
  const PER = 5;
  const BLUE = "#1f4e9c";
  const GREEN = "#1d7a46";
  const GREY = "rgba(100, 110, 125, 0.9)";
  const TRAIL = 3; // seconds of the tip's path in the polar view
  const NEAR_ZERO = 1024;
  const NEAR_ZERO_SIGMAS = 3;

  const V = (window.magciliaVectors = {});
  // the Flag bits a force vector's badge shows (magcilia.readout.protocol.Flag; NEAR ZERO is
  // said by the direction's "—"); TARE UNDER LOAD and ZERO DRIFT come from the pipeline's zero
  // (a tare kept under load, a drift not tracked) on every cilium's estimate
  const TARE_UNDER_LOAD = 4096;
  const ZERO_DRIFT = 8192;
  V.FLAGS = [[1, "OUTSIDE SPAN", "warn"], [4, "SATURATED", "bad"], [8, "EXTRAPOLATED", "warn"],
    [64, "ABOVE SPAN", "warn"], [128, "AMBIGUOUS", "warn"], [256, "UNDETERMINED", "bad"],
    [512, "NOT CONVERGED", "warn"], [2048, "MISSING", "bad"],
    [TARE_UNDER_LOAD, "TARE UNDER LOAD", "bad"], [ZERO_DRIFT, "ZERO DRIFT", "warn"]];
  let info = null;
  let C = 1;
  let T = [];
  let cols = []; // per cilium: [FX, FY, SX, SY, FL]
  let chosen = 0;
  let latest = [];
  let plotXY = null;
  let plotM = null;
  let binSeconds = 0.02;

  const $ = (id) => document.getElementById(id);

  function clearData() {
    T = [];
    cols = Array.from({ length: C }, () => [[], [], [], [], []]);
    latest = Array.from({ length: C }, () => null);
    if (window.magcilia) window.magcilia.vectors = latest;
  }

  V.init = function (inf) {
    info = inf;
    C = Math.max(1, inf.cilia.length);
    clearData();
    chosen = 0;
    window.magcilia.chosen = 0;
    document.body.classList.add(inf.kind === "array" ? "kind-array" : "kind-vector");
    $("vector-view").hidden = false;
    $("map-card").hidden = inf.kind !== "array";
    if (inf.kind === "vector") {
      // beside the polar view: Fx and Fy; below: |F|
      $("vector-view").appendChild($("plot-value").parentElement);
    }
    document.querySelector("#plot-value").parentElement.querySelector(".legend").innerHTML =
      '<i class="sw sw-value"></i>Fx <i class="sw sw-fy"></i>Fy <i class="sw sw-band"></i>± σ';
    makePlots();
    const map = $("map");
    map.addEventListener("click", (ev) => {
      const c = nearest(ev);
      if (c !== null) V.choose(c);
    });
    V.choose(0);
  };

  V.choose = function (c) {
    chosen = Math.max(0, Math.min(C - 1, c));
    window.magcilia.chosen = chosen;
    const name = info.cilia[chosen];
    $("chosen").textContent = info.kind === "array" ? `cilium ${name}` : "";
    $("value-title").textContent = info.kind === "array"
      ? `cilium ${name}: Fx and Fy (${info.unit}) with their σ bands`
      : `Fx and Fy (${info.unit}) with their σ bands`;
    $("raw-title").textContent = info.kind === "array"
      ? `cilium ${name}: |F| (${info.unit})` : `|F| (${info.unit})`;
    V.draw();
  };

  V.clear = clearData;

  // -- frames --------------------------------------------------------------------------------
  V.onFrame = function (dv) {
    const h = (i) => dv.getFloat64(8 * i, true);
    const n = h(2);
    binSeconds = h(5) || binSeconds;
    if (h(7) !== C) return null;
    const at = (row, i) => dv.getFloat64(8 * (HEADER + row * n + i), true);
    const last = T.length ? T[T.length - 1] : null;
    for (let i = 0; i < n; i++) {
      const t = at(0, i);
      const gap = last !== null && i === 0 && t - last > 3 * binSeconds + 0.02;
      if (gap) T.push((t + last) / 2);
      T.push(t);
      for (let c = 0; c < C; c++) {
        const a = cols[c];
        for (let k = 0; k < PER; k++) {
          if (gap) a[k].push(k === 4 ? 0 : null);
          const x = at(1 + c * PER + k, i);
          a[k].push(k === 4 ? x : (Number.isFinite(x) ? x : null));
        }
      }
    }
    let flags = 0;
    if (n > 0) {
      for (let c = 0; c < C; c++) {
        const fx = at(1 + c * PER, n - 1), fy = at(2 + c * PER, n - 1);
        latest[c] = Number.isFinite(fx) && Number.isFinite(fy) ? [fx, fy] : null;
      }
      for (let i = 0; i < n; i++) flags |= at(5 + chosen * PER, i);
    }
    const cutoff = T[T.length - 1] - info.window_s - binSeconds;
    let k = 0;
    while (k < T.length && T[k] < cutoff) k++;
    if (k > 0) {
      T.splice(0, k);
      for (const a of cols) for (const x of a) x.splice(0, k);
    }
    if (n === 0) return null;
    const a = cols[chosen], j = a[0].length - 1;
    const fx = a[0][j], fy = a[1][j];
    const good = fx !== null && fy !== null;
    return {
      value: good ? Math.hypot(fx, fy) : null,
      sigma: good ? sigmaMagnitude(fx, fy, a[2][j], a[3][j]) : null,
      // no direction within NEAR_ZERO_SIGMAS σ of zero (as the terminal view and the read-outs)
      direction: good && !(a[4][j] & NEAR_ZERO) &&
        Math.hypot(fx, fy) > NEAR_ZERO_SIGMAS * Math.max(a[2][j], a[3][j])
        ? Math.atan2(fy, fx) : null,
      components: good ? [fx, fy, a[2][j], a[3][j]] : null,
      flags,
    };
  };

  function sigmaMagnitude(fx, fy, sx, sy) {
    const m = Math.hypot(fx, fy);
    return m > 0 ? Math.hypot(fx * sx, fy * sy) / m : Math.max(sx, sy);
  }

  // -- plots ---------------------------------------------------------------------------------
  function xRange(u, min, max) {
    const w = info ? info.window_s : 10;
    return max === null || max === undefined || max < w ? [0, w] : [max - w, max];
  }

  function yRange(u, min, max) {
    const s = info.span[1];
    if (min === null || max === null) return [-1.06 * s, 1.06 * s];
    return [Math.min(min, -0.1 * s), Math.max(max, 0.1 * s)];
  }

  function width(id) {
    return Math.max(300, $(id).clientWidth);
  }

  function makePlots() {
    const sync = { key: "magcilia" };
    const unit = info.unit;
    plotXY = new uPlot({
      width: width("plot-value"), height: 270, legend: { show: false },
      cursor: { sync, drag: { x: false, y: false } },
      scales: { x: { time: false, range: xRange }, y: { range: yRange } },
      axes: [{ label: "time (s)", labelSize: 20, size: 36 },
        { label: `force (${unit})`, labelSize: 20, size: 64 }],
      series: [{},
        { label: "Fx", stroke: BLUE, width: 1.5, spanGaps: false },
        { label: "Fx+σ", stroke: "rgba(31, 78, 156, 0.25)", width: 0.5, spanGaps: false },
        { label: "Fx−σ", stroke: "rgba(31, 78, 156, 0.25)", width: 0.5, spanGaps: false },
        { label: "Fy", stroke: GREEN, width: 1.5, spanGaps: false },
        { label: "Fy+σ", stroke: "rgba(29, 122, 70, 0.25)", width: 0.5, spanGaps: false },
        { label: "Fy−σ", stroke: "rgba(29, 122, 70, 0.25)", width: 0.5, spanGaps: false }],
      bands: [{ series: [2, 3], fill: "rgba(31, 78, 156, 0.18)" },
        { series: [5, 6], fill: "rgba(29, 122, 70, 0.18)" }],
    }, traces(), $("plot-value"));
    plotM = new uPlot({
      width: width("plot-raw"), height: 160, legend: { show: false },
      cursor: { sync, drag: { x: false, y: false } },
      scales: { x: { time: false, range: xRange },
        y: { range: (u, min, max) => [0, Math.max(info.span[1], max || 0) * 1.06] } },
      axes: [{ label: "time (s)", labelSize: 20, size: 36 },
        { label: `|F| (${unit})`, labelSize: 20, size: 64 }],
      series: [{}, { label: "|F|", stroke: "#3b3f46", width: 1.2, spanGaps: false }],
    }, [T, magnitudes()], $("plot-raw"));
    const resize = () => {
      plotXY.setSize({ width: width("plot-value"), height: 270 });
      plotM.setSize({ width: width("plot-raw"), height: 160 });
    };
    if (window.ResizeObserver) new ResizeObserver(resize).observe($("plot-value"));
  }

  function traces() {
    const a = cols[chosen];
    const band = (v, s, sign) => v.map((x, i) => (x === null || s[i] === null ? null : x + sign * s[i]));
    return [T, a[0], band(a[0], a[2], 1), band(a[0], a[2], -1),
      a[1], band(a[1], a[3], 1), band(a[1], a[3], -1)];
  }

  function magnitudes() {
    const a = cols[chosen];
    return a[0].map((x, i) => (x === null || a[1][i] === null ? null : Math.hypot(x, a[1][i])));
  }

  V.draw = function () {
    if (!plotXY) return;
    plotXY.setData(traces());
    plotM.setData([T, magnitudes()]);
    drawPolar();
    if (info.kind === "array") drawMap();
  };

  // -- the polar view ------------------------------------------------------------------------
  function canvas(id) {
    const el = $(id), dpr = window.devicePixelRatio || 1;
    const w = el.clientWidth, h = el.clientHeight;
    if (el.width !== Math.round(w * dpr) || el.height !== Math.round(h * dpr)) {
      el.width = Math.round(w * dpr);
      el.height = Math.round(h * dpr);
    }
    const ctx = el.getContext("2d");
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    ctx.clearRect(0, 0, w, h);
    return [ctx, w, h];
  }

  function drawPolar() {
    const [ctx, w, h] = canvas("polar");
    const cx = w / 2, cy = h / 2, r = Math.min(w, h) / 2 - 22;
    const span = info.span[1];
    const s = r / span;
    ctx.strokeStyle = "#dde2ea";
    ctx.fillStyle = GREY;
    ctx.font = "11px system-ui, sans-serif";
    for (const f of [0.25, 0.5, 0.75, 1]) {
      ctx.beginPath();
      ctx.arc(cx, cy, r * f, 0, 2 * Math.PI);
      ctx.lineWidth = f === 1 ? 1.5 : 1;
      ctx.strokeStyle = f === 1 ? "rgba(184, 38, 28, 0.6)" : "#dde2ea";
      ctx.stroke();
    }
    ctx.strokeStyle = "#dde2ea";
    ctx.beginPath();
    ctx.moveTo(cx - r, cy); ctx.lineTo(cx + r, cy);
    ctx.moveTo(cx, cy - r); ctx.lineTo(cx, cy + r);
    ctx.stroke();
    ctx.fillText("+Fx", cx + r - 20, cy - 5);
    ctx.fillText("+Fy", cx + 5, cy - r + 12);
    ctx.fillText(`span ${Number(span.toPrecision(3))} ${info.unit}`, 4, h - 6);
    const a = cols[chosen];
    const t0 = T.length ? T[T.length - 1] - TRAIL : 0;
    ctx.lineWidth = 1.2;
    let prev = null;
    for (let i = 0; i < T.length; i++) {
      if (T[i] < t0 || a[0][i] === null || a[1][i] === null) { prev = null; continue; }
      const p = [cx + a[0][i] * s, cy - a[1][i] * s];
      if (prev) {
        ctx.strokeStyle = `rgba(31, 78, 156, ${0.15 + 0.75 * (T[i] - t0) / TRAIL})`;
        ctx.beginPath(); ctx.moveTo(prev[0], prev[1]); ctx.lineTo(p[0], p[1]); ctx.stroke();
      }
      prev = p;
    }
    const j = a[0].length - 1;
    if (j >= 0 && a[0][j] !== null && a[1][j] !== null) {
      const x = cx + a[0][j] * s, y = cy - a[1][j] * s;
      ctx.fillStyle = "rgba(31, 78, 156, 0.18)";
      ctx.beginPath();
      ctx.ellipse(x, y, Math.max(1, a[2][j] * s), Math.max(1, a[3][j] * s), 0, 0, 2 * Math.PI);
      ctx.fill();
      arrow(ctx, cx, cy, x, y, BLUE, 2.5);
    }
  }

  function arrow(ctx, x0, y0, x1, y1, colour, lw) {
    const len = Math.hypot(x1 - x0, y1 - y0);
    ctx.strokeStyle = colour;
    ctx.fillStyle = colour;
    ctx.lineWidth = lw;
    ctx.beginPath(); ctx.moveTo(x0, y0); ctx.lineTo(x1, y1); ctx.stroke();
    if (len < 3) return;
    const ang = Math.atan2(y1 - y0, x1 - x0), head = Math.min(9, 0.4 * len);
    ctx.beginPath();
    ctx.moveTo(x1, y1);
    ctx.lineTo(x1 - head * Math.cos(ang - 0.4), y1 - head * Math.sin(ang - 0.4));
    ctx.lineTo(x1 - head * Math.cos(ang + 0.4), y1 - head * Math.sin(ang + 0.4));
    ctx.closePath();
    ctx.fill();
  }

  // -- the array's map -----------------------------------------------------------------------
  let layout = null;

  function place(w, h) {
    const p = info.positions_mm;
    const xs = p.map((q) => q[0]), ys = p.map((q) => q[1]);
    const x0 = Math.min(...xs), x1 = Math.max(...xs), y0 = Math.min(...ys), y1 = Math.max(...ys);
    let pitch = Infinity;
    for (let a = 0; a < p.length; a++) for (let b = a + 1; b < p.length; b++) {
      pitch = Math.min(pitch, Math.hypot(p[a][0] - p[b][0], p[a][1] - p[b][1]));
    }
    if (!Number.isFinite(pitch) || pitch <= 0) pitch = 1;
    const pad = pitch * 0.6;
    const s = Math.min((w - 10) / (x1 - x0 + 2 * pad), (h - 10) / (y1 - y0 + 2 * pad));
    const ox = w / 2 - s * (x0 + x1) / 2, oy = h / 2 + s * (y0 + y1) / 2;
    return { s, pitch, at: (q) => [ox + s * q[0], oy - s * q[1]] };
  }

  function heat(f) {
    const x = Math.max(0, Math.min(1, f));
    const r = Math.round(255 - 25 * x), g = Math.round(246 - 170 * x), b = Math.round(236 - 206 * x);
    return `rgb(${r}, ${g}, ${b})`;
  }

  function drawMap() {
    const [ctx, w, h] = canvas("map");
    layout = place(w, h);
    const { s, pitch, at } = layout;
    const span = info.span[1];
    const reach = 0.45 * pitch * s;
    ctx.font = "10px system-ui, sans-serif";
    ctx.textAlign = "center";
    for (let c = 0; c < C; c++) {
      const [x, y] = at(info.positions_mm[c]);
      const v = latest[c];
      const m = v ? Math.hypot(v[0], v[1]) : null;
      ctx.fillStyle = m === null ? "#eceff3" : heat(m / span);
      ctx.strokeStyle = c === chosen ? BLUE : "#c5ccd6";
      ctx.lineWidth = c === chosen ? 3 : 1;
      ctx.beginPath();
      ctx.arc(x, y, reach, 0, 2 * Math.PI);
      ctx.fill();
      ctx.stroke();
      if (v) arrow(ctx, x, y, x + v[0] / span * reach, y - v[1] / span * reach, "#17202e", 2);
      ctx.fillStyle = GREY;
      ctx.fillText(info.cilia[c], x, y + reach + 11);
    }
  }

  function nearest(ev) {
    if (!layout) return null;
    const rect = $("map").getBoundingClientRect();
    const px = ev.clientX - rect.left, py = ev.clientY - rect.top;
    let best = null, dist = Infinity;
    for (let c = 0; c < C; c++) {
      const [x, y] = layout.at(info.positions_mm[c]);
      const d = Math.hypot(px - x, py - y);
      if (d < dist) { dist = d; best = c; }
    }
    return dist <= 0.6 * layout.pitch * layout.s ? best : null;
  }

  V.cellOf = function (c) {
    // where cilium c is drawn on the map, in page pixels (for tests)
    if (!layout) return null;
    const rect = $("map").getBoundingClientRect();
    const [x, y] = layout.at(info.positions_mm[c]);
    return [rect.left + x, rect.top + y];
  };
})();
