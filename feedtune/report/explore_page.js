// feedtune explore: the loop of a ball-screw design on its measured FRF, re-evaluated as the filter pack and the gain
// are moved. Formulas (docs/report.md, "The interactive page"; tests/test_explore.py holds them to the library):
//   L(f) = k * L0(f) * Fd(f; notches, low-pass)
// L0 is the analysed loop (discrete case: FRF, discrete controller, ZOH, computational delay) divided by the filter
// pack it was analysed with, Fd the filter pack discretized by pole-zero matching (each root s -> exp(s T), the
// low-pass's excess zeros at z = -1, unit gain at 0 Hz), written as the second-order sections the gains file holds.
"use strict";
const D = JSON.parse(document.getElementById("feedtune-explore-data").textContent);
const T = 1 / D.fs_hz, TWO_PI = 2 * Math.PI;

function pairSection(wn, zeta) {  // z^2 coefficients of exp(T * roots of s^2 + 2 zeta wn s + wn^2): [-(sum), product]
  const prod = Math.exp(-2 * zeta * wn * T);
  let sum;
  if (zeta < 1) sum = 2 * Math.exp(-zeta * wn * T) * Math.cos(wn * Math.sqrt(1 - zeta * zeta) * T);
  else { const r = wn * Math.sqrt(zeta * zeta - 1); sum = Math.exp((-zeta * wn + r) * T) + Math.exp((-zeta * wn - r) * T); }
  return [-sum, prod];
}

function filterSections(p) {  // [b0, b1, b2, 1, a1, a2] rows, each with unit gain at 0 Hz (z = 1)
  const rows = [];
  if (p.lpf_hz) {
    const w = TWO_PI * p.lpf_hz;
    if (p.lpf_order === 2) {
      const [a1, a2] = pairSection(w, p.lpf_zeta), g = (1 + a1 + a2) / 4;
      rows.push([g, 2 * g, g, 1, a1, a2]);
    } else {
      const a1 = -Math.exp(-w * T), g = (1 + a1) / 2;
      rows.push([g, g, 0, 1, a1, 0]);
    }
  }
  for (const n of p.notches) {
    const w = TWO_PI * n.freq_hz, [b1, b2] = pairSection(w, n.zeta_z), [a1, a2] = pairSection(w, n.zeta_p);
    const g = (1 + a1 + a2) / (1 + b1 + b2);
    rows.push([g, g * b1, g * b2, 1, a1, a2]);
  }
  return rows.concat(D.fixed_sos);  // the pack's lead stages, unchanged
}

function sosResponse(rows, f) {  // complex response [re[], im[]] of the sections at the frequencies f [Hz]
  const n = f.length, re = new Float64Array(n).fill(1), im = new Float64Array(n);
  for (let i = 0; i < n; i++) {
    const w = TWO_PI * f[i] * T, c1 = Math.cos(w), s1 = -Math.sin(w), c2 = Math.cos(2 * w), s2 = -Math.sin(2 * w);
    let hr = 1, hi = 0;
    for (const r of rows) {
      const nr = r[0] + r[1] * c1 + r[2] * c2, ni = r[1] * s1 + r[2] * s2;
      const dr = r[3] + r[4] * c1 + r[5] * c2, di = r[4] * s1 + r[5] * s2, dd = dr * dr + di * di;
      const qr = (nr * dr + ni * di) / dd, qi = (ni * dr - nr * di) / dd;
      const tr = hr * qr - hi * qi; hi = hr * qi + hi * qr; hr = tr;
    }
    re[i] = hr; im[i] = hi;
  }
  return [re, im];
}

function loop(p) {  // L = k L0 Fd on the grid
  const [fr, fi] = sosResponse(filterSections(p), D.freq_hz), k = Math.pow(10, p.gain_db / 20), n = fr.length;
  const re = new Float64Array(n), im = new Float64Array(n);
  for (let i = 0; i < n; i++) {
    re[i] = k * (D.L0_re[i] * fr[i] - D.L0_im[i] * fi[i]);
    im[i] = k * (D.L0_re[i] * fi[i] + D.L0_im[i] * fr[i]);
  }
  return {re, im};
}

function winding(L) {  // unwrapped angle change of 1 + L over the grid [rad]
  let total = 0;
  for (let i = 1; i < L.re.length; i++) {
    const ar = 1 + L.re[i - 1], ai = L.im[i - 1], br = 1 + L.re[i], bi = L.im[i];
    total += Math.atan2(ar * bi - ai * br, ar * br + ai * bi);
  }
  return total;
}

function wrapDeg(x) { let y = ((x + 180) % 360 + 360) % 360 - 180; return y === -180 ? 180 : y; }

function metrics(L) {  // Ms, crossovers with their phase margins, phase crossovers with their gain margins
  const f = D.freq_hz, n = f.length, out = {ms: 0, ms_freq_hz: null, crossovers: [], phase_crossovers: []};
  for (let i = 0; i < n; i++) {
    const s = 1 / Math.hypot(1 + L.re[i], L.im[i]);
    if (s > out.ms) { out.ms = s; out.ms_freq_hz = f[i]; }
  }
  for (let i = 0; i + 1 < n; i++) {
    const m0 = Math.log(Math.hypot(L.re[i], L.im[i])), m1 = Math.log(Math.hypot(L.re[i + 1], L.im[i + 1]));
    const p0 = Math.atan2(L.im[i], L.re[i]);
    let dp = Math.atan2(L.im[i + 1], L.re[i + 1]) - p0;
    dp -= TWO_PI * Math.round(dp / TWO_PI);
    const lf0 = Math.log(f[i]), lf1 = Math.log(f[i + 1]);
    if ((m0 < 0) !== (m1 < 0) && m0 !== m1) {
      const t = m0 / (m0 - m1);
      out.crossovers.push({freq_hz: Math.exp(lf0 + t * (lf1 - lf0)), pm_deg: wrapDeg((p0 + t * dp) * 180 / Math.PI + 180)});
    }
    // the phase passes -180 deg: Im L changes sign where Re L < 0
    if ((L.im[i] < 0) !== (L.im[i + 1] < 0) && L.re[i] + L.re[i + 1] < 0) {
      const target = p0 > 0 ? Math.PI : -Math.PI, t = dp === 0 ? 0 : (target - p0) / dp;
      if (t >= 0 && t <= 1) {
        const m = m0 + t * (m1 - m0);
        out.phase_crossovers.push({freq_hz: Math.exp(lf0 + t * (lf1 - lf0)), gm_db: -20 * m / Math.LN10});
      }
    }
  }
  const pms = out.crossovers.map(c => c.pm_deg), ups = out.phase_crossovers.filter(c => c.gm_db > 0);
  const downs = out.phase_crossovers.filter(c => c.gm_db <= 0);
  out.pm_deg = pms.length ? pms.reduce((a, b) => Math.abs(b) < Math.abs(a) ? b : a) : null;
  out.gm_db = ups.length ? Math.min(...ups.map(c => c.gm_db)) : null;
  out.gm_low_db = downs.length ? Math.min(...downs.map(c => -c.gm_db)) : null;
  out.first_crossover_hz = out.crossovers.length ? out.crossovers[0].freq_hz : null;
  let worst = 0;  // balanced disk margin alpha = 1 / max |S - 1/2| (feedtune.analysis.margins)
  for (let i = 0; i < n; i++) {
    const dr = 1 + L.re[i], di = L.im[i], dd = dr * dr + di * di;
    worst = Math.max(worst, Math.hypot(dr / dd - 0.5, -di / dd));
  }
  out.disk_margin = worst > 0 ? 1 / worst : null;
  out.winding = winding(L);
  out.stable = D.reference.stable && Math.round((out.winding - REF_WINDING) / Math.PI) === 0;
  return out;
}

function verdict(m) {  // the limits of the policy, each with its slack (the least slack binds)
  const lim = D.limits, items = [];
  items.push({name: "stable", ok: m.stable, slack: m.stable ? Infinity : -1, text: m.stable ? "stable" : "UNSTABLE"});
  if (lim.ms_max != null) items.push({name: "Ms", ok: m.ms <= lim.ms_max, slack: 1 - m.ms / lim.ms_max,
                                      text: `Ms ${m.ms.toPrecision(3)} (limit ${lim.ms_max})`});
  if (lim.pm_min_deg != null && m.pm_deg != null)
    items.push({name: "PM", ok: Math.abs(m.pm_deg) >= lim.pm_min_deg, slack: Math.abs(m.pm_deg) / lim.pm_min_deg - 1,
                text: `PM ${m.pm_deg.toFixed(1)} deg (limit ${lim.pm_min_deg} deg)`});
  if (lim.gm_min_db != null && m.gm_db != null)
    items.push({name: "GM", ok: m.gm_db >= lim.gm_min_db, slack: m.gm_db / lim.gm_min_db - 1,
                text: `GM ${m.gm_db.toFixed(2)} dB (limit ${lim.gm_min_db} dB)`});
  const low = lim.gm_low_min_db;  // the policy's own (Limits.to_dict resolves "like gm_min_db")
  if (low != null && low > 0 && m.gm_low_db != null)
    items.push({name: "gain-reduction GM", ok: m.gm_low_db >= low, slack: m.gm_low_db / low - 1,
                text: `gain-reduction GM ${m.gm_low_db.toFixed(2)} dB (limit ${low} dB)`});
  if (lim.disk_margin_min != null && m.disk_margin != null)
    items.push({name: "disk margin", ok: m.disk_margin >= lim.disk_margin_min,
                slack: m.disk_margin / lim.disk_margin_min - 1,
                text: `disk margin ${m.disk_margin.toFixed(3)} (limit ${lim.disk_margin_min})`});
  const ok = items.every(i => i.ok), binding = items.reduce((a, b) => b.slack < a.slack ? b : a);
  return {ok, items, binding};
}

// ------------------------------------------------------------------------------------------ drawing
function axes(ctx, box, xlog, x0, x1, y0, y1, xlabel, ylabel) {
  const [L, Tp, W, H] = box;
  const X = v => L + W * (xlog ? Math.log(v / x0) / Math.log(x1 / x0) : (v - x0) / (x1 - x0));
  const Y = v => Tp + H * (1 - (v - y0) / (y1 - y0));
  ctx.strokeStyle = "#ccc"; ctx.lineWidth = 1; ctx.fillStyle = "#333"; ctx.font = "11px sans-serif";
  if (xlog) for (let d = Math.pow(10, Math.floor(Math.log10(x0))); d <= x1; d *= 10) {
    if (d >= x0) { ctx.beginPath(); ctx.moveTo(X(d), Tp); ctx.lineTo(X(d), Tp + H); ctx.stroke(); ctx.fillText(String(d), X(d) - 8, Tp + H + 13); }
  }
  const step = niceStep((y1 - y0) / 5);
  for (let v = Math.ceil(y0 / step) * step; v <= y1; v += step) {
    ctx.beginPath(); ctx.moveTo(L, Y(v)); ctx.lineTo(L + W, Y(v)); ctx.stroke(); ctx.fillText(String(+v.toFixed(2)), L - 34, Y(v) + 4);
  }
  ctx.strokeStyle = "#333"; ctx.strokeRect(L, Tp, W, H);
  ctx.fillText(xlabel, L + W / 2 - 30, Tp + H + 28);
  ctx.save(); ctx.translate(L - 40, Tp + H / 2 + 30); ctx.rotate(-Math.PI / 2); ctx.fillText(ylabel, 0, 0); ctx.restore();
  return {X, Y};
}

function niceStep(x) { const e = Math.pow(10, Math.floor(Math.log10(x))), m = x / e; return (m < 2 ? 2 : m < 5 ? 5 : 10) * e; }

function polyline(ctx, xs, ys, X, Y, color, width, box) {
  ctx.save(); ctx.beginPath(); ctx.rect(box[0], box[1], box[2], box[3]); ctx.clip();
  ctx.strokeStyle = color; ctx.lineWidth = width; ctx.beginPath();
  let pen = false;
  for (let i = 0; i < xs.length; i++) {
    const x = X(xs[i]), y = Y(ys[i]);
    if (!isFinite(x) || !isFinite(y)) { pen = false; continue; }
    if (pen) ctx.lineTo(x, y); else { ctx.moveTo(x, y); pen = true; }
  }
  ctx.stroke(); ctx.restore();
}

function draw(L, m, ref) {
  const f = D.freq_hz, f0 = f[0], f1 = f[f.length - 1];
  const mag = a => Array.from(a.re, (r, i) => 20 * Math.log10(Math.hypot(r, a.im[i])));
  const ph = a => Array.from(a.re, (r, i) => Math.atan2(a.im[i], r) * 180 / Math.PI);
  const sens = a => Array.from(a.re, (r, i) => -20 * Math.log10(Math.hypot(1 + r, a.im[i])));
  // Bode
  let c = document.getElementById("bode"), ctx = c.getContext("2d");
  ctx.clearRect(0, 0, c.width, c.height);
  let box = [60, 20, c.width - 80, 150];
  let A = axes(ctx, box, true, f0, f1, -60, 60, "", "|L| [dB]");
  polyline(ctx, f, mag(ref), A.X, A.Y, "#bbb", 2, box);
  polyline(ctx, f, mag(L), A.X, A.Y, "#0072B2", 1.6, box);
  ctx.strokeStyle = "#333"; ctx.beginPath(); ctx.moveTo(box[0], A.Y(0)); ctx.lineTo(box[0] + box[2], A.Y(0)); ctx.stroke();
  for (const x of m.crossovers) { ctx.fillStyle = "#D55E00"; ctx.beginPath(); ctx.arc(A.X(x.freq_hz), A.Y(0), 3.5, 0, TWO_PI); ctx.fill(); }
  box = [60, 215, c.width - 80, 120];
  A = axes(ctx, box, true, f0, f1, -180, 180, "frequency [Hz]", "phase [deg]");
  polyline(ctx, f, ph(ref), A.X, A.Y, "#bbb", 2, box);
  polyline(ctx, f, ph(L), A.X, A.Y, "#0072B2", 1.4, box);
  // Nyquist
  c = document.getElementById("nyquist"); ctx = c.getContext("2d"); ctx.clearRect(0, 0, c.width, c.height);
  box = [50, 15, c.width - 70, c.height - 55];
  A = axes(ctx, box, false, -4, 2, -3, 3, "Re L", "Im L");
  polyline(ctx, Array.from(ref.re), Array.from(ref.im), A.X, A.Y, "#bbb", 2, box);
  polyline(ctx, Array.from(L.re), Array.from(L.im), A.X, A.Y, "#0072B2", 1.4, box);
  const th = Array.from({length: 121}, (_, i) => i * TWO_PI / 120), r = 1 / m.ms;
  polyline(ctx, th.map(t => -1 + r * Math.cos(t)), th.map(t => r * Math.sin(t)), A.X, A.Y, "#D55E00", 1, box);
  ctx.fillStyle = "#000"; ctx.fillText("+", A.X(-1) - 4, A.Y(0) + 4);
  // |S|
  c = document.getElementById("sens"); ctx = c.getContext("2d"); ctx.clearRect(0, 0, c.width, c.height);
  box = [60, 15, c.width - 80, c.height - 55];
  A = axes(ctx, box, true, f0, f1, -40, 12, "frequency [Hz]", "|S| [dB]");
  polyline(ctx, f, sens(ref), A.X, A.Y, "#bbb", 2, box);
  polyline(ctx, f, sens(L), A.X, A.Y, "#0072B2", 1.4, box);
  if (D.limits.ms_max) { const y = A.Y(20 * Math.log10(D.limits.ms_max)); ctx.setLineDash([5, 4]); ctx.strokeStyle = "#555";
    ctx.beginPath(); ctx.moveTo(box[0], y); ctx.lineTo(box[0] + box[2], y); ctx.stroke(); ctx.setLineDash([]); }
}

// ------------------------------------------------------------------------------------------ the page
const params = JSON.parse(JSON.stringify(D.filters));
params.gain_db = 0;
const REF = loop(params);
const REF_WINDING = winding(REF);

function fmt(x, unit) { return x == null ? "-" : `${Number(x.toPrecision(4))}${unit ? " " + unit : ""}`; }

function update() {
  const t0 = performance.now();
  const L = loop(params), m = metrics(L), v = verdict(m);
  draw(L, m, REF);
  document.getElementById("ms").textContent = m.ms.toFixed(4);
  document.getElementById("ms-at").textContent = fmt(m.ms_freq_hz, "Hz");
  document.getElementById("pm").textContent = fmt(m.pm_deg, "deg");
  document.getElementById("gm").textContent = fmt(m.gm_db, "dB");
  document.getElementById("gm-low").textContent = fmt(m.gm_low_db, "dB");
  document.getElementById("bw").textContent = fmt(m.first_crossover_hz, "Hz");
  document.getElementById("dm").textContent = fmt(m.disk_margin, "");
  const el = document.getElementById("verdict");
  el.textContent = (v.ok ? "PASS" : "FAIL") + ` under ${D.limits.name}: ` + v.items.map(i => i.text + (i.ok ? "" : " FAILS")).join(", ")
    + `; binds: ${v.binding.name}`;
  el.className = v.ok ? "pass" : "fail";
  document.getElementById("elapsed").textContent = `${(performance.now() - t0).toFixed(1)} ms`;
  window.feedtuneExplore.last = {metrics: m, verdict: v, params: JSON.parse(JSON.stringify(params))};
}

function gainsDocument() {  // the gains file the page shows: gains scaled, filter pack edited, no certificate
  const doc = JSON.parse(JSON.stringify(D.document)), k = Math.pow(10, params.gain_db / 20);
  const scale = (sec, name) => {  // a number given bare or as {value, unit}
    if (typeof sec[name] === "number") sec[name] *= k; else if (sec[name]) sec[name].value *= k;
  };
  for (const name of Object.keys(doc.gains)) scale(doc.gains, name);
  if (doc.ppi_gains) for (const name of ["Kpv", "Kiv"]) scale(doc.ppi_gains, name);
  // (Kx1 = Kiv, Kv1 = Kpv, Kx2 = Kpv Kpx, Ki2 = Kiv Kpx: all five scaled by k is Kpv, Kiv scaled, Kpx kept)
  delete doc.certificate;  // edited gains: certify them again with feedtune analyze GAINS --frf FRF
  const cont = doc.filters.continuous;
  cont.notches = params.notches.map(n => ({freq_hz: n.freq_hz, zeta_z: n.zeta_z, zeta_p: n.zeta_p}));
  cont.lpf_hz = params.lpf_hz;
  doc.filters.filter_pack_sos = filterSections(params);
  doc.edited = {by: "feedtune explore", from: D.gains_name, gain_scale: k,
                note: "not certified: run feedtune analyze on this file with --frf to certify it"};
  return doc;
}

function download() {
  const blob = new Blob([JSON.stringify(gainsDocument(), null, 1)], {type: "application/json"});
  const a = document.createElement("a");
  a.href = URL.createObjectURL(blob);
  a.download = D.gains_name.split(/[\\/]/).pop().replace(/\.(toml|json)$/, "") + "_explored.json";
  document.body.appendChild(a); a.click(); a.remove();
}

function slider(parent, label, get, set, lo, hi, log, unit) {
  const row = document.createElement("label"), input = document.createElement("input"), out = document.createElement("span");
  input.type = "range"; input.min = 0; input.max = 1000; input.step = 1;
  const toPos = v => 1000 * (log ? Math.log(v / lo) / Math.log(hi / lo) : (v - lo) / (hi - lo));
  const fromPos = p => log ? lo * Math.pow(hi / lo, p / 1000) : lo + (hi - lo) * p / 1000;
  input.value = toPos(get());
  out.textContent = fmt(get(), unit);
  input.addEventListener("input", () => { set(fromPos(+input.value)); out.textContent = fmt(get(), unit); update(); });
  row.append(label + " ", input, out); parent.appendChild(row);
  return input;
}

window.feedtuneExplore = {params, loop, metrics, verdict, filterSections, sosResponse, gainsDocument, update, data: D};
(function build() {
  const box = document.getElementById("controls"), nyq = D.fs_hz / 2;
  slider(box, "gain [dB]", () => params.gain_db, v => { params.gain_db = v; }, -12, 12, false, "dB");
  params.notches.forEach((n, k) => {
    slider(box, `notch ${k + 1} frequency`, () => n.freq_hz, v => { n.freq_hz = v; }, 20, 0.45 * nyq, true, "Hz").id = `notch-${k + 1}-freq`;
    slider(box, `notch ${k + 1} zero damping`, () => n.zeta_z, v => { n.zeta_z = v; }, 0.0, 1.0, false, "");
    slider(box, `notch ${k + 1} pole damping`, () => n.zeta_p, v => { n.zeta_p = v; }, 0.05, 1.5, false, "");
  });
  if (params.lpf_hz) slider(box, "low-pass pole", () => params.lpf_hz, v => { params.lpf_hz = v; }, 50, 0.9 * nyq, true, "Hz").id = "lpf";
  document.getElementById("download").addEventListener("click", download);
  update();
})();
