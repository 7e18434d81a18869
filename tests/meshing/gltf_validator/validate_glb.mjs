// Independent check of the glTF export (issue 4 §5): `terramrf mesh` exports a small simulator
// mesh, the Khronos glTF validator (npm gltf-validator, not our own reader) must report no error,
// and the vertex/triangle/draw-call counts it measures must equal the ones report.md claims.
// A deliberately truncated copy must be rejected, so a validator that accepts anything fails too.
//
// node validate_glb.mjs --cli BIN --config YAML --work DIR --validator DIR [--tile-texels N]
// Exit 0 = valid; anything else fails the CTest (a missing validator is a failure, not a skip).
import {spawnSync} from 'node:child_process';
import fs from 'node:fs';
import {createRequire} from 'node:module';
import path from 'node:path';

function fail(msg) {
  console.error(`FAIL: ${msg}`);
  process.exit(1);
}

function args() {
  const a = {};
  const argv = process.argv.slice(2);
  for (let i = 0; i < argv.length; i += 2) {
    if (!argv[i].startsWith('--') || i + 1 >= argv.length) fail(`bad argument '${argv[i]}'`);
    a[argv[i].slice(2)] = argv[i + 1];
  }
  for (const k of ['cli', 'config', 'work', 'validator'])
    if (!a[k]) fail(`missing --${k}`);
  return a;
}

function loadValidator(dir) {
  const pkg = path.join(dir, 'package.json');
  if (!fs.existsSync(pkg))
    fail(`the Khronos glTF validator is not installed at ${dir}; run scripts/setup.sh ` +
         `(npm install --prefix <build>/node_tools gltf-validator@<pinned version>)`);
  const version = JSON.parse(fs.readFileSync(pkg, 'utf8')).version;
  return {validator: createRequire(import.meta.url)(dir), version};
}

// "- exported: 19 tiles, 35016 vertices, 49751 triangles" in report.md.
function reportedCounts(reportPath) {
  const text = fs.readFileSync(reportPath, 'utf8');
  const m = text.match(/exported: (\d+) tiles, (\d+) vertices, (\d+) triangles/);
  if (!m) fail(`report.md has no 'exported: N tiles, V vertices, T triangles' line:\n${text}`);
  return {tiles: +m[1], vertices: +m[2], triangles: +m[3]};
}

function severityName(s) {
  return ['ERROR', 'WARNING', 'INFO', 'HINT'][s] ?? `severity ${s}`;
}

async function validate(validator, bytes) {
  return validator.validateBytes(new Uint8Array(bytes), {maxIssues: 0, format: 'glb'});
}

const a = args();
const {validator, version} = loadValidator(a.validator);
console.log(`gltf-validator ${version}, node ${process.version}`);

// 1. Export with the real CLI, as a user would.
fs.rmSync(a.work, {recursive: true, force: true});
fs.mkdirSync(a.work, {recursive: true});
const t0 = Date.now();
const run = spawnSync(a.cli, ['mesh', a.config, '--out', a.work, '--no-progress'], {encoding: 'utf8'});
if (run.error) fail(`cannot run ${a.cli}: ${run.error.message}`);
process.stdout.write(run.stdout);
process.stderr.write(run.stderr);
if (run.status !== 0) fail(`terramrf mesh exited with ${run.status}`);
console.log(`export: ${((Date.now() - t0) / 1000).toFixed(1)} s`);
const meshDir = path.join(a.work, 'mesh');
const glbPath = path.join(meshDir, 'terrain.glb');
if (!fs.existsSync(glbPath)) fail(`no ${glbPath}`);
const glb = fs.readFileSync(glbPath);
const want = reportedCounts(path.join(meshDir, 'report.md'));

// 2. Validate.
const report = await validate(validator, glb);
const issues = report.issues;
const bySeverityAndCode = new Map();
for (const m of issues.messages) {
  const key = `${severityName(m.severity)} ${m.code}`;
  const e = bySeverityAndCode.get(key) ?? {n: 0, first: m};
  e.n += 1;
  bySeverityAndCode.set(key, e);
}
console.log(`validator: ${issues.numErrors} error(s), ${issues.numWarnings} warning(s), ` +
            `${issues.numInfos} info(s), ${issues.numHints} hint(s)`);
for (const [key, e] of bySeverityAndCode)
  console.log(`  ${key} x${e.n}: ${e.first.message} (first at ${e.first.pointer ?? e.first.offset})`);

const problems = [];
if (issues.numErrors > 0) problems.push(`${issues.numErrors} validator error(s) (see above)`);

// 3. What the validator measured must be what we claim to have written.
const info = report.info;
const images = info.resources.filter((r) => r.pointer.startsWith('/images/'));
console.log(`validator info: glTF ${info.version}, ${info.drawCallCount} draw call(s), ` +
            `${info.totalVertexCount} vertices, ${info.totalTriangleCount} triangles, ` +
            `${images.length} image(s), ${info.materialCount} material(s), maxUVs ${info.maxUVs}`);
console.log(`report.md: ${want.tiles} tiles, ${want.vertices} vertices, ${want.triangles} triangles`);
const expect = (ok, what) => { if (!ok) problems.push(what); };
expect(info.version === '2.0', `asset version ${info.version}, expected 2.0`);
expect(info.hasDefaultScene, 'no default scene (viewers show nothing)');
expect(info.drawCallCount === want.tiles, `draw calls ${info.drawCallCount} != tiles ${want.tiles}`);
expect(info.totalVertexCount === want.vertices,
       `validator counts ${info.totalVertexCount} vertices, report.md ${want.vertices}`);
expect(info.totalTriangleCount === want.triangles,
       `validator counts ${info.totalTriangleCount} triangles, report.md ${want.triangles}`);
// Plausibility independent of report.md: the 3-frame drive covers several tiles, each tile holds
// at most tile_vertices² vertices and about two triangles per vertex.
const tileVertices = +(a['tile-vertices'] ?? 81);
expect(want.tiles >= 2, `only ${want.tiles} tile(s) exported`);
expect(info.totalVertexCount >= 1000 && info.totalVertexCount <= want.tiles * tileVertices ** 2,
       `implausible vertex count ${info.totalVertexCount}`);
expect(info.totalTriangleCount >= info.totalVertexCount / 2 &&
       info.totalTriangleCount <= 2 * info.totalVertexCount,
       `implausible triangle count ${info.totalTriangleCount} for ${info.totalVertexCount} vertices`);
expect(info.hasTextures && images.length >= 1, 'no texture images (mesh would render untextured)');
expect(images.length === info.materialCount, `${images.length} images but ${info.materialCount} materials`);
expect(info.maxUVs === 1, `maxUVs ${info.maxUVs}, expected 1 (TEXCOORD_0)`);
const texels = +(a['tile-texels'] ?? 81);
for (const im of images) {
  if (im.mimeType !== 'image/png' || !im.image || im.image.width !== texels || im.image.height !== texels) {
    problems.push(`${im.pointer}: ${im.mimeType} ${im.image?.width}x${im.image?.height}, ` +
                  `expected image/png ${texels}x${texels}`);
    break;
  }
}

// 4. Negative control: a truncated file must give errors, else the check above proves nothing.
const broken = await validate(validator, glb.subarray(0, Math.floor(glb.length / 2)));
console.log(`negative control (glb cut in half): ${broken.issues.numErrors} error(s)`);
expect(broken.issues.numErrors > 0, 'validator accepted a truncated glb');

if (problems.length) fail(problems.join('\n      '));
console.log('PASS: terrain.glb is valid glTF 2.0');
