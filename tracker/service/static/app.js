// The station's status page: polls the JSON API and updates the page in place.
// /api/status every second, /api/schedule and /api/passes every ten; no libraries.
"use strict";

(() => {
  const STATUS_EVERY_MS = 1000;
  const LISTS_EVERY_MS = 10000;
  const R = 100;                          // horizon radius of the sky plot, in SVG units
  const WINDOW_BEFORE_H = 2;              // the timeline shows now-2 h .. now+24 h
  const WINDOW_AFTER_H = 24;

  const $ = (id) => document.getElementById(id);
  let schedule = [];
  let lastOk = null;
  let nowMs = null;

  function setText(id, s) {
    const e = $(id);
    if (e.textContent !== s) e.textContent = s;
  }
  const num = (v, d = 1) => (v === null || v === undefined ? "-" : Number(v).toFixed(d));
  const ms = (iso) => (iso ? Date.parse(iso) : NaN);
  const hms = (iso) => (iso ? iso.slice(11, 19) : "-");
  const dayHm = (iso) => (iso ? `${iso.slice(5, 10)} ${iso.slice(11, 16)}` : "-");

  function duration(s) {
    s = Math.max(0, Math.round(s));
    const h = Math.floor(s / 3600), m = Math.floor((s % 3600) / 60), sec = s % 60;
    return h ? `${h} h ${m} min` : m ? `${m} min ${sec} s` : `${sec} s`;
  }

  // Polar sky plot: bearing clockwise from north (up), elevation 90 in the centre.
  function xy(az, el) {
    const r = (R * (90 - Math.min(90, Math.max(0, el)))) / 90;
    const a = (az * Math.PI) / 180;
    return [r * Math.sin(a), -r * Math.cos(a)];
  }
  const pt = (az, el) => xy(az, el).map((v) => v.toFixed(1)).join(",");

  function place(id, az, el) {
    const g = $(id);
    if (az === null || az === undefined) { g.setAttribute("hidden", ""); return; }
    const [x, y] = xy(az, el === null || el === undefined ? 0 : el);
    g.setAttribute("transform", `translate(${x.toFixed(1)},${y.toFixed(1)})`);
    g.removeAttribute("hidden");
  }

  function drawSky(st) {
    const path = (st.current_pass && st.current_pass.path) || [];
    $("sky-path").setAttribute("points", path.map(([az, el]) => pt(az, el)).join(" "));
    if (path.length) {
      const [x, y] = xy(path[0][0], path[0][1]);
      $("sky-aos").setAttribute("cx", x.toFixed(1));
      $("sky-aos").setAttribute("cy", y.toFixed(1));
      $("sky-aos").removeAttribute("hidden");
    } else {
      $("sky-aos").setAttribute("hidden", "");
    }
    drawMask((st.station && st.station.mask) || []);
    const t = st.target, a = st.antenna;
    place("sky-target", t ? t.az_deg : null, t ? t.el_deg : null);
    place("sky-antenna", a ? a.az_deg : null, a ? a.el_deg : null);
    const words = [];
    if (t) words.push(`Target ${t.name} at azimuth ${num(t.az_deg)}, elevation ${num(t.el_deg)}.`);
    if (a) words.push(`Antenna at azimuth ${num(a.az_deg)}, elevation ${num(a.el_deg)}.`);
    if (path.length) words.push(`Pass path of ${path.length} points.`);
    setText("sky-desc", words.join(" ") || "Nothing to show.");
  }

  // The horizon mask: [[az, el], ...], linear between points and around through north
  // (as the station reads it), drawn every 2 deg between the rim and the mask's elevation.
  let maskKey = null;
  function drawMask(mask) {
    const key = JSON.stringify(mask);
    if (key === maskKey) return;
    maskKey = key;
    const pts = [...mask].sort((p, q) => p[0] - q[0]);
    if (!pts.length) { $("sky-mask").setAttribute("points", ""); return; }
    const elAt = (az) => {
      for (let i = 0; i < pts.length; i++) {
        const [a0, e0] = pts[(i + pts.length - 1) % pts.length], [a1, e1] = pts[i];
        const lo = i === 0 ? a0 - 360 : a0;
        if (az <= a1 && az >= lo) return a1 === lo ? e1 : e0 + ((e1 - e0) * (az - lo)) / (a1 - lo);
      }
      const [a0, e0] = pts[pts.length - 1], [a1, e1] = pts[0];
      return e0 + ((e1 - e0) * (az - a0)) / (a1 + 360 - a0);
    };
    const inner = [], rim = [];
    for (let az = 0; az <= 360; az += 2) {
      inner.push(pt(az, elAt(az % 360)));
      rim.push(pt(az, 0));
    }
    $("sky-mask").setAttribute("points", inner.concat(rim.reverse()).join(" "));
  }

  function describePass(p) {
    if (!p) return null;
    return `${p.target}: AOS ${dayHm(p.aos_utc)}, LOS ${hms(p.los_utc)}, ` +
      `max el ${num(p.max_el_deg)}°, ${p.mode || "mode not chosen"}`;
  }

  function showStatus(st) {
    nowMs = ms(st.now_utc);
    $("sim-banner").hidden = !st.simulated;
    document.title = `${st.simulated ? "SIMULATION - " : ""}${st.state} - ` +
      `${(st.station && st.station.name) || "station"}`;
    setText("station-name", (st.station && st.station.name) || "Station");
    const state = $("state");
    setText("state", st.state.replace("_", " "));
    state.className = `state state-${st.state}`;
    setText("detail", st.detail || "");
    setText("now", hms(st.now_utc));
    setText("started", st.started_utc ? st.started_utc.replace("T", " ") : "-");

    const t = st.target, a = st.antenna;
    setText("tgt-name", t ? t.name : "none");
    setText("tgt-az", num(t && t.az_deg));
    setText("tgt-el", num(t && t.el_deg));
    setText("ant-az", num(a && a.az_deg));
    setText("ant-el", num(a && a.el_deg));
    setText("ant-age", a && a.utc ? `read ${hms(a.utc)}` : "");
    setText("err", num(t && t.error_deg));
    drawSky(st);

    setText("current-pass", describePass(st.current_pass) || "none");
    const np = st.next_pass;
    setText("next-pass", np ? `${describePass(np)} (in ${duration((ms(np.aos_utc) - nowMs) / 1000)})`
      : "none planned");
    const c = st.counts || {};
    setText("counts", `${c.scheduled ?? 0} scheduled, ${c.tracked ?? 0} tracked, ` +
      `${c.skipped ?? 0} skipped, ${c.failed ?? 0} failed`);
    const s = st.station || {}, r = st.rotator || {};
    setText("station", s.name ? `${s.name} (${num(s.lat_deg, 4)}°, ${num(s.lon_deg, 4)}°, ` +
      `${num(s.alt_m, 0)} m)` : "-");
    setText("rotator", r.name ? `${r.name} on ${r.protocol || "?"} at ${r.port || "?"}` : "-");
    setText("limits", r.az_max_deg !== undefined ? `az ${num(r.az_min_deg, 0)}..` +
      `${num(r.az_max_deg, 0)}°, el up to ${num(r.el_max_deg, 0)}°` : "-");
    const cp = st.control_port;
    setText("control-port", cp ? `${cp.listen}; owner: ${cp.owner}; ` +
      `${cp.clients} client${cp.clients === 1 ? "" : "s"}` : "off");

    fillRows("elements-table", st.elements || [], (e) => [
      e.source, e.count, e.age_h === null || e.age_h === undefined ? "-" : `${num(e.age_h)} h`,
      dayHm(e.checked_utc), e.note || ""]);
    const faults = $("faults");
    const items = (st.faults || []).slice().reverse()
      .map((f) => `${f.utc.replace("T", " ")}  ${f.text}`);
    if (faults.dataset.key !== items.join("\n")) {
      faults.dataset.key = items.join("\n");
      faults.replaceChildren(...items.map((s) => {
        const li = document.createElement("li");
        li.textContent = s;
        return li;
      }));
    }
    $("no-faults").hidden = items.length > 0;
    drawTimeline();
  }

  function fillRows(tableId, rows, cells, bad) {
    const body = $(tableId).tBodies[0];
    const key = JSON.stringify(rows);
    if (body.dataset.key === key) return;
    body.dataset.key = key;
    body.replaceChildren(...rows.map((row) => {
      const tr = document.createElement("tr");
      cells(row).forEach((v, i) => {
        const td = document.createElement("td");
        td.textContent = v === null || v === undefined ? "-" : String(v);
        if (bad && bad(row, i)) td.className = "bad";
        tr.appendChild(td);
      });
      return tr;
    }));
  }

  function drawTimeline() {
    if (nowMs === null) return;
    const t0 = nowMs - WINDOW_BEFORE_H * 3600e3, t1 = nowMs + WINDOW_AFTER_H * 3600e3;
    const pct = (t) => `${(((t - t0) / (t1 - t0)) * 100).toFixed(3)}%`;
    const inWindow = schedule.filter((p) => ms(p.los_utc) >= t0 && ms(p.aos_utc) <= t1);
    const bars = inWindow.map((p) => {
      const b = document.createElement("div");
      b.className = `bar st-${p.state}`;
      const a = Math.max(ms(p.aos_utc), t0), l = Math.min(ms(p.los_utc), t1);
      b.style.left = pct(a);
      b.style.width = `${(((l - a) / (t1 - t0)) * 100).toFixed(3)}%`;
      b.title = `${p.target} ${hms(p.aos_utc)}-${hms(p.los_utc)} ${p.state}`;
      return b;
    });
    const barsKey = JSON.stringify([t0 - (t0 % 60000), inWindow]);
    const holder = $("timeline-bars");
    if (holder.dataset.key !== barsKey) {
      holder.dataset.key = barsKey;
      holder.replaceChildren(...bars);
      const ticks = [];
      const first = Math.ceil(t0 / 10800e3) * 10800e3;      // every 3 h, on the UTC hour
      for (let t = first; t < t1; t += 10800e3) {
        const d = document.createElement("div");
        d.className = "tick";
        d.style.left = pct(t);
        d.textContent = new Date(t).toISOString().slice(11, 16);
        ticks.push(d);
      }
      $("timeline-ticks").replaceChildren(...ticks);
    }
    $("timeline-now").style.left = pct(nowMs);
    fillRows("schedule-table", inWindow.filter((p) => ms(p.aos_utc) >= nowMs - 3600e3 ||
      p.state === "tracking"), (p) => [p.target, dayHm(p.aos_utc), hms(p.los_utc),
      `${num(p.max_el_deg)}°`, p.mode, p.state, p.reason || ""]);
  }

  function showPasses(passes) {
    fillRows("passes-table", passes.slice().reverse(), (p) => [
      `${p.target} ${dayHm(p.aos_utc)}${p.mode ? ` (${p.mode})` : ""}`,
      p.reason ? `${p.outcome}: ${p.reason}` : p.outcome,
      num(p.predicted_max_error_deg), num(p.measured_max_error_deg), p.commands],
    (p, i) => (i === 1 && p.outcome === "failed") ||
      (i === 3 && p.measured_max_error_deg > (p.predicted_max_error_deg ?? Infinity) + 5));
  }

  async function getJson(path) {
    const r = await fetch(path, { cache: "no-store" });
    if (!r.ok && r.status !== 503) throw new Error(`${path}: HTTP ${r.status}`);
    return r.json();
  }

  function connected(ok) {
    if (ok) {
      lastOk = new Date();
      setText("conn", "live");
    } else {
      setText("conn", lastOk ? `no answer from the station since ` +
        `${lastOk.toISOString().slice(11, 19)} UTC (browser clock)` : "no answer from the station");
    }
    document.body.classList.toggle("stale", !ok);
  }

  async function pollStatus() {
    try {
      showStatus(await getJson("/api/status"));
      connected(true);
    } catch (e) {
      connected(false);
    }
    setTimeout(pollStatus, STATUS_EVERY_MS);
  }

  async function pollLists() {
    try {
      const [sch, passes] = await Promise.all([getJson("/api/schedule"), getJson("/api/passes")]);
      schedule = sch;
      drawTimeline();
      showPasses(passes);
    } catch (e) {
      connected(false);
    }
    setTimeout(pollLists, LISTS_EVERY_MS);
  }

  pollLists();
  pollStatus();
})();
