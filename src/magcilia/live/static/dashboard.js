/* magcilia dashboard: plain JavaScript, no build step; uPlot draws the traces.
 *
 * The server sends binary frames (little-endian float64: a 7-number header, then the columns
 * time s, raw mV, value, sigma (display units), flags) and JSON status messages over /ws. A
 * 3-axis sensor's or an array's frames are version 2 (force vectors): vectors.js reads and
 * draws them, this file shows the value (|F| and its direction), the badges and the status.
 * After drawing a frame the page answers {"drawn": [frame ids]} so that the server can measure
 * sample-to-screen latency. window.magcilia exposes what is shown (for tests and curious users).
 * Commands (tare, record) carry the run's token, which the server wrote into the page's
 * <meta name="magcilia-token">, in the X-Magcilia-Token header: the server takes commands only
 * from the page it served.
 */
(function () {
  "use strict";

  const HEADER = 7;
  const COLUMNS = 5;
  // the Flag bits a single output's badge shows (magcilia.readout.protocol.Flag); a tare kept
  // under load and a drift not tracked are warnings: the value stays, the badge says so
  const FLAGS = [[1, "OUTSIDE SPAN", "warn"], [2, "FOLD", "bad"], [4, "SATURATED", "bad"],
    [8, "EXTRAPOLATED", "warn"], [16, "CLIPPED", "warn"], [4096, "TARE UNDER LOAD", "bad"],
    [8192, "ZERO DRIFT", "warn"], [16384, "TEMPERATURE OUTSIDE", "warn"],
    [32768, "COIL PULSE", "warn"]];
  const BLUE = "#1f4e9c";
  const RED = "#b8261c";
  const GREY = "rgba(100, 110, 125, 0.9)";
  const VEC = window.magciliaVectors;
  // a force vector's flags: vectors.js's table
  const VFLAGS = VEC.FLAGS;

  const M = (window.magcilia = {
    lastValue: null, // newest value shown, display units (null: flagged or none yet)
    lastSigma: null,
    lastFlags: 0,
    frames: 0,
    drawn: 0,
    connected: false,
    info: null,
    status: null,
  });

  const $ = (id) => document.getElementById(id);
  let info = null;
  let ws = null;
  let plotV = null;
  let plotR = null;
  let fit = false;
  let T = [], V = [], HI = [], LO = [], RAW = [], FL = [];
  let pending = [];
  let drawQueued = false;
  let lastT = null;
  let binSeconds = 0.005;
  let newest = null;
  let vectors = false; // a 3-axis sensor or an array (info.kind)

  // -- formatting ------------------------------------------------------------------------------
  function decimals(sigma) {
    if (!(sigma > 0)) return 4;
    return Math.min(8, Math.max(0, 1 - Math.floor(Math.log10(sigma))));
  }
  function num(x, digits) {
    if (x === null || x === undefined || !Number.isFinite(x)) return "—";
    return String(Number(Number(x).toPrecision(digits === undefined ? 4 : digits)));
  }
  function ms(seconds) {
    return seconds === null || seconds === undefined ? "—" : (seconds * 1e3).toFixed(1) + " ms";
  }
  function count(n) {
    return n === null || n === undefined ? "—" : Number(n).toLocaleString("en-US");
  }
  function el(tag, text, cls) {
    const e = document.createElement(tag);
    if (text !== undefined) e.textContent = text;
    if (cls) e.className = cls;
    return e;
  }

  // -- plots -----------------------------------------------------------------------------------
  function xRange(u, min, max) {
    const w = info ? info.window_s : 10;
    // fill from the left, then scroll
    return max === null || max === undefined || max < w ? [0, w] : [max - w, max];
  }

  function yRangeValue(u, min, max) {
    const lo = info.span[0], hi = info.span[1];
    if (!fit || min === null || max === null) {
      const pad = 0.06 * (hi - lo);
      return [lo - pad, hi + pad];
    }
    const m = 2 * (M.status && M.status.minimum ? M.status.minimum : info.minimum);
    return uPlot.rangeNum(Math.min(min, -m), Math.max(max, m), 0.1, true);
  }

  function yRangeRaw(u, min, max) {
    if (min === null || max === null) return [0, 1];
    if (max - min < 1e-6) return [min - 0.01, max + 0.01];
    return uPlot.rangeNum(min, max, 0.1, true);
  }

  // shade the bins whose readings were flagged (under the traces)
  function drawFlags(u) {
    const ctx = u.ctx, b = u.bbox, xs = u.data[0];
    if (!xs.length) return;
    const half = binSeconds / 2;
    ctx.save();
    ctx.beginPath();
    ctx.rect(b.left, b.top, b.width, b.height);
    ctx.clip();
    ctx.fillStyle = "rgba(230, 126, 34, 0.22)";
    let i = 0;
    while (i < FL.length) {
      if (!(FL[i] > 0)) { i++; continue; }
      let j = i;
      while (j + 1 < FL.length && FL[j + 1] > 0) j++;
      const x0 = u.valToPos(xs[i] - half, "x", true), x1 = u.valToPos(xs[j] + half, "x", true);
      ctx.fillRect(x0, b.top, Math.max(x1 - x0, 1), b.height);
      i = j + 1;
    }
    ctx.restore();
  }

  // the range and ± minimum detectable, on top of the traces
  function drawLimits(u) {
    if (!info) return;
    const ctx = u.ctx, b = u.bbox, dpr = window.devicePixelRatio || 1;
    const range = M.status && M.status.range ? M.status.range : info.range;
    const minimum = M.status && M.status.minimum ? M.status.minimum : info.minimum;
    ctx.save();
    ctx.beginPath();
    ctx.rect(b.left, b.top, b.width, b.height);
    ctx.clip();
    ctx.font = `${11 * dpr}px system-ui, sans-serif`;
    ctx.textAlign = "left";
    ctx.textBaseline = "alphabetic";
    const y0 = u.valToPos(-minimum, "y", true), y1 = u.valToPos(minimum, "y", true);
    ctx.fillStyle = "rgba(100, 110, 125, 0.28)";
    ctx.fillRect(b.left, Math.min(y0, y1) - 0.5 * dpr, b.width, Math.max(Math.abs(y0 - y1), dpr));
    ctx.fillStyle = GREY;
    ctx.fillText(`min. detectable ± ${num(minimum, 2)} ${info.unit}`, b.left + 6 * dpr,
      Math.min(y0, y1) - 4 * dpr);
    ctx.strokeStyle = RED;
    ctx.lineWidth = 1.5 * dpr;
    ctx.setLineDash([6 * dpr, 4 * dpr]);
    for (const [k, y] of range.entries()) {
      const py = u.valToPos(y, "y", true);
      if (py < b.top - 1 || py > b.top + b.height + 1) continue;
      ctx.beginPath();
      ctx.moveTo(b.left, py);
      ctx.lineTo(b.left + b.width, py);
      ctx.stroke();
      ctx.fillStyle = RED;
      const text = `range ${k ? "max" : "min"} ${num(y, 3)} ${info.unit} (${info.limited_by})`;
      ctx.fillText(text, b.left + b.width - ctx.measureText(text).width - 6 * dpr,
        k ? py + 13 * dpr : py - 4 * dpr);
    }
    ctx.restore();
  }

  function plotWidth(id) {
    return Math.max(300, $(id).clientWidth);
  }

  function makePlots() {
    const unit = info.unit;
    const sync = { key: "magcilia" };
    plotV = new uPlot({
      width: plotWidth("plot-value"),
      height: 270,
      legend: { show: false },
      cursor: { sync, drag: { x: false, y: false } },
      scales: { x: { time: false, range: xRange }, y: { range: yRangeValue } },
      axes: [
        { label: "time (s)", labelSize: 20, size: 36 },
        { label: `${info.label} (${unit})`, labelSize: 20, size: 64 },
      ],
      series: [
        {},
        { label: info.label, stroke: BLUE, width: 1.5, spanGaps: false },
        { label: "+σ", stroke: "rgba(31, 78, 156, 0.25)", width: 0.5, spanGaps: false },
        { label: "−σ", stroke: "rgba(31, 78, 156, 0.25)", width: 0.5, spanGaps: false },
      ],
      bands: [{ series: [2, 3], fill: "rgba(31, 78, 156, 0.20)" }],
      hooks: { drawClear: [drawFlags], draw: [drawLimits] },
    }, [T, V, HI, LO], $("plot-value"));
    plotR = new uPlot({
      width: plotWidth("plot-raw"),
      height: 160,
      legend: { show: false },
      cursor: { sync, drag: { x: false, y: false } },
      scales: { x: { time: false, range: xRange }, y: { range: yRangeRaw } },
      axes: [
        { label: "time (s)", labelSize: 20, size: 36 },
        { label: "raw output (mV)", labelSize: 20, size: 64 },
      ],
      series: [{}, { label: "raw", stroke: "#3b3f46", width: 1, spanGaps: false }],
      hooks: { drawClear: [drawFlags] },
    }, [T, RAW], $("plot-raw"));
    const resize = () => {
      plotV.setSize({ width: plotWidth("plot-value"), height: 270 });
      plotR.setSize({ width: plotWidth("plot-raw"), height: 160 });
    };
    if (window.ResizeObserver) new ResizeObserver(resize).observe($("plot-value"));
    else window.addEventListener("resize", resize);
  }

  // -- data ------------------------------------------------------------------------------------
  function clear() {
    T = []; V = []; HI = []; LO = []; RAW = []; FL = [];
    lastT = null;
    newest = null;
    if (vectors) VEC.clear();
  }

  function queue(id) {
    M.frames++;
    pending.push(id);
    if (pending.length > 64) pending.splice(0, pending.length - 64); // a hidden tab draws nothing
    if (!drawQueued) {
      drawQueued = true;
      requestAnimationFrame(draw);
    }
  }

  function onFrame(buffer) {
    const dv = new DataView(buffer);
    const h = (i) => dv.getFloat64(8 * i, true);
    if (vectors && h(0) === 2) {
      const got = VEC.onFrame(dv);
      if (got) newest = got;
      queue(h(1));
      return;
    }
    if (h(0) !== 1) return;
    const id = h(1), n = h(2);
    binSeconds = h(5) || binSeconds;
    const at = (c, i) => dv.getFloat64(8 * (HEADER + c * n + i), true);
    let flags = 0;
    for (let i = 0; i < n; i++) {
      const t = at(0, i);
      if (lastT !== null && t - lastT > 3 * binSeconds + 0.02) {
        // a gap (the source was away): break the lines there
        T.push((t + lastT) / 2); V.push(null); HI.push(null); LO.push(null); RAW.push(null);
        FL.push(0);
      }
      const v = at(2, i), s = at(3, i), f = at(4, i);
      const good = Number.isFinite(v);
      T.push(t);
      RAW.push(at(1, i));
      V.push(good ? v : null);
      HI.push(good ? v + s : null);
      LO.push(good ? v - s : null);
      FL.push(f);
      flags |= f;
      lastT = t;
    }
    if (n > 0) {
      const v = at(2, n - 1), s = at(3, n - 1);
      newest = { value: Number.isFinite(v) ? v : null, sigma: Number.isFinite(s) ? s : null, flags };
    }
    const cutoff = lastT - info.window_s - binSeconds;
    let k = 0;
    while (k < T.length && T[k] < cutoff) k++;
    if (k > 0) {
      for (const a of [T, V, HI, LO, RAW, FL]) a.splice(0, k);
    }
    queue(id);
  }

  function draw() {
    drawQueued = false;
    if (vectors) {
      VEC.draw();
    } else {
      plotV.setData([T, V, HI, LO]);
      plotR.setData([T, RAW]);
    }
    if (newest) {
      // what the page shows from now on (window.magcilia.lastValue: display units; for force
      // vectors |F| of the chosen cilium, lastDirection its direction in rad)
      M.lastValue = newest.value;
      M.lastSigma = newest.sigma;
      M.lastFlags = newest.flags;
      M.lastDirection = newest.direction === undefined ? null : newest.direction;
      M.lastComponents = newest.components || null;
      newest = null;
    }
    showValue();
    const ids = pending;
    pending = [];
    M.drawn += ids.length;
    // a task queued from requestAnimationFrame runs after this frame is painted
    setTimeout(() => {
      if (ws && ws.readyState === WebSocket.OPEN) ws.send(JSON.stringify({ drawn: ids }));
    }, 0);
  }

  function showValue() {
    const v = M.lastValue, s = M.lastSigma;
    if (v === null) {
      $("value").textContent = "—";
      $("sigma").textContent = "";
    } else {
      const d = decimals(s);
      $("value").textContent = (v >= 0 ? "\u2007" : "−") + Math.abs(v).toFixed(d);
      $("sigma").textContent = s === null ? "" : `± ${s.toFixed(d)}`;
    }
    if (vectors) showDirection();
    showBadges();
  }

  function showDirection() {
    const c = M.lastComponents, dir = M.lastDirection;
    if (!c) {
      $("direction").textContent = "";
      return;
    }
    const d = decimals(Math.max(c[2], c[3]));
    const angle = dir === null ? "direction — (near zero)"
      : `toward ${(dir * 180 / Math.PI).toFixed(1)}°`;
    $("direction").textContent = `${angle} · Fx ${c[0].toFixed(d)} ± ${c[2].toFixed(d)} · ` +
      `Fy ${c[1].toFixed(d)} ± ${c[3].toFixed(d)} ${info.unit}`;
  }

  function showBadges() {
    const box = $("badges");
    const badges = [];
    const st = M.status;
    if (!M.connected) badges.push(["NO CONNECTION TO THE SERVER", "bad"]);
    if (st) {
      if (st.state === "disconnected") badges.push(["DISCONNECTED", "bad"]);
      else if (st.state === "failed") badges.push(["FAILED", "bad"]);
      else if (st.state === "stopped") badges.push(["STOPPED", "bad"]);
      else if (st.state === "taring") badges.push(["TARING", "warn"]);
      else if (st.state === "starting") badges.push(["STARTING", "warn"]);
      if (st.recording) badges.push(["REC", "bad"]);
    }
    const live = st && (st.state === "running" || st.state === "taring");
    if (live) {
      for (const [bit, name, cls] of vectors ? VFLAGS : FLAGS) {
        if (M.lastFlags & bit) badges.push([name, cls]);
      }
    }
    if (live && !badges.length) badges.push(["OK", "ok"]);
    const key = badges.map((b) => b.join(":")).join("|");
    if (box.dataset.key === key) return;
    box.dataset.key = key;
    box.replaceChildren(...badges.map(([t, c]) => el("span", t, `badge ${c}`)));
  }

  function onStatus(st) {
    M.status = st;
    $("c-delivered").textContent = count(st.delivered);
    $("c-dropped").textContent = count(st.dropped);
    $("c-overruns").textContent = count(st.overruns);
    $("c-samples").textContent = count(st.samples);
    $("c-latency").textContent = st.latency_median_s === null ? "—"
      : `${ms(st.latency_median_s)} (p99 ${ms(st.latency_p99_s)})`;
    $("c-screen").textContent = st.screen_latency_median_s === null ? "—"
      : `${ms(st.screen_latency_median_s)} (p99 ${ms(st.screen_latency_p99_s)})`;
    $("c-clients").textContent = count(st.clients);
    $("message").textContent = [st.message, st.recalibration].filter(Boolean).join(" · ");
    $("tared").textContent = !st.tared ? "not tared" : st.correction_T !== undefined
      ? `tared: ${st.correction_T.length} channels, largest correction ${(Math.max(...st.correction_T.map(Math.abs)) * 1e4).toFixed(4)} G, drift ${(Math.max(...st.drift_T.map(Math.abs)) * 1e7).toFixed(3)} mG`
      : `tared: correction ${(st.correction_V * 1e3).toFixed(4)} mV, drift ${(st.drift_V * 1e6).toFixed(2)} µV`;
    const rec = $("record");
    rec.textContent = st.recording ? "■ Stop recording" : "● Record";
    rec.classList.toggle("recording", Boolean(st.recording));
    $("recfile").textContent = st.recording ? `recording to ${st.recording}` : "";
    $("event").textContent = st.last_event || "";
    if (info) showLimits(st.range || info.range, st.minimum || info.minimum);
    showBadges();
  }

  function showLimits(range, minimum) {
    const dl = $("limits");
    const rows = [
      ["span", `${num(info.span[0], 3)} … ${num(info.span[1], 3)} ${info.unit}`],
      ["range", `${num(range[0], 3)} … ${num(range[1], 3)} ${info.unit}`],
      ["limited by", info.limited_by],
      ["min. detectable", `± ${num(minimum, 2)} ${info.unit}`],
      ["read-out rate", `${num(info.rate_Hz, 4)} Hz`],
      ["points shown", `${Math.round(info.window_s * info.rate_Hz / info.factor)} (${num(info.window_s, 3)} s)`],
    ];
    const key = JSON.stringify(rows);
    if (dl.dataset.key === key) return;
    dl.dataset.key = key;
    dl.replaceChildren(...rows.flatMap(([k, v]) => [el("dt", k), el("dd", v)]));
  }

  function showInfo() {
    document.title = `magcilia live: ${info.label}`;
    const label = vectors ? `${info.label} |F|` : info.label;
    $("label").textContent = label.charAt(0).toUpperCase() + label.slice(1);
    $("unit").textContent = info.unit;
    $("value-title").textContent = `${info.label} (${info.unit}) with its σ band`;
    $("source").textContent =
      `${info.source.name} at ${num(info.source.rate_Hz, 4)} Hz → read-out at ${num(info.rate_Hz, 4)} Hz`;
    $("readout").textContent = info.readout;
    $("calibration").textContent = info.calibration ||
      `none: σ from the sensor noise${info.scale_note ? " and the " + info.scale_note : ""} (pass --calibration to add the fit's uncertainty)`;
    const box = $("setup");
    box.replaceChildren();
    for (const [section, entries] of Object.entries(info.setup)) {
      box.appendChild(el("h3", section));
      const dl = el("dl", undefined, "kv");
      for (const [k, v] of Object.entries(entries)) {
        dl.append(el("dt", k.replace(/_/g, " ")), el("dd", Array.isArray(v) ? v.join(", ") : String(v)));
      }
      box.appendChild(dl);
    }
    showLimits(info.range, info.minimum);
  }

  // -- connection ------------------------------------------------------------------------------
  function setConnected(ok, text) {
    M.connected = ok;
    const c = $("conn");
    c.textContent = text;
    c.className = `badge ${ok ? "ok" : "bad"}`;
    showBadges();
  }

  function connect() {
    const url = new URL("ws", window.location.href);
    url.protocol = url.protocol === "https:" ? "wss:" : "ws:";
    ws = new WebSocket(url);
    ws.binaryType = "arraybuffer";
    ws.onopen = () => {
      clear();
      setConnected(true, "connected");
    };
    ws.onmessage = (ev) => {
      if (typeof ev.data === "string") onStatus(JSON.parse(ev.data));
      else onFrame(ev.data);
    };
    ws.onclose = () => {
      ws = null;
      setConnected(false, "server gone: reconnecting…");
      setTimeout(connect, 1000);
    };
  }

  const tokenTag = document.querySelector('meta[name="magcilia-token"]');
  const token = tokenTag ? tokenTag.content : "";

  async function post(path, body) {
    const resp = await fetch(path, {
      method: "POST",
      headers: { "Content-Type": "application/json", "X-Magcilia-Token": token },
      body: JSON.stringify(body || {}),
    });
    let answer = {};
    try {
      answer = await resp.json();
    } catch (err) {
      // not JSON: the status text says enough
    }
    if (!resp.ok) throw new Error(answer.error || resp.statusText);
    return answer;
  }

  // body(): what to send, asked at the click (the record button says start or stop)
  function button(id, path, body, done) {
    const b = $(id);
    b.addEventListener("click", async () => {
      b.disabled = true;
      try {
        done(await post(path, body()));
      } catch (err) {
        $("message").textContent = `${id}: ${err.message}`;
      } finally {
        b.disabled = false;
      }
    });
  }

  async function start() {
    try {
      const resp = await fetch("api/info");
      if (!resp.ok) throw new Error(resp.statusText);
      info = M.info = await resp.json();
    } catch (err) {
      setConnected(false, "server gone: retrying…");
      setTimeout(start, 1000);
      return;
    }
    vectors = info.kind === "vector" || info.kind === "array";
    showInfo();
    if (vectors) VEC.init(info);
    else makePlots();
    button("tare", "api/tare", () => ({}), () => { $("tared").textContent = "taring…"; });
    // start or stop as the button shows it, so that repeated clicks never open two recordings
    const recordAction = () => ({ action: M.status && M.status.recording ? "stop" : "start" });
    button("record", "api/record", recordAction, (r) => {
      $("recfile").textContent = r.recording ? `recording to ${r.recording}` : `saved ${r.stopped}`;
    });
    $("fit").addEventListener("click", () => {
      fit = !fit;
      $("fit").textContent = fit ? "Whole span" : "Fit data";
      if (plotV) plotV.setData([T, V, HI, LO]);
    });
    connect();
  }

  start();
})();
