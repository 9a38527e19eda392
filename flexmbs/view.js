// flexmbs interactive view: draws every div of class flexmbs-view on the page from the JSON scene in its
// <script type="application/json"> child (written by flexmbs/view.py; its docstring describes the format).
// Canvas 2D, orthographic; no library, no network: the page works offline.  Drag: turn; shift-drag or
// right-drag: pan; wheel: zoom; double-click: the first view again.
(function () {
  "use strict";
  if (window.flexmbsViewStartAll) { window.flexmbsViewStartAll(); return; }  // the script again: new views only
  window.flexmbsViews = window.flexmbsViews || [];

  function bytes(b64) {
    var text = atob(b64), out = new Uint8Array(text.length);
    for (var i = 0; i < text.length; i++) { out[i] = text.charCodeAt(i); }
    return out;
  }

  function inflate(b64) {  // zlib stream (Python's zlib.compress) → ArrayBuffer, by the browser's own inflater
    var stream = new Blob([bytes(b64)]).stream().pipeThrough(new DecompressionStream("deflate"));
    return new Response(stream).arrayBuffer();
  }

  function coolwarm(u) {  // u in [0, 1] → [r, g, b]: blue (negative) – light grey (zero) – red (positive)
    var lo = [59, 76, 192], mid = [221, 221, 221], hi = [180, 4, 38], a, b, s;
    if (u < 0.5) { a = lo; b = mid; s = u / 0.5; } else { a = mid; b = hi; s = (u - 0.5) / 0.5; }
    return [0, 1, 2].map(function (k) { return Math.round(a[k] + (b[k] - a[k]) * s); });
  }

  var PALETTE = [];  // the 256 levels of a colour channel as CSS colours
  for (var level = 0; level < 256; level++) { PALETTE.push("rgb(" + coolwarm(level / 255).join(",") + ")"); }

  function matmul(a, b) {  // 3×3, row-major arrays of 9
    var c = new Array(9);
    for (var i = 0; i < 3; i++) {
      for (var j = 0; j < 3; j++) {
        c[3 * i + j] = a[3 * i] * b[j] + a[3 * i + 1] * b[3 + j] + a[3 * i + 2] * b[6 + j];
      }
    }
    return c;
  }

  function turn(axis, angle) {  // rotation about a screen axis (0: x, 1: y)
    var c = Math.cos(angle), s = Math.sin(angle);
    return axis === 0 ? [1, 0, 0, 0, c, -s, 0, s, c] : [c, 0, s, 0, 1, 0, -s, 0, c];
  }

  function element(tag, attrs, parent) {
    var e = document.createElement(tag);
    Object.keys(attrs || {}).forEach(function (k) { e.setAttribute(k, attrs[k]); });
    if (parent) { parent.appendChild(e); }
    return e;
  }

  function View(root, scene) {
    this.root = root;
    this.scene = scene;
    this.sequence = 0;
    this.frame = 0;
    this.colour = "";
    this.tubes = true;
    this.axes = true;
    this.playing = false;
    this.drawn = 0;
    this.ready = false;
    this.build();
  }

  View.prototype.build = function () {
    var self = this, s = this.scene, bar;
    this.root.style.position = "relative";
    this.canvas = element("canvas", {"class": "flexmbs-canvas", "tabindex": "0"}, this.root);
    this.canvas.style.cssText = "width:100%;height:" + (s.height || 480) + "px;display:block;background:#fff;" +
      "border:1px solid #ccc;touch-action:none;cursor:grab";
    bar = element("div", {"class": "flexmbs-controls"}, this.root);
    bar.style.cssText = "display:flex;flex-wrap:wrap;gap:.5em;align-items:center;font:13px system-ui,sans-serif;" +
      "margin:.3em 0";
    this.play = element("button", {"type": "button", "title": "play / pause"}, bar);
    this.play.textContent = "▶ play";
    this.slider = element("input", {"type": "range", "min": "0", "value": "0", "step": "1",
                                    "aria-label": "time"}, bar);
    this.slider.style.flex = "1 1 12em";
    this.clock = element("span", {}, bar);
    this.clock.style.cssText = "min-width:9em;font-variant-numeric:tabular-nums";
    this.speed = this.select(bar, "speed", [["0.1", "0.1×"], ["0.25", "0.25×"], ["0.5", "0.5×"], ["1", "1×"],
                                            ["2", "2×"]], "1");
    if (s.sequences.length > 1) {
      this.chooser = this.select(bar, s.kind === "modes" ? "mode" : "sequence",
                                 s.sequences.map(function (q, i) { return [String(i), q.name]; }), "0");
      this.chooser.addEventListener("change", function () { self.setSequence(+self.chooser.value); });
    }
    this.colours = this.select(bar, "colour", [], "");
    this.colours.addEventListener("change", function () { self.setColour(self.colours.value); });
    this.style = this.select(bar, "beams", [["tubes", "tubes"], ["lines", "lines"]], "tubes");
    this.style.addEventListener("change", function () { self.tubes = self.style.value === "tubes"; self.draw(); });
    var label = element("label", {}, bar), box = element("input", {"type": "checkbox", "checked": "checked"}, label);
    label.appendChild(document.createTextNode(" body axes"));
    box.addEventListener("change", function () { self.axes = box.checked; self.draw(); });
    this.play.addEventListener("click", function () { self.toggle(); });
    this.slider.addEventListener("input", function () { self.stop(); self.setFrame(+self.slider.value); });
    this.interact();
    this.home();
    this.setSequence(0);
    new ResizeObserver(function () { self.resize(); }).observe(this.canvas);
    this.resize();
  };

  View.prototype.select = function (parent, name, options, value) {
    var label = element("label", {}, parent), sel;
    label.appendChild(document.createTextNode(name + " "));
    sel = element("select", {"aria-label": name}, label);
    this.fill(sel, options, value);
    return sel;
  };

  View.prototype.fill = function (sel, options, value) {
    sel.innerHTML = "";
    options.forEach(function (o) { var opt = element("option", {"value": o[0]}, sel); opt.textContent = o[1]; });
    sel.value = value;
  };

  View.prototype.home = function () {  // look along the box's thinnest direction, its longest one across
    var lo = this.scene.box[0], hi = this.scene.box[1], ext = [0, 1, 2].map(function (k) { return hi[k] - lo[k]; });
    var order = [0, 1, 2].sort(function (a, b) { return ext[b] - ext[a] || a - b; });
    var a = [0, 0, 0], b = [0, 0, 0];
    a[order[0]] = 1;
    b[order[1]] = 1;
    var n = [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
    this.R = matmul(turn(0, 0.35), matmul(turn(1, -0.3), a.concat(b, n)));
    this.centre = [0, 1, 2].map(function (k) { return 0.5 * (lo[k] + hi[k]); });
    this.diagonal = Math.max(Math.hypot(ext[0], ext[1], ext[2]), 1e-9);
    this.zoom = 1;
    this.pan = [0, 0];
  };

  View.prototype.interact = function () {
    var self = this, last = null, c = this.canvas;
    c.addEventListener("pointerdown", function (e) {
      last = [e.clientX, e.clientY, e.shiftKey || e.button === 2];
      c.setPointerCapture(e.pointerId);
    });
    c.addEventListener("pointermove", function (e) {
      if (!last) { return; }
      var dx = e.clientX - last[0], dy = e.clientY - last[1];
      if (last[2]) { self.pan[0] += dx; self.pan[1] += dy; } else {
        self.R = matmul(turn(0, 0.01 * dy), matmul(turn(1, 0.01 * dx), self.R));
      }
      last = [e.clientX, e.clientY, last[2]];
      self.draw();
    });
    c.addEventListener("pointerup", function () { last = null; });
    c.addEventListener("contextmenu", function (e) { e.preventDefault(); });
    c.addEventListener("wheel", function (e) {
      e.preventDefault();
      self.zoom *= Math.exp(-0.0015 * e.deltaY);
      self.draw();
    }, {passive: false});
    c.addEventListener("dblclick", function () { self.home(); self.draw(); });
  };

  View.prototype.resize = function () {
    var ratio = window.devicePixelRatio || 1, w = this.canvas.clientWidth, h = this.canvas.clientHeight;
    this.canvas.width = Math.max(1, Math.round(w * ratio));
    this.canvas.height = Math.max(1, Math.round(h * ratio));
    this.ratio = ratio;
    this.draw();
  };

  View.prototype.setSequence = function (i, frame) {  // frame: default the sequence's first shown
    var self = this, q = this.scene.sequences[i], k = frame === undefined ? (q.start || 0) : frame;
    this.stop();
    this.sequence = i;
    if (this.chooser) { this.chooser.value = String(i); }
    this.slider.max = String(q.times.length - 1);
    var names = [["", "none"]].concat(Object.keys(q.colours || {}).map(function (k) {
      return [k, q.colours[k].label];
    }));
    this.fill(this.colours, names, q.colours && q.colours[this.colour] ? this.colour : "");
    this.colours.parentNode.style.display = names.length > 1 ? "" : "none";
    this.colour = this.colours.value;
    if (!q.positions16) {
      q.loading = q.loading || this.decode(q);
      q.loading.then(function () { if (self.sequence === i) { self.setFrame(k); } }, function (err) {
        self.fail(err);
      });
    } else {
      this.setFrame(k);
    }
  };

  View.prototype.decode = function (q) {  // positions: uint16 differences between frames; colours: uint8
    var jobs = [inflate(q.positions).then(function (buf) {
      var a = new Uint16Array(buf), n = a.length / q.times.length;
      for (var k = n; k < a.length; k++) { a[k] = a[k] + a[k - n]; }  // wraps modulo 2^16, as written
      q.positions16 = a;
    })];
    Object.keys(q.colours || {}).forEach(function (name) {
      jobs.push(inflate(q.colours[name].data).then(function (buf) { q.colours[name].values = new Uint8Array(buf); }));
    });
    return Promise.all(jobs);
  };

  View.prototype.fail = function (err) {
    var note = element("p", {"class": "flexmbs-error"}, this.root);
    note.textContent = "flexmbs view: the data could not be read (" + err + ")";
    console.error("flexmbs view:", err);
  };

  View.prototype.setColour = function (name) { this.colour = name; this.colours.value = name; this.draw(); };

  View.prototype.setFrame = function (k) {
    var q = this.scene.sequences[this.sequence];
    this.frame = Math.max(0, Math.min(q.times.length - 1, k | 0));
    this.slider.value = String(this.frame);
    this.draw();
  };

  View.prototype.toggle = function () { if (this.playing) { this.stop(); } else { this.start(); } };

  View.prototype.stop = function () { this.playing = false; this.play.textContent = "▶ play"; };

  View.prototype.start = function () {
    var self = this, q = this.scene.sequences[this.sequence], t0 = null, start = q.times[this.frame];
    var span = q.times[q.times.length - 1] - q.times[0], rate = span > 0 ? span / q.duration : 1;
    if (this.frame === q.times.length - 1 && !q.loop) { start = q.times[0]; }
    this.playing = true;
    this.play.textContent = "❚❚ pause";
    function tick(now) {
      if (!self.playing) { return; }
      if (t0 === null) { t0 = now; }
      var t = start + (now - t0) / 1000 * rate * (+self.speed.value), times = q.times, k = self.frame;
      if (t > times[times.length - 1]) {
        if (!q.loop) { self.setFrame(times.length - 1); self.stop(); return; }
        t = times[0] + (t - times[0]) % (span + (times[1] - times[0] || 0));
      }
      while (k + 1 < times.length && times[k + 1] <= t) { k++; }
      while (k > 0 && times[k] > t) { k--; }
      if (k !== self.frame) { self.setFrame(k); }
      requestAnimationFrame(tick);
    }
    requestAnimationFrame(tick);
  };

  View.prototype.draw = function () {
    // a software canvas: it rasterises each frame at once (10,000 thick strokes in milliseconds), where the
    // GPU-backed canvas of a machine without a GPU (headless Chromium's software GL) took seconds a frame
    var s = this.scene, q = s.sequences[this.sequence], c = this.canvas;
    var g = c.getContext("2d", {willReadFrequently: true});
    if (!q || !q.positions16 || !this.R) { return; }
    var W = c.width, H = c.height, r = this.ratio, P = s.points, a = q.positions16, base = this.frame * P * 3;
    var lo = s.box[0], step = [0, 1, 2].map(function (k) { return (s.box[1][k] - s.box[0][k]) / 65535; });
    var R = this.R, cx = this.centre, scale = this.zoom * 0.8 * Math.min(W, H) / this.diagonal;
    var X = new Float32Array(P), Y = new Float32Array(P), Z = new Float32Array(P);
    for (var p = 0; p < P; p++) {
      var v0 = lo[0] + a[base + 3 * p] * step[0] - cx[0], v1 = lo[1] + a[base + 3 * p + 1] * step[1] - cx[1];
      var v2 = lo[2] + a[base + 3 * p + 2] * step[2] - cx[2];
      X[p] = W / 2 + r * this.pan[0] + scale * (R[0] * v0 + R[1] * v1 + R[2] * v2);
      Y[p] = H / 2 + r * this.pan[1] - scale * (R[3] * v0 + R[4] * v1 + R[5] * v2);
      Z[p] = R[6] * v0 + R[7] * v1 + R[8] * v2;
    }
    var seg = s.segments, kind = s.kinds, n = kind.length, order = [], depth = new Float32Array(n);
    for (var i = 0; i < n; i++) {
      if (kind[i] <= -2 && !this.axes) { continue; }
      depth[i] = Z[seg[2 * i]] + Z[seg[2 * i + 1]];
      order.push(i);
    }
    order.sort(function (x, y) { return depth[x] - depth[y]; });
    var colour = this.colour && q.colours[this.colour], E = s.elements.length;
    var tube = this.tubes ? Math.max(3 * r, Math.min(14 * r, scale * this.diagonal * 0.012)) : 1.5 * r;
    var axisColours = ["#d62728", "#2ca02c", "#1f77b4"];
    g.fillStyle = "#fff";
    g.fillRect(0, 0, W, H);
    g.lineCap = "round";
    g.lineJoin = "round";
    var style = null, path = 0;  // consecutive segments of one style are stroked as one path
    function stroke(fill, width) {
      if (style !== null && (fill !== style[0] || width !== style[1])) { g.stroke(); style = null; }
      if (style === null) { g.beginPath(); g.strokeStyle = fill; g.lineWidth = width; style = [fill, width]; }
      path++;
    }
    function finish() { if (style !== null) { g.stroke(); style = null; } }
    if (this.tubes) {  // a dark rim under every tube first, then the bodies: joined segments read as one tube
      for (var m = 0; m < order.length; m++) {
        var f = order[m];
        if (kind[f] < -1) { continue; }
        stroke("rgba(0,0,0,0.55)", (kind[f] === -1 ? 1.3 * tube : tube) + 2 * r);
        g.moveTo(X[seg[2 * f]], Y[seg[2 * f]]);
        g.lineTo(X[seg[2 * f + 1]], Y[seg[2 * f + 1]]);
      }
      finish();
    }
    for (var j = 0; j < order.length; j++) {
      var e = order[j], k = kind[e], A = seg[2 * e], B = seg[2 * e + 1];
      if (k >= 0) {
        stroke(colour ? PALETTE[colour.values[this.frame * E + k]] : "#4a78b5", tube);
      } else if (k === -1) {
        stroke("#666", 1.3 * tube);
      } else {
        stroke(axisColours[-k - 2], 1.5 * r);
      }
      g.moveTo(X[A], Y[A]);
      g.lineTo(X[B], Y[B]);
    }
    finish();
    this.drawn = order.length;
    this.overlay(g, W, H, r, q, colour);
    this.ready = true;
    this.root.setAttribute("data-drawn", String(this.drawn));
  };

  View.prototype.overlay = function (g, W, H, r, q, colour) {
    var t = q.times[this.frame], font = Math.round(12 * r) + "px system-ui,sans-serif", R = this.R;
    var clock = q.unit === "phase" ? "phase " + t.toFixed(3) : q.unit === "s" ? "t = " + t.toFixed(4) + " s" :
      q.unit + " = " + t.toPrecision(5);
    g.fillStyle = "#222";
    g.font = font;
    g.textBaseline = "top";
    g.fillText(this.scene.title + (q.name ? " — " + q.name : ""), 8 * r, 6 * r);
    g.fillText(clock + "   (" + (this.frame + 1) + " / " + q.times.length + ")", 8 * r, 22 * r);
    this.clock.textContent = clock;
    var ox = 34 * r, oy = H - 34 * r, L = 24 * r, names = ["x", "y", "z"], cols = ["#d62728", "#2ca02c", "#1f77b4"];
    for (var k = 0; k < 3; k++) {  // the inertial axes, bottom left
      g.strokeStyle = cols[k];
      g.lineWidth = 2 * r;
      g.beginPath();
      g.moveTo(ox, oy);
      g.lineTo(ox + L * R[k], oy - L * R[3 + k]);
      g.stroke();
      g.fillStyle = cols[k];
      g.fillText(names[k], ox + 1.25 * L * R[k] - 3 * r, oy - 1.25 * L * R[3 + k] - 6 * r);
    }
    if (colour) {  // the colour bar, right: −scale … +scale
      var bw = 14 * r, bh = Math.min(180 * r, H - 60 * r), bx = W - bw - 70 * r, by = 40 * r;
      for (var y = 0; y < bh; y++) {
        g.fillStyle = "rgb(" + coolwarm(1 - y / bh).join(",") + ")";
        g.fillRect(bx, by + y, bw, 1);
      }
      g.strokeStyle = "#444";
      g.lineWidth = 1;
      g.strokeRect(bx, by, bw, bh);
      g.fillStyle = "#222";
      g.fillText(colour.label, Math.max(4 * r, W - 8 * r - g.measureText(colour.label).width), 20 * r);
      [[1, 0], [0, 0.5], [-1, 1]].forEach(function (m) {
        g.fillText((m[0] * colour.scale).toPrecision(3), bx + bw + 4 * r, by + m[1] * bh - 6 * r);
      });
    }
  };

  function start(root) {
    if (root.flexmbsView) { return; }
    var data = root.querySelector("script[type='application/json']");
    try {
      root.flexmbsView = new View(root, JSON.parse(data.textContent));
      window.flexmbsViews.push(root.flexmbsView);
    } catch (err) {
      root.textContent = "flexmbs view: " + err;
      console.error("flexmbs view:", err);
    }
  }

  function startAll() { Array.prototype.forEach.call(document.querySelectorAll("div.flexmbs-view"), start); }
  window.flexmbsViewStartAll = startAll;
  if (document.readyState === "loading") { document.addEventListener("DOMContentLoaded", startAll); } else {
    startAll();
  }
})();
