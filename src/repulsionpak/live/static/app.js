// repulsionpak live view: draws the frames streamed over /ws and sends the user's commands.
// Wire format: see src/repulsionpak/live/protocol.py.
"use strict";
(function () {
  const NS = "http://www.w3.org/2000/svg";
  const token = new URLSearchParams(location.search).get("token") || "";
  const q = (s) => document.querySelector(s);
  const stage = q("#stage"), elemLayer = q("#elements-layer"), contLayer = q("#container-layer");
  const svgUrl = "/packing.svg?token=" + encodeURIComponent(token);
  q("#download-svg").setAttribute("href", svgUrl);

  let ws = null, layout = null, starts = [], groups = [], status = {}, selected = -1;
  let lastFrame = null, drag = null, frames = 0, received = 0, adding = false;
  // frames: drawn into #stage; received: arrived over the WebSocket (some are never drawn
  // when they come faster than the page paints); drawMs: time spent writing the paths
  window.repulsionpak = { get frames() { return frames; }, get received() { return received; },
                          get drawMs() { return drawMs; }, get layout() { return layout; },
                          get status() { return status; },
                          onAdd: null, drawField, fieldOwner: false };  // a page around this one may take the add-copy clicks

  // the elements' outline is one screen pixel wide: --px (user units per pixel) follows
  // the stage's size and view box
  function updatePx() {
    const m = stage.getScreenCTM();
    if (m && m.a > 0) elemLayer.style.setProperty("--px", (1 / m.a) + "px");
  }
  new ResizeObserver(updatePx).observe(stage);
  new MutationObserver(updatePx).observe(stage, { attributes: true, attributeFilter: ["viewBox"] });

  function send(cmd) { if (ws && ws.readyState === 1) ws.send(JSON.stringify(cmd)); }
  function colour(t) { return "hsl(" + ((t * 137.5) % 360).toFixed(1) + " 55% 68%)"; }
  function fmt(x, d) { return (x === null || x === undefined) ? "–" : Number(x).toFixed(d); }

  // the flow field's arrows (one path, container units) over the elements; #show-field
  // toggles the layer
  function drawField(d) {
    const layer = q("#field-layer"), toggle = q("#field-toggle");
    if (!layer) return;
    layer.innerHTML = "";
    if (toggle) toggle.classList.toggle("hidden", !d);
    if (!d) return;
    const p = document.createElementNS(NS, "path");
    p.setAttribute("d", d); p.setAttribute("class", "field");
    layer.appendChild(p);
  }
  const showField = q("#show-field");
  if (showField) showField.addEventListener("change", () => {
    q("#field-layer").classList.toggle("hidden", !showField.checked);
  });

  function onScene(m) {
    if (!window.repulsionpak.fieldOwner) drawField(m.field || "");  // (the studio draws its own)
    stage.setAttribute("viewBox", m.viewBox.join(" "));
    let d = "";
    for (const ring of m.rings) d += "M" + ring.map((p) => p[0] + " " + p[1]).join("L") + "Z";
    contLayer.innerHTML = "";
    // the container as the outputs draw it (--container-paint): the page's own outline
    // never hides the elements; "as-drawn" shows the container's own markup under them
    if (m.paint === "as-drawn" && m.markup) {
      const doc = new DOMParser().parseFromString(
        '<svg xmlns="http://www.w3.org/2000/svg">' + m.markup + "</svg>", "image/svg+xml");
      for (const c of Array.from(doc.documentElement.childNodes)) contLayer.appendChild(document.importNode(c, true));
    } else if (m.paint !== "none") {
      const p = document.createElementNS(NS, "path");
      p.setAttribute("d", d); p.setAttribute("fill-rule", "evenodd"); p.setAttribute("class", "outline");
      p.setAttribute("fill", "none"); p.setAttribute("stroke", m.colour || "#2d3142");
      contLayer.appendChild(p);
    }
  }

  function onLayout(m) {
    const same = layout && layout.id === m.id;
    layout = m;
    if (!same) {
      elemLayer.innerHTML = ""; groups = []; starts = []; let s = 0;
      m.counts.forEach((n, i) => {
        const g = document.createElementNS(NS, "g");
        g.setAttribute("class", "element " + m.kinds[i]);
        g.dataset.index = String(i);
        const p = document.createElementNS(NS, "path");
        p.setAttribute("fill", colour(m.template[i]));
        g.appendChild(p); elemLayer.appendChild(g); groups.push(g); starts.push(s); s += n;
      });
      drawn = [];
      if (selected >= groups.length) selected = -1;
      if (lastFrame && lastFrame.layout === m.id) draw(lastFrame);
    }
    const pinned = new Set(m.pinned || []), removed = new Set(m.removed || []);
    groups.forEach((g, i) => {
      g.classList.toggle("pinned", pinned.has(i));
      g.classList.toggle("removed", removed.has(i));
      g.classList.toggle("frozen", !!m.frozen[i]);
      g.dataset.pinned = pinned.has(i) ? "true" : "false";
    });
    if (removed.has(selected)) select(-1); else select(selected);
  }

  function onStatus(m) {
    status = m;
    q("#iteration").textContent = String(m.iteration);
    q("#phase").textContent = m.phase;
    const est = m.estimated ? " (est.)" : "";
    if (m.area_fraction !== undefined) q("#area-fraction").textContent = fmt(m.area_fraction, 3) + est;
    if (m.median_gap !== undefined) q("#median-gap").textContent = fmt(m.median_gap, 3) + est;
    const pause = q("#pause");
    pause.textContent = m.paused ? "Resume" : "Pause";
    pause.classList.toggle("on", !!m.paused);
    pause.dataset.paused = m.paused ? "true" : "false";
    const msg = q("#message");
    if (m.done) {
      const how = Object.entries(m.stopped_by || {}).map((e) => e[0] + ": " + e[1]).join(", ");
      msg.textContent = (m.converged ? "Converged" : "Finished") + " (" + how +
        "). Press Ctrl-C in the terminal to write the output.";
      msg.classList.add("done");
      setAdding(false);
      ["#pause", "#step", "#pin", "#remove", "#add-copy"].forEach((s) => { q(s).disabled = true; });
    } else {
      msg.textContent = m.paused ? "Paused" : "Running";
    }
  }

  // Drawing: a frame is kept on arrival and drawn at the next animation frame (only the
  // newest; frames that arrive between two paints are never drawn). A path's "d" is written
  // with two decimals through integer arithmetic and a table of the decimals (a quarter of
  // the cost of toFixed), and only when it changed (pinned or frozen elements keep theirs).
  const DEC = [];
  for (let i = 0; i < 100; i++) DEC.push((i < 10 ? ".0" : ".") + i);
  function num(x) {
    let v = Math.round(x * 100);
    if (!(Math.abs(v) < 2e9)) return x.toFixed(2);  // beyond 32-bit integers (and NaN)
    if (v < 0) { v = -v; return "-" + ((v / 100) | 0) + DEC[v % 100]; }
    return ((v / 100) | 0) + DEC[v % 100];
  }
  let drawn = [], drawnLayout = null, pending = null, scheduled = false, drawMs = 0;
  function draw(f) {
    const t0 = performance.now();
    const pts = f.points;
    for (let i = 0; i < groups.length; i++) {
      const n = layout.counts[i];
      if (n < 2) continue;
      let j = 2 * starts[i];
      let d = "M" + num(pts[j]) + " " + num(pts[j + 1]) + "L";
      for (let k = 1; k < n; k++) {
        j += 2;
        d += num(pts[j]) + " " + num(pts[j + 1]) + (k < n - 1 ? " " : "Z");
      }
      if (drawn[i] !== d) { groups[i].firstChild.setAttribute("d", d); drawn[i] = d; }
    }
    frames++;
    drawMs += performance.now() - t0;
  }
  function paint() {
    scheduled = false;
    const f = pending; pending = null;
    if (!f || !layout || f.layout !== layout.id) return;
    drawnLayout = layout.id;
    draw(f);
    if (!status.done) q("#iteration").textContent = String(f.iteration);
  }

  function onFrame(buf) {
    const dv = new DataView(buf);
    const f = { layout: dv.getUint32(4, true), iteration: dv.getUint32(8, true),
                area: dv.getFloat32(12, true), points: new Float32Array(buf, 20, 2 * dv.getUint32(16, true)) };
    lastFrame = f; received++;
    pending = f;
    // the first frame of a new layout is drawn at once: its new groups are never empty
    // longer than between the two messages
    if (layout && f.layout === layout.id && drawnLayout !== layout.id) { drawnLayout = layout.id; paint(); return; }
    if (!scheduled) { scheduled = true; requestAnimationFrame(paint); }
  }

  function connect() {
    const proto = location.protocol === "https:" ? "wss://" : "ws://";
    ws = new WebSocket(proto + location.host + "/ws?token=" + encodeURIComponent(token));
    ws.binaryType = "arraybuffer";
    ws.onopen = () => { q("#message").textContent = "connected"; };
    ws.onmessage = (ev) => {
      if (typeof ev.data !== "string") { onFrame(ev.data); return; }
      const m = JSON.parse(ev.data);
      if (m.type === "scene") onScene(m);
      else if (m.type === "layout") onLayout(m);
      else if (m.type === "status") onStatus(m);
      else if (m.type === "error") { console.warn("repulsionpak:", m.message); q("#selection").textContent = m.message; }
    };
    ws.onclose = () => {
      if (!status.done) q("#message").textContent = "disconnected (the run goes on; reload to reconnect)";
      else q("#message").textContent += " Server closed.";
    };
  }

  function select(i) {
    if (selected >= 0 && groups[selected]) groups[selected].classList.remove("selected");
    selected = i;
    const ok = i >= 0 && groups[i] && !(layout.frozen[i]) && !status.done;
    q("#pin").disabled = !ok; q("#remove").disabled = !ok; q("#add-copy").disabled = !ok;
    if (i >= 0 && groups[i]) {
      groups[i].classList.add("selected");
      const pinned = (layout.pinned || []).includes(i);
      q("#pin").textContent = pinned ? "Unpin" : "Pin";
      q("#selection").textContent = "element " + i + " (" + layout.kinds[i] + (pinned ? ", pinned" : "") +
        (layout.frozen[i] ? ", frozen in this phase" : "") + ")";
    } else {
      q("#pin").textContent = "Pin";
      q("#selection").textContent = "Drag an element to move it; click one to select it.";
    }
  }

  function svgPoint(ev) {
    const p = stage.createSVGPoint(); p.x = ev.clientX; p.y = ev.clientY;
    return p.matrixTransform(stage.getScreenCTM().inverse());
  }

  function setAdding(on) {
    adding = on;
    q("#add-copy").classList.toggle("on", on);
    stage.classList.toggle("adding", on);
    if (on) q("#selection").textContent = "click where the copy of element " + selected + " should grow (Esc cancels)";
    else select(selected);
  }

  stage.addEventListener("pointerdown", (ev) => {
    if (adding) {
      const p = svgPoint(ev);
      if (window.repulsionpak.onAdd) window.repulsionpak.onAdd(selected, p.x, p.y);
      else send({ cmd: "add", index: selected, x: p.x, y: p.y });
      setAdding(false);
      ev.preventDefault();
      return;
    }
    const g = ev.target.closest ? ev.target.closest(".element") : null;
    if (!g) { select(-1); return; }
    const i = Number(g.dataset.index);
    select(i);
    if (status.done || layout.frozen[i]) return;
    const p = svgPoint(ev);
    drag = { index: i, last: p, dx: 0, dy: 0, pending: false };
    g.classList.add("dragging");
    stage.setPointerCapture(ev.pointerId);
    ev.preventDefault();
  });
  function flushDrag() {
    if (!drag) return;
    drag.pending = false;
    if (drag.dx !== 0 || drag.dy !== 0) {
      send({ cmd: "move", index: drag.index, dx: drag.dx, dy: drag.dy });
      drag.dx = 0; drag.dy = 0;
    }
  }
  stage.addEventListener("pointermove", (ev) => {
    if (!drag) return;
    const p = svgPoint(ev);
    drag.dx += p.x - drag.last.x; drag.dy += p.y - drag.last.y; drag.last = p;
    if (!drag.pending) { drag.pending = true; requestAnimationFrame(flushDrag); }
  });
  function endDrag(ev) {
    if (!drag) return;
    flushDrag();
    if (groups[drag.index]) groups[drag.index].classList.remove("dragging");
    drag = null;
  }
  stage.addEventListener("pointerup", endDrag);
  stage.addEventListener("pointercancel", endDrag);

  q("#pause").addEventListener("click", () => send({ cmd: status.paused ? "resume" : "pause" }));
  q("#step").addEventListener("click", () => send({ cmd: "step", n: 1 }));
  q("#pin").addEventListener("click", () => {
    if (selected < 0) return;
    send({ cmd: "pin", index: selected, pinned: !(layout.pinned || []).includes(selected) });
  });
  q("#remove").addEventListener("click", () => { if (selected >= 0) send({ cmd: "remove", index: selected }); });
  q("#add-copy").addEventListener("click", () => { if (selected >= 0) setAdding(!adding); });
  q("#download-png").addEventListener("click", async () => {
    const text = await (await fetch(svgUrl)).text();
    const url = URL.createObjectURL(new Blob([text], { type: "image/svg+xml" }));
    const img = new Image();
    img.onload = () => {
      const k = Math.min(4, 2000 / Math.max(img.naturalWidth, img.naturalHeight));
      const c = document.createElement("canvas");
      c.width = Math.round(img.naturalWidth * k); c.height = Math.round(img.naturalHeight * k);
      const ctx = c.getContext("2d");
      ctx.fillStyle = "#fff"; ctx.fillRect(0, 0, c.width, c.height);
      ctx.drawImage(img, 0, 0, c.width, c.height);
      URL.revokeObjectURL(url);
      c.toBlob((b) => {
        const a = document.createElement("a");
        a.href = URL.createObjectURL(b); a.download = "packing.png";
        document.body.appendChild(a); a.click(); a.remove();
      }, "image/png");
    };
    img.src = url;
  });
  document.addEventListener("keydown", (ev) => {
    if (ev.target.tagName === "INPUT") return;
    if (ev.key === " ") { ev.preventDefault(); q("#pause").click(); }
    else if (ev.key === "s") q("#step").click();
    else if (ev.key === "p" && !q("#pin").disabled) q("#pin").click();
    else if (ev.key === "a" && !q("#add-copy").disabled) q("#add-copy").click();
    else if (ev.key === "Escape" && adding) setAdding(false);
    else if ((ev.key === "Delete" || ev.key === "Backspace") && !q("#remove").disabled) q("#remove").click();
  });
  connect();
})();
