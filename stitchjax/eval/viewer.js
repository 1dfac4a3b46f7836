/* stitchjax motion viewer: skeletons in 3D on a ground grid, drawn on a 2D canvas with a perspective camera.
 *
 * No library and no network: the page that embeds this script holds the motion data as JSON in a script
 * element of type application/json with id "stitchjax-data" (written by stitchjax.eval.viewer, which documents
 * the fields) and an element with id "stitchjax-viewer", into which the canvas and the controls are built.
 *
 * Controls: drag to orbit, shift-drag (or right-drag) to pan, wheel to zoom; play / pause (space), a slider to
 * scrub, arrow keys to step one frame; a check box per motion. A URL ending in #frame=N opens paused at frame N.
 * After each drawing the root element's data-frames-drawn attribute counts the drawings (data-error holds
 * the message if the page could not start).
 */
(function () {
  "use strict";

  var root = document.getElementById("stitchjax-viewer");

  function fail(error) {
    var message = String(error && error.message ? error.message : error);
    if (root) {
      root.setAttribute("data-error", message);
      var box = document.createElement("pre");
      box.className = "sjv-error";
      box.textContent = "The viewer could not start: " + message;
      root.appendChild(box);
    }
  }

  // ------------------------------------------------------------------------------------------- vectors

  function sub(a, b) { return [a[0] - b[0], a[1] - b[1], a[2] - b[2]]; }
  function add(a, b) { return [a[0] + b[0], a[1] + b[1], a[2] + b[2]]; }
  function scale(a, s) { return [a[0] * s, a[1] * s, a[2] * s]; }
  function dot(a, b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
  function cross(a, b) { return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]; }
  function normalize(a) { var n = Math.sqrt(dot(a, a)) || 1; return [a[0] / n, a[1] / n, a[2] / n]; }

  // ---------------------------------------------------------------------------------------------- data

  /** The motions as arrays of poses: track.frames[t][j] = [x, y, z] in the data's units (Y up). */
  function decode(data) {
    var joints = data.parents.length;
    function poses(flat, count) {
      var out = [];
      for (var t = 0; t < count; t++) {
        var pose = [];
        for (var j = 0; j < joints; j++) {
          var k = (t * joints + j) * 3;
          pose.push([flat[k] / data.scale, flat[k + 1] / data.scale, flat[k + 2] / data.scale]);
        }
        out.push(pose);
      }
      return out;
    }
    data.tracks.forEach(function (track) {
      if (track.positions.length !== data.num_frames * joints * 3) {
        throw new Error("motion '" + track.name + "' holds " + track.positions.length + " numbers, expected " +
                        data.num_frames + " frames x " + joints + " joints x 3");
      }
      track.frames = poses(track.positions, data.num_frames);
      track.visible = track.visible !== false;
    });
    data.keyposes.forEach(function (key) { key.pose = poses(key.positions, 1)[0]; });
    return data;
  }

  /** Bounds of every root path and pose: {min, max} (3 numbers each). */
  function bounds(data) {
    var lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
    function take(p) {
      for (var i = 0; i < 3; i++) { lo[i] = Math.min(lo[i], p[i]); hi[i] = Math.max(hi[i], p[i]); }
    }
    data.tracks.forEach(function (track) { track.frames.forEach(function (pose) { pose.forEach(take); }); });
    data.keyposes.forEach(function (key) { key.pose.forEach(take); });
    return { min: lo, max: hi };
  }

  /** A round grid spacing (1, 2 or 5 times a power of ten) near a third of the body's height. */
  function gridStep(height) {
    var raw = Math.max(height / 3, 1e-6), power = Math.pow(10, Math.floor(Math.log10(raw)));
    var best = power;
    [1, 2, 5, 10].forEach(function (m) { if (Math.abs(m * power - raw) < Math.abs(best - raw)) { best = m * power; } });
    return best;
  }

  // -------------------------------------------------------------------------------------------- camera

  function Camera(box, ground, travel) {
    var size = sub(box.max, box.min);
    this.height = Math.max(size[1], 1e-6);
    this.home = {
      target: [(box.min[0] + box.max[0]) / 2, ground + 0.45 * this.height, (box.min[2] + box.max[2]) / 2],
      // seen from the side of the main travel, slightly from above
      yaw: Math.atan2(travel[0], travel[2]) + Math.PI / 2,
      pitch: 0.3,
      distance: 0.7 * Math.max(Math.sqrt(size[0] * size[0] + size[2] * size[2]), 1.6 * this.height) /
                Math.tan(this.fov / 2)
    };
    this.reset();
  }
  Camera.prototype.fov = 45 * Math.PI / 180;
  Camera.prototype.near = 1e-3;
  Camera.prototype.reset = function () {
    this.target = this.home.target.slice();
    this.yaw = this.home.yaw;
    this.pitch = this.home.pitch;
    this.distance = this.home.distance;
  };
  /** The eye and its basis (right, up, forward) for the current yaw, pitch and distance. */
  Camera.prototype.frame = function (width, height) {
    var c = Math.cos(this.pitch);
    var offset = [c * Math.sin(this.yaw), Math.sin(this.pitch), c * Math.cos(this.yaw)];
    var eye = add(this.target, scale(offset, this.distance));
    var forward = normalize(sub(this.target, eye));
    var right = normalize(cross(forward, [0, 1, 0]));
    var up = cross(right, forward);
    this.near = this.distance * 1e-3;
    return { eye: eye, right: right, up: up, forward: forward, focal: 0.5 * height / Math.tan(this.fov / 2),
             cx: 0.5 * width, cy: 0.5 * height };
  };
  Camera.prototype.orbit = function (dx, dy) {
    this.yaw -= dx * 0.008;
    this.pitch = Math.min(1.45, Math.max(-0.2, this.pitch + dy * 0.008));
  };
  Camera.prototype.pan = function (dx, dy, view) {
    var perPixel = this.distance / view.focal;
    this.target = add(this.target, add(scale(view.right, -dx * perPixel), scale(view.up, dy * perPixel)));
  };
  Camera.prototype.zoom = function (factor) {
    this.distance = Math.min(this.home.distance * 20, Math.max(this.height * 0.2, this.distance * factor));
  };

  /** A world point in camera coordinates [x right, y up, z depth]. */
  function toCamera(view, p) {
    var d = sub(p, view.eye);
    return [dot(d, view.right), dot(d, view.up), dot(d, view.forward)];
  }
  function toScreen(view, c) {
    return [view.cx + view.focal * c[0] / c[2], view.cy - view.focal * c[1] / c[2]];
  }
  /** A segment between two camera-space points, cut at the near plane: [a, b] or null when behind it. */
  function clip(a, b, near) {
    if (a[2] < near && b[2] < near) { return null; }
    if (a[2] < near || b[2] < near) {
      var s = (near - a[2]) / (b[2] - a[2]);
      var cut = [a[0] + s * (b[0] - a[0]), a[1] + s * (b[1] - a[1]), near];
      return a[2] < near ? [cut, b] : [a, cut];
    }
    return [a, b];
  }

  // ----------------------------------------------------------------------------------------- the page

  function start(data) {
    decode(data);
    var box = bounds(data);
    var first = data.tracks[0].frames;
    var travel = sub(first[first.length - 1][0], first[0][0]);
    if (Math.abs(travel[0]) + Math.abs(travel[2]) < 1e-6) { travel = [1, 0, 0]; }
    var camera = new Camera(box, data.ground, travel);
    var grid = gridStep(camera.height);
    var state = { frame: 0, playing: true, speed: 1, clock: null, keyframes: true, paths: true, drawn: 0 };
    var hash = /frame=(\d+)/.exec(window.location.hash || "");
    if (hash) { state.frame = Math.min(parseInt(hash[1], 10), data.num_frames - 1); state.playing = false; }

    // --- the page's elements
    root.innerHTML = "";
    var canvas = document.createElement("canvas");
    canvas.className = "sjv-canvas";
    canvas.setAttribute("tabindex", "0");
    root.appendChild(canvas);
    var bar = document.createElement("div");
    bar.className = "sjv-bar";
    root.appendChild(bar);
    var play = button(bar, "", function () { setPlaying(!state.playing); });
    var slider = document.createElement("input");
    slider.type = "range";
    slider.min = "0";
    slider.max = String(data.num_frames - 1);
    slider.step = "1";
    slider.className = "sjv-slider";
    slider.addEventListener("input", function () { setPlaying(false); state.frame = parseInt(slider.value, 10); draw(); });
    bar.appendChild(slider);
    var label = document.createElement("span");
    label.className = "sjv-label";
    bar.appendChild(label);
    var speed = document.createElement("select");
    [0.25, 0.5, 1].forEach(function (s) {
      var option = document.createElement("option");
      option.value = String(s);
      option.textContent = s + "x";
      option.selected = s === 1;
      speed.appendChild(option);
    });
    speed.addEventListener("change", function () { state.speed = parseFloat(speed.value); });
    bar.appendChild(speed);
    button(bar, "reset view", function () { camera.reset(); draw(); });

    var toggles = document.createElement("div");
    toggles.className = "sjv-toggles";
    root.appendChild(toggles);
    data.tracks.forEach(function (track) {
      toggle(toggles, track.name, track.color, track.visible, function (on) { track.visible = on; draw(); });
    });
    toggle(toggles, "keyframes", data.keyframe_color, true, function (on) { state.keyframes = on; draw(); });
    toggle(toggles, "root paths", "#999999", true, function (on) { state.paths = on; draw(); });
    if (data.feet.length > 0) {
      var legend = document.createElement("span");
      legend.className = "sjv-legend";
      var dot = document.createElement("span");
      dot.className = "sjv-dot";
      dot.style.background = data.contact_color;
      legend.appendChild(dot);
      legend.appendChild(document.createTextNode("foot contact (" + data.contact_source + ")"));
      toggles.appendChild(legend);
    }

    function button(parent, text, onClick) {
      var b = document.createElement("button");
      b.type = "button";
      b.textContent = text;
      b.addEventListener("click", onClick);
      parent.appendChild(b);
      return b;
    }
    function toggle(parent, name, color, on, onChange) {
      var item = document.createElement("label");
      item.className = "sjv-toggle";
      var box = document.createElement("input");
      box.type = "checkbox";
      box.checked = on;
      box.addEventListener("change", function () { onChange(box.checked); });
      var swatch = document.createElement("span");
      swatch.className = "sjv-swatch";
      swatch.style.background = color;
      item.appendChild(box);
      item.appendChild(swatch);
      item.appendChild(document.createTextNode(name));
      parent.appendChild(item);
    }
    function setPlaying(on) {
      state.playing = on;
      state.clock = null;
      play.textContent = on ? "pause" : "play";
      if (on) { window.requestAnimationFrame(tick); }
    }

    // --- mouse and keys
    var drag = null;
    canvas.addEventListener("pointerdown", function (e) {
      drag = { x: e.clientX, y: e.clientY, pan: e.shiftKey || e.button === 2 };
      if (canvas.setPointerCapture) { canvas.setPointerCapture(e.pointerId); }
    });
    canvas.addEventListener("pointermove", function (e) {
      if (!drag) { return; }
      var dx = e.clientX - drag.x, dy = e.clientY - drag.y;
      drag.x = e.clientX;
      drag.y = e.clientY;
      if (drag.pan) { camera.pan(dx, dy, view()); } else { camera.orbit(dx, dy); }
      draw();
    });
    ["pointerup", "pointercancel"].forEach(function (name) { canvas.addEventListener(name, function () { drag = null; }); });
    canvas.addEventListener("contextmenu", function (e) { e.preventDefault(); });
    canvas.addEventListener("wheel", function (e) {
      e.preventDefault();
      camera.zoom(Math.exp(Math.max(-100, Math.min(100, e.deltaY)) * 0.002));
      draw();
    }, { passive: false });
    root.addEventListener("keydown", function (e) {
      if (e.key === " ") { setPlaying(!state.playing); e.preventDefault(); }
      else if (e.key === "ArrowRight" || e.key === "ArrowLeft") {
        setPlaying(false);
        state.frame = (state.frame + (e.key === "ArrowRight" ? 1 : data.num_frames - 1)) % data.num_frames;
        draw();
        e.preventDefault();
      }
    });
    window.addEventListener("resize", function () { draw(); });

    // --- drawing
    var context = canvas.getContext("2d");
    if (!context) { throw new Error("this browser gives no 2D canvas"); }

    function view() {
      return camera.frame(canvas.clientWidth || 640, canvas.clientHeight || 400);
    }
    function size() {
      var ratio = window.devicePixelRatio || 1;
      var w = canvas.clientWidth || 640, h = canvas.clientHeight || 400;
      if (canvas.width !== Math.round(w * ratio) || canvas.height !== Math.round(h * ratio)) {
        canvas.width = Math.round(w * ratio);
        canvas.height = Math.round(h * ratio);
      }
      context.setTransform(ratio, 0, 0, ratio, 0, 0);
      return [w, h];
    }
    /** A line between world points a and b, queued with its depth (for drawing far to near). */
    function line(items, v, a, b, color, width, alpha) {
      var seg = clip(toCamera(v, a), toCamera(v, b), camera.near);
      if (!seg) { return; }
      var depth = 0.5 * (seg[0][2] + seg[1][2]);
      items.push({ depth: depth, kind: "line", a: toScreen(v, seg[0]), b: toScreen(v, seg[1]), color: color,
                   width: width * v.focal / depth, alpha: alpha });
    }
    function dotAt(items, v, p, color, radius) {
      var c = toCamera(v, p);
      if (c[2] < camera.near) { return; }
      // dots are markers: drawn over every bone (depth -Infinity), so a contact behind a leg still shows
      items.push({ depth: -Infinity, kind: "dot", a: toScreen(v, c), color: color,
                   radius: Math.max(4, radius * v.focal / c[2]) });
    }
    function skeleton(items, v, pose, color, width, contacts) {
      data.parents.forEach(function (parent, j) {
        if (parent >= 0) { line(items, v, pose[parent], pose[j], color, width, 1); }
      });
      if (contacts) {
        data.feet.forEach(function (joint, k) {
          if (contacts & (1 << k)) { dotAt(items, v, pose[joint], data.contact_color, 0.03 * camera.height); }
        });
      }
    }
    function groundGrid(v) {
      var lo = [box.min[0] - camera.height, box.min[2] - camera.height];
      var hi = [box.max[0] + camera.height, box.max[2] + camera.height];
      var x0 = Math.floor(lo[0] / grid) * grid, x1 = Math.ceil(hi[0] / grid) * grid;
      var z0 = Math.floor(lo[1] / grid) * grid, z1 = Math.ceil(hi[1] / grid) * grid;
      context.lineWidth = 1;
      context.strokeStyle = "#d5d9e0";
      context.beginPath();
      var y = data.ground;
      for (var x = x0; x <= x1 + 1e-9; x += grid) { gridLine(v, [x, y, z0], [x, y, z1]); }
      for (var z = z0; z <= z1 + 1e-9; z += grid) { gridLine(v, [x0, y, z], [x1, y, z]); }
      context.stroke();
    }
    function gridLine(v, a, b) {
      var seg = clip(toCamera(v, a), toCamera(v, b), camera.near);
      if (!seg) { return; }
      var p = toScreen(v, seg[0]), q = toScreen(v, seg[1]);
      context.moveTo(p[0], p[1]);
      context.lineTo(q[0], q[1]);
    }

    function draw() {
      var wh = size();
      var v = camera.frame(wh[0], wh[1]);
      context.fillStyle = "#f7f8fa";
      context.fillRect(0, 0, wh[0], wh[1]);
      groundGrid(v);
      var items = [];
      var bone = 0.016 * camera.height;
      if (state.paths) {
        data.tracks.forEach(function (track) {
          if (!track.visible) { return; }
          for (var t = 1; t < data.num_frames; t++) {
            var a = track.frames[t - 1][0], b = track.frames[t][0];
            line(items, v, [a[0], data.ground, a[2]], [b[0], data.ground, b[2]], track.color, 0.3 * bone, 0.45);
          }
        });
      }
      if (state.keyframes) {
        data.keyposes.forEach(function (key) { skeleton(items, v, key.pose, data.keyframe_color, bone, 0); });
      }
      data.tracks.forEach(function (track) {
        if (!track.visible) { return; }
        var contacts = track.contacts ? track.contacts[state.frame] : 0;
        skeleton(items, v, track.frames[state.frame], track.color, bone, contacts);
      });
      items.sort(function (p, q) { return p.depth === q.depth ? 0 : (p.depth < q.depth ? 1 : -1); });
      context.lineCap = "round";
      items.forEach(function (item) {
        if (item.kind === "line") {
          context.globalAlpha = item.alpha;
          context.strokeStyle = item.color;
          context.lineWidth = Math.max(1, Math.min(12, item.width));
          context.beginPath();
          context.moveTo(item.a[0], item.a[1]);
          context.lineTo(item.b[0], item.b[1]);
          context.stroke();
        } else {
          context.globalAlpha = 1;
          context.fillStyle = item.color;
          context.strokeStyle = "#ffffff";
          context.lineWidth = 1.5;
          context.beginPath();
          context.arc(item.a[0], item.a[1], Math.min(10, item.radius), 0, 2 * Math.PI);
          context.fill();
          context.stroke();
        }
      });
      context.globalAlpha = 1;
      slider.value = String(state.frame);
      var t = state.frame, phase = "context";
      if (data.keyframes.indexOf(t) >= 0) { phase = "keyframe"; }
      else if (t > data.transition[0] && t < data.transition[1]) { phase = "transition"; }
      label.textContent = "frame " + t + " / " + (data.num_frames - 1) + "  " + (t / data.fps).toFixed(2) + " s  " + phase;
      state.drawn += 1;
      root.setAttribute("data-frames-drawn", String(state.drawn));
      root.setAttribute("data-frame", String(state.frame));
    }

    function tick(now) {
      if (!state.playing) { return; }
      if (state.clock === null) { state.clock = now; }
      var steps = Math.floor((now - state.clock) / 1000 * data.fps * state.speed);
      if (steps > 0) {
        state.clock += steps * 1000 / (data.fps * state.speed);
        state.frame = (state.frame + steps) % data.num_frames;
        draw();
      }
      window.requestAnimationFrame(tick);
    }

    draw();
    setPlaying(state.playing);
  }

  try {
    if (!root) { throw new Error("the page has no element with id stitchjax-viewer"); }
    var source = document.getElementById("stitchjax-data");
    if (!source) { throw new Error("the page has no motion data (script id stitchjax-data)"); }
    start(JSON.parse(source.textContent));
  } catch (error) {
    fail(error);
    throw error;
  }
})();
