// View a TerraMRF terrain.glb in a browser with three.js (GLTFLoader), or render it headless.
//
//   node tools/gltf_view/view.mjs OUT/mesh/terrain.glb                # serve; open the printed URL
//   node tools/gltf_view/view.mjs OUT/mesh/terrain.glb --screenshot /tmp/mesh.png
//
// Options: --port N (serve; default 8000), --three DIR (node_modules/three; default
// build/node_tools/node_modules/three, installed by scripts/setup.sh), --chromium PATH (default
// /usr/bin/chromium), --size WxH (default 1280x800), --timeout S (default 180), --check 1 (exit 1
// unless the screenshot shows a textured mesh).
// The screenshot is the WebGL canvas as the page drew it (SwiftShader, no GPU needed); the page's
// counts and pixel statistics are printed as JSON. Exit 1 when the page could not render the mesh.
// Uses only node's standard library.
import {spawn} from 'node:child_process';
import fs from 'node:fs';
import http from 'node:http';
import os from 'node:os';
import path from 'node:path';
import {fileURLToPath} from 'node:url';

const here = path.dirname(fileURLToPath(import.meta.url));

function usage(msg) {
  console.error(`view.mjs: ${msg}\nusage: node view.mjs MESH.glb [--screenshot OUT.png] [--port N] ` +
                `[--three DIR] [--chromium PATH] [--size WxH] [--timeout S]`);
  process.exit(2);
}

const opt = {port: '8000', three: path.join(here, '../../build/node_tools/node_modules/three'),
             chromium: '/usr/bin/chromium', size: '1280x800', timeout: '180'};
let glb = null;
for (let i = 2; i < process.argv.length; ++i) {
  const a = process.argv[i];
  if (a.startsWith('--')) {
    if (i + 1 >= process.argv.length) usage(`${a} needs a value`);
    opt[a.slice(2)] = process.argv[++i];
  } else if (!glb) glb = a;
  else usage(`unexpected argument '${a}'`);
}
if (!glb) usage('no .glb given');
if (!fs.existsSync(glb)) usage(`no such file: ${glb}`);
if (!fs.existsSync(path.join(opt.three, 'build/three.module.js')))
  usage(`three.js not found at ${opt.three}; install it with ` +
        `npm install --prefix build/node_tools three (or pass --three DIR)`);
const [width, height] = opt.size.split('x').map(Number);
if (!(width > 0 && height > 0)) usage(`bad --size '${opt.size}'`);

const types = {'.html': 'text/html', '.js': 'text/javascript', '.json': 'application/json',
               '.glb': 'model/gltf-binary', '.png': 'image/png'};

// Only these files are served: the page, its script, three.js, and the mesh.
function resolve(url) {
  const p = decodeURIComponent(new URL(url, 'http://x').pathname);
  if (p === '/' || p === '/index.html') return path.join(here, 'index.html');
  if (p === '/viewer.js') return path.join(here, 'viewer.js');
  if (p === '/mesh.glb') return path.resolve(glb);
  if (p.startsWith('/three/')) {
    const f = path.resolve(opt.three, '.' + p.slice('/three'.length));
    if (f.startsWith(path.resolve(opt.three) + path.sep)) return f;
  }
  return null;
}

let browser = null;
let profile = null;
function finish(code) {
  if (browser && browser.exitCode === null) {
    try { process.kill(-browser.pid, 'SIGKILL'); } catch { /* already gone */ }
  }
  if (profile) fs.rmSync(profile, {recursive: true, force: true});
  process.exit(code);
}

const shot = opt.screenshot;
const server = http.createServer((req, res) => {
  if (req.method === 'POST' && req.url === '/result') {
    let body = '';
    req.on('data', (c) => { body += c; });
    req.on('end', () => {
      res.end('ok');
      const r = JSON.parse(body);
      if (r.png) {
        fs.writeFileSync(shot, Buffer.from(r.png.split(',')[1], 'base64'));
        delete r.png;
        r.screenshot = path.resolve(shot);
      }
      console.log(JSON.stringify(r, null, 1));
      // --check: the picture must show a textured mesh, not just background or flat grey.
      const problems = !r.ok ? [r.error]
          : !opt.check ? []
          : [[r.meshes > 0, 'no meshes'], [r.textured > 0, 'no textured material'],
             [r.covered_fraction >= 0.02, 'mesh covers < 2 % of the picture'],
             [r.distinct_colours >= 32, 'fewer than 32 colours (texture not drawn?)']]
              .filter(([ok]) => !ok).map(([, what]) => what);
      for (const p of problems) console.error(`view.mjs: FAIL: ${p}`);
      finish(problems.length ? 1 : 0);
    });
    return;
  }
  const f = resolve(req.url);
  if (!f || !fs.existsSync(f) || !fs.statSync(f).isFile()) {
    res.writeHead(404);
    res.end();
    return;
  }
  res.writeHead(200, {'Content-Type': types[path.extname(f)] ?? 'application/octet-stream'});
  fs.createReadStream(f).pipe(res);
});

server.listen(shot ? 0 : Number(opt.port), '127.0.0.1', () => {
  const url = `http://127.0.0.1:${server.address().port}/`;
  if (!shot) {
    console.log(`serving ${glb} at ${url} (Ctrl-C to stop)`);
    return;
  }
  profile = fs.mkdtempSync(path.join(os.tmpdir(), 'gltf-view-chromium-'));
  // SwiftShader gives WebGL without a GPU; the rest keeps a headless run quiet and offline.
  const flags = ['--headless', '--no-sandbox', '--disable-gpu', '--use-angle=swiftshader',
                 '--enable-unsafe-swiftshader', '--disable-quic', '--no-first-run',
                 '--disable-background-networking', '--disable-component-update', '--disable-sync',
                 '--disable-dev-shm-usage', `--user-data-dir=${profile}`,
                 `--window-size=${width},${height}`, `${url}?shot=1`];
  browser = spawn(opt.chromium, flags, {detached: true, stdio: ['ignore', 'ignore', 'pipe']});
  let log = '';
  browser.stderr.on('data', (c) => { log = (log + c).slice(-4000); });
  browser.on('error', (e) => {
    console.error(`view.mjs: cannot start ${opt.chromium}: ${e.message}`);
    finish(1);
  });
  browser.on('exit', (code) => {
    console.error(`view.mjs: ${opt.chromium} exited (${code}) before the page reported:\n${log}`);
    finish(1);
  });
  setTimeout(() => {
    console.error(`view.mjs: no result after ${opt.timeout} s; browser log:\n${log}`);
    finish(1);
  }, Number(opt.timeout) * 1000).unref();
});
