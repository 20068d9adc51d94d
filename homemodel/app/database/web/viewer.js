// The 3D view of the database page: one model at a time, a slider per joint (moving the node
// as the glTF's extras.joint says), its grasp points. It is drawn only when something changed,
// and a model it lets go of is freed (geometries, materials, textures). The page imports this
// module beside its list, so the list shows before three.js has loaded.
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';

// Frees what a model holds on the GPU: geometries, materials and their textures.
function dispose(root) {
  root.traverse((object) => {
    object.geometry?.dispose();
    const materials = Array.isArray(object.material) ? object.material : object.material ? [object.material] : [];
    for (const material of materials) {
      for (const value of Object.values(material)) {
        if (value && value.isTexture) {
          value.source?.data?.close?.(); // an ImageBitmap
          value.dispose();
        }
      }
      material.dispose();
    }
  });
}

function jointSlider(node, joint, render) {
  const rest = { position: node.position.clone(), quaternion: node.quaternion.clone() };
  const axis = new THREE.Vector3(...joint.axis).normalize();
  const [lower, upper] = joint.type === 'continuous' ? [-Math.PI, Math.PI] : [Number(joint.lower), Number(joint.upper)];
  const label = document.createElement('label');
  const name = Object.assign(document.createElement('span'), { textContent: `${joint.name} (${joint.type})` });
  const input = Object.assign(document.createElement('input'), { type: 'range', min: lower, max: upper, step: (upper - lower) / 200 });
  input.value = 0;
  input.dataset.joint = joint.name;
  const output = Object.assign(document.createElement('output'), { textContent: '0' });
  label.append(name, input, output);
  // The joint frame is the child link's frame: move the node about its rest transform.
  input.addEventListener('input', () => {
    const q = Number(input.value);
    if (joint.type === 'prismatic') {
      node.position.copy(rest.position).add(axis.clone().multiplyScalar(q).applyQuaternion(rest.quaternion));
    } else {
      node.quaternion.copy(rest.quaternion).multiply(new THREE.Quaternion().setFromAxisAngle(axis, q));
    }
    output.textContent = joint.type === 'prismatic' ? `${q.toFixed(3)} m` : `${(q * 180 / Math.PI).toFixed(0)}°`;
    render();
  });
  return label;
}

// A view in `element`, its sliders in `sliders`; `hm` is the page's test hook object (frames
// drawn, joint nodes, GPU memory).
export function createViewer(element, sliders, hm) {
  const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
  renderer.setPixelRatio(window.devicePixelRatio);
  element.prepend(renderer.domElement);
  const scene = new THREE.Scene();
  scene.background = new THREE.Color(0xf4f4f4);
  scene.add(new THREE.HemisphereLight(0xffffff, 0x888888, 2.0));
  const sun = new THREE.DirectionalLight(0xffffff, 1.5);
  sun.position.set(3, 5, 4);
  scene.add(sun);
  const camera = new THREE.PerspectiveCamera(40, 1, 0.01, 100);
  const controls = new OrbitControls(camera, renderer.domElement);
  hm.memory = () => renderer.info.memory; // geometries and textures held on the GPU
  let current = null;
  let graspsVisible = true;
  const graspMarkers = [];

  let frameQueued = false;
  function render() {
    if (frameQueued) return;
    frameQueued = true;
    requestAnimationFrame(() => {
      frameQueued = false;
      renderer.render(scene, camera);
      hm.frames += 1;
    });
  }
  controls.addEventListener('change', render);

  function resize() {
    const { clientWidth: w, clientHeight: h } = element;
    if (!w || !h) return;
    renderer.setSize(w, h);
    camera.aspect = w / h;
    camera.updateProjectionMatrix();
    render();
  }
  new ResizeObserver(resize).observe(element);

  function addGraspMarkers(root) {
    const info = root.userData.homemodel || {};
    for (const g of Array.isArray(info.grasp_points) ? info.grasp_points : []) {
      const link = root.getObjectByName(g.link);
      if (!link) continue;
      const marker = new THREE.Mesh(new THREE.SphereGeometry(0.012), new THREE.MeshBasicMaterial({ color: 0xff2266 }));
      marker.add(new THREE.AxesHelper(0.05));
      marker.position.fromArray(g.translation || [0, 0, 0]);
      marker.quaternion.fromArray(g.rotation || [0, 0, 0, 1]);
      marker.name = `grasp:${g.name}`;
      marker.visible = graspsVisible;
      link.add(marker);
      graspMarkers.push(marker);
    }
  }

  function frame(object) {
    const box = new THREE.Box3().setFromObject(object);
    const centre = box.getCenter(new THREE.Vector3());
    const radius = box.getSize(new THREE.Vector3()).length() / 2 || 1;
    controls.target.copy(centre);
    // The front is +x of the model, which glTF's y-up root turns to three.js's +x.
    camera.position.copy(centre).add(new THREE.Vector3(1.6, 0.9, 1.2).multiplyScalar(radius * 1.4));
    camera.near = radius / 100;
    camera.far = radius * 100;
    camera.updateProjectionMatrix();
    controls.update();
  }

  return {
    render,
    // Lets go of the model shown (and frees it).
    clear() {
      if (current) {
        scene.remove(current);
        dispose(current);
      }
      current = null;
      graspMarkers.length = 0;
      hm.joints = {};
      sliders.replaceChildren();
      render();
    },
    // Parses a glb; `isStale()` says, once it is parsed, whether another model was chosen
    // meanwhile (then it is freed, not shown). True when it is shown.
    async show(data, isStale) {
      const gltf = await new GLTFLoader().parseAsync(data, '');
      if (isStale()) {
        dispose(gltf.scene);
        return false;
      }
      current = gltf.scene;
      scene.add(current);
      current.traverse((node) => {
        const joint = node.userData.joint;
        if (joint && joint.type !== 'fixed' && Array.isArray(joint.axis)) {
          hm.joints[joint.name] = node;
          sliders.appendChild(jointSlider(node, joint, render));
        }
      });
      addGraspMarkers(current.children.find((c) => c.userData.homemodel) || current);
      frame(current);
      return true;
    },
    showGrasps(visible) {
      graspsVisible = visible;
      graspMarkers.forEach((m) => { m.visible = visible; });
      render();
    },
  };
}
