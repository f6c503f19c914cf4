// The decision room (docs/model.md §19): linked views, navigation and export over the
// designs hisopt stored in this page. No library, no network: canvases and the DOM.
// The navigation rules are hisopt.optim.navigation's (its tests compare the two).
(function () {
  "use strict";
  const D = JSON.parse(document.getElementById("room-data").textContent);
  const N = D.rows;
  const $ = (id) => document.getElementById(id);
  const esc = (text) => String(text).replace(/[&<>"]/g, (ch) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;" })[ch]);

  function decode(b64, Type) {
    const bin = atob(b64);
    const bytes = new Uint8Array(bin.length);
    for (let i = 0; i < bin.length; i++) bytes[i] = bin.charCodeAt(i);
    return new Type(bytes.buffer);
  }

  const cols = D.columns.map((c) => Object.assign({}, c, { values: decode(c.data, c.type === "f64" ? Float64Array : Float32Array) }));
  const byName = {};
  cols.forEach((c) => { byName[c.name] = c; });
  const source = decode(D.source, Uint8Array), kind = decode(D.kind, Uint8Array), fileRow = decode(D.row, Int32Array);
  const feasible = decode(D.feasible, Uint8Array), onFront = decode(D.front, Uint8Array);
  const buildable = decode(D.buildable, Uint8Array), bindingRule = decode(D.binding_rule, Uint8Array);
  const verified = decode(D.verified, Uint8Array); // index into D.verdicts: a front design's verdict in the time domain, "" where not verified
  const curveBytes = decode(D.curves.bytes, Uint8Array);
  const objectives = D.objectives.map((n) => byName[n]);

  // --- numbers with units ----------------------------------------------------------------
  function trim(text) {
    if (text.indexOf("e") >= 0) {
      const [m, e] = text.split("e");
      return trim(m) + "e" + (e[0] === "+" ? e.slice(1) : e);
    }
    return text.indexOf(".") >= 0 ? text.replace(/0+$/, "").replace(/\.$/, "") : text;
  }
  function number(v, display) {
    if (!isFinite(v)) return "-";
    const x = v * display.scale;
    if (display.scientific || (x !== 0 && (Math.abs(x) >= 1e6 || Math.abs(x) < 1e-3))) return trim(x.toExponential(3));
    return trim(x.toPrecision(4));
  }
  const withUnit = (v, display) => number(v, display) + (display.unit && display.unit !== "-" && isFinite(v) ? " " + display.unit : "");
  const label = (c) => c.name + (c.display.unit ? " [" + c.display.unit + "]" : "");
  function siText(v) { // a value as its shortest exact decimal, which reads back as TOML and CSV
    let s = String(v);
    if (/^-?\d+$/.test(s)) s = Math.abs(v) < 1e15 ? s + ".0" : v.toExponential();
    return s;
  }

  // --- state -----------------------------------------------------------------------------
  const S = {
    brushes: {}, frontOnly: true, feasibleOnly: false, buildableOnly: false, loadCase: "", source: "", bound: "",
    colour: D.objectives[0], shown: -1, hovered: -1, chosen: new Set(), asf: -1, reachable: null,
    nautilus: null, timing: { last: null, runs: [] },
  };
  const base = new Uint8Array(N), selected = new Uint8Array(N);

  function atBound(i, name) {
    const src = D.sources[source[i]];
    if (!(name in src.bounds)) return 0;
    const [lo, hi] = src.bounds[name], tol = D.bound_tolerance * (hi - lo), v = byName[name].values[i];
    return v <= lo + tol ? -1 : v >= hi - tol ? 1 : 0;
  }
  function anyBound(i) {
    return D.sources[source[i]].variables.some((v) => atBound(i, v) !== 0);
  }
  function computeBase() {
    for (let i = 0; i < N; i++) {
      let ok = (!S.frontOnly || onFront[i]) && (!S.feasibleOnly || feasible[i]) && (!S.buildableOnly || buildable[i]) && (!S.source || D.sources[source[i]].name === S.source);
      if (ok && S.bound === "none") ok = !anyBound(i);
      else if (ok && S.bound) ok = atBound(i, S.bound) !== 0;
      base[i] = ok ? 1 : 0;
    }
  }
  function computeSelected() {
    const active = Object.keys(S.brushes).map((n) => [byName[n].values, S.brushes[n][0], S.brushes[n][1]]);
    let count = 0;
    for (let i = 0; i < N; i++) {
      let ok = base[i] === 1;
      for (let b = 0; ok && b < active.length; b++) {
        const v = active[b][0][i];
        ok = v >= active[b][1] && v <= active[b][2];
      }
      selected[i] = ok ? 1 : 0;
      count += ok ? 1 : 0;
    }
    return count;
  }

  // --- scales ------------------------------------------------------------------------------
  function range(c) { // over the designs the filters keep (all of them when they keep none)
    let lo = Infinity, hi = -Infinity, any = false;
    for (let i = 0; i < N && !any; i++) any = base[i] === 1;
    for (let i = 0; i < N; i++) {
      if (any && !base[i]) continue;
      const v = c.values[i];
      if (isFinite(v) && (!c.log || v > 0)) { if (v < lo) lo = v; if (v > hi) hi = v; }
    }
    if (!isFinite(lo)) { lo = 0; hi = 1; }
    if (hi === lo) { const d = lo === 0 ? 1 : Math.abs(lo) * 0.05; lo -= d; hi += d; }
    return [lo, hi];
  }
  function unit(c, v) { // 0..1 along the axis
    const [lo, hi] = c.range;
    if (c.log) return (Math.log10(v) - Math.log10(lo)) / (Math.log10(hi) - Math.log10(lo));
    return (v - lo) / (hi - lo);
  }
  function fromUnit(c, t) {
    const [lo, hi] = c.range;
    if (c.log) return Math.pow(10, Math.log10(lo) + t * (Math.log10(hi) - Math.log10(lo)));
    return lo + t * (hi - lo);
  }
  function ticks(c, count) {
    const [lo, hi] = c.range;
    if (c.log) {
      const out = [];
      for (let e = Math.ceil(Math.log10(lo)); e <= Math.floor(Math.log10(hi)); e++) out.push(Math.pow(10, e));
      if (out.length >= 2) return out;
    }
    const step0 = (hi - lo) / count, mag = Math.pow(10, Math.floor(Math.log10(step0)));
    const step = [1, 2, 5, 10].map((m) => m * mag).find((s) => s >= step0);
    const out = [];
    for (let v = Math.ceil(lo / step) * step; v <= hi + 1e-12 * step; v += step) out.push(v);
    return out;
  }
  const VIRIDIS = ["#440154", "#482475", "#414487", "#355f8d", "#2a788e", "#21918c", "#22a884", "#44bf70", "#7ad151", "#bddf26", "#fde725"];
  const colourBin = (t) => Math.max(0, Math.min(VIRIDIS.length - 1, Math.round(t * (VIRIDIS.length - 1))));

  function sized(canvas, w, h) {
    const r = window.devicePixelRatio || 1;
    canvas.width = Math.round(w * r); canvas.height = Math.round(h * r);
    canvas.style.width = w + "px"; canvas.style.height = h + "px";
    const ctx = canvas.getContext("2d", { willReadFrequently: false });
    ctx.setTransform(r, 0, 0, r, 0, 0);
    return ctx;
  }
  const flush = (canvas) => canvas.getContext("2d").getImageData(0, 0, 1, 1); // finish drawing before the clock stops

  // --- parallel coordinates ------------------------------------------------------------------
  const PC = { top: 78, bottom: 28, left: 60, right: 60, height: 406, rows: 2 };
  let axes = [];
  function visibleColumns() {
    return cols.filter(inCase);
  }
  function inCase(c) { // a load case's column shows only with that case chosen (or none); a valve's of a scenario problem likewise
    const perCase = c.group === "load case" || (c.group === "valve" && c.name.indexOf("@") >= 0);
    return !perCase || !S.loadCase || c.name.endsWith("@" + S.loadCase);
  }
  const outsideRange = (c, i) => c.group === "valve" && c.values[i] > D.validated_resistance; // NaN: no fixed point, nothing to judge
  function layoutAxes() {
    const list = visibleColumns(), width = Math.max($("room").clientWidth, 600, PC.left + PC.right + 96 * (list.length - 1)); // wider: it scrolls
    const gap = (width - PC.left - PC.right) / Math.max(list.length - 1, 1);
    // axis titles in as many staggered rows as it takes for neighbours not to touch
    const probe = $("pc-ax").getContext("2d");
    probe.font = "12px Helvetica, Arial, sans-serif";
    const widest = Math.max.apply(null, list.map((c) => probe.measureText(label(c)).width));
    PC.rows = Math.min(5, Math.max(2, Math.ceil((widest + 10) / gap)));
    PC.top = 46 + 16 * PC.rows;
    PC.height = PC.top + 300 + PC.bottom;
    $("pc-ax").parentElement.style.height = PC.height + "px";
    $("pc-ax").parentElement.style.width = width + "px";
    axes = list.map((c, k) => ({ c: c, x: PC.left + k * gap, y: new Float32Array(N) }));
    const h = PC.height - PC.top - PC.bottom;
    axes.forEach((a) => {
      for (let i = 0; i < N; i++) {
        const v = a.c.values[i];
        a.y[i] = isFinite(v) && (!a.c.log || v > 0) ? PC.top + (1 - unit(a.c, v)) * h : NaN;
      }
    });
    ["pc-bg", "pc-fg", "pc-ax"].forEach((id) => sized($(id), width, PC.height));
  }
  function polylines(ctx, rows) { // a few highlighted designs: anti-aliased paths
    ctx.beginPath();
    for (const i of rows) {
      let pen = false;
      for (const a of axes) {
        const y = a.y[i];
        if (y !== y) { pen = false; continue; }
        if (pen) ctx.lineTo(a.x, y); else { ctx.moveTo(a.x, y); pen = true; }
      }
    }
    ctx.stroke();
  }
  // Thousands of designs: each line's pixels written into one buffer (a column at a time,
  // the gaps of steep segments filled), some ten times faster than the canvas's stroking.
  function rasterLines(canvas, rows, colourOf) {
    const r = window.devicePixelRatio || 1, W = canvas.width, ctx = canvas.getContext("2d");
    const img = ctx.createImageData(W, canvas.height), px = new Uint32Array(img.data.buffer);
    const xs = axes.map((a) => Math.round(a.x * r)), last = axes.length - 1;
    for (const i of rows) {
      const c = colourOf(i);
      for (let k = 0; k < last; k++) {
        const y0 = axes[k].y[i] * r, y1 = axes[k + 1].y[i] * r;
        if (y0 !== y0 || y1 !== y1) continue;
        const x0 = xs[k], x1 = xs[k + 1], slope = (y1 - y0) / (x1 - x0);
        let yf = y0 + 0.5, prev = yf | 0; // y >= 0: truncation rounds
        for (let x = x0; x <= x1; x++, yf += slope) {
          const y = yf | 0;
          if (y === prev) px[y * W + x] = c;
          else if (y > prev) for (let yy = prev + 1; yy <= y; yy++) px[yy * W + x] = c;
          else for (let yy = y; yy < prev; yy++) px[yy * W + x] = c;
          prev = y;
        }
      }
    }
    ctx.putImageData(img, 0, 0);
  }
  const abgr = (hex, alpha) => ((alpha << 24) | (parseInt(hex.slice(5, 7), 16) << 16) | (parseInt(hex.slice(3, 5), 16) << 8) | parseInt(hex.slice(1, 3), 16)) >>> 0;
  function drawPcBackground() {
    const rows = [];
    for (let i = 0; i < N; i++) if (base[i]) rows.push(i);
    const grey = abgr("#a0a8b4", 70);
    rasterLines($("pc-bg"), rows, () => grey);
  }
  function drawPcForeground() {
    const canvas = $("pc-fg"), ctx = canvas.getContext("2d"), colour = byName[S.colour], bins = VIRIDIS.map(() => []);
    for (let i = 0; i < N; i++) if (selected[i]) bins[colourBin(unit(colour, colour.values[i]))].push(i);
    const rows = [].concat.apply([], bins.reverse()), palette = VIRIDIS.map((h) => abgr(h, 255)); // the best drawn last, on top
    rasterLines(canvas, rows, (i) => palette[colourBin(unit(colour, colour.values[i]))]);
    const shown = S.hovered >= 0 ? S.hovered : S.shown;
    if (shown >= 0) { ctx.strokeStyle = "#d1495b"; ctx.lineWidth = 2.5; polylines(ctx, [shown]); }
  }
  function drawPcAxes() {
    const ctx = $("pc-ax").getContext("2d");
    ctx.clearRect(0, 0, 1e5, 1e5);
    ctx.font = "12px Helvetica, Arial, sans-serif"; ctx.textAlign = "center";
    const h = PC.height - PC.top - PC.bottom;
    axes.forEach((a, k) => {
      ctx.strokeStyle = "#333"; ctx.lineWidth = 1;
      ctx.beginPath(); ctx.moveTo(a.x, PC.top); ctx.lineTo(a.x, PC.top + h); ctx.stroke();
      ctx.fillStyle = "#1d2330";
      ctx.save(); ctx.translate(a.x, PC.top - 14 - (k % PC.rows) * 16); ctx.fillText(label(a.c), 0, 0); ctx.restore();
      ctx.fillStyle = "#556"; ctx.textAlign = "right"; ctx.font = "10px Helvetica, Arial, sans-serif";
      ticks(a.c, 4).forEach((v) => {
        const y = PC.top + (1 - unit(a.c, v)) * h;
        ctx.fillRect(a.x - 3, y, 3, 1);
        ctx.strokeStyle = "rgba(255,255,255,0.85)"; ctx.lineWidth = 3; ctx.strokeText(number(v, a.c.display), a.x - 5, y + 3);
        ctx.fillText(number(v, a.c.display), a.x - 5, y + 3);
      });
      ctx.textAlign = "center"; ctx.font = "12px Helvetica, Arial, sans-serif";
      const b = S.brushes[a.c.name];
      if (b) {
        const y0 = PC.top + (1 - unit(a.c, b[1])) * h, y1 = PC.top + (1 - unit(a.c, b[0])) * h;
        ctx.fillStyle = "rgba(0,121,140,0.18)"; ctx.strokeStyle = "#00798c";
        ctx.fillRect(a.x - 8, y0, 16, y1 - y0); ctx.strokeRect(a.x - 8, y0, 16, y1 - y0);
      }
    });
  }

  // --- scatter matrix of the objectives ---------------------------------------------------------
  const SP = { size: 620, pad: 64 };
  let panels = [];
  function layoutSplom() {
    const k = objectives.length, n = Math.max(k - 1, 1), cell = (SP.size - SP.pad) / n;
    panels = [];
    for (let r = 1; r < Math.max(k, 2); r++) for (let c = 0; c < r; c++) {
      if (k < 2) break;
      panels.push({ x: objectives[c], y: objectives[r], left: SP.pad + c * cell + 4, top: (r - 1) * cell + 4, size: cell - 8 });
    }
    const bg = sized($("sp-bg"), SP.size, SP.size); sized($("sp-fg"), SP.size, SP.size);
    bg.font = "11px Helvetica, Arial, sans-serif"; bg.fillStyle = "#1d2330";
    panels.forEach((p) => {
      bg.strokeStyle = "#c8ced6"; bg.strokeRect(p.left, p.top, p.size, p.size);
      if (p.top + p.size + 40 > SP.size - 8 || !panels.some((q) => q.x === p.x && q.top > p.top)) {
        bg.textAlign = "center"; bg.fillText(label(p.x), p.left + p.size / 2, p.top + p.size + 26);
        ticks(p.x, 3).forEach((v) => { const x = p.left + unit(p.x, v) * p.size; bg.fillRect(x, p.top + p.size, 1, 3); bg.fillText(number(v, p.x.display), x, p.top + p.size + 13); });
      }
      if (p.x === objectives[0]) {
        bg.save(); bg.translate(p.left - 44, p.top + p.size / 2); bg.rotate(-Math.PI / 2); bg.textAlign = "center"; bg.fillText(label(p.y), 0, 0); bg.restore();
        bg.textAlign = "right";
        ticks(p.y, 3).forEach((v) => { const y = p.top + (1 - unit(p.y, v)) * p.size; bg.fillRect(p.left - 3, y, 3, 1); bg.fillText(number(v, p.y.display), p.left - 5, y + 3); });
      }
    });
    panels.forEach((p) => { p.px = new Float32Array(N); p.py = new Float32Array(N); for (let i = 0; i < N; i++) { p.px[i] = p.left + unit(p.x, p.x.values[i]) * p.size; p.py[i] = p.top + (1 - unit(p.y, p.y.values[i])) * p.size; } });
  }
  function drawSplom() {
    const canvas = $("sp-fg"), ctx = canvas.getContext("2d"), r = window.devicePixelRatio || 1;
    const img = ctx.createImageData(canvas.width, canvas.height), px = new Uint32Array(img.data.buffer), W = canvas.width, H = canvas.height;
    const colour = byName[S.colour];
    const rgba = VIRIDIS.map((h) => abgr(h, 255)), grey = abgr("#d0d4d8", 255);
    const dot = (x, y, value) => {
      const X = Math.round(x * r), Y = Math.round(y * r);
      if (X < 0 || Y < 0 || X + 1 >= W || Y + 1 >= H) return;
      const o = Y * W + X; px[o] = value; px[o + 1] = value; px[o + W] = value; px[o + W + 1] = value;
    };
    for (const p of panels) {
      for (let i = 0; i < N; i++) if (base[i] && !selected[i] && p.px[i] === p.px[i] && p.py[i] === p.py[i]) dot(p.px[i], p.py[i], grey);
      for (let i = 0; i < N; i++) if (selected[i] && p.px[i] === p.px[i] && p.py[i] === p.py[i]) dot(p.px[i], p.py[i], rgba[colourBin(unit(colour, colour.values[i]))]);
    }
    ctx.putImageData(img, 0, 0);
    const marks = [];
    if (S.nautilus) S.nautilus.options().forEach((o) => marks.push([o.representative, "#edae49", 5]));
    if (S.asf >= 0) marks.push([S.asf, "#00798c", 6]);
    const shown = S.hovered >= 0 ? S.hovered : S.shown;
    if (shown >= 0) marks.push([shown, "#d1495b", 6]);
    for (const [i, c, size] of marks) for (const p of panels) {
      ctx.beginPath(); ctx.arc(p.px[i], p.py[i], size, 0, 2 * Math.PI); ctx.fillStyle = c; ctx.fill(); ctx.strokeStyle = "#000"; ctx.lineWidth = 1; ctx.stroke();
    }
  }

  // --- the table of designs ------------------------------------------------------------------
  const TABLE_ROWS = 100;
  function rowName(i) {
    const src = D.sources.length > 1 ? D.sources[source[i]].label + ": " : "";
    const k = D.kinds[kind[i]];
    return src + (k === "evaluated" ? "evaluation " : k + " row ") + fileRow[i];
  }
  function verdictText(i) { // the buildability verdict: the binding rule where a design has one
    const rule = D.rules[bindingRule[i]];
    return buildable[i] ? "yes" : rule ? "no (" + esc(rule) + ")" : "no (not evaluated)";
  }
  function verifiedText(i) { // blank for a design not verified (hisopt verify RUN_DIR --design N)
    return esc(D.verdicts[verified[i]] || "");
  }
  function drawTable() {
    const rows = S.tableRows || [];
    const shownCols = cols.filter((c) => c.group === "variable" || c.group === "objective");
    const head = "<thead><tr><th>export</th><th class=\"text\">design</th><th class=\"text\">buildable</th><th class=\"text\" title=\"the verdict of hisopt verify (time domain, nonlinear), for the front designs verified\">verified</th>" + shownCols.map((c) => "<th>" + esc(c.name) + "<span class=\"unit\">[" + c.display.unit + "]</span></th>").join("") + "</tr></thead>";
    const body = rows.map((i) => "<tr data-row=\"" + i + "\"" + (i === S.shown ? " class=\"shown\"" : "") + "><td><input type=\"checkbox\" data-row=\"" + i + "\"" + (S.chosen.has(i) ? " checked" : "") + "></td><td class=\"text\">" + esc(rowName(i)) + "</td><td class=\"text\">" + verdictText(i) + "</td><td class=\"text\">" + verifiedText(i) + "</td>" + shownCols.map((c) => "<td>" + number(c.values[i], c.display) + "</td>").join("") + "</tr>").join("");
    $("designs").innerHTML = head + "<tbody>" + body + "</tbody>";
  }

  // --- one design: values, parts, curves --------------------------------------------------------
  function boundNote(i, name) {
    const b = atBound(i, name);
    return b < 0 ? " (at lower bound)" : b > 0 ? " (at upper bound)" : "";
  }
  function showDetails() {
    const i = S.hovered >= 0 ? S.hovered : S.shown;
    if (i < 0) return;
    const outside = cols.some((c) => outsideRange(c, i));
    $("d-title").textContent = rowName(i) + (feasible[i] ? "" : " (not feasible)") + (onFront[i] ? ", on the front" : "") + (buildable[i] ? ", buildable" : ", not buildable") + (verified[i] ? ", verified: " + D.verdicts[verified[i]] : "") + (outside ? ", a damper valve " + D.outside_range : "");
    const src = D.sources[source[i]];
    const rows = cols.filter((c) => (c.group !== "variable" || src.variables.indexOf(c.name) >= 0) && inCase(c));
    $("d-table").innerHTML = "<thead><tr><th class=\"text\">quantity</th><th class=\"text\">kind</th><th>value</th></tr></thead><tbody><tr><td class=\"text\">binding_rule</td><td class=\"text\">build</td><td>" + esc(D.rules[bindingRule[i]] || "-") + "</td></tr>" + rows.map((c) => "<tr><td class=\"text\">" + esc(c.name) + "</td><td class=\"text\">" + c.group + "</td><td>" + withUnit(c.values[i], c.display) + (c.group === "variable" ? boundNote(i, esc(c.name)) : "") + (outsideRange(c, i) ? " (outside the validated range)" : "") + "</td></tr>").join("") + "</tbody>";
    const sheet = D.kinds[kind[i]] === "front" && D.sources.length === 1 ? D.sheets[String(fileRow[i])] : undefined;
    const command = D.kinds[kind[i]] === "front" && src.location ? "hisopt sheet " + src.location + " --design " + fileRow[i] : "";
    const verifyPage = D.kinds[kind[i]] === "front" && D.sources.length === 1 ? D.verify_pages[String(fileRow[i])] : undefined;
    $("d-sheet").innerHTML = (sheet ? "<a href=\"" + esc(sheet) + "\">design sheet</a> · " : "") + (verifyPage ? "<a href=\"" + esc(verifyPage) + "\">verified in the time domain: " + verifiedText(i) + "</a> · " : "") + (command ? "its design sheet: <code>" + command + "</code>" : "export its problem file to evaluate or sheet it");
    drawCurves(i);
  }
  function drawCurves(i) {
    const C = D.curves, k = C.spectra.length, F = C.f_hz.length, P = C.t_s.length, panelsN = k + 1, w = 300, h = 200;
    const ctx = sized($("d-curves"), w * 2, h * Math.ceil(panelsN / 2));
    ctx.font = "11px Helvetica, Arial, sans-serif";
    const base0 = C.baseline[D.sources[source[i]].name];
    const offset = i * D.curves.width;
    const decode8 = (b, low, span) => (b === 255 ? NaN : low + (b / 254) * span);
    const panel = (n, title, xs, ys, bs, logX, logY, xLabel) => {
      const left = (n % 2) * w + 52, top = Math.floor(n / 2) * h + 18, pw = w - 66, ph = h - 54;
      const all = ys.concat(bs).filter((v) => isFinite(v) && (!logY || v > 0));
      if (!all.length) return;
      let lo = Math.min.apply(null, all), hi = Math.max.apply(null, all);
      if (logY) lo = Math.max(lo, hi * 1e-6); // the last six decades: what matters of a spectrum
      if (hi === lo) { hi += 1; lo -= 1; }
      const ax = { range: [xs[0], xs[xs.length - 1]], log: logX, display: { scale: 1, unit: "", scientific: false } };
      const ay = { range: logY ? [lo, hi] : [lo, hi], log: logY, display: { scale: 1, unit: "", scientific: logY } };
      const X = (v) => left + unit(ax, v) * pw, Y = (v) => top + (1 - unit(ay, v)) * ph;
      ctx.strokeStyle = "#c8ced6"; ctx.strokeRect(left, top, pw, ph);
      ctx.fillStyle = "#1d2330"; ctx.textAlign = "left"; ctx.fillText(title, left, top - 6);
      ctx.textAlign = "center"; ctx.fillText(xLabel, left + pw / 2, top + ph + 28);
      ticks(ax, 4).forEach((v) => ctx.fillText(number(v, ax.display), X(v), top + ph + 13));
      ctx.textAlign = "right";
      ticks(ay, 3).forEach((v) => ctx.fillText(number(v, ay.display), left - 4, Y(v) + 3));
      const line = (vals, colour, dash) => {
        ctx.beginPath(); ctx.setLineDash(dash); ctx.strokeStyle = colour; ctx.lineWidth = 1.6;
        let pen = false;
        vals.forEach((v, j) => { if (!isFinite(v) || (logY && v <= 0)) { pen = false; return; } if (pen) ctx.lineTo(X(xs[j]), Y(v)); else { ctx.moveTo(X(xs[j]), Y(v)); pen = true; } });
        ctx.stroke(); ctx.setLineDash([]);
      };
      ctx.save(); ctx.beginPath(); ctx.rect(left, top, pw, ph); ctx.clip();
      line(bs, "#8a94a3", [5, 4]); line(ys, "#d1495b", []);
      ctx.restore();
    };
    C.spectra.forEach((s, j) => {
      const ys = [], bs = base0.spectra[j].map((v) => v * s.display.scale);
      for (let f = 0; f < F; f++) ys.push(Math.pow(10, decode8(curveBytes[offset + j * F + f], s.low, s.decades)) * s.display.scale);
      panel(j, s.name + " PSD [" + s.display.unit + "]", C.f_hz, ys, bs, true, true, "frequency [Hz]");
    });
    const st = C.step, ys = [], bs = base0.step.map((v) => v * st.display.scale);
    for (let p = 0; p < P; p++) ys.push(decode8(curveBytes[offset + k * F + p], st.low, st.high - st.low) * st.display.scale);
    panel(k, "roll angle after a " + st.step_g + " g lateral step [" + st.display.unit + "]", C.t_s, ys, bs, false, false, "time [s]");
    ctx.fillStyle = "#d1495b"; ctx.textAlign = "left"; ctx.fillText("— this design", w + 60, Math.ceil(panelsN / 2) * h - 8);
    ctx.fillStyle = "#8a94a3"; ctx.fillText("- - baseline design", w + 160, Math.ceil(panelsN / 2) * h - 8);
  }

  // --- navigation (hisopt.optim.navigation) ------------------------------------------------------
  function navRows() {
    const rows = [];
    for (let i = 0; i < N; i++) if (selected[i] && onFront[i]) rows.push(i);
    return rows;
  }
  function normalisedFront(rows) { // normalised log objectives of the rows: 0 ideal, 1 nadir
    const k = objectives.length, z = rows.map(() => new Float64Array(k)), ideal = new Float64Array(k), span = new Float64Array(k);
    for (let j = 0; j < k; j++) {
      let lo = Infinity, hi = -Infinity;
      rows.forEach((i, r) => { const v = Math.log10(Math.max(objectives[j].values[i], 1e-300)); z[r][j] = v; if (v < lo) lo = v; if (v > hi) hi = v; });
      ideal[j] = lo; span[j] = hi > lo ? hi - lo : 1.0;
      z.forEach((row) => { row[j] = (row[j] - lo) / span[j]; });
    }
    return { rows: rows, z: z, ideal: ideal, span: span };
  }
  function asfPick(front, reference) { // hisopt.optim.decision.asf_index
    const k = objectives.length, r = new Float64Array(k);
    for (let j = 0; j < k; j++) r[j] = (Math.log10(Math.max(reference[j], 1e-300)) - front.ideal[j]) / front.span[j];
    let best = -1, bestValue = Infinity;
    front.z.forEach((z, n) => {
      let m = -Infinity, s = 0;
      for (let j = 0; j < k; j++) { const d = z[j] - r[j]; if (d > m) m = d; s += d; }
      const value = m + 1e-6 * s;
      if (value < bestValue) { bestValue = value; best = n; }
    });
    return best;
  }
  function orderedSum(z) { let s = 0; for (let j = 0; j < z.length; j++) s = s + z[j]; return s; }
  function distance2(a, b) { let s = 0; for (let j = 0; j < a.length; j++) s = s + (a[j] - b[j]) * (a[j] - b[j]); return s; }
  function representatives(z, k) {
    if (z.length <= k) return z.map((_, n) => n);
    let first = 0;
    for (let n = 1; n < z.length; n++) if (orderedSum(z[n]) < orderedSum(z[first])) first = n;
    const chosen = [first], nearest = z.map((row) => distance2(row, z[first]));
    for (let c = 1; c < k; c++) {
      let next = 0;
      for (let n = 1; n < z.length; n++) if (nearest[n] > nearest[next]) next = n;
      chosen.push(next);
      z.forEach((row, n) => { const d = distance2(row, z[next]); if (d < nearest[n]) nearest[n] = d; });
    }
    return chosen;
  }
  const dominates = (row, point) => row.every((v, j) => v <= point[j]);
  function enautilusOptions(front, current, reachable, stepsLeft, k) { // hisopt.optim.navigation.enautilus_options
    const zr = reachable.map((n) => front.z[n]);
    return representatives(zr, k).map((r) => {
      const q = zr[r], point = stepsLeft === 1 ? Float64Array.from(q) : Float64Array.from(current, (c, j) => c + (q[j] - c) / stepsLeft);
      const rows = reachable.filter((n) => dominates(front.z[n], point));
      const best = Float64Array.from(point, (_, j) => Math.min.apply(null, rows.map((n) => front.z[n][j])));
      return { point: point, representative: front.rows[reachable[r]], reachable: rows, best: best };
    });
  }
  const physical = (front, j, t) => Math.pow(10, front.ideal[j] + t * front.span[j]);

  function refTable() {
    const front = normalisedFront(navRows());
    S.navFront = front;
    $("nav-count").textContent = String(front.rows.length);
    if (!S.reference || S.reference.length !== objectives.length) S.reference = objectives.map((_, j) => front.rows.length ? physical(front, j, 0) : 1);
    $("ref-table").innerHTML = "<thead><tr><th class=\"text\">objective</th><th>aspiration</th><th></th><th>reachable<span class=\"unit\">from</span></th><th>reachable<span class=\"unit\">to</span></th></tr></thead><tbody>" + objectives.map((c, j) => "<tr><td class=\"text\">" + esc(label(c)) + "</td><td><input class=\"ref\" type=\"number\" step=\"any\" data-j=\"" + j + "\" value=\"" + number(S.reference[j], c.display).replace(/[^0-9eE.+-]/g, "") + "\"></td><td><input type=\"range\" min=\"0\" max=\"1000\" data-j=\"" + j + "\"></td><td id=\"reach-lo-" + j + "\"></td><td id=\"reach-hi-" + j + "\"></td></tr>").join("") + "</tbody>";
    document.querySelectorAll("#ref-table input.ref").forEach((el) => el.addEventListener("change", () => {
      const j = +el.dataset.j, c = objectives[j], v = parseFloat(el.value) / c.display.scale;
      if (isFinite(v) && v > 0) { S.reference[j] = v; runReference(); showDetails(); redraw(); } else { $("ref-result").textContent = label(c) + ": expected a positive number in " + c.display.unit + ", got " + JSON.stringify(el.value); }
    }));
    document.querySelectorAll("#ref-table input[type=range]").forEach((el) => el.addEventListener("input", () => {
      const j = +el.dataset.j, c = objectives[j];
      S.reference[j] = physical(S.navFront, j, +el.value / 1000);
      document.querySelector("#ref-table input.ref[data-j=\"" + j + "\"]").value = number(S.reference[j], c.display).replace(/[^0-9eE.+-]/g, "");
      runReference(); showDetails(); redraw();
    }));
    runReference();
  }
  function runReference() {
    const front = S.navFront;
    if (!front || !front.rows.length) { S.asf = -1; $("ref-result").textContent = "No design on the front inside the filters and brushes."; return; }
    objectives.forEach((c, j) => {
      const t = (Math.log10(S.reference[j]) - front.ideal[j]) / front.span[j];
      const el = document.querySelector("#ref-table input[type=range][data-j=\"" + j + "\"]");
      if (el) el.value = String(Math.round(Math.max(0, Math.min(1, t)) * 1000));
    });
    const pick = asfPick(front, S.reference);
    S.asf = front.rows[pick];
    const r = objectives.map((c, j) => (Math.log10(Math.max(S.reference[j], 1e-300)) - front.ideal[j]) / front.span[j]);
    const reach = front.z.map((z, n) => n).filter((n) => dominates(front.z[n], r));
    objectives.forEach((c, j) => {
      const vals = reach.map((n) => c.values[front.rows[n]]);
      $("reach-lo-" + j).textContent = vals.length ? withUnit(Math.min.apply(null, vals), c.display) : "-";
      $("reach-hi-" + j).textContent = vals.length ? withUnit(Math.max.apply(null, vals), c.display) : "-";
    });
    $("ref-result").innerHTML = "Closest design: <a href=\"#\" id=\"asf-link\" data-row=\"" + S.asf + "\">" + esc(rowName(S.asf)) + "</a>. " + (reach.length ? reach.length + " designs are at least as good as the aspiration in every objective (their ranges above)." : "No design reaches every aspiration: the closest one is shown.");
    $("asf-link").addEventListener("click", (e) => { e.preventDefault(); show(S.asf, true); });
    S.shown = S.asf; S.hovered = -1;
  }

  function nautilusStart() {
    const k = Math.max(2, Math.min(10, parseInt($("en-k").value, 10) || 4)), steps = Math.max(1, Math.min(20, parseInt($("en-steps").value, 10) || 5));
    const front = normalisedFront(navRows());
    if (!front.rows.length) { $("en-status").textContent = "No design on the front inside the filters and brushes."; return; }
    const all = front.rows.map((_, n) => n), start = new Float64Array(objectives.length).fill(1.0);
    const history = [{ current: start, reachable: all, stepsLeft: steps, options: enautilusOptions(front, start, all, steps, k) }];
    S.nautilus = { front: front, k: k, steps: steps, history: history, options: () => history[history.length - 1].options };
    nautilusTable();
  }
  function nautilusChoose(o) {
    const N_ = S.nautilus, top = N_.history[N_.history.length - 1], option = top.options[o];
    if (top.stepsLeft === 1) { show(option.representative, true); $("en-status").textContent = "Reached a design of the front: " + rowName(option.representative) + "."; return; }
    N_.history.push({ current: option.point, reachable: option.reachable, stepsLeft: top.stepsLeft - 1, options: enautilusOptions(N_.front, option.point, option.reachable, top.stepsLeft - 1, N_.k) });
    nautilusTable();
  }
  function nautilusTable() {
    const N_ = S.nautilus, top = N_.history[N_.history.length - 1], front = N_.front;
    $("en-back").disabled = N_.history.length < 2;
    $("en-status").textContent = "Step " + (N_.steps - top.stepsLeft + 1) + " of " + N_.steps + ": " + top.reachable.length + " designs reachable. " + (top.stepsLeft === 1 ? "These points are designs of the front." : "Each point with the best value each objective can still reach from it.");
    $("en-table").innerHTML = "<thead><tr><th></th>" + objectives.map((c) => "<th>" + esc(c.name) + "<span class=\"unit\">[" + c.display.unit + "]</span></th>").join("") + "<th>designs</th></tr></thead><tbody>" + top.options.map((o, n) => "<tr data-option=\"" + n + "\" data-representative=\"" + o.representative + "\"><td><button type=\"button\" data-option=\"" + n + "\">choose</button></td>" + objectives.map((c, j) => "<td>" + number(physical(front, j, o.point[j]), c.display) + (top.stepsLeft > 1 ? "<br><small>best " + number(physical(front, j, o.best[j]), c.display) + "</small>" : "") + "</td>").join("") + "<td>" + o.reachable.length + "</td></tr>").join("") + "</tbody>";
    document.querySelectorAll("#en-table button").forEach((b) => b.addEventListener("click", () => nautilusChoose(+b.dataset.option)));
    redraw();
  }

  // --- export ------------------------------------------------------------------------------------
  function download(name, text, type) {
    const a = document.createElement("a");
    a.href = URL.createObjectURL(new Blob([text], { type: type }));
    a.download = name; document.body.appendChild(a); a.click();
    setTimeout(() => { URL.revokeObjectURL(a.href); a.remove(); }, 1000);
  }
  function exportCsv() {
    const rows = S.chosen.size ? Array.from(S.chosen).sort((a, b) => a - b) : S.shown >= 0 ? [S.shown] : [];
    if (!rows.length) { $("export-note").textContent = "Tick designs in the table (or show one) first."; return; }
    const quantity = cols.filter((c) => c.group === "variable" || c.group === "objective");
    const header = ["source", "design", "kind", "row"].concat(quantity.map((c) => c.name));
    const units = ["[-]", "[-]", "[-]", "[-]"].concat(quantity.map((c) => "[" + c.unit + "]"));
    const body = rows.map((i) => [D.sources[source[i]].name, rowName(i).replace(/,/g, ";"), D.kinds[kind[i]], fileRow[i]].concat(quantity.map((c) => siText(c.values[i]))).join(","));
    download("designs.csv", [header.join(","), units.join(",")].concat(body).join("\n") + "\n", "text/csv");
    $("export-note").textContent = rows.length + " designs, SI units: hisopt evaluate PROBLEM --designs designs.csv gives their objectives again.";
  }
  function exportToml() {
    const i = S.shown;
    if (i < 0) { $("export-note").textContent = "Show a design first (click a point or a row)."; return; }
    const src = D.sources[source[i]];
    let text = src.template;
    src.variables.forEach((v) => { text = text.split("{{" + v + "}}").join(siText(byName[v].values[i])); });
    download("design-" + fileRow[i] + ".toml", "# " + rowName(i) + " of " + (src.location || src.name) + "\n" + text, "application/toml");
    $("export-note").textContent = "hisopt evaluate design-" + fileRow[i] + ".toml gives its objectives again.";
  }

  // --- interaction ---------------------------------------------------------------------------------
  function show(i, keep) { if (keep) { S.shown = i; S.hovered = -1; } else S.hovered = i; showDetails(); redraw(); }
  function sortRows() {
    const colour = byName[S.colour], rows = [];
    for (let i = 0; i < N; i++) if (selected[i]) rows.push(i);
    rows.sort((a, b) => (colour.values[a] - colour.values[b]) || (a - b));
    S.tableRows = rows.slice(0, TABLE_ROWS);
    return rows.length;
  }
  function redraw() { drawPcForeground(); drawPcAxes(); drawSplom(); drawTable(); }
  function update(baseChanged) { // a filter or brush changed: every view and the navigation
    const t0 = performance.now();
    if (baseChanged) { computeBase(); cols.forEach((c) => { c.range = range(c); }); layoutAxes(); layoutSplom(); drawPcBackground(); }
    computeSelected();
    const count = sortRows();
    $("count").textContent = String(count);
    if (S.nautilus) { S.nautilus = null; $("en-table").innerHTML = ""; $("en-status").textContent = "The designs changed: start again."; $("en-back").disabled = true; }
    refTable(); showDetails(); redraw();
    flush($("pc-fg")); flush($("sp-fg"));
    const ms = performance.now() - t0;
    S.timing.last = ms; S.timing.runs.push(ms);
    $("timing").textContent = "(views updated in " + ms.toFixed(0) + " ms)";
  }
  let drag = null;
  function axisAt(x) { return axes.find((a) => Math.abs(a.x - x) < 14); }
  $("pc-ax").addEventListener("pointerdown", (e) => {
    const r = e.target.getBoundingClientRect(), x = e.clientX - r.left, y = e.clientY - r.top, a = axisAt(x);
    if (!a) return;
    drag = { a: a, y0: y, moved: false };
    e.target.setPointerCapture(e.pointerId);
  });
  $("pc-ax").addEventListener("pointermove", (e) => {
    if (!drag) return;
    const r = e.target.getBoundingClientRect(), y = e.clientY - r.top, h = PC.height - PC.top - PC.bottom;
    if (Math.abs(y - drag.y0) < 3 && !drag.moved) return;
    drag.moved = true;
    const t0 = 1 - (Math.min(Math.max(drag.y0, PC.top), PC.top + h) - PC.top) / h, t1 = 1 - (Math.min(Math.max(y, PC.top), PC.top + h) - PC.top) / h;
    S.brushes[drag.a.c.name] = [fromUnit(drag.a.c, Math.min(t0, t1)), fromUnit(drag.a.c, Math.max(t0, t1))];
    if (!drag.pending) { drag.pending = true; requestAnimationFrame(() => { if (drag) drag.pending = false; update(false); }); }
  });
  $("pc-ax").addEventListener("pointerup", () => {
    if (drag && !drag.moved) { delete S.brushes[drag.a.c.name]; }
    drag = null; update(false);
  });
  function nearest(x, y) {
    const p = panels.find((q) => x >= q.left && x <= q.left + q.size && y >= q.top && y <= q.top + q.size);
    if (!p) return -1;
    let best = -1, bestD = 64;
    for (let i = 0; i < N; i++) if (selected[i]) { const d = (p.px[i] - x) * (p.px[i] - x) + (p.py[i] - y) * (p.py[i] - y); if (d < bestD) { bestD = d; best = i; } }
    return best;
  }
  $("sp-fg").addEventListener("mousemove", (e) => { const r = e.target.getBoundingClientRect(), i = nearest(e.clientX - r.left, e.clientY - r.top); if (i !== S.hovered) { S.hovered = i; showDetails(); redraw(); } });
  $("sp-fg").addEventListener("mouseleave", () => { S.hovered = -1; showDetails(); redraw(); });
  $("sp-fg").addEventListener("click", (e) => { const r = e.target.getBoundingClientRect(), i = nearest(e.clientX - r.left, e.clientY - r.top); if (i >= 0) show(i, true); });
  $("designs").addEventListener("click", (e) => {
    const box = e.target.closest("input[type=checkbox]");
    if (box) { const i = +box.dataset.row; if (box.checked) S.chosen.add(i); else S.chosen.delete(i); return; }
    const tr = e.target.closest("tr[data-row]");
    if (tr) show(+tr.dataset.row, true);
  });
  $("designs").addEventListener("mouseover", (e) => { const tr = e.target.closest("tr[data-row]"); if (tr && +tr.dataset.row !== S.hovered) { S.hovered = +tr.dataset.row; showDetails(); drawPcForeground(); drawSplom(); } });
  $("designs").addEventListener("mouseleave", () => { S.hovered = -1; showDetails(); drawPcForeground(); drawSplom(); });
  $("f-front").addEventListener("change", (e) => { S.frontOnly = e.target.checked; update(true); });
  $("f-feasible").addEventListener("change", (e) => { S.feasibleOnly = e.target.checked; update(true); });
  $("f-buildable").addEventListener("change", (e) => { S.buildableOnly = e.target.checked; update(true); });
  $("f-bound").addEventListener("change", (e) => { S.bound = e.target.value; update(true); });
  $("f-source").addEventListener("change", (e) => { S.source = e.target.value; update(true); });
  $("f-case").addEventListener("change", (e) => { S.loadCase = e.target.value; update(true); });
  $("f-colour").addEventListener("change", (e) => { S.colour = e.target.value; update(false); });
  $("clear-brushes").addEventListener("click", () => { S.brushes = {}; update(false); });
  $("en-start").addEventListener("click", nautilusStart);
  $("en-back").addEventListener("click", () => { if (S.nautilus && S.nautilus.history.length > 1) { S.nautilus.history.pop(); nautilusTable(); } });
  $("export-csv").addEventListener("click", exportCsv);
  $("export-toml").addEventListener("click", exportToml);

  // --- start -------------------------------------------------------------------------------------
  $("total").textContent = String(N);
  const cases = Array.from(new Set(cols.filter((c) => c.group === "load case").map((c) => c.name.split("@")[1])));
  if (cases.length) cases.forEach((c) => $("f-case").insertAdjacentHTML("beforeend", "<option>" + esc(c) + "</option>")); else $("f-case-label").style.display = "none";
  const names = Array.from(new Set(D.sources.map((s) => s.name)));
  if (names.length > 1) names.forEach((s) => $("f-source").insertAdjacentHTML("beforeend", "<option>" + esc(s) + "</option>")); else $("f-source-label").style.display = "none";
  Array.from(new Set(D.sources.flatMap((s) => s.variables))).forEach((v) => $("f-bound").insertAdjacentHTML("beforeend", "<option value=\"" + esc(v) + "\">" + esc(v) + " at a bound</option>"));
  cols.filter((c) => c.group !== "variable").forEach((c) => $("f-colour").insertAdjacentHTML("beforeend", "<option>" + esc(c.name) + "</option>"));
  update(true);

  // Read-only view for notebooks and the page's test: the state, never a second code path.
  window.hisoptRoom = {
    axes: () => axes.map((a) => ({ name: a.c.name, x: a.x, top: PC.top, bottom: PC.height - PC.bottom })),
    brushes: () => JSON.parse(JSON.stringify(S.brushes)),
    selectedRows: () => { const out = []; for (let i = 0; i < N; i++) if (selected[i]) out.push(i); return out; },
    shown: () => S.shown, asf: () => S.asf, timing: () => S.timing,
    options: () => (S.nautilus ? S.nautilus.options().map((o) => o.representative) : []),
  };
})();
