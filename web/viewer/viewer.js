// Doppel's web viewer: draws the shapes of GET /api/scene with three.js (field frame: x towards
// the yellow goal, z up, m), shows GET /api/state and GET /api/buses, and sends the simulation
// control requests of control/http_api.h. Plain script (three.js r111 from Debian is not a module).
'use strict';

(function () {
  const SCENE_PERIOD_MS = 50;   // 20 Hz: doppel publishes the scene at most 30 times a second
  const STATE_PERIOD_MS = 100;  // 10 Hz
  const BUSES_PERIOD_MS = 500;
  const CAMERA_PERIOD_MS = 300;  // doppel renders a still at most every 250 ms per camera  // the bus threads publish their servo tables every 100 ms
  const PUSH_N = 30, PUSH_MS = 200;
  const PLOT_WINDOW_S = 10;     // the rolling plots show the last 10 s of simulation time
  const FRUSTUM_DEPTH_M = 0.4;  // how far the camera frustums reach into the field
  // Hardware Error Status bits (Protocol 2.0 e-Manual, X series, address 70).
  const ERROR_BITS = { 0: 'input voltage', 2: 'overheating', 3: 'motor encoder', 4: 'electrical shock', 5: 'overload' };

  const $ = (id) => document.getElementById(id);
  const canvas = $('canvas');
  const view = $('view');

  // --- three.js scene -------------------------------------------------------------------------
  const renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
  renderer.setPixelRatio(window.devicePixelRatio || 1);
  const scene = new THREE.Scene();
  scene.background = new THREE.Color(0x223344);
  const camera = new THREE.PerspectiveCamera(45, 1, 0.02, 100);
  camera.up.set(0, 0, 1);  // before the controls: they orbit about camera.up
  camera.position.set(-2.6, -3.2, 2.0);
  const controls = new THREE.OrbitControls(camera, canvas);
  controls.target.set(-1.0, -0.8, 0.2);
  controls.enableDamping = false;
  controls.update();
  scene.add(new THREE.HemisphereLight(0xffffff, 0x445544, 0.75));
  const sun = new THREE.DirectionalLight(0xffffff, 0.6);
  sun.position.set(2, -3, 6);
  scene.add(sun);

  let meshes = [];        // one per shape of /api/scene, in its order
  let shapeKey = '';      // types and kinds of the shapes the meshes were built for
  let carpet = [];        // meshes a click may place a robot on
  let robotIds = new Set();
  let frames = 0;
  let sceneUpdates = 0;
  let lastScene = null;
  let lastState = null;
  let lastBuses = null;
  let lastReplay = null;   // GET /api/replay's answer; null for a live doppel
  let selectedRobot = 0;
  let placing = false;

  function material(shape) {
    const [r, g, b] = shape.rgb;
    const options = { color: new THREE.Color(r / 255, g / 255, b / 255) };
    if (shape.kind === 'goal_net') Object.assign(options, { transparent: true, opacity: 0.35, depthWrite: false });
    return new THREE.MeshLambertMaterial(options);
  }

  // A mesh whose local frame is the shape frame of control::SceneShape.
  function makeMesh(shape) {
    const [a, b, c] = shape.size;
    const mat = material(shape);
    switch (shape.type) {
      case 'box':
        return new THREE.Mesh(new THREE.BoxBufferGeometry(a, b, c), mat);
      case 'sphere':
        return new THREE.Mesh(new THREE.SphereBufferGeometry(a, 24, 16), mat);
      case 'cylinder': {
        const geometry = new THREE.CylinderBufferGeometry(a, a, b, 24);
        geometry.rotateX(Math.PI / 2);  // three's cylinders run along y, the shape's along z
        return new THREE.Mesh(geometry, mat);
      }
      case 'capsule': {  // r111 has no capsule: a cylinder and two spheres
        const group = new THREE.Group();
        const body = new THREE.CylinderBufferGeometry(a, a, b, 20);
        body.rotateX(Math.PI / 2);
        group.add(new THREE.Mesh(body, mat));
        for (const z of [-b / 2, b / 2]) {
          const end = new THREE.Mesh(new THREE.SphereBufferGeometry(a, 20, 12), mat);
          end.position.z = z;
          group.add(end);
        }
        return group;
      }
      case 'ring': {
        const geometry = new THREE.RingBufferGeometry(b, a, 64);
        geometry.translate(0, 0, c / 2);  // its top face, where the flat boxes of the lines end too
        return new THREE.Mesh(geometry, mat);
      }
      case 'convex': {  // a URDF mesh's hull: its triangles as sent
        const geometry = new THREE.BufferGeometry();
        geometry.setAttribute('position', new THREE.Float32BufferAttribute(shape.vertices, 3));
        geometry.setIndex(shape.triangles);
        geometry.computeVertexNormals();
        return new THREE.Mesh(geometry, mat);
      }
      default:
        return new THREE.Mesh(new THREE.BoxBufferGeometry(a || 0.05, b || 0.05, c || 0.05), mat);
    }
  }

  function build(shapes) {
    for (const mesh of meshes) scene.remove(mesh);
    meshes = [];
    carpet = [];
    robotIds = new Set();
    for (const shape of shapes) {
      const mesh = makeMesh(shape);
      mesh.userData = { kind: shape.kind, object: shape.object };
      meshes.push(mesh);
      scene.add(mesh);
      if (shape.kind === 'carpet') carpet.push(mesh);
      if (shape.kind === 'robot') robotIds.add(shape.object);
    }
    shapeKey = shapes.map((s) => s.type + s.kind).join();
  }

  function applyScene(answer) {
    const shapes = answer.shapes;
    if (meshes.length !== shapes.length || shapes.map((s) => s.type + s.kind).join() !== shapeKey) build(shapes);
    for (let i = 0; i < shapes.length; ++i) {
      const shape = shapes[i];
      const mesh = meshes[i];
      mesh.position.set(shape.p[0], shape.p[1], shape.p[2]);
      mesh.quaternion.set(shape.q[0], shape.q[1], shape.q[2], shape.q[3]);
    }
    lastScene = answer;
    ++sceneUpdates;
  }

  // --- camera frustums (state: robots[].cameras[] with pose and corner rays) --------------------
  let frustums = [];  // one LineSegments per camera, in state order
  let frustumKey = '';
  function makeFrustum(corners, colour) {
    const points = [];
    const far = corners.map(([x, y, z]) => [x * FRUSTUM_DEPTH_M, y * FRUSTUM_DEPTH_M, z * FRUSTUM_DEPTH_M]);
    for (let i = 0; i < 4; ++i) {
      points.push(0, 0, 0, ...far[i]);              // apex to corner
      points.push(...far[i], ...far[(i + 1) % 4]);  // the image rectangle
    }
    points.push(...far[0], ...far[2]);  // a cross on the top-left to bottom-right diagonal marks "up"
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute('position', new THREE.Float32BufferAttribute(points, 3));
    const lines = new THREE.LineSegments(geometry, new THREE.LineBasicMaterial({ color: colour }));
    // The top edge (first corner to second) in a second colour shows which way is up in the image.
    const top = new THREE.BufferGeometry();
    top.setAttribute('position', new THREE.Float32BufferAttribute([...far[0], ...far[1]], 3));
    lines.add(new THREE.LineSegments(top, new THREE.LineBasicMaterial({ color: 0xff4040 })));
    return lines;
  }
  function applyFrustums(state) {
    const cameras = [];
    for (const robot of state.robots) for (const cam of robot.cameras || []) cameras.push(cam);
    const key = cameras.map((c) => c.name + c.corners.flat().join(',')).join(';');
    if (key !== frustumKey) {
      for (const f of frustums) scene.remove(f);
      frustums = cameras.map((c) => makeFrustum(c.corners, 0xffee55));
      for (const f of frustums) scene.add(f);
      frustumKey = key;
    }
    cameras.forEach((c, i) => {
      frustums[i].position.set(c.p[0], c.p[1], c.p[2]);
      frustums[i].quaternion.set(c.q[0], c.q[1], c.q[2], c.q[3]);
    });
  }

  function resize() {
    const width = view.clientWidth, height = view.clientHeight;
    if (canvas.width !== Math.floor(width * renderer.getPixelRatio()) || canvas.height !== Math.floor(height * renderer.getPixelRatio())) {
      renderer.setSize(width, height, false);
      camera.aspect = width / Math.max(height, 1);
      camera.updateProjectionMatrix();
    }
  }

  function render() {
    resize();
    controls.update();
    renderer.render(scene, camera);
    ++frames;
    requestAnimationFrame(render);
  }
  requestAnimationFrame(render);

  // --- the API ---------------------------------------------------------------------------------
  function showError(text) {
    const box = $('error');
    box.textContent = text;
    box.hidden = false;
  }
  function clearError() { $('error').hidden = true; }

  // A request to doppel; throws Error with the API's message (or why it did not answer). Every
  // request that changes something is JSON, a DELETE without a body too: doppel refuses any other
  // (docs/security.md). The token travels in the page's cookie.
  async function api(method, path, body) {
    let response;
    try {
      response = await fetch(path, {
        method,
        headers: method !== 'GET' ? { 'Content-Type': 'application/json' } : {},
        body: body !== undefined ? JSON.stringify(body) : undefined,
        cache: 'no-store',
      });
    } catch (e) {
      throw new Error(`${method} ${path}: doppel does not answer (${e.message})`);
    }
    let answer = null;
    try { answer = await response.json(); } catch (e) { /* not JSON */ }
    if (!response.ok) {
      const why = answer && answer.error ? answer.error : response.statusText;
      throw new Error(`${method} ${path}: ${response.status} ${why}`);
    }
    return answer;
  }

  // A control request from a button: its error goes to the error box.
  async function command(path, body, done) {
    try {
      const answer = await api('POST', path, body || {});
      clearError();
      if (answer && answer.robots) applyState(answer);
      $('message').textContent = done || '';
      return true;
    } catch (e) {
      showError(e.message);
      return false;
    }
  }

  // Polls `path` every `period` ms, never two requests at once.
  function poll(path, period, apply) {
    let busy = false;
    let failing = false;
    setInterval(async () => {
      if (busy) return;
      busy = true;
      try {
        apply(await api('GET', path));
        if (failing) clearError();
        failing = false;
      } catch (e) {
        failing = true;
        showError(e.message);
      } finally {
        busy = false;
      }
    }, period);
  }

  // --- panels ----------------------------------------------------------------------------------
  function fixed(x, digits) {
    if (typeof x !== 'number') return '–';
    const text = x.toFixed(digits);
    return Object.is(Number(text), -0) ? text.slice(1) : text;  // "-0.00" -> "0.00"
  }

  // A rolling plot of a few series over simulation time, drawn on a canvas (no library).
  class Plot {
    constructor(title, unit, series) {  // series: [{label, colour, width}]
      this.series = series;
      this.unit = unit;
      this.samples = [];  // [t, v0, v1, ...]
      this.box = document.createElement('div');
      const caption = document.createElement('div');
      caption.className = 'plot-title';
      caption.textContent = title;
      this.canvas = document.createElement('canvas');
      this.canvas.width = 300;
      this.canvas.height = 60;
      this.box.append(caption, this.canvas);
    }
    push(t, values) {
      const last = this.samples[this.samples.length - 1];
      if (last && t <= last[0]) {
        if (t < last[0]) this.samples = [];  // time went back: a new doppel
        else return;                          // paused: nothing new
      }
      this.samples.push([t, ...values]);
      while (this.samples.length > 0 && this.samples[0][0] < t - PLOT_WINDOW_S) this.samples.shift();
    }
    draw() {
      const ctx = this.canvas.getContext('2d');
      const w = this.canvas.width, h = this.canvas.height, top = 12, bottom = h - 2;
      ctx.fillStyle = '#ffffff';
      ctx.fillRect(0, 0, w, h);
      if (this.samples.length === 0) return;
      // The last PLOT_WINDOW_S, or all there is while there is less (the plot fills its width).
      const t1 = this.samples[this.samples.length - 1][0];
      const t0 = Math.min(this.samples[0][0], t1 - 0.5), span = t1 - t0;
      let lo = Infinity, hi = -Infinity;
      for (const s of this.samples) for (let k = 1; k < s.length; ++k) { lo = Math.min(lo, s[k]); hi = Math.max(hi, s[k]); }
      if (hi - lo < 1e-6) { lo -= 0.5; hi += 0.5; }
      const pad = 0.05 * (hi - lo);
      lo -= pad; hi += pad;
      const x = (t) => (t - t0) / span * (w - 1);
      const y = (v) => bottom - (v - lo) / (hi - lo) * (bottom - top);
      if (lo < 0 && hi > 0) {  // the zero line
        ctx.strokeStyle = '#bbb';
        ctx.lineWidth = 1;
        ctx.beginPath();
        ctx.moveTo(0, y(0));
        ctx.lineTo(w, y(0));
        ctx.stroke();
      }
      this.series.forEach((series, k) => {
        ctx.strokeStyle = series.colour;
        ctx.lineWidth = series.width || 1;
        ctx.beginPath();
        this.samples.forEach((s, i) => (i === 0 ? ctx.moveTo(x(s[0]), y(s[k + 1])) : ctx.lineTo(x(s[0]), y(s[k + 1]))));
        ctx.stroke();
      });
      ctx.font = '10px sans-serif';
      let lx = 2;
      for (const series of this.series) {
        ctx.fillStyle = series.colour;
        ctx.fillText(series.label, lx, 10);
        lx += ctx.measureText(series.label).width + 6;
      }
      ctx.fillStyle = '#555';
      const range = `${fixed(lo, 1)}…${fixed(hi, 1)} ${this.unit}, ${fixed(span, 1)} s`;
      ctx.fillText(range, w - ctx.measureText(range).width - 2, 10);
    }
  }

  let plots = null;  // {robot, key, imus: [[angles, gyro]], feet: [plot]}
  const DEG = 180 / Math.PI;
  const CELL_COLOURS = ['#1f77b4', '#ff7f0e', '#2ca02c', '#9467bd'];
  function applyPlots(state) {
    const robot = state.robots[selectedRobot];
    const container = $('plots');
    const imus = (robot && robot.imus) || [], feet = (robot && robot.feet) || [];
    const key = `${selectedRobot}:` + imus.map((i) => i.name).join() + '/' + feet.map((f) => f.name).join();
    if (!plots || plots.key !== key) {
      container.innerHTML = '';
      $('sensor-robot').textContent = robot ? `${selectedRobot} '${robot.name}'` : '';
      plots = { key, imus: [], feet: [] };
      for (const imu of imus) {
        const angles = new Plot(`${imu.name} (ID ${imu.id}): roll, pitch`, '°',
                                [{ label: 'roll', colour: '#d62728' }, { label: 'pitch', colour: '#1f77b4' }]);
        const gyro = new Plot(`${imu.name} (ID ${imu.id}): gyro`, '°/s',
                              ['x', 'y', 'z'].map((a, k) => ({ label: a, colour: ['#d62728', '#2ca02c', '#1f77b4'][k] })));
        plots.imus.push([angles, gyro]);
        container.append(angles.box, gyro.box);
      }
      for (const foot of feet) {
        const plot = new Plot(`${foot.name} (ID ${foot.id}): total and cells FL FR BL BR`, 'N',
                              [{ label: 'total', colour: '#000', width: 2 },
                               ...['FL', 'FR', 'BL', 'BR'].map((c, k) => ({ label: c, colour: CELL_COLOURS[k] }))]);
        plots.feet.push(plot);
        container.append(plot.box);
      }
      if (imus.length === 0 && feet.length === 0) {
        container.innerHTML = '<div class="none">no IMU or foot board in the world for this robot</div>';
      }
    }
    imus.forEach((imu, i) => {
      plots.imus[i][0].push(state.sim_time_s, [imu.roll * DEG, imu.pitch * DEG]);
      plots.imus[i][1].push(state.sim_time_s, imu.gyro.map((g) => g * DEG));
      plots.imus[i][0].draw();
      plots.imus[i][1].draw();
    });
    feet.forEach((foot, i) => {
      plots.feet[i].push(state.sim_time_s, [foot.total, ...foot.cells]);
      plots.feet[i].draw();
    });
  }

  // The camera list of the state in the select; the chosen one's still is polled as PNG.
  let cameraImages = 0;
  function applyCameraList(state) {
    const select = $('camera-name');
    const names = [];
    for (const robot of state.robots) for (const cam of robot.cameras || []) names.push(cam.name);
    if (lastReplay) for (const name of lastReplay.cameras || []) if (!names.includes(name)) names.push(name);
    if (select.dataset.names !== names.join()) {
      const chosen = select.value;
      select.innerHTML = '';
      for (const name of names) select.add(new Option(name, name));
      if (names.length > 0) select.add(new Option('off', ''));  // no stills: doppel renders none
      if (names.includes(chosen) || (chosen === '' && select.dataset.names !== undefined)) select.value = chosen;
      select.dataset.names = names.join();
      if (names.length === 0) $('camera-image').alt = 'no robot camera';
    }
  }
  let cameraBusy = false;
  setInterval(() => {
    const name = $('camera-name').value;
    if (!name || cameraBusy) return;
    cameraBusy = true;
    fetch(`/api/camera/${encodeURIComponent(name)}`, { cache: 'no-store' }).then(async (response) => {
      if (!response.ok) {
        const answer = await response.json().catch(() => ({}));
        throw new Error(`GET /api/camera/${name}: ${response.status} ${answer.error || response.statusText}`);
      }
      const time = Number(response.headers.get('X-Sim-Time'));
      const blob = await response.blob();
      const image = $('camera-image');
      const old = image.src;
      image.src = URL.createObjectURL(blob);
      if (old.startsWith('blob:')) URL.revokeObjectURL(old);
      $('camera-time').textContent = `at ${fixed(time, 2)} s`;
      ++cameraImages;
    }).catch((e) => showError(e.message)).finally(() => { cameraBusy = false; });
  }, CAMERA_PERIOD_MS);

  function applyState(state) {
    lastState = state;
    applyFrustums(state);
    applyCameraList(state);
    applyPlots(state);
    $('sim-time').textContent = fixed(state.sim_time_s, 3);
    $('paused').textContent = state.paused ? (state.steps_left > 0 ? 'stepping' : 'paused') : 'running';
    const body = $('robots').tBodies[0];
    if (body.rows.length !== state.robots.length) {
      body.innerHTML = '';
      state.robots.forEach((robot, r) => {
        const row = body.insertRow();
        row.innerHTML = `<td><input type="radio" name="robot" value="${r}"></td><td>${r}</td><td class="text"></td>` +
                        '<td></td><td></td><td></td><td class="text"></td>';
        row.cells[2].textContent = robot.name;
        row.querySelector('input').addEventListener('change', () => { selectedRobot = r; });
      });
    }
    state.robots.forEach((robot, r) => {
      const row = body.rows[r];
      row.querySelector('input').checked = r === selectedRobot;
      row.cells[3].textContent = robot.simulated ? fixed(robot.pose.x, 2) : '–';
      row.cells[4].textContent = robot.simulated ? fixed(robot.pose.y, 2) : '–';
      row.cells[5].textContent = robot.simulated ? fixed(robot.pose.yaw * 180 / Math.PI, 0) : '–';
      row.cells[6].textContent = !robot.simulated ? 'no body' : robot.fallen ? 'fallen' : robot.held ? 'held' : 'upright';
      row.className = robot.fallen ? 'fallen' : '';
    });
  }

  function errorText(error) {
    if (error === null || error === undefined) return ['–', ''];
    const names = Object.keys(ERROR_BITS).filter((bit) => error & (1 << bit)).map((bit) => ERROR_BITS[bit]);
    return ['0x' + error.toString(16).padStart(2, '0'), names.join(', ')];
  }

  // Bus counters of /api/buses: key, column, what it counts, whether a non-zero value is bad.
  const COUNTERS = [
    ['packets', 'packets', 'instruction packets framed', false],
    ['replies', 'replies', 'instructions answered with a status packet', false],
    ['bad_checksums', 'bad sum', 'packets with a wrong checksum', true],
    ['collisions', 'collisions', 'replies of several devices at once on the wire', true],
    ['timeouts', 'timeouts', 'partial packets dropped by the inter-byte timeout', true],
    ['dropped_replies', 'dropped', 'replies dropped because the client did not read', true],
    ['late_deliveries', 'late', 'status packets written after the late threshold', true],
    ['max_lateness_us', 'worst µs', 'worst lateness of a status packet, µs', false],
  ];

  function applyBuses(buses) {
    lastBuses = buses;
    const container = $('buses');
    const wanted = buses.map((b) => `${b.robot}/${b.bus}/${b.servos.length}`).join();
    if (container.dataset.layout !== wanted) {
      container.innerHTML = '';
      for (const bus of buses) {
        const box = document.createElement('div');
        const title = document.createElement('h3');
        title.textContent = `robot ${bus.robot} '${bus.robot_name}', bus ${bus.bus} (${bus.link})`;
        const counters = document.createElement('table');
        counters.className = 'bus-counters';
        counters.innerHTML = '<thead><tr>' + COUNTERS.map(([, label, hint]) => `<th title="${hint}">${label}</th>`).join('') +
                             '</tr></thead><tbody><tr>' + COUNTERS.map(() => '<td></td>').join('') + '</tr></tbody>';
        const table = document.createElement('table');
        table.className = 'servo-table';
        table.innerHTML = '<thead><tr><th>ID</th><th class="text">name</th><th class="text">model</th><th>torque</th>' +
                          '<th>goal</th><th>present</th><th>speed</th><th>load</th><th>temp °C</th><th>voltage V</th>' +
                          '<th>error</th></tr></thead><tbody></tbody>';
        for (let i = 0; i < bus.servos.length; ++i) {
          const row = table.tBodies[0].insertRow();
          for (let c = 0; c < 11; ++c) row.insertCell().className = c === 1 || c === 2 ? 'text' : '';
        }
        box.append(title, counters, table);
        container.append(box);
      }
      container.dataset.layout = wanted;
    }
    const tables = container.querySelectorAll('table.servo-table');
    const counterTables = container.querySelectorAll('table.bus-counters');
    buses.forEach((bus, b) => {
      const cells = counterTables[b].tBodies[0].rows[0].cells;
      COUNTERS.forEach(([key, , , bad], c) => {
        const value = bus.counters ? bus.counters[key] : undefined;
        cells[c].textContent = value === undefined ? '–' : key === 'max_lateness_us' ? value.toFixed(0) : value;
        cells[c].className = bad && value > 0 ? 'bad' : '';
      });
      bus.servos.forEach((servo, i) => {
        const cells = tables[b].tBodies[0].rows[i].cells;
        const [error, names] = errorText(servo.error);
        const values = [servo.id, servo.name, servo.model, servo.torque ? 'on' : 'off', servo.goal_position,
                        servo.present_position, servo.present_speed, servo.present_load, servo.temperature,
                        servo.voltage >= 0 ? (servo.voltage / 10).toFixed(1) : '–', error];
        values.forEach((value, c) => { cells[c].textContent = value; });
        cells[3].className = servo.torque ? 'torque-on' : '';
        cells[10].className = servo.error > 0 ? 'error-set' : '';
        cells[10].title = names;
      });
    });
  }

  // --- controls --------------------------------------------------------------------------------
  $('pause').addEventListener('click', () => command('/api/pause', {}, 'paused'));
  $('resume').addEventListener('click', () => command('/api/resume', {}, 'running'));
  $('step').addEventListener('click', () => command('/api/step', { ms: 100 }, 'stepped 100 ms'));
  $('reset').addEventListener('click', () => command('/api/reset', {}, 'reset'));
  $('place-mode').addEventListener('click', () => {
    placing = !placing;
    $('place-mode').classList.toggle('active', placing);
    view.classList.toggle('placing', placing);
  });
  for (const button of document.querySelectorAll('#push-buttons button')) {
    button.addEventListener('click', () => {
      const fx = Number(button.dataset.fx), fy = Number(button.dataset.fy);
      command('/api/push', { robot: selectedRobot, fx, fy, fz: 0, ms: PUSH_MS }, `pushed robot ${selectedRobot}: ${fx} N x, ${fy} N y`);
    });
  }

  // The carpet point under canvas pixel (x, y), field frame; null when the ray misses it.
  function carpetPoint(clientX, clientY) {
    const rect = canvas.getBoundingClientRect();
    const ndc = new THREE.Vector2(((clientX - rect.left) / rect.width) * 2 - 1, -((clientY - rect.top) / rect.height) * 2 + 1);
    const ray = new THREE.Raycaster();
    ray.setFromCamera(ndc, camera);
    const hits = ray.intersectObjects(carpet, true);
    return hits.length > 0 ? hits[0].point : null;
  }

  // Places the selected robot at field (x, y), keeping its heading.
  function placeAt(x, y) {
    const robot = lastState && lastState.robots[selectedRobot];
    const yaw = robot && robot.simulated ? robot.pose.yaw : 0;
    return command('/api/place', { robot: selectedRobot, x, y, yaw },
                   `placed robot ${selectedRobot} at (${x.toFixed(2)}, ${y.toFixed(2)})`);
  }

  // A click (not a drag) with shift or in place mode places the selected robot.
  let down = null;
  canvas.addEventListener('pointerdown', (e) => { down = { x: e.clientX, y: e.clientY }; });
  canvas.addEventListener('pointerup', (e) => {
    if (down === null) return;
    const moved = Math.hypot(e.clientX - down.x, e.clientY - down.y);
    down = null;
    if (moved > 4 || !(e.shiftKey || placing)) return;
    const point = carpetPoint(e.clientX, e.clientY);
    if (point === null) {
      showError('place: that is not on the carpet');
      return;
    }
    placeAt(point.x, point.y);
  });

  // --- replay timeline (doppel-replay: docs/replay.md) -----------------------------------------
  // Shown only when /api/replay answers; a live doppel answers 404 and the page stays as it was.
  let scrubbing = false;   // the slider is being dragged: polling does not move it
  let seekBusy = false, seekWanted = null;
  function applyReplay(replay) {
    lastReplay = replay;
    $('timeline').hidden = false;
    $('replay-badge').hidden = false;
    const slider = $('replay-slider');
    slider.min = replay.start_s;
    slider.max = replay.end_s;
    if (!scrubbing) slider.value = replay.position_s;
    $('replay-play').textContent = replay.playing ? 'Pause' : 'Play';
    $('replay-time').textContent = `${fixed(replay.position_s, 3)} / ${fixed(replay.end_s, 3)} s`;
    const speed = $('replay-speed');
    if (document.activeElement !== speed && Number(speed.value) !== replay.speed) {
      if (![...speed.options].some((o) => Number(o.value) === replay.speed)) speed.add(new Option(`${replay.speed}×`, replay.speed));
      speed.value = String(replay.speed);
    }
    for (const b of document.querySelectorAll('#push-buttons button, #place-mode')) {
      b.disabled = true;
      b.title = 'a replay cannot change the world';
    }
    if (periodPlots.length > 0) moveAnalysisCursor();
  }
  async function replayChange(change) {
    try {
      applyReplay(await api('POST', '/api/replay', change));
      clearError();
    } catch (e) {
      showError(e.message);
    }
  }
  // Seeks as fast as the server answers while the slider moves, always ending at the last value.
  async function seek(position) {
    seekWanted = position;
    if (seekBusy) return;
    seekBusy = true;
    while (seekWanted !== null) {
      const next = seekWanted;
      seekWanted = null;
      await replayChange({ position_s: next });
    }
    seekBusy = false;
  }
  $('replay-slider').addEventListener('input', (e) => { scrubbing = true; seek(Number(e.target.value)); });
  $('replay-slider').addEventListener('change', (e) => { scrubbing = false; seek(Number(e.target.value)); });
  $('replay-play').addEventListener('click', () => replayChange({ playing: !(lastReplay && lastReplay.playing) }));
  $('replay-speed').addEventListener('change', (e) => replayChange({ speed: Number(e.target.value) }));
  fetch('/api/replay', { cache: 'no-store' }).then(async (response) => {
    if (!response.ok) return;  // live
    applyReplay(await response.json());
    poll('/api/replay', STATE_PERIOD_MS, applyReplay);
  }).catch(() => {});

  // --- GameController (GET/POST /api/game, docs/gamecontroller.md) --------------------------------
  let lastGame = null;
  function cell(row, text, cls) {
    const td = row.insertCell();
    td.textContent = text;
    if (cls) td.className = cls;
  }
  function applyGame(game) {
    lastGame = game;
    $('game').hidden = false;
    const a = game.teams[0], b = game.teams[1];
    const kickOff = game.kick_off_team === 255 ? 'drop ball' : `team ${game.kick_off_team}`;
    const secondary = game.secondary_state !== 'normal' ? ` · ${game.secondary_state} (team ${game.secondary_team})` : '';
    $('game-status').textContent = `${game.state.toUpperCase()} · A (team ${a.number}) ${a.score} : ${b.score} B (team ${b.number}) · ` +
        `kick-off ${kickOff} · ${game.first_half ? '1st' : '2nd'} half ${game.secs_remaining} s${secondary}`;
    const sending = $('game-sending');
    sending.textContent = !game.on ? 'off' : game.sending ? `sending to ${game.destination}` :
        (game.stepped_aside ? `stepped aside: ${game.stepped_aside}` : 'not sending');
    sending.className = game.on && !game.sending && game.stepped_aside ? 'aside' : '';
    document.querySelectorAll('#game-states button').forEach((button) => {
      button.classList.toggle('active', button.dataset.state === game.state);
    });
    const penalties = $('game-penalties').tBodies[0];
    penalties.innerHTML = '';
    game.teams.forEach((team) => team.penalties.forEach((p) => {
      const row = penalties.insertRow();
      cell(row, team.number); cell(row, p.player); cell(row, p.reason, 'text'); cell(row, p.seconds_left);
    }));
    const returns = $('game-returns').tBodies[0];
    returns.innerHTML = '';
    game.returns.forEach((r) => {
      const row = returns.insertRow();
      cell(row, r.team); cell(row, r.player); cell(row, r.message, 'text'); cell(row, r.count); cell(row, fixed(r.age_s, 1));
    });
  }
  async function gameCommand(body) {
    try {
      applyGame(await api('POST', '/api/game', body));
      clearError();
    } catch (e) {
      showError(e.message);
    }
  }
  document.querySelectorAll('#game-states button').forEach((button) => {
    button.addEventListener('click', () => gameCommand({ command: 'state', state: button.dataset.state }));
  });
  $('game-goal-a').addEventListener('click', () => gameCommand({ command: 'goal', team: 'A' }));
  $('game-goal-b').addEventListener('click', () => gameCommand({ command: 'goal', team: 'B' }));
  $('game-on').addEventListener('click', () => gameCommand({ command: 'on' }));
  $('game-off').addEventListener('click', () => gameCommand({ command: 'off' }));
  const gamePlayer = () => ({ team: $('game-team').value, player: Number($('game-player').value) });
  $('game-penalize').addEventListener('click', () => gameCommand({ command: 'penalize', ...gamePlayer() }));
  $('game-unpenalize').addEventListener('click', () => gameCommand({ command: 'unpenalize', ...gamePlayer() }));
  fetch('/api/game', { cache: 'no-store' }).then(async (response) => {
    if (!response.ok) return;  // no GameController here (a replay)
    applyGame(await response.json());
    poll('/api/game', 500, applyGame);
  }).catch(() => {});

  // --- faults on demand (GET/POST/DELETE /api/faults, docs/faults.md) ------------------------------
  // The form offers every kind the API lists, with the value field that kind takes; the table lists
  // every fault of the run with a button that ends it.
  let lastFaults = null;
  let faultListsApplied = 0;
  let faultKinds = [];
  function selectedKind() {
    return faultKinds.find((k) => k.kind === $('fault-kind').value);
  }
  function showKindFields() {
    const k = selectedKind();
    if (!k) return;
    $('fault-value-name').textContent = k.value_field || 'value';
    $('fault-value').disabled = !k.value_field;
    $('fault-rate').disabled = !k.rate;
    $('fault-what').textContent = `${k.kind} (${k.scope}): ${k.what}`;
  }
  function faultTarget(f) {
    return `robot ${f.robot}` + (f.bus !== undefined ? ` bus ${f.bus}` : '') + (f.id !== undefined ? ` id ${f.id}` : '');
  }
  function applyFaults(list) {
    lastFaults = list;
    $('faults').hidden = false;
    if (faultKinds.length === 0 && list.kinds) {
      faultKinds = list.kinds;
      const select = $('fault-kind');
      faultKinds.forEach((k) => {
        const option = document.createElement('option');
        option.value = k.kind;
        option.textContent = k.kind;
        select.appendChild(option);
      });
      showKindFields();
    }
    ++faultListsApplied;
    // Rebuilt only when the list changed: a row rebuilt between a mouse press and its release on
    // its Clear button loses the click (seen under load with the 500 ms poll).
    const body = $('fault-list').tBodies[0];
    const shown = JSON.stringify(list.faults);
    if (body.dataset.shown === shown) return;
    body.dataset.shown = shown;
    body.textContent = '';
    list.faults.forEach((f) => {
      const row = body.insertRow();
      row.dataset.number = f.number;
      cell(row, f.number);
      cell(row, f.kind, 'text');
      cell(row, faultTarget(f), 'text');
      cell(row, fixed(f.start_s, 3));
      cell(row, f.end_s === null ? '–' : fixed(f.end_s, 3));
      cell(row, f.active ? 'active' : f.ended ? 'ended' : 'pending', 'text');
      const td = row.insertCell();
      if (!f.ended) {
        const button = document.createElement('button');
        button.textContent = 'Clear';
        button.className = 'fault-clear';
        button.addEventListener('click', () => faultRequest('DELETE', `/api/faults/${f.number}`));
        td.appendChild(button);
      }
    });
  }
  async function faultRequest(method, path, body) {
    try {
      applyFaults(await api(method, path, body));
      clearError();
    } catch (e) {
      showError(e.message);
    }
  }
  $('fault-kind').addEventListener('change', showKindFields);
  $('fault-add').addEventListener('click', () => {
    const k = selectedKind();
    if (!k) return;
    const body = { kind: k.kind, robot: Number($('fault-robot').value) };
    const whole = (id) => ($(id).value === '' ? undefined : Number($(id).value));
    if (whole('fault-bus') !== undefined) body.bus = whole('fault-bus');
    if (whole('fault-id') !== undefined) body.id = whole('fault-id');
    if (k.value_field && $('fault-value').value !== '') body[k.value_field] = Number($('fault-value').value);
    if (k.rate && $('fault-rate').value !== '') body.rate = Number($('fault-rate').value);
    if ($('fault-for').value !== '') body.duration_s = Number($('fault-for').value);
    faultRequest('POST', '/api/faults', body);
  });
  $('fault-clear-all').addEventListener('click', () => faultRequest('DELETE', '/api/faults'));
  fetch('/api/faults', { cache: 'no-store' }).then(async (response) => {
    if (!response.ok) return;  // no faults here (a replay)
    applyFaults(await response.json());
    poll('/api/faults', 500, applyFaults);
  }).catch(() => {});

  // --- bus analysis of a replay (GET /api/analysis: analyzer/, docs/analyzer.md) --------------------
  // Drawn once (the recording does not change); the period plot's cursor follows the replay.
  const SPLIT_PARTS = [  // the time split's parts (analyzer KindStats), in the order they add up
    ['host_write', 'host write', '#4878b0'], ['return_delay', 'return delay', '#e8a33c'],
    ['status_wire', 'status wire', '#5aa05a'], ['status_gaps', 'status gaps', '#9bd18b'],
    ['adapter', 'adapter', '#c0504d'], ['lateness', 'Doppel late', '#999999'],
  ];
  let lastAnalysis = null;
  const periodPlots = [];  // {canvas, series, t0, t1} per report, for the replay cursor
  function sizedCanvas(box, title) {
    const caption = document.createElement('div');
    caption.className = 'plot-title';
    caption.textContent = title;
    const c = document.createElement('canvas');
    box.append(caption, c);
    const ratio = window.devicePixelRatio || 1;
    c.width = Math.round(400 * ratio);
    c.height = Math.round(160 * ratio);
    const ctx = c.getContext('2d');
    ctx.scale(ratio, ratio);
    return { c, ctx, w: 400, h: 160 };
  }
  function wrap(box) {
    const d = document.createElement('div');
    box.appendChild(d);
    return d;
  }
  function drawPeriods(plot, cursorS) {
    const { ctx, w, h } = plot;
    const { t_s: ts, period_us: ps } = plot.series;
    ctx.fillStyle = '#fff';
    ctx.fillRect(0, 0, w, h);
    const left = 52, right = w - 8, top = 8, bottom = h - 20;
    const t0 = plot.t0, t1 = Math.max(plot.t1, t0 + 1e-3);
    const hi = Math.max(...ps) * 1.1 || 1;
    const x = (t) => left + (t - t0) / (t1 - t0) * (right - left);
    const y = (v) => bottom - v / hi * (bottom - top);
    ctx.strokeStyle = '#ccc';
    ctx.lineWidth = 1;
    ctx.strokeRect(left, top, right - left, bottom - top);
    ctx.fillStyle = '#444';
    ctx.font = '10px sans-serif';
    ctx.textAlign = 'right';
    for (const v of [0, hi / 2, hi]) ctx.fillText(v >= 1000 ? `${fixed(v / 1000, 1)} ms` : `${fixed(v, 0)} µs`, left - 3, y(v) + 3);
    ctx.textAlign = 'left';
    ctx.fillText(`${fixed(t0, 1)} s`, left, h - 6);
    ctx.textAlign = 'right';
    ctx.fillText(`${fixed(t1, 1)} s`, right, h - 6);
    ctx.strokeStyle = '#2a6ebb';
    ctx.lineWidth = 1.2;
    ctx.beginPath();
    ts.forEach((t, i) => (i ? ctx.lineTo(x(t), y(ps[i])) : ctx.moveTo(x(t), y(ps[i]))));
    if (ts.length === 1) ctx.lineTo(x(ts[0]) + 2, y(ps[0]));
    ctx.stroke();
    if (typeof cursorS === 'number' && cursorS >= t0 && cursorS <= t1) {
      ctx.strokeStyle = '#a60';
      ctx.beginPath();
      ctx.moveTo(x(cursorS), top);
      ctx.lineTo(x(cursorS), bottom);
      ctx.stroke();
    }
  }
  function drawBars(canvasBox, rows, legend) {  // rows: [{label, parts: [[value, colour]], text}]
    const { ctx, w, h } = canvasBox;
    ctx.fillStyle = '#fff';
    ctx.fillRect(0, 0, w, h);
    const left = 150, right = w - 70, top = legend ? 22 : 6;
    const rowH = Math.min(22, (h - top - 4) / Math.max(1, rows.length));
    const hi = Math.max(...rows.map((r) => r.parts.reduce((a, [v]) => a + v, 0))) || 1;
    ctx.font = '10px sans-serif';
    if (legend) {
      ctx.font = '9px sans-serif';
      let lx = 4;
      for (const [label, colour] of legend) {
        ctx.fillStyle = colour;
        ctx.fillRect(lx, 6, 9, 9);
        ctx.fillStyle = '#333';
        ctx.textAlign = 'left';
        ctx.fillText(label, lx + 12, 14);
        lx += ctx.measureText(label).width + 17;
      }
      ctx.font = '10px sans-serif';
    }
    rows.forEach((row, i) => {
      const y0 = top + i * rowH;
      ctx.fillStyle = '#333';
      ctx.textAlign = 'right';
      ctx.fillText(row.label.length > 26 ? row.label.slice(0, 25) + '…' : row.label, left - 4, y0 + rowH / 2 + 3);
      let x0 = left;
      for (const [v, colour] of row.parts) {
        const bw = v / hi * (right - left);
        ctx.fillStyle = colour;
        ctx.fillRect(x0, y0 + 2, Math.max(bw, v > 0 ? 1 : 0), rowH - 4);
        x0 += bw;
      }
      ctx.fillStyle = '#333';
      ctx.textAlign = 'left';
      ctx.fillText(row.text, x0 + 3, y0 + rowH / 2 + 3);
    });
  }
  function usText(us) { return us >= 1000 ? `${fixed(us / 1000, 2)} ms` : `${fixed(us, 0)} µs`; }
  function applyAnalysis(analysis) {
    lastAnalysis = analysis;
    const reports = analysis.reports || [];
    if (reports.length === 0) return;
    $('analysis').hidden = false;
    $('analysis-note').textContent = '(the whole recording: analyzer, as doppel-bus report shows it)';
    const container = $('analysis-reports');
    container.textContent = '';
    periodPlots.length = 0;
    for (const r of reports) {
      const head = document.createElement('div');
      head.className = 'analysis-cycle';
      const c = r.cycle;
      const who = `robot ${r.robot}${r.robot_name ? ` (${r.robot_name})` : ''}, ${r.transactions} transactions, timing ${r.timing_mode || '?'}`;
      head.textContent = c.found
        ? `${who}: control cycle ${fixed(c.rate_hz, 1)} Hz, opener ${c.opener_kind} on bus ${c.opener_bus}, ${c.cycles} cycles; ` +
          `period p50 ${usText(c.period.p50_us)}, p99 ${usText(c.period.p99_us)}, max ${usText(c.period.max_us)}`
        : `${who}: no control cycle found (no request repeats at least 3 times)`;
      head.dataset.rateHz = c.found ? String(c.rate_hz) : '';
      container.appendChild(head);
      const plots = document.createElement('div');
      plots.className = 'analysis-plots';
      container.appendChild(plots);
      if (c.found && r.period_series && r.period_series.t_s.length > 0) {
        const per = r.period_series.per_point;
        const plot = sizedCanvas(wrap(plots), per > 1 ? `cycle period over time (longest of each ${per})` : 'cycle period over time');
        plot.series = r.period_series;
        const ts = r.period_series.t_s;
        plot.t0 = lastReplay ? Math.min(lastReplay.start_s, ts[0]) : ts[0];
        plot.t1 = lastReplay ? Math.max(lastReplay.end_s, ts[ts.length - 1]) : ts[ts.length - 1];
        periodPlots.push(plot);
        drawPeriods(plot, lastReplay ? lastReplay.position_s : null);
      }
      const kinds = r.kinds.slice(0, 7);
      drawBars(sizedCanvas(wrap(plots), 'time split per kind, mean'), kinds.map((k) => ({
        label: `${k.kind} ×${k.count}`,
        parts: SPLIT_PARTS.map(([key, , colour]) => [k[key].count > 0 ? Math.max(0, k[key].mean_us) : 0, colour]),
        text: usText(k.total.mean_us),
      })), SPLIT_PARTS.map(([, label, colour]) => [label, colour]));
      const rates = [];
      if (c.found) rates.push({ label: 'measured', parts: [[c.rate_hz, '#555']], text: `${fixed(c.rate_hz, 1)} Hz` });
      for (const wi of r.what_if) {
        if (!(wi.cycles > 0)) continue;
        const label = wi.scenario === 'recorded' ? 'model, recorded settings' : wi.scenario;
        rates.push({ label, parts: [[wi.rate_hz, '#2a6ebb']], text: `${fixed(wi.rate_hz, 1)} Hz` });
      }
      if (rates.length > 0) drawBars(sizedCanvas(wrap(plots), 'what if: achievable cycle rate'), rates, null);
    }
  }
  function moveAnalysisCursor() {
    for (const plot of periodPlots) drawPeriods(plot, lastReplay ? lastReplay.position_s : null);
  }
  fetch('/api/analysis', { cache: 'no-store' }).then(async (response) => {
    if (!response.ok) return;  // a live doppel, or a recording without bus traffic
    applyAnalysis(await response.json());
  }).catch(() => {});

  poll('/api/scene', SCENE_PERIOD_MS, applyScene);
  poll('/api/state', STATE_PERIOD_MS, applyState);
  poll('/api/buses', BUSES_PERIOD_MS, applyBuses);

  // For tests and the curious (tests/control/viewer_browser_test.py).
  window.doppelViewer = {
    robotCount: () => robotIds.size,
    shapeCount: () => meshes.length,
    frames: () => frames,
    sceneUpdates: () => sceneUpdates,
    servoRows: () => document.querySelectorAll('#buses table.servo-table tbody tr').length,
    // Canvas pixels of the sensor plots that are not background (white), per plot.
    plotInk: () => Array.from(document.querySelectorAll('#plots canvas')).map((c) => {
      const data = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
      let ink = 0;
      for (let i = 12 * c.width * 4; i < data.length; i += 4) if (data[i] < 200 || data[i + 1] < 200 || data[i + 2] < 200) ++ink;
      return ink;  // below the legend line (the top 12 rows)
    }),
    plotTitles: () => Array.from(document.querySelectorAll('#plots .plot-title')).map((d) => d.textContent),
    frustumCount: () => frustums.length,
    cameraImages: () => cameraImages,
    // The camera image's size and how many of a 16 x 12 grid of its pixels are carpet green.
    cameraImage: () => {
      const image = $('camera-image');
      if (!image.complete || image.naturalWidth === 0) return null;
      const c = document.createElement('canvas');
      c.width = 16; c.height = 12;
      const g = c.getContext('2d');
      g.drawImage(image, 0, 0, 16, 12);
      const data = g.getImageData(0, 0, 16, 12).data;
      let green = 0;
      for (let i = 0; i < data.length; i += 4) if (data[i + 1] > data[i] + 20 && data[i + 1] > data[i + 2] + 20) ++green;
      return { width: image.naturalWidth, height: image.naturalHeight, green };
    },
    busCounters: () => Array.from(document.querySelectorAll('#buses table.bus-counters')).map((t) => {
      const out = {};
      COUNTERS.forEach(([key], c) => { out[key] = t.tBodies[0].rows[0].cells[c].textContent; });
      return out;
    }),
    state: () => lastState,
    replay: () => lastReplay,
    timelineShown: () => !$('timeline').hidden,
    analysis: () => lastAnalysis,
    analysisShown: () => !$('analysis').hidden,
    analysisCycleText: () => Array.from(document.querySelectorAll('#analysis .analysis-cycle')).map((d) => d.textContent),
    // Canvas pixels of the Bus panel's plots that are not background (white), per plot.
    analysisInk: () => Array.from(document.querySelectorAll('#analysis canvas')).map((c) => {
      const data = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
      let ink = 0;
      for (let i = 0; i < data.length; i += 4) if (data[i] < 200 || data[i + 1] < 200 || data[i + 2] < 200) ++ink;
      return ink;
    }),
    buses: () => lastBuses,
    game: () => lastGame,
    gameShown: () => !$('game').hidden,
    faults: () => lastFaults,
    faultsShown: () => !$('faults').hidden,
    faultListsApplied: () => faultListsApplied,
    faultRows: () => Array.from($('fault-list').tBodies[0].rows).map((r) => Array.from(r.cells).map((c) => c.textContent)),
    scene: () => lastScene,
    error: () => ($('error').hidden ? '' : $('error').textContent),
    // Where field point (x, y, z) is on the page (CSS pixels), to click on it.
    pageXY: (x, y, z) => {
      const v = new THREE.Vector3(x, y, z || 0).project(camera);
      const rect = canvas.getBoundingClientRect();
      return { x: rect.left + (v.x + 1) / 2 * rect.width, y: rect.top + (1 - v.y) / 2 * rect.height };
    },
  };
})();
