// omnipoint view: the folder list, one prediction's pictures and summary, and its point cloud
// in 3D; for a rig frame (predict --rig), its fused cloud in the body frame with every camera
// placed by its body_from_camera and labelled with its name and scale. Rendering is on demand (after a change), not in a loop. Once a cloud's first frame is
// drawn, <body data-rendered="NAME"> and the title say so (the browser test waits for it).
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';

const $ = (id) => document.getElementById(id);

// Colours are used as given: the GLB's are the image's own (sRGB) bytes.
THREE.ColorManagement.enabled = false;
const renderer = new THREE.WebGLRenderer({ canvas: $('scene'), antialias: true });
renderer.outputColorSpace = THREE.LinearSRGBColorSpace;
renderer.setPixelRatio(window.devicePixelRatio);
const scene = new THREE.Scene();
scene.background = new THREE.Color(0x1d2026);
const view = new THREE.PerspectiveCamera(60, 1, 0.01, 1e5);
const controls = new OrbitControls(view, renderer.domElement);  // orbit, wheel zoom, right-drag pan
controls.addEventListener('change', render);
const material = new THREE.PointsMaterial({ vertexColors: true, size: 2, sizeAttenuation: false });

// What is shown now: the cloud, its two colourings, and the camera and grid drawings.
let shown = null;

function render() {
  const canvas = renderer.domElement;
  const width = canvas.clientWidth, height = canvas.clientHeight;
  if (canvas.width !== Math.floor(width * renderer.getPixelRatio()) ||
      canvas.height !== Math.floor(height * renderer.getPixelRatio())) {
    renderer.setSize(width, height, false);
    view.aspect = width / Math.max(height, 1);
    view.updateProjectionMatrix();
  }
  renderer.render(scene, view);
}
new ResizeObserver(render).observe(renderer.domElement);

// Our camera frame (x right, y down, z forward) in the GLB's frame (y up, looking along -z).
const toScene = ([x, y, z]) => new THREE.Vector3(x, -y, -z);

function lines(pairs, color) {
  const geometry = new THREE.BufferGeometry().setFromPoints(pairs.flat());
  return new THREE.LineSegments(geometry, new THREE.LineBasicMaterial({ color }));
}

// Distances of (a sample of) the points, sorted: the view's and the colour map's scale.
function sortedDistances(positions) {
  const count = positions.count, step = Math.max(1, Math.floor(count / 20000));
  const distances = [];
  for (let i = 0; i < count; i += step) {
    distances.push(Math.hypot(positions.getX(i), positions.getY(i), positions.getZ(i)));
  }
  return distances.sort((a, b) => a - b);
}
const quantile = (sorted, q) => sorted[Math.min(sorted.length - 1, Math.floor(q * sorted.length))];

// Near red through yellow and green to far blue, between the 2nd and 98th percentile.
function distanceColours(positions, sorted) {
  const near = quantile(sorted, 0.02), far = quantile(sorted, 0.98);
  const colours = new Float32Array(positions.count * 3), colour = new THREE.Color();
  for (let i = 0; i < positions.count; ++i) {
    const distance = Math.hypot(positions.getX(i), positions.getY(i), positions.getZ(i));
    const t = Math.min(1, Math.max(0, (distance - near) / Math.max(far - near, 1e-9)));
    colour.setHSL(0.7 * t, 1, 0.5).toArray(colours, 3 * i);
  }
  return { attribute: new THREE.BufferAttribute(colours, 3), near, far };
}

// The camera's frustum through the image border, `depth` deep; for lenses too wide for one
// (the server sends no rays then), its centre and axes (x red, y green, z blue, camera frame).
// `place` takes a point of the camera's frame into the scene.
function cameraDrawing(rays, depth, place = toScene) {
  const group = new THREE.Group();
  const origin = place([0, 0, 0]);
  if (rays) {
    const border = rays.map((ray) => place(ray.map((value) => (value * depth) / ray[2])));
    const corners = [0, 1, 2, 3].map((side) => border[Math.floor((side * border.length) / 4)]);
    group.add(lines([
      ...corners.map((corner) => [origin, corner]),
      ...border.map((point, i) => [point, border[(i + 1) % border.length]]),
    ], 0xffd166));
  } else {
    const axis = (x, y, z) => [origin, place([x * depth, y * depth, z * depth])];
    group.add(lines([axis(1, 0, 0)], 0xff5555), lines([axis(0, 1, 0)], 0x55ff55),
              lines([axis(0, 0, 1)], 0x5599ff));
    const centre = new THREE.Mesh(new THREE.SphereGeometry(depth * 0.04),
                                  new THREE.MeshBasicMaterial({ color: 0xffd166 }));
    centre.position.copy(origin);
    group.add(centre);
  }
  return group;
}

// A text label at `position` that keeps its size on screen.
function label(text, position) {
  const canvas = document.createElement('canvas');
  const context = canvas.getContext('2d');
  const font = '28px sans-serif';
  context.font = font;
  canvas.width = Math.ceil(context.measureText(text).width) + 16;
  canvas.height = 40;
  context.font = font;
  context.fillStyle = 'rgba(29, 32, 38, 0.75)';
  context.fillRect(0, 0, canvas.width, canvas.height);
  context.fillStyle = '#ffd166';
  context.textBaseline = 'middle';
  context.fillText(text, 8, canvas.height / 2);
  const texture = new THREE.CanvasTexture(canvas);
  const sprite = new THREE.Sprite(new THREE.SpriteMaterial({ map: texture, sizeAttenuation: false, depthTest: false }));
  sprite.scale.set((0.035 * canvas.width) / canvas.height, 0.035, 1);
  sprite.center.set(0.5, 0);
  sprite.position.copy(position);
  return sprite;
}

// A rig frame's cameras: the body frame's points come in the GLB's frame (toScene of the body
// frame's coordinates), turned so that the body's up (the server's estimate) is the scene's.
function rigDrawing(detail, geometry, depth) {
  const turn = new THREE.Quaternion().setFromUnitVectors(toScene(detail.up).normalize(), new THREE.Vector3(0, 1, 0));
  geometry.applyQuaternion(turn);
  const group = new THREE.Group();
  const places = detail.cameras.map((camera) => {
    const rows = camera.body_from_camera;
    const body = (p) => [0, 1, 2].map((i) => rows[i][0] * p[0] + rows[i][1] * p[1] + rows[i][2] * p[2] + rows[i][3]);
    const place = (p) => toScene(body(p)).applyQuaternion(turn);
    group.add(cameraDrawing(camera.frustum_rays, depth, place));
    group.add(label(`${camera.name} ×${camera.scale.toPrecision(4)} (${camera.scale_source})`, place([0, -0.2 * depth, 0])));
    return place;
  });
  // Home: behind the first camera, level, looking at the body's origin from above.
  const forward = places[0]([0, 0, 1]).sub(places[0]([0, 0, 0])).setY(0);
  if (forward.length() < 1e-6) forward.set(0, 0, -1);
  forward.normalize();
  return { group, forward };
}

// A floor grid under the cloud in round metric cells (1, 2 or 5 times a power of ten).
function metricGrid(box) {
  const extent = Math.max(box.max.x - box.min.x, box.max.z - box.min.z, 1e-3);
  const rough = extent / 8, power = 10 ** Math.floor(Math.log10(rough));
  const cell = [1, 2, 5, 10].map((m) => m * power).find((size) => size >= rough);
  const cells = Math.ceil(extent / cell) + 2;
  const grid = new THREE.GridHelper(cells * cell, cells, 0x59606e, 0x393e48);
  grid.position.set((box.min.x + box.max.x) / 2, box.min.y, (box.min.z + box.max.z) / 2);
  return { grid, cell };
}

const metres = (value) => (value >= 1 ? `${+value.toPrecision(3)} m` : `${+(value * 100).toPrecision(3)} cm`);
const count = (n) => (n >= 1e6 ? `${+(n / 1e6).toFixed(2)} M` : n.toLocaleString('en'));

function updateLegend() {
  if (!shown) return;
  const parts = [];
  if ($('show-grid').checked) parts.push(`grid cell ${metres(shown.cell)}`);
  if ($('colour').value === 'distance') {
    parts.push(`colour: distance ${metres(shown.distance.near)} (red) – ${metres(shown.distance.far)} (blue)`);
  }
  $('legend').textContent = parts.join(' · ');
}

function applyControls() {
  material.size = Number($('point-size').value);
  if (shown) {
    const colours = $('colour').value === 'distance' ? shown.distance.attribute : shown.imageColours;
    shown.points.geometry.setAttribute('color', colours);
    material.needsUpdate = true;  // 3 or 4 colour components: another shader
    shown.camera.visible = $('show-camera').checked;
    shown.grid.visible = $('show-grid').checked;
  }
  updateLegend();
  render();
}
for (const id of ['point-size', 'colour', 'show-camera', 'show-grid']) {
  $(id).addEventListener('input', applyControls);
}

// Seen from behind and above the camera: a perspective camera's view, a wide lens's or
// panorama's from further up, looking at its centre; a rig from behind its first camera.
function resetView() {
  if (!shown) return;
  const median = shown.median;
  if (shown.rigForward) {
    view.position.copy(shown.rigForward).multiplyScalar(-1.5 * median).setY(1.2 * median);
    controls.target.set(0, 0, 0);
  } else if (shown.wide) {
    const back = shown.panorama ? 1.2 : 2.4, up = shown.panorama ? 1.6 : 2;
    view.position.set(0, up * median, back * median);
    controls.target.set(0, 0, 0);
  } else {
    view.position.set(0.45 * median, 0.5 * median, 0.55 * median);
    controls.target.set(0, 0, -median);
  }
  view.near = median / 1000;
  view.far = median * 1000;
  view.updateProjectionMatrix();
  controls.update();
  render();
}
$('reset').addEventListener('click', resetView);

function clearScene() {
  if (!shown) return;
  scene.remove(shown.points, shown.camera, shown.grid);
  shown.points.geometry.dispose();
  shown = null;
}

async function showCloud(name, detail) {
  const response = await fetch(`/cloud?name=${encodeURIComponent(name)}`);
  if (!response.ok) {
    $('status').textContent = 'no point cloud in this folder (points.glb or points.ply)';
    return;
  }
  const total = response.headers.get('X-Omnipoint-Points-Total');
  const gltf = await new GLTFLoader().parseAsync(await response.arrayBuffer(), '');
  let points = null;
  gltf.scene.traverse((object) => { if (object.isPoints) points = object; });
  if (!points) {
    $('status').textContent = 'the point cloud is empty';
    return;
  }
  const geometry = points.geometry, positions = geometry.getAttribute('position');
  const sorted = sortedDistances(positions);
  const median = quantile(sorted, 0.5) || 1;
  const rig = detail.kind === 'rig' ? rigDrawing(detail, geometry, 0.15 * median) : null;
  geometry.computeBoundingBox();
  const { grid, cell } = metricGrid(geometry.boundingBox);
  shown = {
    points: new THREE.Points(geometry, material),
    imageColours: geometry.getAttribute('color'),
    distance: distanceColours(positions, sorted),
    camera: rig ? rig.group : cameraDrawing(detail.frustum_rays, 0.3 * median),
    grid,
    cell,
    median,
    wide: !detail.frustum_rays,
    panorama: detail.camera_class === 'panorama',
    rigForward: rig?.forward,
  };
  scene.add(shown.points, shown.camera, shown.grid);
  const of = total && Number(total) > positions.count ? ` of ${count(Number(total))}` : '';
  $('status').textContent = `showing ${count(positions.count)}${of} points` +
      (of ? ` (subsampled to the --max-points budget)` : '') +
      (rig ? ` and ${detail.cameras.length} cameras in the body frame (${detail.record.frame ?? 'body'})` : '');
  applyControls();
  resetView();
  document.title = `omnipoint view: ${name}`;
  document.body.dataset.rendered = name;
}

const fileUrl = (name, file, route = '/files') =>
  `${route}/${name.split('/').map(encodeURIComponent).join('/')}/${file}`;

function figure(href, src, caption) {
  const item = document.createElement('figure');
  const link = Object.assign(document.createElement('a'), { href });
  link.append(Object.assign(new Image(), { src, alt: caption }));
  item.append(link, Object.assign(document.createElement('figcaption'), { textContent: caption }));
  return item;
}

function showPictures(name, files) {
  // depth.png is 16-bit (a browser shows its high byte): the server colours it (Viridis).
  const pictures = [
    ['image.png', 'image', '/files'], ['depth_vis.png', 'distance', '/files'],
    ['depth.png', 'depth z', '/colourised'], ['mask.png', 'mask', '/files'],
  ];
  const figures = pictures.filter(([file]) => files.includes(file)).map(([file, caption, route]) => {
    const item = figure(fileUrl(name, file), fileUrl(name, file, route), caption);
    item.querySelector('a').target = '_blank';
    return item;
  });
  $('pictures').replaceChildren(...figures);
}

// A rig frame's camera images, each a link to that camera's own prediction.
function showRigPictures(cameras) {
  $('pictures').replaceChildren(...cameras.filter((camera) => camera.has_image).map((camera) =>
    figure(`#${encodeURIComponent(camera.folder)}`, fileUrl(camera.folder, 'image.png'), camera.name)));
}

function showRigSummary(detail) {
  const record = detail.record, rows = [];
  const add = (term, value) => { if (value !== undefined && value !== null && value !== '') rows.push([term, value]); };
  add('body frame', record.frame);
  add('rig scale', typeof record.rig_scale === 'number' ? `${record.rig_scale.toFixed(4)} (${record.scale_rule ?? ''})` : undefined);
  add('overlap residual', record.overlap_residual);
  add('lidar', record.lidar ?? 'none');
  if (record.missing_cameras?.length) add('missing cameras', record.missing_cameras.join(', '));
  add('fused points', record.fused_points?.toLocaleString('en'));
  for (const camera of detail.cameras) {
    const disagreement = typeof camera.disagreement === 'number' ? `, disagreement ${(100 * camera.disagreement).toFixed(2)} %` : '';
    const applied = typeof camera.applied_scale === 'number' && camera.applied_scale !== camera.scale
      ? `, shown at the rig scale ${camera.applied_scale.toFixed(4)}` : '';
    add(camera.name, `scale ${camera.scale.toFixed(4)} (${camera.scale_source})${disagreement}${applied}` +
      (camera.camera_error ? ` — no camera: ${camera.camera_error}` : ''));
  }
  add('files', detail.files.join(', '));
  $('summary').replaceChildren(...rows.flatMap(([term, value]) => [
    Object.assign(document.createElement('dt'), { textContent: term }),
    Object.assign(document.createElement('dd'), { textContent: value }),
  ]));
}

function showSummary(record, files) {
  const rows = [];
  const add = (term, value) => { if (value !== undefined && value !== null && value !== '') rows.push([term, value]); };
  const fixed = (value, digits) => (typeof value === 'number' ? value.toFixed(digits) : undefined);
  if (record) {
    const rounded = (spec) => spec.replace(/-?\d+\.\d+(e-?\d+)?/g, (number) => `${+Number(number).toPrecision(5)}`);
    add('camera', record.camera_spec ? rounded(record.camera_spec)
      : record.fit_error ? `none (${record.fit_error})` : undefined);
    add('camera from', record.camera_source === 'fitted' && record.fit_residual_deg
      ? `fitted to the rays (residual median ${fixed(record.fit_residual_deg.median, 3)}°, max ${fixed(record.fit_residual_deg.max, 3)}°)`
      : record.camera_source);
    const fov = record.fov_deg;
    if (fov) add('field of view', `${fixed(fov.horizontal, 1)}° × ${fixed(fov.vertical, 1)}° (diagonal ${fixed(fov.diagonal, 1)}°)`);
    add('metric scale', fixed(record.metric_scale, 4));
    const sparse = record.sparse_depth;
    add('sparse depth', sparse && sparse.samples > 0
      ? `${sparse.samples} samples, aligned ×${fixed(sparse.alignment_factor, 4)}` : 'none');
    add('valid pixels', record.valid_pixels?.toLocaleString('en'));
    if (record.edge_filter) add('edge filter', `rtol ${record.edge_filter.rtol}, ${record.edge_filter.removed_pixels} pixels removed`);
    const t = record.timing_ms;
    if (t) add('timing', ['prepare', 'network', 'alignment', 'camera_fit', 'writing']
      .filter((stage) => typeof t[stage] === 'number').map((stage) => `${stage} ${t[stage].toFixed(0)} ms`).join(', '));
    for (const note of record.notes ?? []) add('note', note);
    for (const warning of record.warnings ?? []) add('warning', warning);
  } else {
    add('camera.json', 'missing or not JSON');
  }
  add('files', files.join(', '));
  $('summary').replaceChildren(...rows.flatMap(([term, value]) => [
    Object.assign(document.createElement('dt'), { textContent: term }),
    Object.assign(document.createElement('dd'), { textContent: value }),
  ]));
}

async function showPrediction(name) {
  clearScene();
  delete document.body.dataset.rendered;
  for (const link of document.querySelectorAll('#folders a')) {
    link.classList.toggle('current', link.dataset.name === name);
  }
  $('name').textContent = name;
  $('status').textContent = 'loading…';
  const response = await fetch(`/api/prediction?name=${encodeURIComponent(name)}`);
  if (!response.ok) {
    $('status').textContent = `${name}: ${response.status} ${response.statusText}`;
    render();
    return;
  }
  const detail = await response.json();
  if (detail.kind === 'rig') {
    showRigPictures(detail.cameras);
    showRigSummary(detail);
  } else {
    showPictures(name, detail.files);
    showSummary(detail.record, detail.files);
  }
  await showCloud(name, detail);
  render();
}

async function main() {
  const list = await (await fetch('/api/predictions')).json();
  $('root').textContent = list.root;
  $('folders').replaceChildren(...list.predictions.map(({ name, kind, points }) => {
    const link = Object.assign(document.createElement('a'), { href: `#${encodeURIComponent(name)}`, textContent: name });
    link.dataset.name = name;
    const about = [kind === 'rig' ? 'rig frame' : '', points !== null ? `${count(points)} points` : ''].filter(Boolean).join(' · ');
    if (about) link.append(document.createElement('br'), Object.assign(document.createElement('small'), { textContent: about }));
    const item = document.createElement('li');
    item.append(link);
    return item;
  }));
  const names = list.predictions.map(({ name }) => name);
  const current = () => {
    const wanted = decodeURIComponent(location.hash.slice(1));
    return names.includes(wanted) ? wanted : names[0];
  };
  window.addEventListener('hashchange', () => showPrediction(current()));
  await showPrediction(current());
}

main().catch((error) => { $('status').textContent = `error: ${error.message}`; });
