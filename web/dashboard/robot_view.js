// SPDX-License-Identifier: GPL-3.0-or-later
// The dashboard's 3D view of a robot (`serve --robot`, docs/robot.md), drawn with three.js
// (npm, installed by scripts/setup): every geom of GET /api/robot in its body's frame, each body
// placed at its pose from the telemetry (`robot.poses[i]`: x, y, z, qw, qx, qy, qz in the world
// frame). MuJoCo's frames as they are: z up, metres.
//
// Cost: a frame is drawn only when something changed (a pose from the telemetry, the camera, the
// servo selected) and only while the canvas is on screen; the telemetry brings poses at the
// page's update rate (20 a second, 2 while the machine has no core to spare), so the view never
// draws more often than the rest of the page, except while a user turns the camera.
import * as THREE from "three";
import { OrbitControls } from "three/addons/controls/OrbitControls.js";

const HIDDEN_GROUP = 3;           // MuJoCo's viewers hide geom groups 3 and up
const FLOOR_GRID_M = 0.1;         // the floor's grid lines, 10 cm apart
const HIGHLIGHT = 0x1d6fe8;       // the selected servo's link and joint axis
const VIEW_DIRECTION = new THREE.Vector3(0.9, -1.5, 0.85).normalize(); // from the front right, above
const FOV_DEG = 35;
const PICK_MOVE_PX = 4;           // a click moves the pointer less than this; a drag turns the camera

const rgbColor = (rgba) => new THREE.Color().setRGB(rgba[0], rgba[1], rgba[2], THREE.SRGBColorSpace);
const quaternion = (wxyz) => new THREE.Quaternion(wxyz[1], wxyz[2], wxyz[3], wxyz[0]);

// A geom's shape in its own frame (MuJoCo's sizes, docs/robot.md); cylinders and capsules lie
// along z as in MuJoCo (three's along y). Planes are drawn by floor().
function geometry(geom, meshes) {
  const [a, b, c] = geom.size;
  switch (geom.type) {
    case "box": return new THREE.BoxGeometry(2 * a, 2 * b, 2 * c);
    case "sphere": return new THREE.SphereGeometry(a, 24, 16);
    case "ellipsoid": return new THREE.SphereGeometry(1, 24, 16).scale(a, b, c);
    case "cylinder": return new THREE.CylinderGeometry(a, a, 2 * b, 24).rotateX(Math.PI / 2);
    case "capsule": return new THREE.CapsuleGeometry(a, 2 * b, 6, 16).rotateX(Math.PI / 2);
    case "mesh": {
      const mesh = meshes[geom.mesh];
      const g = new THREE.BufferGeometry();
      g.setAttribute("position", new THREE.Float32BufferAttribute(mesh.vertices, 3));
      g.setIndex(mesh.faces);
      // Each triangle its own normal: meshes of parts have sharp edges.
      const flat = g.toNonIndexed();
      flat.computeVertexNormals();
      return flat;
    }
    default: return null; // hfield, sdf: not drawn
  }
}

export class RobotView {
  // holder: the element the canvas goes into; robot: GET /api/robot's "robot"; onPick(slot):
  // called with the servo whose link was clicked. Throws when the browser has no WebGL.
  constructor(holder, robot, onPick) {
    this.robot = robot;
    this.onPick = onPick;
    this.renderer = new THREE.WebGLRenderer({ antialias: true, powerPreference: "low-power" });
    this.renderer.setPixelRatio(Math.min(window.devicePixelRatio || 1, 2));
    holder.append(this.renderer.domElement);
    this.canvas = this.renderer.domElement;
    this.scene = new THREE.Scene();
    this.scene.background = new THREE.Color(0xf2f4f7);
    this.camera = new THREE.PerspectiveCamera(FOV_DEG, holder.clientWidth / holder.clientHeight || 1.5, 0.001, 100);
    this.camera.up.set(0, 0, 1);
    this.bodies = robot.bodies.map(() => new THREE.Group());
    for (const body of this.bodies) this.scene.add(body);
    this.meshesOfBody = robot.bodies.map(() => []);
    this.materials = new Map();
    const planes = [];
    for (const geom of robot.geoms) {
      if (geom.group >= HIDDEN_GROUP) continue;
      if (geom.type === "plane") { planes.push(geom); continue; }
      const shape = geometry(geom, robot.meshes);
      if (!shape) continue;
      const mesh = new THREE.Mesh(shape, this.material(geom.rgba, geom.type === "mesh"));
      mesh.position.fromArray(geom.pos);
      mesh.quaternion.copy(quaternion(geom.quat));
      mesh.userData.body = geom.body;
      mesh.userData.material = mesh.material;
      this.bodies[geom.body].add(mesh);
      this.meshesOfBody[geom.body].push(mesh);
    }
    this.setPose(robot.pose);
    this.frame(); // from the robot's pose at start: its size sets the floor's and the camera's
    for (const geom of planes) this.floor(geom);
    this.scene.add(new THREE.HemisphereLight(0xffffff, 0x8a8f99, 2.2));
    const sun = new THREE.DirectionalLight(0xffffff, 1.6);
    sun.position.set(0.6, -1.0, 2.0);
    this.scene.add(sun);

    this.controls = new OrbitControls(this.camera, this.canvas);
    this.controls.target.copy(this.home.target);
    this.controls.update();
    this.controls.addEventListener("change", () => this.requestDraw());
    this.watchScreen(holder);
    this.watchClicks();
    this.highlighted = null;
  }

  // One material per colour (the shipped robots have a handful); a mesh's two-sided (a part's
  // file may wind some of its triangles the wrong way round).
  material(rgba, twoSided) {
    const key = rgba.join(",") + (twoSided ? " both" : "");
    let m = this.materials.get(key);
    if (!m) {
      m = new THREE.MeshLambertMaterial({ color: rgbColor(rgba), transparent: rgba[3] < 1, opacity: rgba[3],
        side: twoSided ? THREE.DoubleSide : THREE.FrontSide });
      this.materials.set(key, m);
    }
    return m;
  }

  // A plane: its half-sizes (an infinite one, size 0, as far as three times the robot's size),
  // its colour and a grid every FLOOR_GRID_M, in the world body's frame.
  floor(geom) {
    const reach = Math.max(3 * this.radius, 0.5);
    const half = [geom.size[0] || reach, geom.size[1] || reach];
    const floor = new THREE.Mesh(new THREE.PlaneGeometry(2 * half[0], 2 * half[1]),
      new THREE.MeshLambertMaterial({ color: rgbColor(geom.rgba), polygonOffset: true, polygonOffsetFactor: 1,
        polygonOffsetUnits: 1 }));
    const side = 2 * Math.max(half[0], half[1]);
    const lines = Math.max(1, Math.round(side / FLOOR_GRID_M));
    const grid = new THREE.GridHelper(lines * FLOOR_GRID_M, lines, 0xa9adb4, 0xc4c7cc);
    grid.rotateX(Math.PI / 2); // three's grid lies in x-z; MuJoCo's floor in x-y
    const place = new THREE.Group();
    place.position.fromArray(geom.pos);
    place.quaternion.copy(quaternion(geom.quat));
    place.add(floor, grid);
    this.bodies[geom.body].add(place);
  }

  // The camera's home: looking at the centre of the robot's bounding box (its planes left out)
  // from VIEW_DIRECTION, just far enough for the box's eight corners to be in view with a margin.
  frame() {
    const box = new THREE.Box3();
    for (const body of this.bodies) box.expandByObject(body);
    if (box.isEmpty()) box.set(new THREE.Vector3(-0.1, -0.1, 0), new THREE.Vector3(0.1, 0.1, 0.2));
    const target = box.getCenter(new THREE.Vector3());
    this.radius = Math.max(box.getSize(new THREE.Vector3()).length() / 2, 0.05);
    const back = VIEW_DIRECTION;
    const right = new THREE.Vector3().crossVectors(this.camera.up, back).normalize();
    const up = new THREE.Vector3().crossVectors(back, right);
    const tanV = Math.tan(THREE.MathUtils.degToRad(FOV_DEG / 2)) / 1.15; // 15 % margin
    const tanH = tanV * this.camera.aspect;
    let distance = 0;
    for (let corner = 0; corner < 8; corner++) {
      const p = new THREE.Vector3(corner & 1 ? box.max.x : box.min.x, corner & 2 ? box.max.y : box.min.y,
        corner & 4 ? box.max.z : box.min.z).sub(target);
      const toward = p.dot(back); // a corner nearer the camera needs it further back
      distance = Math.max(distance, toward + Math.abs(p.dot(up)) / tanV, toward + Math.abs(p.dot(right)) / tanH);
    }
    this.home = { target, position: target.clone().addScaledVector(back, distance) };
    this.camera.near = distance / 100;
    this.camera.far = distance * 100;
    this.camera.position.copy(this.home.position);
    this.camera.lookAt(target);
    this.camera.updateProjectionMatrix();
  }

  resetView() {
    this.camera.position.copy(this.home.position);
    this.controls.target.copy(this.home.target);
    this.controls.update();
    this.requestDraw();
  }

  // The telemetry's pose: {"poses": [[x, y, z, qw, qx, qy, qz], ...], ...}, one per body.
  setPose(pose) {
    if (!pose || !pose.poses || pose.poses === this.lastPoses) return;
    this.lastPoses = pose.poses;
    pose.poses.forEach((p, i) => {
      const body = this.bodies[i];
      if (!body) return;
      body.position.set(p[0], p[1], p[2]);
      body.quaternion.set(p[4], p[5], p[6], p[3]);
    });
    this.requestDraw();
  }

  // The servo selected in the dashboard (its slot, the ID its joint is bound to): the link its
  // joint moves tinted, and the joint's axis drawn through everything.
  highlight(slot) {
    const joint = this.robot.joints.find((j) => j.servo === slot) || null;
    if (joint === this.highlighted) return;
    if (this.highlighted) {
      for (const mesh of this.meshesOfBody[this.highlighted.body]) mesh.material = mesh.userData.material;
      this.axis.removeFromParent();
    }
    this.highlighted = joint;
    if (joint) {
      for (const mesh of this.meshesOfBody[joint.body]) mesh.material = this.tinted(mesh.userData.material);
      this.axis = this.axis || this.axisMarker();
      this.axis.position.fromArray(joint.pos);
      this.axis.quaternion.setFromUnitVectors(new THREE.Vector3(0, 0, 1), new THREE.Vector3().fromArray(joint.axis).normalize());
      this.bodies[joint.body].add(this.axis);
    }
    this.requestDraw();
  }

  tinted(material) {
    if (!material.userData.tinted) {
      const m = material.clone();
      m.emissive = new THREE.Color(HIGHLIGHT);
      m.emissiveIntensity = 0.45;
      material.userData.tinted = m;
    }
    return material.userData.tinted;
  }

  // An arrow along +z (the joint's axis, its positive turn counter-clockwise seen from the
  // tip), sized to the robot, drawn over the geoms.
  axisMarker() {
    const length = Math.max(0.35 * this.radius, 0.03);
    const marker = new THREE.Group();
    const matter = new THREE.MeshBasicMaterial({ color: HIGHLIGHT, depthTest: false, transparent: true, opacity: 0.85 });
    const shaft = new THREE.Mesh(new THREE.CylinderGeometry(length / 60, length / 60, length, 8).rotateX(Math.PI / 2), matter);
    shaft.position.z = 0;
    const tip = new THREE.Mesh(new THREE.ConeGeometry(length / 20, length / 7, 12).rotateX(Math.PI / 2), matter);
    tip.position.z = length / 2 + length / 14;
    const ring = new THREE.Mesh(new THREE.TorusGeometry(length / 6, length / 80, 6, 32), matter);
    for (const part of [shaft, tip, ring]) {
      part.renderOrder = 1;
      marker.add(part);
    }
    return marker;
  }

  // Draws at the next animation frame, once, while on screen (else when it comes back).
  requestDraw() {
    this.dirty = true;
    if (!this.onScreen || this.drawPending) return;
    this.drawPending = true;
    requestAnimationFrame(() => {
      this.drawPending = false;
      this.draw();
    });
  }

  draw() {
    if (!this.dirty || !this.onScreen) return;
    this.dirty = false;
    this.renderer.render(this.scene, this.camera);
    this.frames = (this.frames || 0) + 1;
  }

  watchScreen(holder) {
    this.onScreen = false;
    new IntersectionObserver((entries) => {
      this.onScreen = entries.some((e) => e.isIntersecting);
      if (this.onScreen) this.requestDraw();
    }).observe(this.canvas);
    new ResizeObserver(() => {
      const width = holder.clientWidth, height = holder.clientHeight;
      if (!width || !height) return;
      this.renderer.setSize(width, height, false);
      this.camera.aspect = width / height;
      this.camera.updateProjectionMatrix();
      this.dirty = true;
      this.draw(); // at once: a resized canvas is blank until drawn
    }).observe(holder);
  }

  // A click (not a drag) on a link selects the servo whose joint moves it, or the nearest such
  // joint toward the robot's root.
  watchClicks() {
    let down = null;
    this.canvas.addEventListener("pointerdown", (e) => { down = [e.clientX, e.clientY]; });
    this.canvas.addEventListener("pointerup", (e) => {
      if (!down || Math.hypot(e.clientX - down[0], e.clientY - down[1]) > PICK_MOVE_PX) return;
      const slot = this.servoAt(e);
      if (slot !== null && this.onPick) this.onPick(slot);
    });
  }

  // Where body i is drawn: the centre of its largest geom, in CSS pixels from the canvas's top
  // left (null when the body has no geom, or it is behind the camera).
  screenPoint(i) {
    const sizeOf = (mesh) => {
      mesh.geometry.computeBoundingSphere();
      return mesh.geometry.boundingSphere.radius * Math.max(...mesh.scale.toArray());
    };
    const meshes = [...(this.meshesOfBody[i] || [])].sort((a, b) => sizeOf(b) - sizeOf(a));
    if (!meshes.length) return null;
    const p = meshes[0].localToWorld(meshes[0].geometry.boundingSphere.center.clone()).project(this.camera);
    if (p.z > 1) return null;
    return { x: (p.x + 1) / 2 * this.canvas.clientWidth, y: (1 - p.y) / 2 * this.canvas.clientHeight };
  }

  servoAt(event) {
    const rect = this.canvas.getBoundingClientRect();
    const pointer = new THREE.Vector2(((event.clientX - rect.left) / rect.width) * 2 - 1,
      -((event.clientY - rect.top) / rect.height) * 2 + 1);
    const ray = new THREE.Raycaster();
    ray.setFromCamera(pointer, this.camera);
    const hit = ray.intersectObjects(this.meshesOfBody.flat(), false)[0];
    for (let body = hit ? hit.object.userData.body : -1; body > 0; body = this.robot.bodies[body].parent) {
      const joint = this.robot.joints.find((j) => j.body === body && j.servo !== undefined);
      if (joint) return joint.servo;
    }
    return null;
  }
}
