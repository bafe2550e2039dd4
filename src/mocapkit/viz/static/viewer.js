/* mocapkit viewer: three.js skeleton player with cleaning / stitch / motion-graph overlays.
 * Data: the JSON in <script id="mocapkit-data"> (see mocapkit/viz/viewer.py).
 * Bones are solid (Lambert-shaded tubes + sphere sprites at the joints); a ground root (the
 * body's projection on the floor, e.g. Bandai's joint_Root) is a ring + arrow on the floor; the
 * camera targets the (smoothed) pelvis path and follows it while the user orbits.
 * Each motion comes in metres (its own unit applied in Python: meta.units, unitsSource,
 * metresPerUnit), so one grid and one camera fit them all.
 * Test hook: window.mocapkitViewer (frame, play(), pause(), seek(f), jointColor(m, j),
 * boneColor(m, k), screenPoint(j, m), bones(m), groundMarker(m), timelineLabels(), ...). */
(function () {
  'use strict';
  var D = JSON.parse(document.getElementById('mocapkit-data').textContent);
  var $ = function (id) { return document.getElementById(id); };

  function b64bytes(s) {
    var bin = atob(s), n = bin.length, out = new Uint8Array(n);
    for (var i = 0; i < n; i++) out[i] = bin.charCodeAt(i);
    return out;
  }
  function hexRgb(h) {
    var c = new THREE.Color(h);
    return [c.r, c.g, c.b];
  }
  function ramp(v) { // MDM colour: blue (0) -> yellow (0.5) -> red (1)
    v = Math.max(0, Math.min(1, v));
    if (v < 0.5) { var t = v * 2; return [0.19 + 0.81 * t, 0.38 + 0.54 * t, 1.0 - 0.8 * t]; }
    var u = (v - 0.5) * 2;
    return [1.0, 0.92 - 0.82 * u, 0.2 - 0.2 * u];
  }

  // ---------------------------------------------------------------- motions
  var motions = D.motions.map(function (m) {
    var q = new Uint16Array(b64bytes(m.pos).buffer);
    var n = m.names.length, P = new Float32Array(q.length);
    for (var i = 0; i < q.length; i += 3) {
      P[i] = m.lo[0] + q[i] * m.step[0];
      P[i + 1] = m.lo[1] + q[i + 1] * m.step[1];
      P[i + 2] = m.lo[2] + q[i + 2] * m.step[2];
    }
    var gr = (m.groundRoot === null || m.groundRoot === undefined) ? -1 : m.groundRoot;
    var bones = [], joints = [];
    for (var j = 0; j < n; j++) {
      if (j !== gr) joints.push(j);
      // no bone from the ground root: it is drawn as a marker on the floor
      if (m.parents[j] >= 0 && m.parents[j] !== gr && j !== gr) bones.push([m.parents[j], j]);
    }
    var F = m.frames, pv = Math.min(n - 1, m.pelvis || 0);
    // the pelvis path, horizontally smoothed over ~0.5 s (the camera follows it without the
    // side-to-side sway of a walk), at the take's median pelvis height
    var S = new Float32Array(F * 2), half = Math.max(0, Math.round(0.25 * m.fps));
    var cx = new Float64Array(F + 1), cz = new Float64Array(F + 1), ys = [];
    for (var f = 0; f < F; f++) {
      var o = (f * n + pv) * 3;
      cx[f + 1] = cx[f] + P[o]; cz[f + 1] = cz[f] + P[o + 2];
      if (f % Math.max(1, Math.floor(F / 512)) === 0) ys.push(P[o + 1]);
    }
    for (var f2 = 0; f2 < F; f2++) {
      var a = Math.max(0, f2 - half), b = Math.min(F, f2 + half + 1);
      S[2 * f2] = (cx[b] - cx[a]) / (b - a); S[2 * f2 + 1] = (cz[b] - cz[a]) / (b - a);
    }
    ys.sort(function (u, v) { return u - v; });
    var heading = null;
    if (gr >= 0 && m.rootHeading) heading = new Float32Array(b64bytes(m.rootHeading).buffer);
    return {
      meta: m, P: P, n: n, bones: bones, joints: joints, gr: gr, pelvis: pv, path: S,
      pathY: ys[Math.floor(ys.length / 2)], heading: heading, rgb: hexRgb(m.color), frame: 0
    };
  });
  var fps = motions[0].meta.fps;
  var duration = Math.max.apply(null, motions.map(function (m) { return m.meta.frames / m.meta.fps; }));
  var nFrames = Math.max(1, Math.round(duration * fps));
  var clean = D.clean, stitch = D.stitch, graph = D.graph;
  var mdm = null;
  if (clean && clean.mdm) mdm = b64bytes(clean.mdm);

  // ---------------------------------------------------------------- scene
  var stage = $('stage');
  // software WebGL (SwiftShader: headless, no GPU) cannot afford multisampling at 30+ fps
  var software = (function () {
    try {
      var gl = document.createElement('canvas').getContext('webgl');
      var ext = gl && gl.getExtension('WEBGL_debug_renderer_info');
      var name = ext ? String(gl.getParameter(ext.UNMASKED_RENDERER_WEBGL)) : '';
      var lose = gl && gl.getExtension('WEBGL_lose_context');
      if (lose) lose.loseContext();
      return /swiftshader|llvmpipe|software/i.test(name);
    } catch (e) { return false; }
  })();
  var renderer = new THREE.WebGLRenderer({ antialias: !software });
  renderer.setPixelRatio(software ? 1 : (window.devicePixelRatio || 1));
  renderer.setClearColor(0x1d1f27, 1);
  stage.appendChild(renderer.domElement);
  var scene = new THREE.Scene();
  var camera = new THREE.PerspectiveCamera(45, 1, 0.01, 2000);
  var controls = new THREE.OrbitControls(camera, renderer.domElement);
  controls.enableDamping = false;

  var groundY = Math.min.apply(null, motions.map(function (m) { return m.meta.ground; }));
  var charH = Math.max(0.1, Math.max.apply(null, motions.map(function (m) { return m.meta.stature || m.meta.height; })));
  var width = Math.max(0.3, Math.max.apply(null, motions.map(function (m) { return m.meta.width; })));
  // grid in metres: 1 m cells (0.1 m for small characters), big enough for the whole take
  var ext = 0;
  motions.forEach(function (m) {
    for (var a = 0; a < 3; a += 2) {
      var lo = m.meta.lo[a], hi = lo + m.meta.step[a] * 65535;
      ext = Math.max(ext, Math.abs(lo), Math.abs(hi));
    }
  });
  var cell = charH < 0.5 ? 0.1 : 1.0;
  // at most 40 x 40 cells; the grid moves with the camera target in whole cells
  var half = Math.min(20 * cell, Math.max(5 * cell, Math.ceil((ext + 2 * charH) / cell) * cell));
  // the grid as one segment per cell edge: a long line crossing the camera plane is dropped
  // whole by some software rasterisers (SwiftShader), a short one only when behind the camera
  var grid = (function () {
    var n = Math.round(2 * half / cell), v = [], c = [], major = [0.33, 0.35, 0.42], minor = [0.2, 0.21, 0.25];
    for (var i = 0; i <= n; i++) {
      var a = -half + i * cell, col = (i % 5 === n / 2 % 5) ? major : minor;
      for (var k = 0; k < n; k++) {
        var b0 = -half + k * cell, b1 = b0 + cell;
        v.push(a, 0, b0, a, 0, b1, b0, 0, a, b1, 0, a);
        for (var r = 0; r < 4; r++) c.push(col[0], col[1], col[2]);
      }
    }
    var geo = new THREE.BufferGeometry();
    geo.setAttribute('position', new THREE.Float32BufferAttribute(v, 3));
    geo.setAttribute('color', new THREE.Float32BufferAttribute(c, 3));
    return new THREE.LineSegments(geo, new THREE.LineBasicMaterial({ vertexColors: true }));
  })();
  grid.position.y = groundY;
  scene.add(grid);
  var axes = new THREE.AxesHelper(Math.min(0.5, cell));
  axes.position.y = groundY + 0.001;
  scene.add(axes);

  // lights: a soft ambient term and a head light (a child of the camera, from above its right
  // shoulder), so that the side of a bone facing the viewer keeps the motion's colour
  scene.add(camera);
  scene.add(new THREE.AmbientLight(0xffffff, 0.42));
  var headLight = new THREE.DirectionalLight(0xffffff, 0.66);
  headLight.position.set(0.35, 0.6, 0.2);
  headLight.target.position.set(0, 0, -1);
  camera.add(headLight); camera.add(headLight.target);

  // bones: one mesh per motion of open tubes (SEG sides), its vertices written each frame (as
  // cheap in software WebGL as the old lines; instanced cylinders cost several ms a frame)
  var SEG = 8, COS = [], SIN = [];
  for (var sg = 0; sg < SEG; sg++) { COS.push(Math.cos(2 * Math.PI * sg / SEG)); SIN.push(Math.sin(2 * Math.PI * sg / SEG)); }
  function tubeMesh(nb, mat) {
    var nv = nb * 2 * SEG, idx = new (nv > 65535 ? Uint32Array : Uint16Array)(nb * SEG * 6);
    for (var k = 0, t = 0; k < nb; k++) {
      var v0 = k * 2 * SEG;
      for (var q = 0; q < SEG; q++) {
        var a = v0 + q, b = v0 + (q + 1) % SEG, c = a + SEG, d = b + SEG;
        idx[t++] = a; idx[t++] = b; idx[t++] = c; idx[t++] = b; idx[t++] = d; idx[t++] = c;
      }
    }
    var geo = new THREE.BufferGeometry();
    geo.setIndex(new THREE.BufferAttribute(idx, 1));
    ['position', 'normal', 'color'].forEach(function (name) {
      geo.setAttribute(name, new THREE.BufferAttribute(new Float32Array(nv * 3), 3).setUsage(THREE.DynamicDrawUsage));
    });
    var mesh = new THREE.Mesh(geo, mat);
    mesh.frustumCulled = false;
    return mesh;
  }
  // joints: point sprites of a shaded sphere (60 instanced sphere meshes cost software WebGL
  // ~10 ms a frame; a sprite per joint costs next to nothing), sized in world units
  var sphereTex = (function () {
    var c = document.createElement('canvas'); c.width = c.height = 64;
    var x = c.getContext('2d'), gr = x.createRadialGradient(38, 24, 2, 32, 32, 31);
    gr.addColorStop(0, '#ffffff'); gr.addColorStop(0.45, '#f4f4f4'); gr.addColorStop(1, '#6a6a6a');
    x.fillStyle = gr; x.beginPath(); x.arc(32, 32, 31, 0, 2 * Math.PI); x.fill();
    var t = new THREE.CanvasTexture(c);
    return t;
  })();
  var solidMat = new THREE.MeshLambertMaterial({ color: 0xffffff, vertexColors: true });

  function groundMarker(m) { // a ring with an arrow (the heading), flat on the floor
    var H = m.meta.stature || charH, mk = new THREE.Group();
    var mat = new THREE.MeshBasicMaterial({ color: m.meta.color, side: THREE.DoubleSide, transparent: true, opacity: 0.85, depthWrite: false });
    var ring = new THREE.Mesh(new THREE.RingGeometry(0.15 * H, 0.18 * H, 48), mat);
    ring.rotation.x = -Math.PI / 2;
    var tri = new THREE.Shape();
    tri.moveTo(-0.07 * H, 0.19 * H); tri.lineTo(0.07 * H, 0.19 * H); tri.lineTo(0, 0.32 * H); tri.lineTo(-0.07 * H, 0.19 * H);
    var arrow = new THREE.Mesh(new THREE.ShapeGeometry(tri), mat);
    arrow.rotation.x = -Math.PI / 2; arrow.scale.y = -1; // shape +y -> world +z
    var dot = new THREE.Mesh(new THREE.CircleGeometry(0.025 * H, 16), mat);
    dot.rotation.x = -Math.PI / 2;
    mk.add(ring); mk.add(arrow); mk.add(dot);
    mk.renderOrder = 1;
    return mk;
  }

  var sideBySide = motions.length > 2;
  $('side').checked = sideBySide;
  motions.forEach(function (m, i) {
    var g = new THREE.Group(), H = m.meta.stature || charH;
    m.rBone = 0.017 * H; m.rJoint = 0.026 * H;
    var nb = Math.max(1, m.bones.length), nj = Math.max(1, m.joints.length);
    var bm = tubeMesh(nb, solidMat);
    bm.geometry.setDrawRange(0, m.bones.length * SEG * 6);
    m.boneCol = new Float32Array(nb * 3); m.jointCol = new Float32Array(nj * 3);
    m.jointPos = new Float32Array(nj * 3);
    var jg = new THREE.BufferGeometry();
    jg.setAttribute('position', new THREE.BufferAttribute(m.jointPos, 3).setUsage(THREE.DynamicDrawUsage));
    jg.setAttribute('color', new THREE.BufferAttribute(m.jointCol, 3).setUsage(THREE.DynamicDrawUsage));
    jg.setDrawRange(0, m.joints.length);
    // three's attenuated point size is size * (canvas height / 2) / depth: a world diameter D
    // needs size = D / tan(fov / 2)
    var jmat = new THREE.PointsMaterial({
      size: 2 * m.rJoint / Math.tan(camera.fov * Math.PI / 360), sizeAttenuation: true,
      vertexColors: true, map: sphereTex, alphaTest: 0.5
    });
    var jm = new THREE.Points(jg, jmat);
    jm.frustumCulled = false;
    var colBuf = new Float32Array(m.n * 3);
    for (var j = 0; j < m.n; j++) colBuf.set(m.rgb, 3 * j);
    // the first motion (the analysed one, with MDM colours) is drawn last: on top where the
    // motions coincide (equal depths pass the LessEqual depth test)
    bm.renderOrder = 2 * (motions.length - i); jm.renderOrder = 2 * (motions.length - i) + 1;
    g.add(bm); g.add(jm);
    if (m.gr >= 0) { m.marker = groundMarker(m); g.add(m.marker); }
    scene.add(g);
    m.group = g; m.bm = bm; m.jm = jm; m.colBuf = colBuf; m.boneRgb = null;
    m.index = i;
  });
  var selJoint = null; // {m, j}
  var selGeom = new THREE.BufferGeometry();
  selGeom.setAttribute('position', new THREE.BufferAttribute(new Float32Array(3), 3));
  var selPts = new THREE.Points(selGeom, new THREE.PointsMaterial({ size: 16, sizeAttenuation: false, color: 0xffffff, transparent: true, opacity: 0.55 }));
  selPts.visible = false; selPts.frustumCulled = false;
  scene.add(selPts);

  function layout() {
    // side by side, each motion starts in its own lane (its first pelvis ground point moved
    // there: takes recorded far apart in the capture volume still stand in one row); overlaid,
    // motions keep their world positions, to be compared where they are
    motions.forEach(function (m, i) {
      var lane = (i - (motions.length - 1) / 2) * (width + 0.6 * charH);
      m.group.position.x = sideBySide ? lane - m.path[0] : 0;
      m.group.position.z = sideBySide ? -m.path[1] : 0;
    });
  }
  layout();

  // ---------------------------------------------------------------- state
  var frame = 0, playing = false, loop = true, speed = 1, tPlay = 0, lastNow = null;
  var follow = true, lastCentre = null;
  var GEN_RGB = hexRgb('#ffeb3b');

  function motionFrame(m, f) {
    var t = f / fps;
    return Math.max(0, Math.min(m.meta.frames - 1, Math.round(t * m.meta.fps)));
  }
  function mdmAt(f, j) {
    if (!mdm || j >= clean.joints) return 0;
    f = Math.max(0, Math.min(clean.frames - 1, f));
    return mdm[f * clean.joints + j] / 255;
  }
  function centre() { // the camera target: the motions' smoothed pelvis paths, averaged
    var c = new THREE.Vector3();
    motions.forEach(function (m) {
      c.x += m.path[2 * m.frame] + m.group.position.x; c.y += m.pathY;
      c.z += m.path[2 * m.frame + 1] + m.group.position.z;
    });
    return c.multiplyScalar(1 / motions.length);
  }
  function drawMotion(m, f, injected) {
    var P = m.P, o = f * m.n * 3, k, j, b;
    var ga = m.bm.geometry.attributes, V = ga.position.array, N = ga.normal.array, r = m.rBone;
    for (k = 0; k < m.bones.length; k++) {
      var p = o + 3 * m.bones[k][0], c = o + 3 * m.bones[k][1];
      var px = P[p], py = P[p + 1], pz = P[p + 2], qx = P[c], qy = P[c + 1], qz = P[c + 2];
      var dx = qx - px, dy = qy - py, dz = qz - pz, dl = Math.sqrt(dx * dx + dy * dy + dz * dz);
      if (dl > 1e-9) { dx /= dl; dy /= dl; dz /= dl; } else { dx = 0; dy = 1; dz = 0; }
      // u: perpendicular to the bone (crossed with the axis it is least aligned with), w = d x u
      var ux, uy, uz;
      if (Math.abs(dx) < 0.9) { ux = 0; uy = dz; uz = -dy; } else { ux = -dz; uy = 0; uz = dx; }
      var ul = Math.sqrt(ux * ux + uy * uy + uz * uz); ux /= ul; uy /= ul; uz /= ul;
      var wx = dy * uz - dz * uy, wy = dz * ux - dx * uz, wz = dx * uy - dy * ux;
      var v = k * 2 * SEG * 3;
      for (var q = 0; q < SEG; q++) {
        var nx = COS[q] * ux + SIN[q] * wx, ny = COS[q] * uy + SIN[q] * wy, nz = COS[q] * uz + SIN[q] * wz;
        var a = v + 3 * q, e = a + 3 * SEG;
        N[a] = N[e] = nx; N[a + 1] = N[e + 1] = ny; N[a + 2] = N[e + 2] = nz;
        V[a] = px + r * nx; V[a + 1] = py + r * ny; V[a + 2] = pz + r * nz;
        V[e] = qx + r * nx; V[e + 1] = qy + r * ny; V[e + 2] = qz + r * nz;
      }
    }
    ga.position.needsUpdate = true; ga.normal.needsUpdate = true;
    var JP = m.jointPos;
    for (k = 0; k < m.joints.length; k++) {
      j = o + 3 * m.joints[k];
      JP[3 * k] = P[j]; JP[3 * k + 1] = P[j + 1]; JP[3 * k + 2] = P[j + 2];
    }
    m.jm.geometry.attributes.position.needsUpdate = true;
    var rgb = injected ? GEN_RGB : m.rgb, B = m.boneCol;
    if (rgb !== m.boneRgb) {
      var BC = ga.color.array;
      for (k = 0; k < m.bones.length; k++) B.set(rgb, 3 * k);
      for (k = 0; k < m.bones.length * 2 * SEG; k++) BC.set(rgb, 3 * k);
      m.boneRgb = rgb; ga.color.needsUpdate = true;
    }
    var C = m.colBuf, JC = m.jointCol;
    for (k = 0; k < m.joints.length; k++) {
      b = 3 * m.joints[k];
      JC[3 * k] = C[b]; JC[3 * k + 1] = C[b + 1]; JC[3 * k + 2] = C[b + 2];
    }
    m.jm.geometry.attributes.color.needsUpdate = true;
    if (m.marker) {
      var r = o + 3 * m.gr;
      m.marker.position.set(P[r], P[r + 1] + 0.002 * charH, P[r + 2]);
      m.marker.rotation.y = m.heading ? m.heading[f] : 0;
    }
  }

  function inRange(r, f) { return f >= r[0] && f < r[1]; }

  function updatePose() {
    motions.forEach(function (m) {
      var f = motionFrame(m, frame); m.frame = f;
      var injected = !!(stitch && stitch.motion === m.index && (inRange(stitch.generated, f) ||
        (stitch.earlier || []).some(function (e) { return inRange(e.generated, f); })));
      var C = m.colBuf;
      if (mdm && clean.motion === m.index) {
        for (var j = 0; j < m.n; j++) C.set(j < m.meta.numJoints ? ramp(mdmAt(f, j)) : m.rgb, 3 * j);
      } else {
        for (var j2 = 0; j2 < m.n; j2++) C.set(injected ? GEN_RGB : m.rgb, 3 * j2);
      }
      drawMotion(m, f, injected);
    });
    if (selJoint) {
      var sm = motions[selJoint.m], so = (sm.frame * sm.n + selJoint.j) * 3;
      var sp = selGeom.attributes.position.array;
      sp[0] = sm.P[so] + sm.group.position.x; sp[1] = sm.P[so + 1];
      sp[2] = sm.P[so + 2] + sm.group.position.z;
      selGeom.attributes.position.needsUpdate = true;
    }
    if (follow) {
      var c = centre();
      if (lastCentre) {
        var d = c.clone().sub(lastCentre); d.y = 0;
        camera.position.add(d); controls.target.add(d);
      }
      lastCentre = c;
    }
  }

  function readout() {
    var t = frame / fps;
    var el = $('readout');
    el.textContent = 'frame ' + frame + ' / ' + (nFrames - 1) + ' \u00b7 ' + t.toFixed(3) + ' s';
    el.setAttribute('data-frame', String(frame));
    $('scrubber').value = String(frame);
  }

  function setFrame(f) {
    f = Math.max(0, Math.min(nFrames - 1, Math.floor(f)));
    frame = f;
    updatePose();
    readout();
  }

  function seek(f) { setFrame(f); tPlay = frame / fps; drawTimeline(); }
  function play() {
    if (frame >= nFrames - 1 && !loop) seek(0);
    playing = true; lastNow = null; $('play').innerHTML = '&#10074;&#10074;';
  }
  function pause() { playing = false; $('play').innerHTML = '&#9654;'; }

  // ---------------------------------------------------------------- camera
  function fitCamera() {
    // target the pelvis path; the distance makes the character ~60% of the stage's height (and
    // the row of motions, side by side, fit its width)
    var c = centre(), tanH = Math.tan(camera.fov * Math.PI / 360);
    var span = sideBySide ? (motions.length - 1) * (width + 0.6 * charH) + width : width;
    var d = Math.max(charH / (0.6 * 2 * tanH), span / (0.8 * 2 * tanH * Math.max(0.3, camera.aspect)));
    var dir = new THREE.Vector3(0.9, 0.5, 1.9).normalize();
    controls.target.copy(c);
    camera.position.copy(c).addScaledVector(dir, d);
    camera.near = Math.max(0.001, d / 100); camera.far = Math.max(100, half * 8, d * 20);
    camera.updateProjectionMatrix();
    controls.update();
    lastCentre = c;
  }
  function resize() {
    var w = stage.clientWidth || 800, h = stage.clientHeight || 450;
    renderer.setSize(w, h, false);
    renderer.domElement.style.width = w + 'px'; renderer.domElement.style.height = h + 'px';
    camera.aspect = w / h; camera.updateProjectionMatrix();
    sizeTimeline();
  }

  // ---------------------------------------------------------------- timeline
  // Rows, top to bottom: the marker band (transition / take-off / landing markers, their labels
  // in up to LABEL_ROWS rows, laid out so that no two overlap: a label with no room is left out
  // and its details are on hover and in the list), the MDM heat map (one row per joint, names
  // in a left gutter where the rows are tall enough) or a thin bar, and a time axis in seconds.
  // Hidden when there is nothing to show on it.
  var tl = $('timeline'), tctx = tl.getContext('2d');
  var graphTrans = graph ? graph.transitions : [];
  var hasTimeline = !!(clean || stitch || graphTrans.length);
  if (!hasTimeline) $('timeline-wrap').hidden = true;
  var MARK_H = 9, LABEL_H = 11, AXIS = 16, LABEL_FONT = '10px sans-serif';
  var LABEL_ROWS = graphTrans.length ? 3 : (stitch ? 2 : 0);
  var BAND = Math.max(22, MARK_H + LABEL_ROWS * LABEL_H + 3); // marker band height (css px)
  var heat = null; // offscreen canvas: MDM, one column per frame (scaled when drawn)
  var rowH = 0, nRows = 0, gutter = 0, nameFont = null;
  if (mdm) {
    nRows = clean.joints;
    rowH = Math.max(2, Math.min(10, Math.floor(260 / nRows)));
    var cols = Math.min(clean.frames, 4096), step = clean.frames / cols;
    heat = document.createElement('canvas'); heat.width = cols; heat.height = nRows;
    var hctx = heat.getContext('2d'), img = hctx.createImageData(cols, nRows);
    for (var x = 0; x < cols; x++) {
      var f0 = Math.floor(x * step), f1 = Math.max(f0 + 1, Math.floor((x + 1) * step));
      for (var j = 0; j < nRows; j++) {
        var v = 0;
        for (var f = f0; f < f1; f++) v = Math.max(v, mdm[f * nRows + j]);
        var rgb = ramp(v / 255), o = 4 * (j * cols + x);
        img.data[o] = 255 * rgb[0]; img.data[o + 1] = 255 * rgb[1]; img.data[o + 2] = 255 * rgb[2]; img.data[o + 3] = 255;
      }
    }
    hctx.putImageData(img, 0, 0);
    if (rowH >= 8) { // joint names fit beside the rows
      nameFont = (rowH - 1) + 'px sans-serif';
      tctx.font = nameFont;
      var jn = motions[clean.motion].meta.names, widest = 0;
      for (var jj = 0; jj < nRows; jj++) widest = Math.max(widest, tctx.measureText(String(jn[jj])).width);
      gutter = Math.ceil(Math.min(130, widest + 8));
    }
    $('tl-cap').textContent = 'MDM of ' + base(motions[clean.motion].meta.name) + ', a row per joint over time: blue 0 = like its neighbours \u2192 red 1 = distinct; ' +
      'white boxes: flagged segments';
    $('tl-cap').hidden = false;
  }
  function bodyH() { return heat ? nRows * rowH : 18; }
  function tlHeight() { return BAND + bodyH() + AXIS; }
  var labels = [], labelsHidden = 0; // the placed labels ({x, y, w, text, color}, css px)
  function shortCost(c) { // 3 significant digits or more, no exponent: 0.253, 12.5, 1569
    var a = Math.abs(c);
    return c.toFixed(a >= 100 ? 0 : a >= 10 ? 1 : a >= 1 ? 2 : 3);
  }
  function layoutLabels(w) {
    // stitch labels first, then the transitions' costs left to right, each in the first row
    // where it overlaps no label already placed (4 px apart); no room: left out
    var items = [];
    if (stitch) {
      var gapLabels = stitch.kind === 'inbetween' ? ['last frame before gap', 'first frame after gap'] : ['take-off', 'landing'];
      // a gap at the clip's start or end has no frame before or after it (null)
      if (stitch.takeoff != null) items.push({ x: mfx(stitch.motion, stitch.takeoff, w), text: gapLabels[0], color: '#4fc3f7' });
      if (stitch.landing != null) items.push({ x: mfx(stitch.motion, stitch.landing, w), text: gapLabels[1], color: '#81c784' });
    }
    var costs = graphTrans.filter(function (t) { return t.cost !== null; }).map(function (t) {
      return { x: mfx(graph.motion, t.frame, w), text: shortCost(t.cost), color: '#ff8a65' };
    }).sort(function (a, b) { return a.x - b.x; });
    items = items.concat(costs);
    tctx.font = LABEL_FONT;
    var rows = [];
    for (var r = 0; r < LABEL_ROWS; r++) rows.push([]);
    labels = []; labelsHidden = 0;
    items.forEach(function (it) {
      var tw = Math.ceil(tctx.measureText(it.text).width);
      var lx = Math.max(gutter, Math.min(it.x + 3, w - tw - 1));
      for (var r2 = 0; r2 < LABEL_ROWS; r2++) {
        var clash = rows[r2].some(function (b) { return lx < b[1] + 4 && b[0] < lx + tw + 4; });
        if (!clash) {
          rows[r2].push([lx, lx + tw]);
          labels.push({ x: lx, y: MARK_H + 1 + r2 * LABEL_H, w: tw, h: LABEL_H - 1, text: it.text, color: it.color, at: it.x });
          return;
        }
      }
      labelsHidden++;
    });
    var note = '';
    if (labelsHidden) note = labelsHidden + ' of ' + items.length + ' labels left out where the markers crowd: hover a marker for its details';
    $('tl-note').textContent = note;
  }
  function sizeTimeline() {
    if (!hasTimeline) return;
    tl.style.height = tlHeight() + 'px';
    var w = tl.clientWidth || tl.parentNode.clientWidth || 800, dpr = window.devicePixelRatio || 1;
    if (tl.width === Math.round(w * dpr) && tl.height === Math.round(tlHeight() * dpr) && labels.w === w) return;
    tl.width = Math.round(w * dpr); tl.height = Math.round(tlHeight() * dpr);
    tctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    layoutLabels(w); labels.w = w;
    drawTimeline();
  }
  // the page may gain or lose a scroll bar after the first layout: follow the strip's width
  if (hasTimeline && window.ResizeObserver) new ResizeObserver(function () { sizeTimeline(); }).observe($('timeline-wrap'));
  function fx(f, w) { return gutter + (f / Math.max(1, nFrames - 1)) * (w - gutter - 1); }
  function mfx(mi, f, w) { // a frame of motion mi on the timeline
    return fx(f / motions[mi].meta.fps * fps, w);
  }
  var axisTicks = 0;
  function drawAxis(w, y) { // seconds, a tick every 1, 2 or 5 x 10^k s, labels >= 60 px apart
    var secs = (nFrames - 1) / fps, span = w - gutter - 1, stepS = 0.01;
    var steps = [0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1, 2, 5, 10, 15, 30, 60, 120, 300, 600, 1200, 1800, 3600];
    for (var i = 0; i < steps.length; i++) { stepS = steps[i]; if (secs <= 0 || stepS / secs * span >= 60) break; }
    tctx.fillStyle = '#16171d'; tctx.fillRect(0, y, w, AXIS);
    tctx.strokeStyle = '#667'; tctx.fillStyle = '#aab'; tctx.font = LABEL_FONT; tctx.lineWidth = 1;
    tctx.beginPath(); tctx.moveTo(gutter, y + 0.5); tctx.lineTo(w, y + 0.5); tctx.stroke();
    axisTicks = 0;
    for (var ti = 0; ti * stepS <= secs + 1e-9; ti++) {
      var t = ti * stepS;
      axisTicks++;
      var x = fx(t * fps, w), s = +t.toFixed(2) + ' s', tw = tctx.measureText(s).width;
      tctx.beginPath(); tctx.moveTo(Math.round(x) + 0.5, y); tctx.lineTo(Math.round(x) + 0.5, y + 4); tctx.stroke();
      tctx.fillText(s, Math.max(gutter, Math.min(x - tw / 2, w - tw - 1)), y + AXIS - 3);
    }
    if (gutter) { tctx.fillText('time', 2, y + AXIS - 3); }
  }
  function drawTimeline() {
    if (!hasTimeline) return;
    var w = tl.clientWidth || 800, h = tlHeight(), bh = bodyH();
    tctx.clearRect(0, 0, w, h);
    tctx.fillStyle = '#262833'; tctx.fillRect(gutter, 0, w - gutter, BAND);
    if (heat) {
      tctx.imageSmoothingEnabled = false;
      var x1 = mfx(clean.motion, clean.frames - 1, w) + 1;
      tctx.drawImage(heat, gutter, BAND, x1 - gutter, nRows * rowH);
      tctx.strokeStyle = '#ffffff'; tctx.lineWidth = 1;
      clean.segments.forEach(function (s) {
        var a = mfx(clean.motion, s.start, w), b = mfx(clean.motion, s.end + 1, w);
        tctx.strokeRect(a - 0.5, BAND + s.joint * rowH - 0.5, Math.max(2, b - a) + 1, rowH + 1);
      });
      if (selJoint && selJoint.m === clean.motion) {
        tctx.fillStyle = 'rgba(255,255,255,0.25)';
        tctx.fillRect(0, BAND + selJoint.j * rowH, w, rowH);
      }
      if (nameFont) {
        var jn = motions[clean.motion].meta.names;
        tctx.font = nameFont; tctx.fillStyle = '#aab'; tctx.textBaseline = 'middle';
        for (var j = 0; j < nRows; j++) tctx.fillText(String(jn[j]), 2, BAND + (j + 0.5) * rowH, gutter - 6);
        tctx.textBaseline = 'alphabetic';
      }
    } else {
      tctx.fillStyle = '#30323d'; tctx.fillRect(gutter, BAND + 4, w - gutter, 10);
      if (clean) { // a report without its MDM: the flagged segments as red bars
        tctx.fillStyle = '#e53935';
        clean.segments.forEach(function (s) {
          var a = mfx(clean.motion, s.start, w), b = mfx(clean.motion, s.end + 1, w);
          tctx.fillRect(a, BAND + 4, Math.max(2, b - a), 10);
        });
      }
    }
    var top = BAND + bh; // markers span the band and the body, not the axis
    if (stitch) {
      var mi = stitch.motion;
      var g0 = mfx(mi, stitch.generated[0], w), g1 = mfx(mi, stitch.generated[1], w);
      tctx.fillStyle = 'rgba(255,235,59,0.45)'; tctx.fillRect(g0, 0, Math.max(2, g1 - g0), top);
      (stitch.earlier || []).forEach(function (e) {
        var e0 = mfx(mi, e.generated[0], w), e1 = mfx(mi, e.generated[1], w);
        tctx.fillRect(e0, 0, Math.max(2, e1 - e0), top);
      });
      if (stitch.takeoff != null) { tctx.fillStyle = '#4fc3f7'; tctx.fillRect(mfx(mi, stitch.takeoff, w) - 1, 0, 2, top); }
      if (stitch.landing != null) { tctx.fillStyle = '#81c784'; tctx.fillRect(mfx(mi, stitch.landing, w) - 1, 0, 2, top); }
    }
    graphTrans.forEach(function (t) {
      var a = mfx(graph.motion, t.frame, w), b = mfx(graph.motion, t.end, w);
      tctx.fillStyle = 'rgba(255,138,101,0.35)'; tctx.fillRect(a, 0, Math.max(2, b - a), top);
      tctx.fillStyle = '#ff8a65';
      tctx.beginPath(); tctx.moveTo(a - 5, 0); tctx.lineTo(a + 5, 0); tctx.lineTo(a, MARK_H); tctx.fill();
    });
    tctx.font = LABEL_FONT; tctx.textBaseline = 'top';
    labels.forEach(function (l) {
      tctx.fillStyle = 'rgba(38,40,51,0.85)'; tctx.fillRect(l.x - 1, l.y, l.w + 2, l.h);
      tctx.fillStyle = l.color; tctx.fillText(l.text, l.x, l.y);
    });
    tctx.textBaseline = 'alphabetic';
    drawAxis(w, top);
    moveCursor();
  }
  var cursor = $('tl-cursor');
  function moveCursor() { // a positioned div: moving it costs no canvas redraw
    if (!hasTimeline) return;
    var w = tl.clientWidth || 800;
    cursor.style.height = (BAND + bodyH()) + 'px';
    cursor.style.transform = 'translateX(' + (fx(frame, w) - 1).toFixed(1) + 'px)';
  }
  function tlHit(ev) {
    var r = tl.getBoundingClientRect(), x = ev.clientX - r.left, y = ev.clientY - r.top;
    var f = Math.round((x - gutter) / Math.max(1, r.width - gutter - 1) * (nFrames - 1));
    var j = null;
    if (heat && y >= BAND && y < BAND + nRows * rowH) j = Math.min(nRows - 1, Math.floor((y - BAND) / rowH));
    return { frame: Math.max(0, Math.min(nFrames - 1, f)), joint: j, x: x };
  }
  tl.addEventListener('click', function (ev) {
    var h = tlHit(ev);
    pause();
    if (h.joint !== null) selectJoint(clean.motion, h.joint);
    if (h.x >= gutter) seek(h.frame);
  });
  tl.addEventListener('mousemove', function (ev) {
    var h = tlHit(ev), s = 'frame ' + h.frame + ' \u00b7 ' + (h.frame / fps).toFixed(2) + ' s';
    if (h.joint !== null) {
      var mi = clean.motion, mf = motionFrame(motions[mi], h.frame);
      s += ' \u00b7 ' + motions[mi].meta.names[h.joint] + ' \u00b7 MDM ' + mdmAt(mf, h.joint).toFixed(2);
    }
    var w = tl.clientWidth || 800;
    if (graphTrans.length) { // the nearest transition marker within 6 px, and how many more
      var best = null, bd = 7, near = 0;
      graphTrans.forEach(function (t) {
        var d = Math.abs(mfx(graph.motion, t.frame, w) - h.x);
        if (d <= 6) { near++; if (d < bd) { bd = d; best = t; } }
      });
      if (best) {
        s += ' \u00b7 transition at frame ' + best.frame + ': ' + best.src_name + ' @' + best.src_frame + ' \u2192 ' + best.dst_name + ' @' + best.dst_frame +
          (best.cost !== null ? ', cost ' + best.cost.toFixed(3) : '') + (near > 1 ? ' (' + (near - 1) + ' more nearby: see the list below)' : '');
      }
    }
    if (stitch) {
      var mi2 = stitch.motion, mf2 = motionFrame(motions[mi2], h.frame);
      if (mf2 === stitch.takeoff) s += stitch.kind === 'inbetween' ? ' \u00b7 last frame before the gap' : ' \u00b7 take-off';
      else if (mf2 >= stitch.generated[0] && mf2 < stitch.generated[1] && stitch.kind === 'inbetween') s += ' \u00b7 filled frame ' + (mf2 - stitch.generated[0] + 1) + ' of ' + (stitch.generated[1] - stitch.generated[0]) + (stitch.data ? ' (' + base(stitch.data) + ')' : ' (Kalman)');
      else if (mf2 >= stitch.generated[0] && mf2 < stitch.generated[1]) s += ' \u00b7 injected frame ' + (mf2 - stitch.generated[0] + 1) + ' of ' + (stitch.generated[1] - stitch.generated[0]);
      else if (mf2 === stitch.landing) s += stitch.kind === 'inbetween' ? ' \u00b7 first frame after the gap' : ' \u00b7 landing (data frame ' + stitch.landingData + ')';
      else {
        var early = (stitch.earlier || []).filter(function (e) { return inRange(e.generated, mf2); })[0];
        if (early) s += ' \u00b7 filled by an earlier run, frame ' + (mf2 - early.generated[0] + 1) + ' of ' + (early.generated[1] - early.generated[0]) + (early.data ? ' (' + base(early.data) + ')' : ' (Kalman)');
      }
    }
    $('hover-info').textContent = s;
  });
  function selectJoint(mi, j) {
    selJoint = { m: mi, j: j };
    selPts.visible = true;
    var name = motions[mi].meta.names[j];
    $('hover-info').textContent = 'selected ' + name;
    $('info-sel').textContent = 'selected joint: ' + name;
    updatePose();
  }

  // ---------------------------------------------------------------- side panel
  function info(text, id) {
    var d = document.createElement('div'); d.textContent = text; if (id) d.id = id;
    $('info').appendChild(d); return d;
  }
  $('title').textContent = D.title;
  function base(p) { return String(p).split(/[\\/]/).pop(); }
  motions.forEach(function (m) {
    var s = document.createElement('span'); s.className = 'sw'; s.style.background = m.meta.color;
    $('legend').appendChild(s);
    $('legend').appendChild(document.createTextNode(base(m.meta.name) + ' (' + m.meta.frames + ' frames, ' + m.meta.fps.toFixed(3).replace(/\.?0+$/, '') + ' fps, ' + m.meta.numJoints + ' joints)'));
  });
  // each motion is drawn in metres by its own unit: say which, and where it came from
  function unitText(mm) {
    var m = (+mm.metresPerUnit.toPrecision(4)) + ' m';
    var u = mm.units === 'file' ? m : /^(m|cm|mm|inch)$/.test(mm.units) ? mm.units : mm.units + ' = ' + m;
    var said = { file: 'from the file', guessed: 'guessed from the height', given: 'given' }[mm.unitsSource];
    return 'units ' + u + (said ? ' (' + said + ')' : '');
  }
  info((D.up ? 'up axis ' + D.up + ' \u00b7 ' : '') + 'drawn in metres (grid ' + (cell === 1 ? '1 m' : '10 cm') + ' cells)');
  motions.forEach(function (m) {
    var t = base(m.meta.name) + ': ' + (m.meta.stature || m.meta.height).toFixed(2) + ' m tall \u00b7 ' + unitText(m.meta);
    if (!D.up) t += ' \u00b7 up axis ' + m.meta.up;
    if (m.gr >= 0) t += '; ground root ' + m.meta.names[m.gr] + ' drawn as the ring and arrow on the floor';
    var d = info(t);
    d.className = 'info-motion'; d.style.borderLeft = '3px solid ' + m.meta.color; d.style.paddingLeft = '5px';
  });
  info('', 'info-sel');
  if (clean) {
    info('cleaning: ' + clean.segments.length + ' flagged segment(s)' + (clean.threshold != null ? ', threshold ' + clean.threshold : '') +
      (clean.repairedCells != null ? ', ' + clean.repairedCells + ' repaired cells' : '') + '; joints of ' + base(motions[clean.motion].meta.name) + ' coloured by MDM (blue 0 \u2192 red 1)');
  }
  if (stitch && stitch.kind === 'inbetween') {
    var pct = function (w) { var r = Math.round(100 * Number(w)); return (r === 0 ? 0 : r) + '%'; };
    var segText = function (x) {
      return base(x.data) + (stitch.query && x.data === stitch.query ? ' (the take\'s own frames)' : '') + ' frames ' + x.frames[0] + '\u2013' + (x.frames[1] - 1) + (x.backwards ? ' played backwards' : '') +
        (x.rate != null && Number(x.rate) !== 1 ? ' at speed \u00d7' + Number(x.rate) : '') +
        (x.weight != null ? ' (weight ' + pct(x.weight) + ')' : '');
    };
    var blended = stitch.blended || [];
    var takes = stitch.takes || [];  // the shares summed by take (viewer.py: weighing_takes)
    var from = !stitch.data ? (stitch.requested === 'kalman' ? 'by the Kalman transition (asked for)' :
        stitch.note ? 'by the Kalman transition (' + stitch.note + ')' :
        stitch.unlike ? 'by the Kalman transition (' + stitch.warning.replace(/^(.*) (holds?) nothing like the motion around the gap \((.*)\); the Kalman transition filled the gap$/, '$1 $2 nothing like the motion around the gap: $3') + ')' :
        'by the Kalman transition (the library fill was far less smooth at the junctions)') :
      blended.length > 1 ? 'by combining ' + blended.length + ' segments of ' + (takes.length + (stitch.takesAtZero || 0)) + ' take(s), by take: ' +
        takes.map(function (t) { return t.name + ' ' + pct(t.share); }).join(', ') +
        (stitch.takesAtZero ? ', ' + stitch.takesAtZero + ' more take(s) at 0%' : '') +
        ' (weighted by how well each matches, corrected for what they share in missing the clip; some may count negatively); largest share: ' +
        segText(blended.reduce(function (m, x) { return x.weight > m.weight ? x : m; })) + '; every segment in the sidecar' :
      'from ' + segText({data: stitch.data, frames: stitch.sourceFrames, backwards: stitch.backwards}) +
        (stitch.motionKept != null ? ' alone (combined, the best segments would keep ' + pct(stitch.motionKept) +
          ' of their own motion: a standing take\'s strokes out of step cancel)' : '');
    if (stitch.data && stitch.gaitShare) {
      from += '; ' + (stitch.gaitShare < 0.005 ? 'under 1%' : pct(stitch.gaitShare)) +
        ' of its pose carries on the clip\'s own gait (the frames before the gap, mirrored every half cycle, fitted: ' +
        Number(stitch.gaitHalfPeriod).toFixed(2) + ' s)';
    }
    info('in-betweening: frames ' + stitch.generated[0] + '\u2013' + (stitch.generated[1] - 1) + ' (--gap ' + stitch.generated[0] + ':' + stitch.generated[1] + ') filled (drawn yellow) ' + from +
      (stitch.lscore == null ? '' : (stitch.takeoff == null || stitch.landing == null) ?
        '; L-score of its one junction with the clip (a gap at the clip\'s ' + (stitch.takeoff == null ? 'start' : 'end') + ') ' + Number(stitch.lscore).toPrecision(4) :
        '; two-sided L-score of the filled frames ' + Number(stitch.lscore).toPrecision(4)));
    if (stitch.earlier && stitch.earlier.length) {
      info('filled by earlier runs on this take (drawn yellow too): ' + stitch.earlier.map(function (e) {
        return 'frames ' + e.generated[0] + '\u2013' + (e.generated[1] - 1) + (e.data ? ' from ' + base(e.data) : ' (Kalman)');
      }).join('; '));
    }
    if (stitch.warning && stitch.data) info('warning: ' + stitch.warning).style.color = '#ffb74d';  // a library fill's
    if (stitch.feetWarning) info('warning: ' + stitch.feetWarning).style.color = '#ffb74d';  // whatever filled it
  } else if (stitch) {
    // a cut (k = 0) has no injected frame: its yellow frames are the landing eased in; a
    // cross-fade's are the blend
    var made = stitch.method === 'crossfade' ? 'blended frames ' : (stitch.k === 0 ? 'eased frames ' : 'injected frames ');
    var what = stitch.method === 'crossfade' ? 'cross-fade' : (stitch.k === 0 ? 'a cut, k = 0' : 'k = ' + stitch.k);
    info('stitch: take-off ' + stitch.takeoff + ', ' + made + stitch.generated[0] + '\u2013' + (stitch.generated[1] - 1) +
      ' (' + what + ', drawn yellow), landing ' + stitch.landing + (stitch.lscore != null ? ', L* = ' + Number(stitch.lscore).toPrecision(4) : ''));
    if (stitch.lscoreByK.length) { $('lk-wrap').hidden = false; drawLk(); }
  }
  if (graph) {
    info('motion graph: ' + graph.transitions.length + ' transition(s) taken by ' + motions[graph.motion].meta.name +
      ' (of ' + graph.numTransitions + ' in the graph)' + (graph.missingClips.length ? '; clips not found: ' + graph.missingClips.join(', ') : ''));
    graph.transitions.forEach(function (t) {
      var d = document.createElement('div');
      d.textContent = 'frame ' + t.frame + ': ' + t.src_name + ' @' + t.src_frame + ' \u2192 ' + t.dst_name + ' @' + t.dst_frame +
        (t.cost !== null ? ' (cost ' + t.cost.toFixed(3) + ')' : ' (no matching graph transition)');
      d.addEventListener('click', function () { pause(); seek(t.frame / motions[graph.motion].meta.fps * fps); });
      $('transitions').appendChild(d);
    });
  }
  function drawLk() {
    var c = $('lk'), x = c.getContext('2d'), L = stitch.lscoreByK, W = c.width, H = c.height;
    var pad = 28, finite = L.filter(isFinite), lo = Math.min.apply(null, finite), hi = Math.max.apply(null, finite);
    if (!(hi > lo)) { hi = lo + 1; }
    x.clearRect(0, 0, W, H);
    x.strokeStyle = '#667'; x.strokeRect(pad, 6, W - pad - 6, H - pad - 6);
    var px = function (k) { return pad + (k / Math.max(1, L.length - 1)) * (W - pad - 8); };
    var py = function (v) { return 6 + (1 - (v - lo) / (hi - lo)) * (H - pad - 8); };
    x.strokeStyle = '#4fc3f7'; x.lineWidth = 1.5; x.beginPath();
    var started = false;
    L.forEach(function (v, k) { if (!isFinite(v)) return; if (!started) { x.moveTo(px(k), py(v)); started = true; } else x.lineTo(px(k), py(v)); });
    x.stroke();
    if (stitch.k < L.length && isFinite(L[stitch.k])) {
      x.fillStyle = '#ffeb3b'; x.beginPath(); x.arc(px(stitch.k), py(L[stitch.k]), 4, 0, 7); x.fill();
    }
    x.fillStyle = '#aab'; x.font = '10px sans-serif';
    x.fillText('k = 0', pad, H - 10); x.fillText(String(L.length - 1), W - 22, H - 10);
    x.fillText('k* = ' + stitch.k, px(stitch.k) + 6, 18);
    x.fillText(hi.toPrecision(3), 0, 14); x.fillText(lo.toPrecision(3), 0, H - pad);
  }

  // ---------------------------------------------------------------- controls
  var scr = $('scrubber');
  scr.max = String(nFrames - 1);
  scr.addEventListener('input', function () { pause(); seek(+scr.value); });
  $('play').addEventListener('click', function () { if (playing) pause(); else play(); });
  $('speed').addEventListener('change', function () { speed = +$('speed').value; });
  $('loop').addEventListener('change', function () { loop = $('loop').checked; });
  $('follow').addEventListener('change', function () { follow = $('follow').checked; lastCentre = centre(); });
  $('side').addEventListener('change', function () { sideBySide = $('side').checked; layout(); updatePose(); fitCamera(); });
  window.addEventListener('keydown', function (ev) {
    if (ev.target && ev.target.tagName === 'INPUT' && ev.target.type !== 'checkbox') return;
    if (ev.code === 'Space') { ev.preventDefault(); if (playing) pause(); else play(); }
    else if (ev.code === 'ArrowRight') { pause(); seek(frame + 1); }
    else if (ev.code === 'ArrowLeft') { pause(); seek(frame - 1); }
  });
  window.addEventListener('resize', resize);

  // ---------------------------------------------------------------- loop
  var stats = { t0: null, n: 0, last: null, worst: 0 };
  function tick(now) {
    requestAnimationFrame(tick);
    if (stats.t0 === null) stats.t0 = now;
    else { stats.n++; stats.worst = Math.max(stats.worst, now - stats.last); }
    stats.last = now;
    if (playing) {
      if (lastNow !== null) tPlay += (now - lastNow) / 1000 * speed;
      lastNow = now;
      var f = Math.floor(tPlay * fps + 1e-6);
      if (f >= nFrames) {
        if (loop) { tPlay = tPlay % (nFrames / fps); f = Math.floor(tPlay * fps + 1e-6) % nFrames; }
        else { f = nFrames - 1; pause(); }
      }
      if (f !== frame) { setFrame(f); moveCursor(); }
    }
    controls.update();
    grid.position.x = Math.round(controls.target.x / cell) * cell;
    grid.position.z = Math.round(controls.target.z / cell) * cell;
    renderer.render(scene, camera);
  }

  // a fill's page opens a second before the filled frames: playing it shows the fill at once
  var startFrame = 0;
  if (stitch && stitch.kind === 'inbetween') {
    var fillFps = motions[stitch.motion].meta.fps;
    startFrame = Math.max(0, Math.min(nFrames - 1, Math.round((stitch.generated[0] - fillFps) / fillFps * fps)));
  }
  setFrame(startFrame);
  tPlay = startFrame / fps;
  resize();
  fitCamera();
  requestAnimationFrame(tick);

  window.mocapkitViewer = {
    get frame() { return frame; },
    get playing() { return playing; },
    nFrames: nFrames,
    fps: fps,
    data: D,
    play: play,
    pause: pause,
    seek: seek,
    setSpeed: function (s) { speed = s; },
    selectJoint: selectJoint,
    groupX: function (mi) { return motions[mi].group.position.x; },
    jointColor: function (mi, j) { var C = motions[mi].colBuf; return [C[3 * j], C[3 * j + 1], C[3 * j + 2]]; },
    boneColor: function (mi, k) { var B = motions[mi].boneCol, b = 3 * (k || 0); return [B[b], B[b + 1], B[b + 2]]; },
    bones: function (mi) { return motions[mi || 0].bones.map(function (b) { return b.slice(); }); },
    groundMarker: function (mi) {
      var m = motions[mi || 0];
      if (!m.marker) return null;
      return { visible: m.marker.visible, x: m.marker.position.x + m.group.position.x, y: m.marker.position.y, z: m.marker.position.z + m.group.position.z, heading: m.marker.rotation.y };
    },
    screenPoint: function (j, mi) { // client coordinates (CSS px) of joint j of motion mi now
      var m = motions[mi || 0], o = (m.frame * m.n + j) * 3;
      controls.update(); camera.updateMatrixWorld();
      var v = new THREE.Vector3(m.P[o] + m.group.position.x, m.P[o + 1], m.P[o + 2] + m.group.position.z).project(camera);
      var r = renderer.domElement.getBoundingClientRect();
      return { x: r.left + (v.x + 1) / 2 * r.width, y: r.top + (1 - v.y) / 2 * r.height, depth: v.z };
    },
    stageRect: function () {
      var r = renderer.domElement.getBoundingClientRect();
      return { x: r.left, y: r.top, width: r.width, height: r.height };
    },
    timelinePoint: function (f, j) { // client coordinates of (frame, joint) on the timeline
      var r = tl.getBoundingClientRect();
      return { x: r.left + fx(f, r.width), y: r.top + (j === null || j === undefined ? BAND / 2 : BAND + (j + 0.5) * rowH) };
    },
    timelineLayout: function () {
      return { band: BAND, rowH: rowH, gutter: gutter, names: !!nameFont, axis: hasTimeline ? AXIS : 0, ticks: axisTicks };
    },
    timelineShown: function () { return hasTimeline && !$('timeline-wrap').hidden; },
    timelineLabels: function () { // the labels drawn on the timeline, client coordinates
      var r = tl.getBoundingClientRect();
      return { hidden: labelsHidden, labels: labels.map(function (l) {
        return { x: r.left + l.x, y: r.top + l.y, width: l.w, height: l.h, text: l.text, at: r.left + l.at };
      }) };
    },
    fpsStats: function () {
      var el = stats.last - stats.t0;
      return { fps: el > 0 ? stats.n / el * 1000 : 0, frames: stats.n, ms: el, worstMs: stats.worst };
    },
    resetStats: function () { stats = { t0: null, n: 0, last: null, worst: 0 }; },
    errors: window.__mkErrors,
    three: { scene: scene, camera: camera, controls: controls, renderer: renderer, grid: grid, motions: motions },
    ready: true
  };
  document.body.setAttribute('data-ready', '1');
})();
