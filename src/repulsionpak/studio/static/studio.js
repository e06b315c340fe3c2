// repulsionpak studio: the inputs, settings, brush, history and exports around the live
// view's page (app.js draws the stage, drags, pins over the WebSocket and shows the status).
// Routes: see src/repulsionpak/studio/server.py.
"use strict";
(function () {
  const NS = "http://www.w3.org/2000/svg";
  const token = new URLSearchParams(location.search).get("token") || "";
  const q = (s) => document.querySelector(s);
  const stage = q("#stage"), regionLayer = q("#region-layer"), brushLayer = q("#brush-layer");
  const withToken = (path) => path + (path.includes("?") ? "&" : "?") + "token=" + encodeURIComponent(token);
  let shownLists = null, shownField = null;
  window.repulsionpak.fieldOwner = true;  // the field is the document's guides' (drawn by render)
  let state = null, mode = null, stroke = null, drag = null, lastPhase = null, busy = 0;
  const SETTINGS = ["gap", "count", "seed", "stiffness"];

  for (const k of ["svg", "pdf", "png"]) q("#export-" + k).setAttribute("href", withToken("/export." + k));
  q("#save-project").setAttribute("href", withToken("/project.zip"));

  function showError(msg) { q("#setting-error").textContent = msg || ""; }

  // refresh: a state poll, which leaves the last edit's error message in place. A poll's
  // answer is shown only when no edit was on its way while the poll was: the server may
  // have answered it before the edit, and its answer, arriving after the edit's (a busy
  // machine), would put the page back to the document before the edit. A poll left unshown
  // is made again at the status check's next tick (what changed since the edit's answer,
  // a run that finished, still shows)
  let edits = 0, editsOut = 0;  // edits sent so far; edits awaiting their answer
  async function call(path, opts, refresh) {
    busy++;
    const sent = edits, quiet = editsOut === 0;
    if (!refresh) { edits++; editsOut++; }
    try {
      const r = await fetch(withToken(path), opts);
      const text = await r.text();
      let body = null;
      try { body = JSON.parse(text); } catch (e) { body = { error: text }; }
      if (refresh && !(quiet && editsOut === 0 && edits === sent)) {  // an edit's answer is newer
        lastPhase = null;
        return body;
      }
      if (!r.ok) { showError(body.error || ("error " + r.status)); render(state, true); return null; }
      if (!refresh) showError("");
      render(body);
      return body;
    } finally { busy--; if (!refresh) editsOut--; }
  }
  const post = (path, obj) => call(path, { method: "POST", headers: { "Content-Type": "application/json" },
                                           body: JSON.stringify(obj) });
  const edit = (obj) => post("/edit", obj);
  async function upload(path, files) {
    const fd = new FormData();
    for (const f of files) fd.append("file", f, f.relPath || f.webkitRelativePath || f.name);
    return call(path, { method: "POST", body: fd });
  }

  // -- the document ---------------------------------------------------------------------
  function render(s, force) {
    if (!s) return;
    state = s;
    window.repulsionpakStudio.state = s;
    q("#container-name").textContent = s.container ? s.container + (s.painted ? " + painted" : "")
      : (s.painted ? "painted" : "none: paint one with the brush");
    // the lists are rebuilt only when they changed (a field being typed in keeps its focus),
    // or to show the document again after a refused value (force)
    const listsKey = JSON.stringify([s.elements, s.weights, s.own, s.secondary, !!(s.guides && s.guides.length)]);
    for (const [field, sel] of (listsKey === shownLists && !force) ? [] : [["elements", "#element-list"], ["secondary", "#secondary-list"]]) {
      const ul = q(sel);
      ul.innerHTML = "";
      s[field].forEach((name, i) => {
        const li = document.createElement("li");
        const label = document.createElement("span");
        label.textContent = name; li.appendChild(label);
        if (field === "elements") {  // the element's weight (relative frequency of its copies)
          const w = document.createElement("input");
          w.type = "number"; w.min = "0"; w.step = "any"; w.className = "weight"; w.title = "weight of " + name;
          w.value = String(s.weights[i]);
          w.addEventListener("change", () => edit({ op: "weight", index: i, value: w.value }));
          li.appendChild(w);
        }
        const b = document.createElement("button");
        b.textContent = "×"; b.title = "remove " + name;
        b.addEventListener("click", () => edit({ op: "remove-element", index: i, secondary: field === "secondary" }));
        li.appendChild(b);
        if (field === "elements") {
          const own = (s.own && s.own[i]) || {};
          li.appendChild(ownControls(name, i, own));
          if ((s.guides && s.guides.length) || "flow" in own || "axis" in own || "flow_bend" in own)
            li.appendChild(ownFlowControls(name, i, own));
        }
        ul.appendChild(li);
      });
    }
    shownLists = listsKey;
    q("#secondary-hint").classList.toggle("hidden", s.secondary.length > 0);
    const st = s.settings;
    for (const k of SETTINGS) {
      const el = q("#" + k);
      if (document.activeElement !== el) el.value = st[k] === null ? "" : String(st[k]);
    }
    const [rot, ang] = String(st.rotation).split(":");
    if (document.activeElement !== q("#rotation")) q("#rotation").value = rot;
    if (document.activeElement !== q("#rotation-angle")) q("#rotation-angle").value = ang === undefined ? "" : ang;
    q("#rigid").checked = !!st.rigid;
    q("#pocket-fill").checked = !!st.pocket_fill;
    q("#command").textContent = s.command || "(open a container and elements)";
    q("#undo").disabled = !s.history.can_undo;
    q("#redo").disabled = !s.history.can_redo;
    q("#undo").title = s.history.undo_label ? "Undo " + s.history.undo_label : "Undo";
    q("#redo").title = s.history.redo_label ? "Redo " + s.history.redo_label : "Redo";
    let d = "";
    for (const ring of s.region) d += "M" + ring.map((p) => p[0] + " " + p[1]).join("L") + "Z";
    regionLayer.innerHTML = "";
    if (d) {
      const p = document.createElementNS(NS, "path");
      p.setAttribute("d", d); p.setAttribute("fill-rule", "evenodd");
      regionLayer.appendChild(p);
    }
    stage.setAttribute("viewBox", s.view_box.join(" "));
    // the flow guides (arrowheads: the direction of travel) and the field's arrows
    const gl = q("#guide-layer");
    gl.innerHTML = "";
    for (const g of s.guides || []) {
      const p = document.createElementNS(NS, "path");
      p.setAttribute("d", "M" + g.map((pt) => pt[0] + " " + pt[1]).join("L"));
      gl.appendChild(p);
    }
    if (s.field !== shownField) { window.repulsionpak.drawField(s.field || ""); shownField = s.field; }
    q("#clear-guides").disabled = !(s.guides && s.guides.length);
    if (s.error) q("#message").textContent = "Failed: " + s.error;
  }
  window.repulsionpakStudio = { state: null, get busy() { return busy; } };

  // an element's own settings (empty: the run's): rotation with its angle, rigid, stiffness
  function ownControls(name, i, own) {
    const box = document.createElement("div");
    box.className = "own";
    const [rot, ang] = own.rotation ? String(own.rotation).split(":") : ["", undefined];
    const r = document.createElement("select");
    r.className = "own-rotation"; r.title = "rotation of " + name;
    for (const [v, t] of [["", "rot.: run's"], ["free", "free"], ["fixed", "fixed"], ["limited", "limited"], ["upright", "upright"]]) {
      const o = document.createElement("option"); o.value = v; o.textContent = t; r.appendChild(o);
    }
    r.value = rot;
    const a = document.createElement("input");
    a.type = "number"; a.step = "any"; a.className = "own-angle"; a.placeholder = "°";
    a.title = "fixed: the angle; limited, upright: degrees either side"; a.value = ang === undefined ? "" : ang;
    const sendRot = () => {
      const v = r.value, d = a.value.trim();
      edit({ op: "element", index: i, key: "rotation", value: v && d && v !== "free" ? v + ":" + d : v });
    };
    r.addEventListener("change", sendRot); a.addEventListener("change", sendRot);
    const g = document.createElement("select");
    g.className = "own-rigid"; g.title = "rigid " + name;
    for (const [v, t] of [["", "rigid: run's"], ["true", "rigid"], ["false", "deformable"]]) {
      const o = document.createElement("option"); o.value = v; o.textContent = t; g.appendChild(o);
    }
    g.value = own.rigid === undefined ? "" : String(own.rigid);
    g.addEventListener("change", () => edit({ op: "element", index: i, key: "rigid", value: g.value }));
    const k = document.createElement("input");
    k.type = "number"; k.step = "any"; k.min = "0"; k.className = "own-stiffness"; k.placeholder = "k";
    k.title = "stiffness of " + name + " (empty: the run's)";
    k.value = own.stiffness === undefined ? "" : String(own.stiffness);
    k.addEventListener("change", () => edit({ op: "element", index: i, key: "stiffness", value: k.value }));
    box.append(r, a, g, k);
    return box;
  }
  // an element's own flow keys (shown with flow guides): follow or ignore the field, its
  // axis (degrees in its source's frame; empty: its principal axis), bending along it
  function ownFlowControls(name, i, own) {
    const box = document.createElement("div");
    box.className = "own own-flow-row";
    const f = document.createElement("select");
    f.className = "own-flow"; f.title = "how " + name + " follows the flow";
    for (const [v, t] of [["", "flow: follows"], ["align", "follows"], ["ignore", "ignores"]]) {
      const o = document.createElement("option"); o.value = v; o.textContent = t; f.appendChild(o);
    }
    f.value = own.flow || "";
    f.addEventListener("change", () => edit({ op: "element", index: i, key: "flow", value: f.value }));
    const ax = document.createElement("input");
    ax.type = "number"; ax.step = "any"; ax.className = "own-axis"; ax.placeholder = "axis";
    ax.title = "axis of " + name + ": degrees clockwise in its file, pointing along the flow (empty: its principal axis)";
    ax.value = own.axis === undefined ? "" : String(own.axis);
    ax.addEventListener("change", () => edit({ op: "element", index: i, key: "axis", value: ax.value }));
    const bl = document.createElement("label");
    bl.className = "check"; bl.title = "bend " + name + " along the streamline";
    const b = document.createElement("input");
    b.type = "checkbox"; b.className = "own-bend"; b.checked = !!own.flow_bend;
    b.addEventListener("change", () => edit({ op: "element", index: i, key: "flow_bend", value: b.checked ? true : "" }));
    bl.append(b, " bend");
    box.append(f, ax, bl);
    return box;
  }

  // -- inputs ----------------------------------------------------------------------------
  q("#open-container").addEventListener("change", (ev) => {
    if (ev.target.files.length) upload("/open-container", ev.target.files);
    ev.target.value = "";
  });
  q("#open-elements").addEventListener("change", (ev) => {
    if (ev.target.files.length) upload("/open-elements", ev.target.files);
    ev.target.value = "";
  });
  q("#open-folder").addEventListener("change", (ev) => {
    if (ev.target.files.length) upload("/open-elements", ev.target.files);
    ev.target.value = "";
  });
  q("#open-secondary").addEventListener("change", (ev) => {
    if (ev.target.files.length) upload("/open-secondary", ev.target.files);
    ev.target.value = "";
  });
  q("#open-project").addEventListener("change", (ev) => {
    if (ev.target.files.length) upload("/open-project", ev.target.files);
    ev.target.value = "";
  });
  // files dropped on the page: a zip is a project; an SVG dropped on the container's section
  // opens the container; anywhere else, SVGs are added as elements
  document.addEventListener("dragover", (ev) => { ev.preventDefault(); });
  // a dropped folder: its files with their paths relative to the folder's parent
  async function entryFiles(entry, prefix, out) {
    if (entry.isFile) {
      const f = await new Promise((ok, bad) => entry.file(ok, bad));
      f.relPath = prefix + f.name; out.push(f);
    } else if (entry.isDirectory) {
      const reader = entry.createReader();
      for (;;) {
        const batch = await new Promise((ok, bad) => reader.readEntries(ok, bad));
        if (!batch.length) break;
        for (const e of batch) await entryFiles(e, prefix + entry.name + "/", out);
      }
    }
  }
  document.addEventListener("drop", async (ev) => {
    ev.preventDefault();
    const entries = Array.from(ev.dataTransfer.items || []).map((it) => it.webkitGetAsEntry && it.webkitGetAsEntry())
      .filter((e) => e);
    if (entries.some((e) => e.isDirectory)) {
      const tree = [];
      for (const e of entries) await entryFiles(e, "", tree);
      await upload("/open-elements", tree);
      return;
    }
    const files = Array.from(ev.dataTransfer.files || []);
    const zips = files.filter((f) => /\.zip$/i.test(f.name)), svgs = files.filter((f) => /\.(svg|path)$/i.test(f.name));
    if (zips.length) { await upload("/open-project", zips.slice(0, 1)); return; }
    if (files.some((f) => /\.toml$/i.test(f.name))) { await upload("/open-elements", files); return; }
    if (!svgs.length) { showError("drop SVG or .path files, a folder, a manifest (.toml) with its files, or a saved project (.zip)"); return; }
    const onContainer = ev.target.closest && ev.target.closest("#panel section") === q("#open-container").closest("section");
    if (onContainer) {
      await upload("/open-container", svgs.slice(0, 1));
      svgs.shift();
    }
    if (svgs.length) await upload("/open-elements", svgs);
  });
  q("#example-container").addEventListener("change", (ev) => {
    if (ev.target.value) edit({ op: "examples", container: ev.target.value });
    ev.target.value = "";
  });
  q("#example-elements").addEventListener("click", () => edit({ op: "examples", elements: [] }));
  fetch(withToken("/examples")).then((r) => r.json()).then((ex) => {
    for (const name of ex.containers) {
      const o = document.createElement("option"); o.value = name; o.textContent = name;
      q("#example-container").appendChild(o);
    }
  });

  // -- settings --------------------------------------------------------------------------
  for (const k of SETTINGS) q("#" + k).addEventListener("change", (ev) => edit({ op: "setting", name: k, value: ev.target.value }));
  function sendRotation() {
    const r = q("#rotation").value, a = q("#rotation-angle").value.trim();
    edit({ op: "setting", name: "rotation", value: a && r !== "free" ? r + ":" + a : r });
  }
  q("#rotation").addEventListener("change", sendRotation);
  q("#rotation-angle").addEventListener("change", sendRotation);
  q("#rigid").addEventListener("change", (ev) => edit({ op: "setting", name: "rigid", value: ev.target.checked }));
  q("#pocket-fill").addEventListener("change", (ev) => edit({ op: "setting", name: "pocket_fill", value: ev.target.checked }));

  // -- run -------------------------------------------------------------------------------
  q("#start").addEventListener("click", () => post("/run", { action: "start" }));
  q("#restart").addEventListener("click", () => post("/run", { action: "restart" }));
  q("#undo").addEventListener("click", () => edit({ op: "undo" }));
  q("#redo").addEventListener("click", () => edit({ op: "redo" }));

  // added copies, pins and removals go through the history (undoable): taken before app.js
  // sends them itself
  window.repulsionpak.onAdd = (i, x, y) => edit({ op: "add", index: i, x, y });
  q("#pin").addEventListener("click", (ev) => {
    ev.stopImmediatePropagation();
    const g = stage.querySelector(".element.selected");
    if (!g) return;
    edit({ op: "pin", index: Number(g.dataset.index), pinned: g.dataset.pinned !== "true" });
  }, true);
  q("#remove").addEventListener("click", (ev) => {
    ev.stopImmediatePropagation();
    const g = stage.querySelector(".element.selected");
    if (g) edit({ op: "remove", index: Number(g.dataset.index) });
  }, true);

  // -- brush -----------------------------------------------------------------------------
  function setMode(m) {
    mode = mode === m ? null : m;
    q("#brush").classList.toggle("on", mode === "paint");
    q("#eraser").classList.toggle("on", mode === "erase");
    q("#guide").classList.toggle("on", mode === "guide");
    stage.classList.toggle("painting", mode !== null);
    if (!mode) cursor(null);
  }
  q("#brush").addEventListener("click", () => setMode("paint"));
  q("#eraser").addEventListener("click", () => setMode("erase"));
  q("#guide").addEventListener("click", () => setMode("guide"));
  q("#clear-guides").addEventListener("click", () => edit({ op: "clear-guides" }));
  function svgPoint(ev) {
    const p = stage.createSVGPoint(); p.x = ev.clientX; p.y = ev.clientY;
    return p.matrixTransform(stage.getScreenCTM().inverse());
  }
  function radius() {  // the slider is the brush's diameter in screen pixels
    const m = stage.getScreenCTM();
    return Number(q("#brush-size").value) / 2 / Math.hypot(m.a, m.b);
  }
  function cursor(p) {
    let c = brushLayer.querySelector(".cursor");
    if (!p) { if (c) c.remove(); return; }
    if (!c) { c = document.createElementNS(NS, "circle"); c.setAttribute("class", "cursor"); brushLayer.appendChild(c); }
    c.setAttribute("cx", p.x); c.setAttribute("cy", p.y); c.setAttribute("r", radius());
  }
  const body = q("#body");
  // capture phase on an ancestor: while painting, app.js never sees the pointer
  body.addEventListener("pointerdown", (ev) => {
    if (!mode || !stage.contains(ev.target)) {
      const g = ev.target.closest ? ev.target.closest(".element") : null;
      if (g && stage.contains(g) && !mode) drag = { index: Number(g.dataset.index), start: svgPoint(ev), end: null };
      return;
    }
    ev.stopPropagation(); ev.preventDefault();
    const p = svgPoint(ev), r = radius();
    const path = document.createElementNS(NS, "path");
    path.setAttribute("class", "stroke " + mode);
    if (mode !== "guide") path.setAttribute("stroke-width", 2 * r);
    brushLayer.appendChild(path);
    stroke = { mode, radius: r, points: [[p.x, p.y]], path };
    drawStroke();
    stage.setPointerCapture(ev.pointerId);
  }, true);
  function drawStroke() {
    const pts = stroke.points;
    stroke.path.setAttribute("d", "M" + pts.map((p) => p[0].toFixed(2) + " " + p[1].toFixed(2)).join("L") +
      (pts.length === 1 && stroke.mode !== "guide" ? "l0.01 0" : ""));
  }
  body.addEventListener("pointermove", (ev) => {
    if (mode) cursor(mode === "guide" ? null : svgPoint(ev));
    if (drag) drag.end = svgPoint(ev);
    if (!stroke) return;
    ev.stopPropagation();
    const p = svgPoint(ev), last = stroke.points[stroke.points.length - 1];
    if (Math.hypot(p.x - last[0], p.y - last[1]) < stroke.radius * 0.2) return;
    stroke.points.push([p.x, p.y]);
    drawStroke();
  }, true);
  async function endStroke(ev) {
    if (drag) {
      const d = drag; drag = null;
      if (d.end && (d.end.x !== d.start.x || d.end.y !== d.start.y))
        edit({ op: "moved", index: d.index, dx: d.end.x - d.start.x, dy: d.end.y - d.start.y });
    }
    if (!stroke) return;
    ev.stopPropagation();
    const s = stroke; stroke = null;
    if (s.mode === "guide") {
      if (s.points.length > 1) await edit({ op: "guide", guide: { points: s.points } });
    } else {
      await edit({ op: "stroke", stroke: { mode: s.mode, radius: s.radius, points: s.points } });
    }
    s.path.remove();
  }
  body.addEventListener("pointerup", endStroke, true);
  body.addEventListener("pointercancel", endStroke, true);
  stage.addEventListener("pointerleave", () => cursor(null));

  document.addEventListener("keydown", (ev) => {
    if (ev.target.tagName === "INPUT" || ev.target.tagName === "SELECT") return;
    if ((ev.ctrlKey || ev.metaKey) && ev.key.toLowerCase() === "z") {
      ev.preventDefault(); edit({ op: ev.shiftKey ? "redo" : "undo" });
    } else if (ev.key === "b") setMode("paint");
    else if (ev.key === "g") setMode("guide");
    else if (ev.key === "e") setMode("erase");
  });

  // -- the run's status, as app.js receives it ---------------------------------------------
  setInterval(() => {
    const st = (window.repulsionpak && window.repulsionpak.status) || {};
    const key = st.phase + "/" + !!st.done + "/" + !!st.paused;
    if (key === lastPhase) return;
    lastPhase = key;
    if (st.done) {
      q("#message").textContent = (st.converged ? "Converged" : "Finished") +
        ": export it, or change something and Start again.";
    } else if (st.phase && st.phase !== "idle") {
      ["#pause", "#step"].forEach((s) => { q(s).disabled = false; });
    }
    if (st.phase === "failed") q("#message").textContent = "Failed";
    call("/state", undefined, true);
  }, 250);
  call("/state", undefined, true);
})();
