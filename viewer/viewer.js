// Doppel's web viewer: draws the shapes of GET /api/scene with three.js (field frame: x towards
// the yellow goal, z up, m), shows GET /api/state and GET /api/buses, and sends the simulation
// control requests of control/http_api.h. Plain script (three.js r111 from Debian is not a module).
'use strict';

(function () {
  const SCENE_PERIOD_MS = 50;   // 20 Hz: doppel publishes the scene at most 30 times a second
  const STATE_PERIOD_MS = 100;  // 10 Hz
  const BUSES_PERIOD_MS = 500;  // the bus threads publish their servo tables every 100 ms
  const PUSH_N = 30, PUSH_MS = 200;
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

  // A request to doppel; throws Error with the API's message (or why it did not answer).
  async function api(method, path, body) {
    let response;
    try {
      response = await fetch(path, {
        method,
        headers: body !== undefined ? { 'Content-Type': 'application/json' } : {},
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

  function applyState(state) {
    lastState = state;
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
        const table = document.createElement('table');
        table.className = 'servo-table';
        table.innerHTML = '<thead><tr><th>ID</th><th class="text">name</th><th class="text">model</th><th>torque</th>' +
                          '<th>goal</th><th>present</th><th>speed</th><th>load</th><th>temp °C</th><th>voltage V</th>' +
                          '<th>error</th></tr></thead><tbody></tbody>';
        for (let i = 0; i < bus.servos.length; ++i) {
          const row = table.tBodies[0].insertRow();
          for (let c = 0; c < 11; ++c) row.insertCell().className = c === 1 || c === 2 ? 'text' : '';
        }
        box.append(title, table);
        container.append(box);
      }
      container.dataset.layout = wanted;
    }
    const tables = container.querySelectorAll('table.servo-table');
    buses.forEach((bus, b) => {
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
    state: () => lastState,
    buses: () => lastBuses,
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
